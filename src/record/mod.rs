//! The session log: one MCAP file per session, JSON messages with a JSON Schema per topic,
//! unchunked and synced to disk after every event, so that a crash loses nothing. Also the
//! reader (tolerant of a truncated tail) and the replay that rebuilds a session from a log.

mod messages;
mod schemas;

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde_json::Value;

use crate::protocol::{ProtocolError, Study};
use crate::session::{Applied, Event, Session, SessionError, SessionStart, Stamped};

pub use messages::{event_from_message, initial_beliefs, messages_for, topic_of as event_topic};
pub use schemas::{TOPICS, schema};

/// Topics whose messages are events (the others are derived from them).
pub const EVENT_TOPICS: [&str; 10] = [
    "/trial/query",
    "/trial/response",
    "/trial/void",
    "/trial/undo",
    "/notes",
    "/session/pause",
    "/session/resume",
    "/questionnaire/likert",
    "/questionnaire/choice",
    "/session/end",
];

/// Name of the attachment that holds the protocol text.
pub const PROTOCOL_ATTACHMENT: &str = "protocol.json";

/// Why a log could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}: MCAP: {message}")]
    Mcap { path: PathBuf, message: String },
    #[error("{path}: not a handover session log: {why}")]
    NotALog { path: PathBuf, why: String },
    #[error("{path}: the embedded protocol is invalid: {source}")]
    Protocol { path: PathBuf, source: ProtocolError },
    #[error("{path}: event {index} ({topic}) does not replay: {source}")]
    Replay { path: PathBuf, index: usize, topic: String, source: Box<SessionError> },
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> RecordError + '_ {
    move |source| RecordError::Io { path: path.to_path_buf(), source }
}

fn mcap_err(path: &Path) -> impl Fn(mcap::McapError) -> RecordError + '_ {
    move |e| RecordError::Mcap { path: path.to_path_buf(), message: e.to_string() }
}

/// `logs/<participant>/<participant>_<UTC time>.mcap`, with a suffix if that name is taken.
pub fn new_log_path(logs: &Path, participant: &str, time: chrono::DateTime<chrono::Utc>) -> PathBuf {
    let dir = logs.join(participant);
    let stem = format!("{participant}_{}", time.format("%Y%m%dT%H%M%SZ"));
    let mut path = dir.join(format!("{stem}.mcap"));
    let mut k = 2;
    while path.exists() {
        path = dir.join(format!("{stem}-{k}.mcap"));
        k += 1;
    }
    path
}

/// Writes one session's log. Every `record` call returns only after the event's messages
/// are on disk (written, flushed and fsynced).
pub struct Recorder {
    path: PathBuf,
    writer: mcap::Writer<BufWriter<File>>,
    sync: File,
    channels: HashMap<&'static str, u16>,
    next_index: usize,
}

