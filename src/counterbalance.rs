//! Counterbalancing: which slot (condition order) the next participant gets, from the
//! completed sessions already logged and the participants registered but not yet run.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use crate::participant::ParticipantRecord;
use crate::record::{LogContents, mcap_files_reporting, read_log};
use crate::session::Event;

/// The completed real sessions per slot, the participants registered who wait for theirs,
/// and the files that could not be counted.
#[derive(Clone, Debug, PartialEq)]
pub struct SlotCounts {
    pub completed: Vec<usize>,
    /// Registered participants (not withdrawn) with no completed session and none that was
    /// aborted: each holds their slot, so that a day's participants registered in the
    /// morning are balanced too.
    pub waiting: Vec<usize>,
    /// (file, why): logs that could not be read, so were not counted.
    pub skipped: Vec<(PathBuf, String)>,
}

impl SlotCounts {
    /// The slot with the fewest participants completed or waiting (the first on ties):
    /// dropouts (an aborted session and none completed), pilots and withdrawn participants do
    /// not use up a slot.
    pub fn least_filled(&self) -> usize {
        (0..self.completed.len()).min_by_key(|&i| (self.completed[i] + self.waiting[i], i)).unwrap_or(0)
    }

    /// The running balance in one short line: per slot, sessions completed and participants
    /// waiting.
    pub fn describe(&self) -> String {
        let parts: Vec<String> = (0..self.completed.len())
            .map(|i| format!("slot {i}: {} done, {} waiting", self.completed[i], self.waiting[i]))
            .collect();
        parts.join(" · ")
    }

    /// One line per file not counted, for the operator.
    pub fn warnings(&self) -> Vec<String> {
        self.skipped
            .iter()
            .map(|(p, why)| format!("{} is not counted toward counterbalancing: {why}", p.display()))
            .collect()
    }
}

/// Completed real (not pilot) sessions per counterbalancing slot in the logs under `root`,
/// each session counted once however often it was resumed, and the participants registered
/// in `participants` who wait for a session (see [`SlotCounts::waiting`]); participants whose
/// record says they withdrew do not count.
pub fn completed_per_slot(root: &Path, participants: &Path, slots: usize) -> SlotCounts {
    let mut logs = Vec::new();
    let (files, mut skipped) = mcap_files_reporting(root);
    for path in files {
        match read_log(&path) {
            Ok(log) => logs.push(log),
            Err(e) => skipped.push((path, e.to_string())),
        }
    }
    let (records, unreadable) = crate::participant::registered(participants);
    skipped.extend(unreadable);
    slot_counts(&logs, &records, participants, slots, skipped)
}

/// [`completed_per_slot`] over logs and participant records already read (`skipped`: the
/// files that could not be).
pub fn slot_counts(
    logs: &[LogContents],
    records: &[ParticipantRecord],
    participants: &Path,
    slots: usize,
    skipped: Vec<(PathBuf, String)>,
) -> SlotCounts {
    let mut completed = vec![0; slots];
    let mut seen = HashSet::new();
    // Participants with a completed or an aborted real session: they wait for nothing.
    let mut settled: HashSet<String> = HashSet::new();
    for log in logs {
        let ended = log.events.iter().any(|e| e.event == Event::Ended);
        let aborted = log.events.iter().any(|e| matches!(e.event, Event::Aborted { .. }));
        if (ended || aborted) && !log.start.pilot {
            settled.insert(log.start.participant.clone());
        }
        if ended
            && !log.start.pilot
            && log.start.slot < slots
            && !crate::participant::has_withdrawn(participants, &log.start.participant)
            && seen.insert(log.start.session_id.clone())
        {
            completed[log.start.slot] += 1;
        }
    }
    let mut waiting = vec![0; slots];
    for record in records {
        if !record.is_withdrawn() && record.slot < slots && !settled.contains(&record.id) {
            waiting[record.slot] += 1;
        }
    }
    SlotCounts { completed, waiting, skipped }
}

#[cfg(test)]
mod tests {
    use super::completed_per_slot;

    #[test]
    fn an_unreadable_log_is_reported_not_counted() {
        let dir = std::env::temp_dir().join(format!("handover-slots-{}", std::process::id()));
        let logs = dir.join("logs/p-1");
        std::fs::create_dir_all(&logs).unwrap();
        std::fs::write(logs.join("p-1_20261202T000000Z.mcap"), b"not a log").unwrap();
        let counts = completed_per_slot(&dir.join("logs"), &dir.join("participants"), 2);
        assert_eq!(counts.completed, vec![0, 0]);
        assert_eq!(counts.waiting, vec![0, 0]);
        assert_eq!(counts.skipped.len(), 1);
        assert_eq!(counts.least_filled(), 0);
        let w = counts.warnings();
        assert!(w[0].contains("p-1_20261202T000000Z.mcap") && w[0].contains("MCAP magic"), "{w:?}");
        let _ = std::fs::remove_dir_all(dir);
    }
}
