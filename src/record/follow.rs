//! A log followed as it is written, by a second, read-only screen (`handover follow`): the
//! session folded over the events on disk so far, brought up to date when the file grows,
//! and carried over to the continuation when the session is resumed in a new log.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::{LogContents, RecordError, is_over, lineage, read_log, replay_rest, replay_with, study_of};
use crate::session::Session;

/// The session of a log being written, as far as it is on disk. Reads only; never locks.
pub struct Follower {
    log: LogContents,
    session: Session,
    /// The file's length when last read.
    len: u64,
    /// The other logs beside it (name and length) when last looked at: a continuation is
    /// looked for when they change (one listing of a participant's folder per poll).
    beside: Vec<(PathBuf, u64)>,
}

impl Follower {
    /// Reads and replays the log (everything in it untrusted, as for any log).
    pub fn open(path: &Path) -> Result<Self, RecordError> {
        let log = read_log(path)?;
        let study = Arc::new(study_of(&log)?);
        let session = replay_with(study, &log, |_, _| {})?;
        let len = file_len(path);
        Ok(Self { log, session, len, beside: Vec::new() })
    }

    /// Brings the session up to date: the events appended since the last read are folded
    /// in; a log continued elsewhere is followed into its newest continuation, whether it was
    /// closed by a quit or left open by a crash or `kill -9` (the continuation is looked for
    /// whenever a log appears or grows beside it). Whether anything changed.
    pub fn poll(&mut self) -> Result<bool, RecordError> {
        let len = file_len(&self.log.path);
        if len != self.len {
            let log = read_log(&self.log.path)?;
            self.len = len;
            let done = self.log.events.len();
            if log.start != self.log.start || log.events.len() < done || log.events[..done] != self.log.events[..] {
                // Not the file it was (replaced or cut): start over.
                *self = Self::open(&self.log.path.clone())?;
                return Ok(true);
            }
            replay_rest(&mut self.session, &log, done)?;
            self.log = log;
            return Ok(true);
        }
        if is_over(&self.log) {
            return Ok(false);
        }
        let beside = logs_beside(&self.log.path);
        if beside == self.beside {
            return Ok(false);
        }
        self.beside = beside;
        let Some(newest) = lineage(&self.log).newest else { return Ok(false) };
        // A continuation first copies every event of the log it continues, one synced
        // event at a time: until it holds them all it shows an older state (an earlier
        // trial's pose), so the screen stays on this log (and "console lost") until then.
        // It grows with each copied event, so the next look at it comes with the next poll.
        let next = Self::open(&newest.path)?;
        if !next.log.events.starts_with(&self.log.events) {
            return Ok(false);
        }
        *self = next;
        Ok(true)
    }

    pub fn session(&self) -> &Session {
        &self.session
    }

    /// The log followed now (a continuation once the session was resumed).
    pub fn path(&self) -> &PathBuf {
        &self.log.path
    }

    /// The log time of the last event on disk (ns), if any.
    pub fn last_event_ns(&self) -> Option<u64> {
        self.log.events.last().map(|e| e.time_ns)
    }

    /// When the robot was last sent a pose (ns, log time), if a robot is in the loop.
    pub fn last_robot_command_ns(&self) -> Option<u64> {
        let commanded = |e: &&crate::session::Stamped| matches!(e.event, crate::session::Event::RobotCommanded { .. });
        self.log.events.iter().rev().find(commanded).map(|e| e.time_ns)
    }

    /// Whether the log was closed (a quit or the end) rather than still being written.
    pub fn closed(&self) -> bool {
        self.log.finished
    }
}

/// The other `.mcap` files in the folder of `path`, with their lengths, in name order.
fn logs_beside(path: &Path) -> Vec<(PathBuf, u64)> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut out: Vec<(PathBuf, u64)> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
        .map(|e| e.path())
        .filter(|p| p != path && p.extension().is_some_and(|x| x == "mcap"))
        .map(|p| {
            let len = file_len(&p);
            (p, len)
        })
        .collect();
    out.sort();
    out
}

fn file_len(path: &Path) -> u64 {
    std::fs::metadata(path).map_or(0, |m| m.len())
}