impl Recorder {
    /// Creates the log file (owner-only, never overwriting), writes the protocol, the start
    /// record and the initial beliefs, and syncs.
    pub fn create(path: &Path, protocol_text: &str, session: &Session, time_ns: u64) -> Result<Self, RecordError> {
        if let Some(dir) = path.parent() {
            crate::private_files::create_dir(dir).map_err(io(dir))?;
        }
        let file = crate::private_files::create_file(path).map_err(io(path))?;
        let sync = file.try_clone().map_err(io(path))?;
        let options = mcap::WriteOptions::new()
            .use_chunks(false)
            .compression(None)
            .profile("")
            .library(format!("handover {}", env!("CARGO_PKG_VERSION")));
        let mut writer = options.create(BufWriter::new(file)).map_err(mcap_err(path))?;
        writer
            .attach(&mcap::Attachment {
                log_time: time_ns,
                create_time: time_ns,
                name: PROTOCOL_ATTACHMENT.into(),
                media_type: "application/json".into(),
                data: protocol_text.as_bytes().into(),
            })
            .map_err(mcap_err(path))?;
        let mut channels = HashMap::new();
        for topic in TOPICS {
            let (name, schema) = schema(topic);
            let sid = writer.add_schema(name, "jsonschema", schema.to_string().as_bytes()).map_err(mcap_err(path))?;
            let cid = writer.add_channel(sid, topic, "json", &BTreeMap::new()).map_err(mcap_err(path))?;
            channels.insert(topic, cid);
        }
        let mut rec = Self { path: path.to_path_buf(), writer, sync, channels, next_index: 0 };
        let mut start = serde_json::to_value(session.start()).expect("serialisable");
        start["event_index"] = Value::from(0);
        let mut msgs = vec![("/session/start", start)];
        msgs.extend(messages::initial_beliefs(session));
        rec.write(&msgs, 0, time_ns)?;
        Ok(rec)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Logs one applied event (and what it derived), durably.
    pub fn record(&mut self, stamped: &Stamped, applied: &Applied, session: &Session) -> Result<(), RecordError> {
        self.next_index += 1;
        let index = self.next_index;
        let msgs = messages_for(stamped, index, applied, session);
        self.write(&msgs, index as u32, stamped.time_ns)
    }

    fn write(&mut self, msgs: &[(&'static str, Value)], sequence: u32, time_ns: u64) -> Result<(), RecordError> {
        for (topic, value) in msgs {
            let header = mcap::records::MessageHeader {
                channel_id: self.channels[topic],
                sequence,
                log_time: time_ns,
                publish_time: time_ns,
            };
            let data = serde_json::to_vec(value).expect("serialisable");
            self.writer.write_to_known_channel(&header, &data).map_err(mcap_err(&self.path))?;
        }
        self.writer.flush().map_err(mcap_err(&self.path))?;
        self.sync.sync_data().map_err(io(&self.path))?;
        Ok(())
    }

    /// Writes the summary and footer (a finished file) and syncs.
    pub fn finish(mut self) -> Result<PathBuf, RecordError> {
        self.writer.finish().map_err(mcap_err(&self.path))?;
        self.sync.sync_all().map_err(io(&self.path))?;
        Ok(self.path)
    }
}

/// One message read back from a log.
#[derive(Clone, Debug)]
pub struct LoggedMessage {
    pub topic: String,
    pub sequence: u32,
    pub log_time: u64,
    pub value: Value,
}

/// Everything a log holds.
#[derive(Clone, Debug)]
pub struct LogContents {
    pub path: PathBuf,
    pub protocol_text: String,
    pub start: SessionStart,
    pub start_time_ns: u64,
    /// The events in order.
    pub events: Vec<Stamped>,
    /// Every message, in file order.
    pub messages: Vec<LoggedMessage>,
    /// Whether the file ends with a summary and footer (false: a crash or a quit not yet
    /// finished; everything up to the last whole message is here).
    pub finished: bool,
    /// Whether the file ends in a partial record (cut off by a crash).
    pub cut_tail: bool,
}

/// Reads a log up to its last whole message.
pub fn read_log(path: &Path) -> Result<LogContents, RecordError> {
    let bytes = std::fs::read(path).map_err(io(path))?;
    let not_log = |why: &str| RecordError::NotALog { path: path.to_path_buf(), why: why.to_string() };
    if !bytes.starts_with(mcap::MAGIC) {
        return Err(not_log("it does not start with the MCAP magic bytes"));
    }
    let reader = mcap::read::LinearReader::new_with_options(&bytes, mcap::read::Options::IgnoreEndMagic.into())
        .map_err(mcap_err(path))?;
    let mut topics: HashMap<u16, String> = HashMap::new();
    let mut protocol_text = None;
    let mut messages = Vec::new();
    let mut finished = false;
    let mut cut = false;
    for record in reader {
        let Ok(record) = record else {
            cut = true;
            break;
        };
        match record {
            mcap::records::Record::Channel(c) => {
                topics.insert(c.id, c.topic);
            }
            mcap::records::Record::Attachment { header, data, .. } if header.name == PROTOCOL_ATTACHMENT => {
                protocol_text = Some(String::from_utf8_lossy(&data).into_owned());
            }
            mcap::records::Record::Message { header, data } => {
                let Some(topic) = topics.get(&header.channel_id) else { continue };
                let Ok(value) = serde_json::from_slice::<Value>(&data) else {
                    return Err(not_log(&format!("a {topic} message is not JSON")));
                };
                messages.push(LoggedMessage {
                    topic: topic.clone(),
                    sequence: header.sequence,
                    log_time: header.log_time,
                    value,
                });
            }
            mcap::records::Record::Footer(_) => finished = true,
            _ => {}
        }
    }
    let protocol_text = protocol_text.ok_or_else(|| not_log("it has no protocol attachment"))?;
    let first =
        messages.iter().find(|m| m.topic == "/session/start").ok_or_else(|| not_log("it has no /session/start"))?;
    let start_time_ns = first.log_time;
    let mut start_value = first.value.clone();
    if let Some(o) = start_value.as_object_mut() {
        o.remove("event_index");
    }
    let start: SessionStart =
        serde_json::from_value(start_value).map_err(|e| not_log(&format!("/session/start: {e}")))?;
    let mut events = Vec::new();
    for m in messages.iter().filter(|m| EVENT_TOPICS.contains(&m.topic.as_str())) {
        let event = event_from_message(&m.topic, &m.value).ok_or_else(|| {
            not_log(&format!("a {} message (event {}) cannot be read as an event", m.topic, m.sequence))
        })?;
        events.push((m.sequence, Stamped { time_ns: m.log_time, event }));
    }
    events.sort_by_key(|(s, _)| *s);
    Ok(LogContents {
        path: path.to_path_buf(),
        protocol_text,
        start,
        start_time_ns,
        events: events.into_iter().map(|(_, e)| e).collect(),
        messages,
        finished,
        cut_tail: cut,
    })
}

/// The study of a log's embedded protocol.
pub fn study_of(log: &LogContents) -> Result<Study, RecordError> {
    Study::from_json(&log.protocol_text, &format!("{} (embedded protocol)", log.path.display()))
        .map_err(|source| RecordError::Protocol { path: log.path.clone(), source })
}

/// One replayed event: its index in the log (1, 2, …), the event and what it applied.
pub type ReplayStep<'a> = (usize, &'a Stamped, &'a Applied);

/// Rebuilds the session of a log by folding its events, calling `visit` with the session
/// once at the start (no step) and after every event (with that step).
pub fn replay_with(
    study: Arc<Study>,
    log: &LogContents,
    mut visit: impl FnMut(&Session, Option<ReplayStep>),
) -> Result<Session, RecordError> {
    let err = |index: usize, event: &Event, source: SessionError| RecordError::Replay {
        path: log.path.clone(),
        index,
        topic: messages::topic_of(event).to_string(),
        source: Box::new(source),
    };
    let mut session = Session::new(study, log.start.clone()).map_err(|e| err(0, &Event::Ended, e))?;
    visit(&session, None);
    for (i, s) in log.events.iter().enumerate() {
        let applied = session.apply(&s.event).map_err(|e| err(i + 1, &s.event, e))?;
        visit(&session, Some((i + 1, s, &applied)));
    }
    Ok(session)
}

/// A session whose every event is logged durably before the state moves on.
pub struct RecordedSession {
    session: Session,
    recorder: Recorder,
}

/// Why an event was not taken.
#[derive(Debug, thiserror::Error)]
pub enum SubmitError {
    /// The event does not fit the state; nothing was logged or changed.
    #[error(transparent)]
    Rejected(#[from] SessionError),
    /// The log could not be written; the state is unchanged.
    #[error(transparent)]
    Log(#[from] RecordError),
}

impl RecordedSession {
    /// Starts a new log for a session (new, or replayed from an earlier log).
    pub fn create(path: &Path, protocol_text: &str, session: Session, time_ns: u64) -> Result<Self, RecordError> {
        let recorder = Recorder::create(path, protocol_text, &session, time_ns)?;
        Ok(Self { session, recorder })
    }

    /// Continues an interrupted log in a new file: replays its events and writes them all,
    /// with their original times, before anything new. The old file is left as it is.
    pub fn resume(old: &LogContents, new_path: &Path, time_ns: u64) -> Result<Self, RecordError> {
        let study = Arc::new(study_of(old)?);
        let mut start = old.start.clone();
        start.resumed_from = old.path.file_name().map(|n| n.to_string_lossy().into_owned());
        let session = Session::new(Arc::clone(&study), start).map_err(|source| RecordError::Replay {
            path: old.path.clone(),
            index: 0,
            topic: "/session/start".into(),
            source: Box::new(source),
        })?;
        let mut rec = Self::create(new_path, &old.protocol_text, session, old.start_time_ns.min(time_ns))?;
        for (i, s) in old.events.iter().enumerate() {
            rec.submit(s.clone()).map_err(|e| match e {
                SubmitError::Rejected(source) => RecordError::Replay {
                    path: old.path.clone(),
                    index: i + 1,
                    topic: messages::topic_of(&s.event).into(),
                    source: Box::new(source),
                },
                SubmitError::Log(e) => e,
            })?;
        }
        Ok(rec)
    }

    pub fn session(&self) -> &Session {
        &self.session
    }

    pub fn path(&self) -> &Path {
        self.recorder.path()
    }

    /// Applies an event to a copy of the state, logs it durably, then adopts the new state.
    pub fn submit(&mut self, stamped: Stamped) -> Result<Applied, SubmitError> {
        let mut next = self.session.clone();
        let applied = next.apply(&stamped.event)?;
        self.recorder.record(&stamped, &applied, &next)?;
        self.session = next;
        Ok(applied)
    }

    /// Finishes the file (summary and footer).
    pub fn finish(self) -> Result<PathBuf, RecordError> {
        self.recorder.finish()
    }
}

/// Every `.mcap` file under `root` (recursively), sorted; a file is itself.
pub fn mcap_files(root: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    if root.is_file() {
        out.push(root.to_path_buf());
        return out;
    }
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else { continue };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "mcap") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// Completed real (not pilot) sessions per counterbalancing slot in the logs under `root`,
/// each session counted once however often it was resumed.
pub fn completed_per_slot(root: &Path, slots: usize) -> Vec<usize> {
    let mut counts = vec![0; slots];
    let mut seen = std::collections::HashSet::new();
    for path in mcap_files(root) {
        let Ok(log) = read_log(&path) else { continue };
        let completed = log.events.iter().any(|e| e.event == Event::Ended);
        if completed && !log.start.pilot && log.start.slot < slots && seen.insert(log.start.session_id.clone()) {
            counts[log.start.slot] += 1;
        }
    }
    counts
}

/// The slot with the fewest completed real sessions (the first on ties): dropouts and
/// pilots do not use up a slot.
pub fn least_filled_slot(root: &Path, slots: usize) -> usize {
    let counts = completed_per_slot(root, slots);
    (0..slots).min_by_key(|&i| (counts[i], i)).unwrap_or(0)
}
