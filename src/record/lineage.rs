//! Where a log stands among its session's logs: continued or not, and its newest
//! continuation (the one to resume).

use std::path::{Path, PathBuf};

use super::paths::created_key;
use super::{LogContents, read_log};
use crate::session::Event;

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

/// The sessions in a participant's log folder that are not over, one log each: the newest
/// log of the session that no other continues (the one `resume` continues), oldest session
/// first. Links and anything but regular files are passed over.
pub fn open_sessions(dir: &Path) -> Vec<LogContents> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut names: Vec<PathBuf> = entries
        .flatten()
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
        .collect();
    names.sort();
    let logs: Vec<LogContents> = names.iter().filter_map(|p| read_log(p).ok()).collect();
    session_heads(&logs).into_iter().filter(|l| !is_over(l)).cloned().collect()
}

/// Of logs already read, the head of each session: per folder and session id, the log no
/// other continues (of a fork's branches, the one created last), in the order given.
pub fn session_heads(logs: &[LogContents]) -> Vec<&LogContents> {
    let file_name = |p: &Path| p.file_name().map(|n| n.to_string_lossy().into_owned());
    let same = |a: &LogContents, b: &LogContents| {
        a.start.session_id == b.start.session_id && a.path.parent() == b.path.parent()
    };
    let continued = |l: &LogContents| logs.iter().any(|o| same(o, l) && o.start.resumed_from == file_name(&l.path));
    let mut heads: Vec<&LogContents> = Vec::new();
    for l in logs.iter().filter(|l| !continued(l)) {
        match heads.iter_mut().find(|h| same(h, l)) {
            Some(h) if created_key(&l.path) > created_key(&h.path) => *h = l,
            Some(_) => {}
            None => heads.push(l),
        }
    }
    heads
}

/// Whether a log's session is over (ended or aborted): such a log is only read, never
/// continued.
pub fn is_over(log: &LogContents) -> bool {
    log.events.iter().any(|e| matches!(e.event, Event::Ended | Event::Aborted { .. }))
}
