//! Which logs count and what they give: a session is counted once, from its most complete
//! log; a participant who withdrew is never counted; every log is replayed (and verified when
//! asked), and what could not be used is said.

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::Serialize;

use super::{SessionAnalysis, StudySummary, analyse_and_verify, summarise};
use crate::participant::has_withdrawn;
use crate::record::{LOG_FORMAT, LogContents, Topic, read_log, study_of};
use crate::study_dir::StudyDirs;

/// A log and what its replay found.
#[derive(Clone, Debug)]
pub struct Analysed {
    pub log: LogContents,
    pub analysis: SessionAnalysis,
}

/// The most complete log of each session (a session is its id under its protocol:
/// `dry-run --versus` runs the same ids under two protocols): more events, then finished,
/// wins; the first read wins a tie. The others are named in the warnings.
fn most_complete(logs: impl IntoIterator<Item = LogContents>) -> (Vec<LogContents>, Vec<String>) {
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

/// Sessions (and participants) left out because the participant withdrew.
#[derive(Serialize, Clone, Copy, Debug, Default)]
pub struct WithdrawnLeftOut {
    pub sessions: usize,
    pub participants: usize,
}

/// What a set of logs gives: each counted session's analysis, real sessions first, then
/// pilots, each by start time; and what could not be used, with why.
#[derive(Debug, Default)]
pub struct Collected {
    pub analysed: Vec<Analysed>,
    /// Logs that could not be read or replayed.
    pub skipped: Vec<String>,
    /// Logs superseded by a continuation, logs that end early.
    pub warnings: Vec<String>,
    /// With verification: every difference between a log and its recomputation.
    pub differences: Vec<String>,
    /// What the operator is told on the way (where withdrawals were looked up, which earlier
    /// formats were verified on their events only).
    pub notes: Vec<String>,
    pub left_out: WithdrawnLeftOut,
}

impl Collected {
    /// The real sessions, or the pilots.
    pub fn group(&self, pilot: bool) -> Vec<&Analysed> {
        self.analysed.iter().filter(|a| a.log.start.pilot == pilot).collect()
    }

    /// Fig. 10 and Table I over the real sessions, or the pilots (None without any).
    pub fn summary(&self, pilot: bool) -> Option<StudySummary> {
        let group = self.group(pilot);
        let study = study_of(&group.first()?.log).ok()?;
        let conditions: Vec<String> = study.protocol.session.conditions.iter().map(|c| c.name().to_string()).collect();
        let items: Vec<(String, String)> =
            study.protocol.questionnaire.items.iter().map(|i| (i.id.clone(), i.statement.clone())).collect();
        let sessions: Vec<SessionAnalysis> = group.iter().map(|a| a.analysis.clone()).collect();
        Some(summarise(&sessions, &conditions, &items))
    }
}

/// Reads, replays (and with `verify` checks) the logs in `files`: the most complete log of
/// each session, participants who withdrew left out. `study_of_log` gives the study folders a
/// log belongs to (where its participant's record says whether they withdrew).
pub fn collect(files: &[PathBuf], verify: bool, study_of_log: impl Fn(&LogContents) -> StudyDirs) -> Collected {
    let mut c = Collected::default();
    let mut logs = Vec::new();
    for f in files {
        match read_log(f) {
            Ok(log) => logs.push(log),
            Err(e) => {
                // A log that cannot be read (or whose ids break the rules) fails verification.
                if verify {
                    c.differences.push(e.to_string());
                }
                c.skipped.push(format!("skipped {e}"));
            }
        }
    }
    let (mut logs, warnings) = most_complete(logs);
    c.warnings = warnings;
    let records = |l: &LogContents| study_of_log(l).participants;
    let before = logs.len();
    let mut consulted: Vec<PathBuf> = logs.iter().filter(|l| !l.start.pilot).map(records).collect();
    consulted.sort();
    consulted.dedup();
    if !consulted.is_empty() {
        let names: Vec<String> = consulted.iter().map(|p| p.display().to_string()).collect();
        c.notes.push(format!("withdrawals: participant records in {}", names.join(", ")));
    }
    let mut withdrawn: Vec<String> = logs
        .iter()
        .filter(|l| !l.start.pilot && has_withdrawn(&records(l), &l.start.participant))
        .map(|l| l.start.participant.clone())
        .collect();
    logs.retain(|l| l.start.pilot || !withdrawn.contains(&l.start.participant));
    withdrawn.sort();
    withdrawn.dedup();
    c.left_out = WithdrawnLeftOut { sessions: before - logs.len(), participants: withdrawn.len() };
    if c.left_out.sessions > 0 {
        c.notes.push(format!(
            "left out {} session(s) of {} participant(s) who withdrew",
            c.left_out.sessions, c.left_out.participants
        ));
    }
    for log in logs {
        replay_one(log, verify, &mut c);
    }
    c.analysed.sort_by(|a, b| {
        (a.log.start.pilot, &a.log.start.started_at).cmp(&(b.log.start.pilot, &b.log.start.started_at))
    });
    c
}

/// Replays one log into `c`: its analysis, or why it was skipped; its differences.
fn replay_one(log: LogContents, verify: bool, c: &mut Collected) {
    if !log.finished {
        c.warnings.push(format!(
            "{}: the log ends early (a crash not yet resumed, or a quit): analysed up to its last whole message ({} events){}",
            log.path.display(),
            log.events.len(),
            if log.cut_tail { "; a partial record at the end was ignored" } else { "" }
        ));
    }
    if verify {
        c.differences.extend(log.integrity.iter().map(|p| format!("{}: {p}", log.path.display())));
    }
    match analyse_and_verify(&log, verify) {
        Ok((analysis, mut diffs)) => {
            if verify && log.format < LOG_FORMAT {
                // An earlier format's derived topics have that format's names and shapes: its
                // events are checked (they replay, and their messages are compared); the
                // topics derived from them are not.
                let before = diffs.len();
                diffs.retain(|d| Topic::from_name(&d.topic).is_some_and(Topic::is_event));
                c.notes.push(format!(
                    "verify: {}: log format {} (this version writes {LOG_FORMAT}): its events replay and are compared; \
                     its derived topics are in that format's shape and are not ({} such difference(s) not counted)",
                    log.path.display(),
                    log.format,
                    before - diffs.len()
                ));
            }
            c.differences.extend(
                diffs
                    .into_iter()
                    .map(|d| format!("{}: event {} {}: {}", log.path.display(), d.event_index, d.topic, d.detail)),
            );
            c.analysed.push(Analysed { log, analysis });
        }
        Err(e) => {
            // A log whose events do not replay is both a verification failure and a skip.
            if verify {
                c.differences.push(e.to_string());
            }
            c.skipped.push(format!("skipped {e}"));
        }
    }
}
