//! The session log: one MCAP file per session, JSON messages with a JSON Schema per topic,
//! unchunked and synced to disk after every event, so that a crash loses nothing. Also the
//! reader (tolerant of a truncated tail) and the replay that rebuilds a session from a log.

pub mod foxglove;
mod integrity;
mod messages;
mod scene;
mod schemas;
mod topic;
pub mod types;
mod writer;

use std::collections::HashMap;
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde_json::Value;

use crate::protocol::{ProtocolError, Study};
use crate::session::{Applied, Event, Session, SessionError, SessionStart, Stamped};

pub use messages::{event_from_message, messages_for, start_messages, topic_of as event_topic};
pub use schemas::schema;
pub use topic::Topic;
pub use writer::{McapWriter, Sink};

/// Name of the attachment that holds the protocol text.
pub const PROTOCOL_ATTACHMENT: &str = "protocol.json";

/// Why a log could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error(
        "{path}: the log could not be written: {cause}; nothing after event {last_event} is recorded{}",
        if *restored { "" } else { " (and the file could not be cut back: do not write to it again)" }
    )]
    Write { path: PathBuf, last_event: usize, restored: bool, cause: std::io::Error },
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

/// `logs/<participant>/<participant>_<UTC time>.mcap` (the id must be valid: it becomes a
/// file name). The recorder adds a suffix if that name is taken when it creates the file.
pub fn new_log_path(logs: &Path, participant: &str, time: chrono::DateTime<chrono::Utc>) -> PathBuf {
    log_path_in(&logs.join(participant), participant, time)
}

/// `<dir>/<participant>_<UTC time>.mcap`.
pub fn log_path_in(dir: &Path, participant: &str, time: chrono::DateTime<chrono::Utc>) -> PathBuf {
    dir.join(format!("{participant}_{}.mcap", time.format("%Y%m%dT%H%M%SZ")))
}

