//! The live view: a session's log served to Foxglove while it runs, over the Foxglove
//! WebSocket protocol (`foxglove.websocket.v1`, by the official `foxglove` crate's server).
//! Every message is served once it is on disk, on the log's topics with the log's schemas, so
//! the app shows the same 3D scene, plots and notes as the log opened later
//! (`docs/foxglove-layout.json`). Every topic a session may publish has its channel from the
//! moment the server starts, so it is advertised to a viewer as it connects. (A channel made
//! after a viewer connected is advertised to it before the SDK, foxglove 0.30.3, records it
//! as advertised to that viewer, so a viewer that answers at once can have its subscription
//! refused as an unknown channel: under load, a topic lost for good.) A viewer connected from
//! the start subscribes in time to get every message in order; one that connects late gets
//! each topic's latest message when it subscribes (the body is in every `/human/arm`), so the
//! scene is there at once. A viewer gets each message once: it is sent to a subscriber only
//! after that subscriber's replay, both under one lock, so a message published while a
//! viewer subscribes is not sent twice.

use std::collections::{HashMap, HashSet};
use std::net::SocketAddr;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use foxglove::websocket::{ChannelView, Client, ServerListener};
use foxglove::{Context, PartialMetadata, RawChannel, Schema, SinkId, WebSocketServer, WebSocketServerHandle};

use crate::record::{Tap, Topic, schema};

/// Where the live view listens unless told otherwise: this machine only, Foxglove's port.
pub const DEFAULT_ADDR: &str = "127.0.0.1:8765";

/// The channels, each topic's latest message (time, JSON), and the viewers subscribed to
/// each topic that have had its replay (the only ones new messages are sent to), and when
/// the last message was published.
#[derive(Default)]
struct Shared {
    channels: HashMap<Topic, Arc<RawChannel>>,
    latest: HashMap<Topic, (u64, Vec<u8>)>,
    subscribers: HashMap<Topic, HashSet<SinkId>>,
    last_publish: Option<Instant>,
}

/// Replays a topic's latest message to a viewer that subscribes to it.
struct Latch(Arc<Mutex<Shared>>);

fn lock(m: &Mutex<Shared>) -> MutexGuard<'_, Shared> {
    // A panic while holding it leaves plain maps, still usable.
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl ServerListener for Latch {
    fn on_subscribe(&self, client: Client, channel: ChannelView) {
        let mut shared = lock(&self.0);
        let (Some(topic), Some(sink)) = (Topic::from_name(channel.topic()), client.sink_id()) else { return };
        if let (Some(ch), Some((time_ns, data))) = (shared.channels.get(&topic), shared.latest.get(&topic)) {
            ch.log_with_meta_to_sink(data, PartialMetadata { log_time: Some(*time_ns) }, Some(sink));
        }
        shared.subscribers.entry(topic).or_default().insert(sink);
    }

    fn on_unsubscribe(&self, client: Client, channel: ChannelView) {
        let mut shared = lock(&self.0);
        if let (Some(topic), Some(sink)) = (Topic::from_name(channel.topic()), client.sink_id())
            && let Some(sinks) = shared.subscribers.get_mut(&topic)
        {
            sinks.remove(&sink);
        }
    }
}

/// The live view's server; clones share it (one per process, however many sessions). It
/// serves until the last clone is dropped (`Serving`).
#[derive(Clone)]
pub struct LiveView {
    /// Held so the channels stay advertised (the server holds it weakly).
    _context: Arc<Context>,
    shared: Arc<Mutex<Shared>>,
    _server: Arc<Serving>,
    addr: SocketAddr,
}

impl LiveView {
    /// Starts serving on `addr` (port 0: any free port).
    pub fn start(addr: SocketAddr) -> Result<Self, String> {
        let context = Context::new();
        // Every channel before the first viewer can connect (the module's header says why).
        let mut channels = HashMap::new();
        for topic in Topic::ALL {
            if let Some(c) = make_channel(&context, topic) {
                channels.insert(topic, c);
            }
        }
        let shared = Arc::new(Mutex::new(Shared { channels, ..Shared::default() }));
        let server = WebSocketServer::new()
            .name(format!("handover {}", env!("CARGO_PKG_VERSION")))
            .bind(addr.ip().to_string(), addr.port())
            .context(&context)
            .listener(Arc::new(Latch(Arc::clone(&shared))))
            .start_blocking()
            .map_err(|e| format!("the live view cannot listen on {addr}: {e}"))?;
        let addr = SocketAddr::new(addr.ip(), server.port());
        let serving = Serving { _handle: server, shared: Arc::clone(&shared) };
        Ok(Self { _context: context, shared, _server: Arc::new(serving), addr })
    }

    /// What Foxglove's *Open connection…* takes.
    pub fn url(&self) -> String {
        format!("ws://{}", self.addr)
    }
}

/// How long the live view keeps serving after its last message when it is dropped.
const LINGER: Duration = Duration::from_secs(1);

/// The server, which serves until the last clone of the view is dropped; then it waits
/// until `LINGER` has passed since the last message. The server sends each viewer's queue
/// asynchronously and has no drain, so a process that ended with its last message would
/// take that message with it on a loaded machine.
struct Serving {
    _handle: WebSocketServerHandle,
    shared: Arc<Mutex<Shared>>,
}

impl Drop for Serving {
    fn drop(&mut self) {
        let last = lock(&self.shared).last_publish;
        if let Some(left) = last.map(|t| LINGER.saturating_sub(t.elapsed())) {
            std::thread::sleep(left);
        }
    }
}

/// The topic's channel with the log's schema; `None` when it cannot be made (the topic is
/// left out of the view; the log has it).
fn make_channel(context: &Arc<Context>, topic: Topic) -> Option<Arc<RawChannel>> {
    let (name, text) = schema(topic);
    context
        .channel_builder(topic.name())
        .message_encoding("json")
        .schema(Schema::new(name, "jsonschema", text.into_bytes()))
        .build_raw()
        .ok()
}

impl Tap for LiveView {
    fn publish(&mut self, topic: Topic, time_ns: u64, data: &[u8]) {
        let mut shared = lock(&self.shared);
        let Some(channel) = shared.channels.get(&topic).cloned() else { return };
        shared.latest.insert(topic, (time_ns, data.to_vec()));
        shared.last_publish = Some(Instant::now());
        // Under the lock: a viewer subscribing now gets this message either as its replay or
        // here, never both. The server calls `on_subscribe` holding none of its own locks.
        for &sink in shared.subscribers.get(&topic).into_iter().flatten() {
            channel.log_with_meta_to_sink(data, PartialMetadata { log_time: Some(time_ns) }, Some(sink));
        }
    }

    fn boxed_clone(&self) -> Box<dyn Tap> {
        Box::new(self.clone())
    }
}
