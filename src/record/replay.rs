//! The replay: a log's session rebuilt by folding its events.

use std::sync::Arc;

use super::{LogContents, RecordError, messages};
use crate::protocol::Study;
use crate::session::{Applied, Event, Session, SessionError, Stamped};

/// One replayed event: its index in the log (1, 2, …), the event and what it applied.
pub type ReplayStep<'a> = (usize, &'a Stamped, &'a Applied);

/// Rebuilds the session of a log by folding its events, calling `visit` with the session
/// once at the start (no step) and after every event (with that step).
pub fn replay_with(
    study: Arc<Study>,
    log: &LogContents,
    mut visit: impl FnMut(&Session, Option<ReplayStep>),
) -> Result<Session, RecordError> {
    let mut session = Session::new(study, log.start.clone()).map_err(|e| replay_error(log, 0, &Event::Ended, e))?;
    visit(&session, None);
    for (i, s) in log.events.iter().enumerate() {
        let applied = session.apply(&s.event).map_err(|e| replay_error(log, i + 1, &s.event, e))?;
        visit(&session, Some((i + 1, s, &applied)));
    }
    Ok(session)
}

/// Folds the log's events after the first `done` into a session already folded over those
/// (a log followed as it grows).
pub fn replay_rest(session: &mut Session, log: &LogContents, done: usize) -> Result<(), RecordError> {
    for (i, s) in log.events.iter().enumerate().skip(done) {
        session.apply(&s.event).map_err(|e| replay_error(log, i + 1, &s.event, e))?;
    }
    Ok(())
}

fn replay_error(log: &LogContents, index: usize, event: &Event, source: SessionError) -> RecordError {
    RecordError::Replay {
        path: log.path.clone(),
        index,
        topic: messages::topic_of(event).to_string(),
        source: Box::new(source),
    }
}
