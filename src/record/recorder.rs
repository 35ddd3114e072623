//! The recorder: writes one session's log, each event durable before the call returns.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde_json::Value;

use super::paths::create_unique;
use super::writer::{self, McapWriter, Sink};
use super::{PROTOCOL_ATTACHMENT, RecordError, Topic, io, messages, messages_for, schema};
use crate::session::{Applied, Session, Stamped};

/// Where a session's messages also go once they are on disk (a live view). It must not
/// block: it runs on the recording thread. A tap knows every topic before the session
/// starts (`Topic::ALL`; the live view makes their channels when it starts).
pub trait Tap: Send {
    /// One message of `topic`, logged at `time_ns`, as the log holds it (JSON).
    fn publish(&mut self, topic: Topic, time_ns: u64, data: &[u8]);
    /// Another handle on the same destination (one per session).
    fn boxed_clone(&self) -> Box<dyn Tap>;
}

/// A [`Tap`] that configurations can hold: cloned per session, printed by name.
pub struct SharedTap(pub Box<dyn Tap>);

impl Clone for SharedTap {
    fn clone(&self) -> Self {
        Self(self.0.boxed_clone())
    }
}

impl std::fmt::Debug for SharedTap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SharedTap")
    }
}

/// Writes one session's log. Every `record` call returns only after the event's messages
/// are on disk (written as one buffer and synced); a failed write leaves the file as it was
/// after the last good event, so a retry logs the event once.
pub struct Recorder {
    path: PathBuf,
    writer: McapWriter<Box<dyn Sink>>,
    channels: HashMap<Topic, u16>,
    /// The schemas written, by name.
    schema_ids: HashMap<&'static str, u16>,
    /// Index of the last event on disk.
    last_index: usize,
    /// Log time of the last message on disk.
    last_time_ns: u64,
    /// Where messages also go once on disk.
    tap: Option<Box<dyn Tap>>,
    /// The start's messages and time (for a tap set later).
    start: (Vec<(Topic, Vec<u8>)>, u64),
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
        let writer = McapWriter::new(sink, &library).map_err(commit_err(path, 0))?;
        let mut rec = Self {
            path: path.to_path_buf(),
            writer,
            channels: HashMap::new(),
            schema_ids: HashMap::new(),
            last_index: 0,
            last_time_ns: time_ns,
            tap: None,
            start: (Vec::new(), time_ns),
        };
        let conditions = &session.start().condition_order;
        for topic in Topic::ALL.into_iter().filter(|t| t.used_by(conditions)) {
            rec.add_channel(topic);
        }
        rec.writer.attach(time_ns, time_ns, PROTOCOL_ATTACHMENT, "application/json", protocol_text.as_bytes());
        rec.start.0 = rec.write(&messages::start_messages(session, time_ns), 0, time_ns)?;
        Ok(rec)
    }

    #[cfg(test)]
    pub(super) fn with_sink(sink: Box<dyn Sink>, protocol_text: &str, session: &Session) -> Result<Self, RecordError> {
        Self::start(sink, Path::new("test.mcap"), protocol_text, session, 1)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Log time of the last event on disk (of the start before any).
    pub fn last_time_ns(&self) -> u64 {
        self.last_time_ns
    }

    /// Sends every message from now on to `tap` too, starting with the session's start (the
    /// frames, the body, the priors), so that a viewer has the scene.
    pub fn set_tap(&mut self, mut tap: Box<dyn Tap>) {
        for (topic, data) in &self.start.0 {
            tap.publish(*topic, self.start.1, data);
        }
        self.tap = Some(tap);
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

    /// Stages a topic's channel (and its schema, once per schema).
    fn add_channel(&mut self, topic: Topic) -> u16 {
        let (name, schema) = schema(topic);
        let writer = &mut self.writer;
        let sid =
            *self.schema_ids.entry(name).or_insert_with(|| writer.add_schema(name, "jsonschema", schema.as_bytes()));
        let id = self.writer.add_channel(sid, topic.name(), "json");
        self.channels.insert(topic, id);
        id
    }

    /// Writes and syncs one event's messages; what was written.
    fn write(
        &mut self,
        msgs: &[(Topic, Value)],
        sequence: u32,
        time_ns: u64,
    ) -> Result<Vec<(Topic, Vec<u8>)>, RecordError> {
        // Channels (and schemas) registered with this commit are forgotten again if it fails.
        let mut added: Vec<Topic> = Vec::new();
        let mut written = Vec::with_capacity(msgs.len());
        for (topic, value) in msgs {
            let data = serde_json::to_vec(value).map_err(|e| self.not_serialisable(e))?;
            let channel = match self.channels.get(topic) {
                Some(&c) => c,
                None if topic.registered_on_use() => {
                    added.push(*topic);
                    self.add_channel(*topic)
                }
                None => {
                    let why = format!("{topic} has no channel in this log");
                    return Err(RecordError::Io { path: self.path.clone(), source: std::io::Error::other(why) });
                }
            };
            self.writer.message(&writer::Message { channel, sequence, log_time: time_ns, data: &data });
            written.push((*topic, data));
        }
        if let Err(e) = self.writer.commit() {
            for topic in added {
                self.channels.remove(&topic);
                self.schema_ids.remove(schema(topic).0);
            }
            return Err(commit_err(&self.path, self.last_index)(e));
        }
        if let Some(tap) = self.tap.as_mut() {
            for (topic, data) in &written {
                tap.publish(*topic, time_ns, data);
            }
        }
        Ok(written)
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
