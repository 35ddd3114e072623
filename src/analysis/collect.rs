//! Which logs count: a session is counted once, from its most complete log.

use std::collections::BTreeMap;

use super::SessionAnalysis;
use crate::record::LogContents;

/// A log and what its replay found.
#[derive(Clone, Debug)]
pub struct Analysed {
    pub log: LogContents,
    pub analysis: SessionAnalysis,
}

/// The most complete log of each session (a session is its id under its protocol:
/// `dry-run --versus` runs the same ids under two protocols): more events, then finished,
/// wins; the first read wins a tie. The others are named in the warnings.
pub fn most_complete(logs: impl IntoIterator<Item = LogContents>) -> (Vec<LogContents>, Vec<String>) {
    let mut by_session: BTreeMap<(String, String), LogContents> = BTreeMap::new();
    let mut warnings = Vec::new();
    for log in logs {
        let id = (log.start.session_id.clone(), log.start.protocol_sha256.clone());
        let superseded = |old: &LogContents, new: &LogContents| {
            format!("{}: superseded by {} (same session, resumed)", old.path.display(), new.path.display())
        };
        match by_session.get(&id) {
            Some(old) if (old.events.len(), old.finished) >= (log.events.len(), log.finished) => {
                warnings.push(superseded(&log, old));
            }
            Some(old) => {
                warnings.push(superseded(old, &log));
                by_session.insert(id, log);
            }
            None => {
                by_session.insert(id, log);
            }
        }
    }
    (by_session.into_values().collect(), warnings)
}