/// The folder a log is in ("." for a bare file name): where its continuation and its
/// participant's lock live.
pub fn log_folder(log: &Path) -> PathBuf {
    log.parent().filter(|d| !d.as_os_str().is_empty()).map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// Where the continuation of `old` is written: beside it, named after its participant id
/// (validated when the log was read) — never a path taken from the log's content.
pub fn continuation_path(old: &LogContents, time: chrono::DateTime<chrono::Utc>) -> PathBuf {
    log_path_in(&log_folder(&old.path), &old.start.participant, time)
}

/// Creates `path` owner-only, or, if that name is taken, `<stem>-2.mcap`, `-3`, … (two
/// consoles started in the same second each get their own file; nothing is overwritten).
/// When a log file was created, from the name [`log_path_in`] and [`create_unique`] give it:
/// (`YYYYMMDDTHHMMSSZ`, the `-k` suffix of a name taken in the same second, 1 without).
fn created_key(path: &Path) -> Option<(String, u32)> {
    let stem = path.file_stem()?.to_str()?;
    let (_, stamp) = stem.rsplit_once('_')?;
    let (time, k) = match stamp.split_once('-') {
        Some((t, k)) => (t, k.parse().ok()?),
        None => (stamp, 1),
    };
    let digits = |s: &str| s.bytes().all(|b| b.is_ascii_digit());
    (time.len() == 16 && digits(&time[..8]) && &time[8..9] == "T" && digits(&time[9..15]) && time.ends_with('Z'))
        .then(|| (time.to_string(), k))
}

fn create_unique(path: &Path) -> std::io::Result<(PathBuf, File)> {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let mut candidate = path.to_path_buf();
    for k in 2..=1000 {
        match crate::private_files::create_file(&candidate) {
            Ok(f) => return Ok((candidate, f)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                candidate = path.with_file_name(format!("{stem}-{k}.mcap"));
            }
            Err(e) => return Err(e),
        }
    }
    Err(std::io::Error::new(std::io::ErrorKind::AlreadyExists, "1000 logs of that name exist"))
}

/// Writes one session's log. Every `record` call returns only after the event's messages
/// are on disk (written as one buffer and synced); a failed write leaves the file as it was
/// after the last good event, so a retry logs the event once.
pub struct Recorder {
    path: PathBuf,
    writer: McapWriter<Box<dyn Sink>>,
    channels: HashMap<Topic, u16>,
    /// Index of the last event on disk.
    last_index: usize,
    /// Log time of the last message on disk.
    last_time_ns: u64,
}

impl Recorder {
    /// Creates the log file (owner-only, never overwriting: a taken name gets a suffix),
    /// writes the protocol, the start record and the initial beliefs, and syncs. If any of
    /// that fails, no file is left behind.
    pub fn create(path: &Path, protocol_text: &str, session: &Session, time_ns: u64) -> Result<Self, RecordError> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            crate::private_files::create_dir(dir).map_err(io(dir))?;
        }
        let (path, file) = create_unique(path).map_err(io(path))?;
        match Self::start(Box::new(file), &path, protocol_text, session, time_ns) {
            Ok(rec) => {
                crate::private_files::sync_parent(&path);
                Ok(rec)
            }
            Err(e) => {
                let _ = std::fs::remove_file(&path);
                Err(e)
            }
        }
    }

    /// The header, schemas, channels, protocol, start record and initial beliefs, in one
    /// durable commit.
    fn start(
        sink: Box<dyn Sink>,
        path: &Path,
        protocol_text: &str,
        session: &Session,
        time_ns: u64,
    ) -> Result<Self, RecordError> {
        let library = format!("handover {}", env!("CARGO_PKG_VERSION"));
        let mut writer = McapWriter::new(sink, &library).map_err(commit_err(path, 0))?;
        let mut channels = HashMap::new();
        let conditions = &session.start().condition_order;
        let mut schema_ids: HashMap<&str, u16> = HashMap::new();
        for topic in Topic::ALL.into_iter().filter(|t| t.used_by(conditions)) {
            let (name, schema) = schema(topic);
            let sid =
                *schema_ids.entry(name).or_insert_with(|| writer.add_schema(name, "jsonschema", schema.as_bytes()));
            channels.insert(topic, writer.add_channel(sid, topic.name(), "json"));
        }
        writer.attach(time_ns, time_ns, PROTOCOL_ATTACHMENT, "application/json", protocol_text.as_bytes());
        let mut rec = Self { path: path.to_path_buf(), writer, channels, last_index: 0, last_time_ns: time_ns };
        rec.write(&messages::start_messages(session, time_ns), 0, time_ns)?;
        Ok(rec)
    }

    #[cfg(test)]
    fn with_sink(sink: Box<dyn Sink>, protocol_text: &str, session: &Session) -> Result<Self, RecordError> {
        Self::start(sink, Path::new("test.mcap"), protocol_text, session, 1)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Index of the last event on disk (0: only the start).
    pub fn last_index(&self) -> usize {
        self.last_index
    }

    /// Logs one applied event (and what it derived), durably; on failure nothing of it is
    /// in the file and the index does not move.
    pub fn record(&mut self, stamped: &Stamped, applied: &Applied, session: &Session) -> Result<(), RecordError> {
        let index = self.last_index + 1;
        let msgs = messages_for(stamped, index, applied, session);
        let topic = messages::topic_of(&stamped.event);
        if !msgs.iter().any(|(t, _)| *t == topic) {
            // An event is never dropped: one the log cannot hold stops the session.
            return Err(RecordError::Io {
                path: self.path.clone(),
                source: std::io::Error::other(format!("the event {:?} was applied as {applied:?}", stamped.event)),
            });
        }
        self.write(&msgs, index as u32, stamped.time_ns)?;
        self.last_index = index;
        self.last_time_ns = stamped.time_ns;
        Ok(())
    }

    fn not_serialisable(&self, e: serde_json::Error) -> RecordError {
        RecordError::Io { path: self.path.clone(), source: std::io::Error::other(e) }
    }

    fn write(&mut self, msgs: &[(Topic, Value)], sequence: u32, time_ns: u64) -> Result<(), RecordError> {
        for (topic, value) in msgs {
            let data = serde_json::to_vec(value).map_err(|e| self.not_serialisable(e))?;
            let Some(&channel) = self.channels.get(topic) else {
                let why = format!("{topic} has no channel in this log");
                return Err(RecordError::Io { path: self.path.clone(), source: std::io::Error::other(why) });
            };
            self.writer.message(&writer::Message { channel, sequence, log_time: time_ns, data: &data });
        }
        self.writer.commit().map_err(commit_err(&self.path, self.last_index))
    }

    /// Writes the summary and footer (a finished file) and syncs.
    pub fn finish(self) -> Result<PathBuf, RecordError> {
        let path = self.path;
        self.writer.finish().map_err(commit_err(&path, self.last_index))?;
        Ok(path)
    }
}

