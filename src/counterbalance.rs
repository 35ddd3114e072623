//! Counterbalancing: which slot (condition order) the next participant gets, from the
//! completed sessions already logged.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use crate::record::{mcap_files, read_log};
use crate::session::Event;

/// The completed real sessions per slot, and the files that could not be counted.
#[derive(Clone, Debug, PartialEq)]
pub struct SlotCounts {
    pub completed: Vec<usize>,
    /// (file, why): logs that could not be read, so were not counted.
    pub skipped: Vec<(PathBuf, String)>,
}

impl SlotCounts {
    /// The slot with the fewest completed real sessions (the first on ties): dropouts,
    /// pilots and withdrawn participants do not use up a slot.
    pub fn least_filled(&self) -> usize {
        (0..self.completed.len()).min_by_key(|&i| (self.completed[i], i)).unwrap_or(0)
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
/// each session counted once however often it was resumed; sessions of participants whose
/// record in `participants` says they withdrew do not count.
pub fn completed_per_slot(root: &Path, participants: &Path, slots: usize) -> SlotCounts {
    let mut completed = vec![0; slots];
    let mut skipped = Vec::new();
    let mut seen = HashSet::new();
    for path in mcap_files(root) {
        let log = match read_log(&path) {
            Ok(log) => log,
            Err(e) => {
                skipped.push((path, e.to_string()));
                continue;
            }
        };
        let ended = log.events.iter().any(|e| e.event == Event::Ended);
        if ended
            && !log.start.pilot
            && log.start.slot < slots
            && !crate::participant::has_withdrawn(participants, &log.start.participant)
            && seen.insert(log.start.session_id.clone())
        {
            completed[log.start.slot] += 1;
        }
    }
    SlotCounts { completed, skipped }
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
        assert_eq!(counts.skipped.len(), 1);
        assert_eq!(counts.least_filled(), 0);
        let w = counts.warnings();
        assert!(w[0].contains("p-1_20261202T000000Z.mcap") && w[0].contains("MCAP magic"), "{w:?}");
        let _ = std::fs::remove_dir_all(dir);
    }
}
