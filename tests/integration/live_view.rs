//! The live view as Foxglove sees it: a WebSocket client speaking the Foxglove WebSocket
//! protocol connects to a dry run's `--live` server, reads its advertisements, subscribes to
//! every topic, and gets every message the log holds, byte for byte and in order (a topic's
//! messages logged before its subscription took effect as that topic's latest); a viewer
//! that joins half-way gets the scene at once, the body included.
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

    // Every topic of the session is advertised at once, with the log's schemas; the client
    // subscribes to each as it is advertised, as a viewer does.
    let mut topics: std::collections::HashMap<u32, String> = Default::default();
    let mut got: Vec<(String, u64, Vec<u8>)> = Vec::new();
    let mut late: Option<Socket> = None;
    let mut late_arm: Option<Value> = None;
    let t = Instant::now();
    if let MaybeTlsStream::Plain(stream) = ws.get_mut() {
        stream.set_read_timeout(Some(Duration::from_millis(100))).unwrap();
    }
    loop {
        assert!(t.elapsed() < Duration::from_secs(120), "the session did not end");
        let frame = match ws.read() {
            Ok(f) => f,
            Err(tungstenite::Error::Io(e))
                if e.kind() == std::io::ErrorKind::WouldBlock || e.kind() == std::io::ErrorKind::TimedOut =>
            {
                if child.try_wait().unwrap().is_some() {
                    break;
                }
                continue;
            }
            Err(_) => break, // the dry run ended and its server with it
        };
        match frame {
            Message::Text(text) => {
                let m: Value = serde_json::from_str(&text).unwrap();
                // A subscription the server refused (it had not yet recorded the channel as
                // advertised to this viewer: src/live.rs makes every channel at start for it).
                assert!(m["op"] != "status" || m["level"] != 2, "the server refused: {m}");
                if m["op"] != "advertise" {
                    continue;
                }
                let mut subscriptions = Vec::new();
                for c in m["channels"].as_array().unwrap() {
                    let topic = Topic::from_name(c["topic"].as_str().unwrap()).unwrap();
                    let (name, text) = schema(topic);
                    assert_eq!((c["encoding"].as_str(), c["schemaName"].as_str()), (Some("json"), Some(name)));
                    assert_eq!(c["schemaEncoding"], "jsonschema");
                    assert_eq!(c["schema"].as_str().unwrap(), text, "{topic}");
                    let id = topics.len() as u32 + 1;
                    topics.insert(id, topic.name().to_string());
                    subscriptions.push(json!({"id": id, "channelId": c["id"]}));
                }
                let subscribe = json!({"op": "subscribe", "subscriptions": subscriptions});
                ws.send(Message::text(subscribe.to_string())).unwrap();
            }
            Message::Binary(b) => {
                assert_eq!(b[0], 1, "opcode 1: a message data frame");
                let id = u32::from_le_bytes(b[1..5].try_into().unwrap());
                let time = u64::from_le_bytes(b[5..13].try_into().unwrap());
                got.push((topics[&id].clone(), time, b[13..].to_vec()));
            }
            _ => {}
        }
        // Half-way through, a second viewer joins: it gets the scene at once, body included.
        if late.is_none() && got.iter().filter(|g| g.0 == "/trial/response").count() == 5 {
            let (mut w, _) = tungstenite::connect(request("foxglove.sdk.v1")).unwrap();
            let mut arm_channel = None;
            while arm_channel.is_none() {
                if let Got::Text(m) = next(&mut w)
                    && m["op"] == "advertise"
                {
                    arm_channel = m["channels"]
                        .as_array()
                        .unwrap()
                        .iter()
                        .find(|c| c["topic"] == "/human/arm")
                        .map(|c| c["id"].clone());
                }
            }
            let subscribe = json!({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": arm_channel}]});
            w.send(Message::text(subscribe.to_string())).unwrap();
            while late_arm.is_none() {
                if let Got::Data(1, payload) = next(&mut w) {
                    late_arm = Some(serde_json::from_slice(&payload).unwrap());
                }
            }
            late = Some(w);
        }
    }
    assert!(child.wait().unwrap().success());
    drop(late);
    let ids: Vec<&str> = late_arm.as_ref().expect("a late viewer got /human/arm")["entities"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["id"].as_str().unwrap())
        .collect();
    assert!(ids.contains(&"body") && ids.contains(&"human_arm"), "the late viewer sees the body and the arm: {ids:?}");

    // What was served is every message the log holds, byte for byte, in the log's order, but
    // for the race the protocol leaves open: a topic's messages logged before the viewer's
    // subscription took effect reach it only as that topic's latest (its replay). So each
    // topic's served messages are the last ones logged on it, and a message not served was
    // logged before the first response: the viewer joined late, nothing was lost mid-session
    // or at the end.
    let path = &mcap_files(&dir.join("logs"))[0];
    let bytes = std::fs::read(path).unwrap();
    let logged: Vec<(String, u64, Vec<u8>)> = mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| {
            let m = m.unwrap();
            (m.channel.topic.clone(), m.log_time, m.data.to_vec())
        })
        .collect();
    let logged_topics: std::collections::BTreeSet<&str> = logged.iter().map(|m| m.0.as_str()).collect();
    for topic in logged_topics {
        let on = |v: &[(String, u64, Vec<u8>)]| v.iter().filter(|m| m.0 == topic).cloned().collect::<Vec<_>>();
        let (l, g) = (on(&logged), on(&got));
        // On failure, whether the topic was advertised to this viewer at all tells a
        // subscription race (advertised, its replay missing) from an advertisement lost.
        assert!(
            !g.is_empty() && l.ends_with(&g),
            "{topic}: {} of {} logged served, not its last ones (advertised to the viewer: {})",
            g.len(),
            l.len(),
            topics.values().any(|t| t == topic)
        );
    }
    assert!(got.len() <= logged.len(), "a message served twice");
    let first_response = logged.iter().position(|m| m.0 == "/trial/response").expect("a response");
    let missing: Vec<(usize, &str)> =
        logged.iter().enumerate().filter(|(_, m)| !got.contains(m)).map(|(i, m)| (i, m.0.as_str())).collect();
    assert!(
        missing.iter().all(|&(i, _)| i < first_response),
        "lost after the first response (index {first_response}): {missing:?} of {} logged",
        logged.len()
    );
    if !missing.is_empty() {
        eprintln!("the viewer subscribed after {missing:?} were superseded (a late join, allowed)");
    }
    // From the first response on, every message in the order logged.
    let from = |v: &[(String, u64, Vec<u8>)]| {
        let k = v.iter().position(|m| m.0 == "/trial/response").expect("a response");
        v[k..].to_vec()
    };
    assert_eq!(from(&got), from(&logged), "every message from the first response on, in order");
    let read = read_log(path).unwrap();
    assert!(read.finished);
    let _ = std::fs::remove_dir_all(&dir);
}