fn commit_err(path: &Path, last: usize) -> impl Fn(writer::CommitError) -> RecordError + '_ {
    move |e| RecordError::Write { path: path.to_path_buf(), last_event: last, restored: e.restored, cause: e.source }
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
    /// What the file's CRCs and its schema and channel records say is wrong (reported by
    /// `analyze --verify`; empty for an intact log).
    pub integrity: Vec<String>,
}

/// The largest log read (a whole study session is well under 10 MiB).
pub const MAX_LOG_BYTES: u64 = 256 << 20;
/// The longest note or void detail in a log, in bytes.
pub const MAX_TEXT_BYTES: usize = 10_000;

/// Checks a log's start record with the same rules as on creation: ids that become file
/// names, labels, the slot, the times and the simulated truth.
pub fn validate_start(start: &SessionStart) -> Result<(), String> {
    crate::participant::validate_id(&start.participant).map_err(|e| format!("participant: {e}"))?;
    let session_ok = (1..=64).contains(&start.session_id.len())
        && start.session_id.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-');
    if !session_ok {
        return Err(format!(
            "session_id '{}' is invalid: expected 1 to 64 characters from A–Z, a–z, 0–9 and '-'",
            start.session_id.escape_debug()
        ));
    }
    let printable = |field: &str, v: &str, max: usize| {
        if v.len() > max || v.chars().any(char::is_control) {
            Err(format!("{field} is not a printable text of at most {max} bytes"))
        } else {
            Ok(())
        }
    };
    printable("protocol_name", &start.protocol_name, 200)?;
    printable("software_version", &start.software_version, 64)?;
    if start.protocol_sha256.len() != 64 || !start.protocol_sha256.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err("protocol_sha256 is not 64 hexadecimal digits".into());
    }
    for (i, l) in start.program_labels.iter().enumerate() {
        printable(&format!("program_labels[{i}]"), l, 100)?;
    }
    if start.slot >= 2 {
        return Err(format!("slot is {}, expected 0 or 1 (the orders AB and BA)", start.slot));
    }
    if chrono::DateTime::parse_from_rfc3339(&start.started_at).is_err() {
        return Err(format!("started_at '{}' is not an RFC 3339 time", start.started_at.escape_debug()));
    }
    if let Some(name) = &start.resumed_from
        && !is_log_file_name(name)
    {
        return Err(format!(
            "resumed_from '{}' is not a log file name (A–Z, a–z, 0–9, '-', '_', ending in .mcap)",
            name.escape_debug()
        ));
    }
    if let Some(t) = &start.simulated_truth {
        let ok = t.q_star.len() == t.w.len()
            && t.q_star.len() <= 64
            && t.q_star.iter().all(|v| v.is_finite() && v.abs() <= 10.0)
            && t.w.iter().all(|v| v.is_finite() && (0.0..=1e3).contains(v));
        if !ok {
            return Err("simulated_truth is not a λ of finite angles (|q*| ≤ 10 rad) and weights in [0, 1000]".into());
        }
    }
    Ok(())
}

/// Whether `name` is a plain log file name (no directory, no leading dot).
pub fn is_log_file_name(name: &str) -> bool {
    name.len() <= 128
        && name.ends_with(".mcap")
        && !name.starts_with('.')
        && name.bytes().all(|b| b.is_ascii_alphanumeric() || matches!(b, b'-' | b'_' | b'.'))
}

