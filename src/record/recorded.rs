//! The recorded session: the one place an event is applied, logged and synced, then adopted;
//! and the continuation of an interrupted log.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::{LogContents, RecordError, Recorder, Topic, messages, study_of};
use crate::session::{Applied, Session, SessionError, Stamped};

/// A session whose every event is logged durably before the state moves on.
pub struct RecordedSession {
    pub(super) session: Session,
    pub(super) recorder: Recorder,
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

    /// Sends every message to `tap` too once it is on disk (see [`super::Tap`]).
    pub fn set_tap(&mut self, tap: Box<dyn super::Tap>) {
        self.recorder.set_tap(tap);
    }

    /// Log time of the last event on disk (of the start before any).
    pub fn last_time_ns(&self) -> u64 {
        self.recorder.last_time_ns()
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

    /// Learns ahead for the presented query ([`Session::speculate`]); nothing is logged.
    pub fn speculate(&mut self, stop: &mut dyn FnMut() -> bool) -> bool {
        self.session.speculate(stop)
    }

    /// Finishes the file (summary and footer).
    pub fn finish(self) -> Result<PathBuf, RecordError> {
        self.recorder.finish()
    }
}
