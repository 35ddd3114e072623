//! The session log: one MCAP file per session, JSON messages with a JSON Schema per topic,
//! one chunk and its message indexes per event, synced to disk after every event, so that a
//! crash loses nothing and a viewer seeks through the index.
//! `recorder` writes, `reader` reads back, `replay` folds the events into a session,
//! `recorded` is the session whose events are logged before they are adopted, `lineage`
//! follows continuations, `follow` reads a log as it is written, `paths` names the files.

mod follow;
pub mod foxglove;
mod integrity;
pub use integrity::problems as integrity_problems;
mod lineage;
mod messages;
mod paths;
mod reader;
mod recorded;
mod recorder;
mod replay;
mod scene;
mod schemas;
mod topic;
pub mod types;
mod writer;

use std::path::{Path, PathBuf};

use crate::protocol::ProtocolError;
use crate::session::SessionError;

pub use follow::Follower;
pub use lineage::{Lineage, is_over, lineage, open_sessions, session_heads};
pub use paths::{
    continuation_path, is_log_file_name, log_folder, log_path_in, mcap_files, mcap_files_reporting, new_log_path,
};
pub use reader::{
    LogContents, LoggedMessage, MAX_LOG_BYTES, MAX_TEXT_BYTES, read_log, read_log_bytes, study_of, validate_start,
};
pub use recorded::{RecordedSession, SubmitError};
pub use recorder::{Recorder, SharedTap, Tap};
pub use replay::{ReplayStep, replay_rest, replay_with};

pub use messages::{event_from_message, messages_for, start_messages, topic_of as event_topic};
pub use schemas::schema;
pub use topic::Topic;
pub use writer::{McapWriter, Sink};

/// The log format this version writes (`/session/start`'s `log_format`; a log without one is
/// format 1). Readers accept every format up to it; a change to a topic's name, schema or
/// message shape, or to the file's layout, raises it (`docs/log-format.md`, "Formats").
/// 1: unindexed records, `/test/log_likelihood` for every condition, the body only at the start.
/// 2: one chunk and its message indexes per event, schemas in the viewers' subset,
///    `/test/log_likelihood/<condition>`, `/session/transition`, the body in every
///    `/human/arm`, seeds below 2^53.
/// 3: `/session/start`'s `selection`: a session that learns from the measured arm scores
///    its queries' measured outcomes (format 2 scored regions).
/// 4: robot commands have ids (`/robot/command`'s `command`), and each `/robot/status` says
///    which command it answers and whether it is stale.
/// 5: the 3D scene: a `view` frame the layout's camera follows; the last grasp's arm deleted
///    with each query, undo and retracting void; grip labels as the participant has them, in
///    a column above the object.
pub const LOG_FORMAT: u32 = 5;

/// What `handover --version` says: the software's version and the log format it writes.
pub const VERSION: &str = concat!(env!("CARGO_PKG_VERSION"), " (writes log format 5, reads 1 to 5)");

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

pub(crate) fn io(path: &Path) -> impl Fn(std::io::Error) -> RecordError + '_ {
    move |source| RecordError::Io { path: path.to_path_buf(), source }
}

pub(crate) fn mcap_err(path: &Path) -> impl Fn(mcap::McapError) -> RecordError + '_ {
    move |e| RecordError::Mcap { path: path.to_path_buf(), message: e.to_string() }
}

#[cfg(test)]
mod tests;
