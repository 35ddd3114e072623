//! The live view as Foxglove sees it: a WebSocket client speaking the Foxglove WebSocket
//! protocol connects to a dry run's `--live` server, reads its advertisements, subscribes, and
//! gets the messages the log holds.
//!
//! The official server (the `foxglove` crate) negotiates the protocol as `foxglove.sdk.v1`,
//! the name `foxglove.websocket.v1` has had since the SDK took it over (the wire format is the
//! same: serverInfo, advertise, subscribe, message data frames). The client offers both names,
//! as current Foxglove and Lichtblick do; one that offers only the old name is refused.

use std::io::{BufRead, BufReader};
use std::net::TcpStream;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use handover::record::{Topic, mcap_files, read_log, schema};
use serde_json::{Value, json};
use tungstenite::client::IntoClientRequest;
use tungstenite::{Message, WebSocket, stream::MaybeTlsStream};

type Socket = WebSocket<MaybeTlsStream<TcpStream>>;

/// The next text message (JSON), or a binary message's subscription id and payload.
enum Got {
    Text(Value),
    Data(u32, Vec<u8>),
}

fn next(ws: &mut Socket) -> Got {
    loop {
        match ws.read().unwrap() {
            Message::Text(t) => return Got::Text(serde_json::from_str(&t).unwrap()),
            Message::Binary(b) => {
                assert_eq!(b[0], 1, "opcode 1: a message data frame");
                let id = u32::from_le_bytes(b[1..5].try_into().unwrap());
                return Got::Data(id, b[13..].to_vec());
            }
            _ => {}
        }
    }
}

#[test]
fn a_foxglove_client_gets_the_logged_messages_live() {
    let dir = std::env::temp_dir().join(format!("handover-live-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut v: Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 300.into();
    std::fs::write(dir.join("small.json"), v.to_string()).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_handover"))
        .args(["dry-run", "--seed", "2", "--pace", "150", "--live", "127.0.0.1:0"])
        .args(["--protocol", dir.join("small.json").to_str().unwrap()])
        .args(["--logs", dir.join("logs").to_str().unwrap()])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    err.read_line(&mut line).unwrap();
    let url = line.split_whitespace().find(|w| w.starts_with("ws://")).unwrap_or_else(|| panic!("{line}")).to_string();
    assert!(url.starts_with("ws://127.0.0.1:"), "bound to this machine: {url}");

    let request = |protocols: &str| {
        let mut r = url.as_str().into_client_request().unwrap();
        r.headers_mut().insert("Sec-WebSocket-Protocol", protocols.parse().unwrap());
        r
    };
    let old_only = tungstenite::connect(request("foxglove.websocket.v1")).map(|_| ()).unwrap_err();
    assert!(old_only.to_string().contains("400"), "{old_only}");
    let (mut ws, response) = tungstenite::connect(request("foxglove.websocket.v1, foxglove.sdk.v1")).unwrap();
    assert_eq!(response.headers()["Sec-WebSocket-Protocol"], "foxglove.sdk.v1");
    let Got::Text(info) = next(&mut ws) else { panic!("serverInfo first") };
    assert_eq!(info["op"], "serverInfo");
    assert!(info["name"].as_str().unwrap().starts_with("handover "), "{info}");

    // Advertisements name the log's topics with the log's schemas.
    let mut channels: std::collections::BTreeMap<String, u64> = Default::default();
    let t = Instant::now();
    while !(channels.contains_key("/tf") && channels.contains_key("/trial/query")) {
        assert!(t.elapsed() < Duration::from_secs(60), "advertised: {channels:?}");
        if let Got::Text(m) = next(&mut ws)
            && m["op"] == "advertise"
        {
            for c in m["channels"].as_array().unwrap() {
                let topic = Topic::from_name(c["topic"].as_str().unwrap()).unwrap();
                let (name, text) = schema(topic);
                assert_eq!((c["encoding"].as_str(), c["schemaName"].as_str()), (Some("json"), Some(name)));
                assert_eq!(c["schemaEncoding"], "jsonschema");
                assert_eq!(c["schema"].as_str().unwrap(), text, "{topic}");
                channels.insert(topic.name().to_string(), c["id"].as_u64().unwrap());
            }
        }
    }
    let subscribe = json!({"op": "subscribe", "subscriptions": [
        {"id": 1, "channelId": channels["/tf"]},
        {"id": 2, "channelId": channels["/trial/query"]},
    ]});
    ws.send(Message::text(subscribe.to_string())).unwrap();
    // The frames come at once (the latest, sent to a late subscriber); a query as it happens.
    let (mut tf, mut query) = (None, None);
    while tf.is_none() || query.is_none() {
        assert!(t.elapsed() < Duration::from_secs(60));
        if let Got::Data(id, payload) = next(&mut ws) {
            let v: Value = serde_json::from_slice(&payload).unwrap();
            match id {
                1 => tf = Some(v),
                2 => query = Some(v),
                other => panic!("subscription {other}"),
            }
        }
    }
    assert!(tf.unwrap()["transforms"].as_array().is_some_and(|t| !t.is_empty()));
    drop(ws);
    assert!(child.wait().unwrap().success());
    // What was served is what the log holds.
    let log = read_log(&mcap_files(&dir.join("logs"))[0]).unwrap();
    let query = query.unwrap();
    assert!(
        log.messages.iter().any(|m| m.topic == "/trial/query" && m.value == query),
        "the served /trial/query is in the log: {query}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