fn validate_event(event: &Event) -> Result<(), String> {
    let long = |field: &str, v: &str| {
        if v.len() > MAX_TEXT_BYTES {
            Err(format!("{field} has {} bytes, expected at most {MAX_TEXT_BYTES}", v.len()))
        } else {
            Ok(())
        }
    };
    match event {
        Event::Note { text } => long("text", text),
        Event::TrialVoided { detail, .. } => long("detail", detail),
        Event::Aborted { reason } => long("reason", reason),
        _ => Ok(()),
    }
}

/// Reads a log up to its last whole message. Everything in it is untrusted: the size is
/// bounded, the start record is validated and every event is checked before use.
pub fn read_log(path: &Path) -> Result<LogContents, RecordError> {
    let not_log = |why: &str| RecordError::NotALog { path: path.to_path_buf(), why: why.to_string() };
    let len = std::fs::metadata(path).map_err(io(path))?.len();
    if len > MAX_LOG_BYTES {
        return Err(not_log(&format!("it has {len} bytes, over the budget of {MAX_LOG_BYTES} bytes for a log")));
    }
    let mut bytes = Vec::new();
    File::open(path).and_then(|f| f.take(MAX_LOG_BYTES + 1).read_to_end(&mut bytes)).map_err(io(path))?;
    if bytes.len() as u64 > MAX_LOG_BYTES {
        return Err(not_log(&format!("it is over the budget of {MAX_LOG_BYTES} bytes for a log")));
    }
    if !bytes.starts_with(mcap::MAGIC) {
        return Err(not_log("it does not start with the MCAP magic bytes"));
    }
    let reader = mcap::read::LinearReader::new_with_options(&bytes, mcap::read::Options::IgnoreEndMagic.into())
        .map_err(mcap_err(path))?;
    let mut topics: HashMap<u16, String> = HashMap::new();
    let mut declared = integrity::Declared::default();
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
                declared.channels.push((c.id, c.topic.clone(), c.schema_id, c.message_encoding));
                topics.insert(c.id, c.topic);
            }
            mcap::records::Record::Schema { header, data } => {
                declared.schemas.push((header.id, header.name, header.encoding, data.into_owned()));
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
    let first = messages
        .iter()
        .find(|m| m.topic == Topic::SessionStart.name())
        .ok_or_else(|| not_log("it has no /session/start"))?;
    let start_time_ns = first.log_time;
    let mut start_value = first.value.clone();
    let mut seed_decimal = None;
    if let Some(o) = start_value.as_object_mut() {
        o.remove("event_index");
        seed_decimal = o.remove("seed_decimal");
    }
    let start: SessionStart =
        serde_json::from_value(start_value).map_err(|e| not_log(&format!("/session/start: {e}")))?;
    validate_start(&start).map_err(|e| not_log(&format!("/session/start: {e}")))?;
    // Logs before the text seed lack it; when present it must be the seed.
    if let Some(d) = seed_decimal
        && d.as_str() != Some(start.seed.to_string().as_str())
    {
        return Err(not_log(&format!("/session/start: seed_decimal {d} is not the seed {}", start.seed)));
    }
    let mut events = Vec::new();
    for (m, topic) in messages.iter().filter_map(|m| Some((m, Topic::from_name(&m.topic).filter(|t| t.is_event())?))) {
        let event = event_from_message(topic, &m.value).ok_or_else(|| {
            not_log(&format!("a {} message (event {}) cannot be read as an event", m.topic, m.sequence))
        })?;
        validate_event(&event).map_err(|e| not_log(&format!("{} (event {}): {e}", m.topic, m.sequence)))?;
        events.push((m.sequence, Stamped { time_ns: m.log_time, event }));
    }
    events.sort_by_key(|(s, _)| *s);
    let mut problems = integrity::check_crcs(&bytes);
    problems.extend(integrity::check_declarations(&declared, start.software_version == env!("CARGO_PKG_VERSION")));
    Ok(LogContents {
        path: path.to_path_buf(),
        protocol_text,
        start,
        start_time_ns,
        events: events.into_iter().map(|(_, e)| e).collect(),
        messages,
        finished,
        cut_tail: cut,
        integrity: problems,
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
            topic: Topic::SessionStart.to_string(),
            source: Box::new(source),
        })?;
        let mut rec = Self::create(new_path, &old.protocol_text, session, old.start_time_ns.min(time_ns))?;
        for (i, s) in old.events.iter().enumerate() {
            rec.submit(s.clone()).map_err(|e| match e {
                SubmitError::Rejected(source) => RecordError::Replay {
                    path: old.path.clone(),
                    index: i + 1,
                    topic: messages::topic_of(&s.event).to_string(),
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

    /// Log time of the last event on disk (of the start before any).
    pub fn last_time_ns(&self) -> u64 {
        self.recorder.last_time_ns
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

/// Where a log stands among the logs of its session in the same folder.
#[derive(Debug)]
pub struct Lineage {
    /// The newest continuation of the log (following `resumed_from` links), if it was
    /// resumed; `None` when the log itself is the newest.
    pub newest: Option<LogContents>,
    /// How many logs continue this one directly (more than one: it was forked before).
    pub direct_continuations: usize,
}

/// Follows the continuations of `log` among the logs beside it (same folder, same session
/// id): the one to resume is the newest, never a superseded one.
pub fn lineage(log: &LogContents) -> Lineage {
    let dir = log.path.parent().unwrap_or(Path::new("."));
    let Ok(entries) = std::fs::read_dir(dir) else { return Lineage { newest: None, direct_continuations: 0 } };
    let mut names: Vec<PathBuf> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "mcap") && p.is_file())
        .collect();
    names.sort();
    let family: Vec<LogContents> = names
        .iter()
        .filter(|p| **p != log.path)
        .filter_map(|p| read_log(p).ok())
        .filter(|l| l.start.session_id == log.start.session_id && l.start.resumed_from.is_some())
        .collect();
    let file_name = |p: &Path| p.file_name().map(|n| n.to_string_lossy().into_owned());
    let children = |name: &Option<String>| -> Vec<&LogContents> {
        family.iter().filter(|l| l.start.resumed_from == *name).collect()
    };
    let direct = children(&file_name(&log.path)).len();
    let mut newest: Option<&LogContents> = None;
    let mut seen = std::collections::HashSet::new();
    loop {
        let current = newest.map_or_else(|| file_name(&log.path), |l| file_name(&l.path));
        // Of several continuations (a fork), the one created last: by the UTC time its name
        // was given (a dry run's log times are simulated and say nothing of when a file was
        // written), then by its last log time.
        let next = children(&current)
            .into_iter()
            .filter(|l| seen.insert(l.path.clone()))
            .max_by_key(|l| (created_key(&l.path), l.messages.last().map_or(0, |m| m.log_time), l.path.clone()));
        match next {
            Some(l) => newest = Some(l),
            None => break,
        }
    }
    Lineage { newest: newest.cloned(), direct_continuations: direct }
}

/// Whether a log's session is over (ended or aborted): such a log is only read, never
/// continued.
pub fn is_over(log: &LogContents) -> bool {
    log.events.iter().any(|e| matches!(e.event, Event::Ended | Event::Aborted { .. }))
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
/// each session counted once however often it was resumed; sessions of participants whose
/// record in `participants` says they withdrew do not count.
pub fn completed_per_slot(root: &Path, participants: &Path, slots: usize) -> Vec<usize> {
    let mut counts = vec![0; slots];
    let mut seen = std::collections::HashSet::new();
    for path in mcap_files(root) {
        let Ok(log) = read_log(&path) else { continue };
        let completed = log.events.iter().any(|e| e.event == Event::Ended);
        if completed
            && !log.start.pilot
            && log.start.slot < slots
            && !crate::participant::has_withdrawn(participants, &log.start.participant)
            && seen.insert(log.start.session_id.clone())
        {
            counts[log.start.slot] += 1;
        }
    }
    counts
}

/// The slot with the fewest completed real sessions (the first on ties): dropouts, pilots
/// and withdrawn participants do not use up a slot.
pub fn least_filled_slot(root: &Path, participants: &Path, slots: usize) -> usize {
    let counts = completed_per_slot(root, participants, slots);
    (0..slots).min_by_key(|&i| (counts[i], i)).unwrap_or(0)
}

#[cfg(test)]
mod tests;
