//! Where a study stands, at a glance (`handover status`): its participants by state, its pilot
//! sessions, the counterbalancing and the next participant's order, the sessions interrupted
//! with the command that continues each, and the logs that cannot be read. Only reads.

use std::path::PathBuf;

use serde::Serialize;

use crate::counterbalance::{SlotCounts, slot_counts};
use crate::participant::{deleted, registered};
use crate::protocol::Study;
use crate::record::{LogContents, is_over, mcap_files_reporting, read_log, session_heads};
use crate::session::{Event, condition_order};
use crate::study_dir::{StudyDirs, holder_running, shell_word};

/// A participant's state in the study.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ParticipantState {
    /// Registered, no session yet.
    Waiting,
    /// A session not over (running now, or interrupted and resumable).
    InProgress,
    /// A session completed.
    Completed,
    /// Sessions only aborted (a dropout).
    DroppedOut,
    Withdrawn,
}

impl ParticipantState {
    pub fn name(self) -> &'static str {
        match self {
            ParticipantState::Waiting => "waiting",
            ParticipantState::InProgress => "in progress",
            ParticipantState::Completed => "completed",
            ParticipantState::DroppedOut => "dropped out",
            ParticipantState::Withdrawn => "withdrawn",
        }
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct ParticipantStatus {
    pub id: String,
    pub slot: usize,
    pub state: ParticipantState,
}

/// A session not over: where it stopped and the whole command that continues it.
#[derive(Clone, Debug, Serialize)]
pub struct OpenSession {
    pub participant: String,
    pub pilot: bool,
    pub log: PathBuf,
    pub events: usize,
    /// Trials recorded (grasps net of undos and voided grasps).
    pub trials: usize,
    /// When its last event happened (RFC 3339 UTC).
    pub last_event: String,
    /// A console (or a dry run) runs it now.
    pub live: bool,
    /// Closed by a quit or a signal (else left open by a crash or `kill -9`).
    pub closed: bool,
    pub resume: String,
}

#[derive(Clone, Debug, Serialize)]
pub struct SlotStatus {
    pub slot: usize,
    /// The conditions in the order run (Program A first).
    pub order: Vec<String>,
    pub completed: usize,
    pub waiting: usize,
}

#[derive(Clone, Debug, Serialize)]
pub struct Unreadable {
    pub log: PathBuf,
    pub error: String,
}

impl Unreadable {
    /// A file or folder, and why it could not be read (the message names it).
    fn new((log, why): (PathBuf, String)) -> Self {
        Unreadable { error: format!("{}: {why}", log.display()), log }
    }
}

/// An output folder in the study (one with a `manifest.json`) and the withdrawn
/// participants whose data it still holds.
#[derive(Clone, Debug, Serialize)]
pub struct OutputStatus {
    pub dir: PathBuf,
    pub command: String,
    pub written_at: String,
    /// False: the command that wrote it was cut short.
    pub complete: bool,
    pub sessions: usize,
    pub holds_withdrawn: Vec<String>,
}

/// The study at a glance.
#[derive(Clone, Debug, Serialize)]
pub struct StudyStatus {
    pub participants_dir: PathBuf,
    pub logs_dir: PathBuf,
    pub participants: Vec<ParticipantStatus>,
    /// Withdrawn participants whose data was deleted (only the id is left).
    pub deleted: Vec<String>,
    /// Pilot sessions (dry runs, rehearsals, `run --pilot`): completed, aborted, not over.
    pub pilot_sessions: PilotCounts,
    pub slots: Vec<SlotStatus>,
    /// The slot the next new participant gets.
    pub next_slot: usize,
    pub open_sessions: Vec<OpenSession>,
    pub unreadable: Vec<Unreadable>,
    /// Participant records (or their folder) that cannot be read: not counted anywhere.
    pub unreadable_records: Vec<Unreadable>,
    /// The output folders under the study folder, by their manifests.
    pub outputs: Vec<OutputStatus>,
    /// Output folders and manifests that could not be looked at.
    pub unreadable_outputs: Vec<String>,
    /// The slot counts `slots` is made of (for the one-line balance).
    #[serde(skip)]
    pub counts: SlotCounts,
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct PilotCounts {
    pub completed: usize,
    pub aborted: usize,
    pub not_over: usize,
}

/// Reads the study's records and logs (every log once).
pub fn study_status(dirs: &StudyDirs, study: &Study) -> StudyStatus {
    let mut logs: Vec<LogContents> = Vec::new();
    let (files, unlistable) = mcap_files_reporting(&dirs.logs);
    let mut unreadable: Vec<Unreadable> = unlistable
        .into_iter()
        .map(|(log, why)| Unreadable { error: format!("{}: {why}", log.display()), log })
        .collect();
    for path in files {
        match read_log(&path) {
            Ok(log) => logs.push(log),
            Err(e) => unreadable.push(Unreadable { log: path, error: e.to_string() }),
        }
    }
    let heads = session_heads(&logs);
    let ended = |l: &LogContents| l.events.iter().any(|e| e.event == Event::Ended);
    let mut pilot_sessions = PilotCounts::default();
    for h in heads.iter().filter(|h| h.start.pilot) {
        match (ended(h), is_over(h)) {
            (true, _) => pilot_sessions.completed += 1,
            (false, true) => pilot_sessions.aborted += 1,
            (false, false) => pilot_sessions.not_over += 1,
        }
    }
    let (records, unreadable_records) = registered(&dirs.participants);
    let participants: Vec<ParticipantStatus> = records
        .iter()
        .map(|r| {
            let theirs: Vec<&&LogContents> =
                heads.iter().filter(|h| !h.start.pilot && h.start.participant == r.id).collect();
            let state = if r.is_withdrawn() {
                ParticipantState::Withdrawn
            } else if theirs.iter().any(|h| ended(h)) {
                ParticipantState::Completed
            } else if theirs.iter().any(|h| !is_over(h)) {
                ParticipantState::InProgress
            } else if !theirs.is_empty() {
                ParticipantState::DroppedOut
            } else {
                ParticipantState::Waiting
            };
            ParticipantStatus { id: r.id.clone(), slot: r.slot, state }
        })
        .collect();
    let withdrawn: Vec<String> = participants
        .iter()
        .filter(|p| p.state == ParticipantState::Withdrawn)
        .map(|p| p.id.clone())
        .chain(deleted(&dirs.participants))
        .collect();
    let open_sessions = heads
        .iter()
        .filter(|h| !is_over(h))
        .map(|h| {
            let trials = h.events.iter().fold(0usize, |n, e| match e.event {
                Event::GraspRecorded { .. } => n + 1,
                Event::GraspUndone => n.saturating_sub(1),
                _ => n,
            });
            // With no event after its start, the start is the last thing that happened.
            let last_event = match h.events.last() {
                Some(e) => chrono::DateTime::from_timestamp_nanos(e.time_ns as i64)
                    .to_rfc3339_opts(chrono::SecondsFormat::Secs, true),
                None => h.start.started_at.clone(),
            };
            let resume = if withdrawn.contains(&h.start.participant) {
                String::new()
            } else if h.start.pilot {
                format!("handover resume {}", shell_word(&h.path.display().to_string()))
            } else {
                dirs.resume_command(&h.start.participant)
            };
            OpenSession {
                participant: h.start.participant.clone(),
                pilot: h.start.pilot,
                log: h.path.clone(),
                events: h.events.len(),
                trials,
                last_event,
                live: h.path.parent().and_then(holder_running) == Some(true),
                closed: h.finished,
                resume,
            }
        })
        .collect();
    // The logs and records read above, counted once more for the slots (not read again).
    let skipped =
        unreadable.iter().map(|u| (u.log.clone(), u.error.clone())).chain(unreadable_records.iter().cloned()).collect();
    let counts = slot_counts(&logs, &records, &dirs.participants, 2, skipped);
    let unreadable_records: Vec<Unreadable> = unreadable_records.into_iter().map(Unreadable::new).collect();
    let slots = (0..counts.completed.len())
        .map(|slot| SlotStatus {
            slot,
            order: condition_order(study, slot).iter().map(|c| c.name().to_string()).collect(),
            completed: counts.completed[slot],
            waiting: counts.waiting[slot],
        })
        .collect();
    let mut errors = Vec::new();
    let outputs = crate::output_dir::manifests(&dirs.root, &mut errors)
        .into_iter()
        .map(|(dir, m)| {
            let mut holds: Vec<String> = withdrawn.iter().filter(|w| m.holds(w)).cloned().collect();
            holds.sort();
            OutputStatus {
                dir,
                command: m.command,
                written_at: m.written_at,
                complete: m.complete,
                sessions: m.sessions.len(),
                holds_withdrawn: holds,
            }
        })
        .collect();
    StudyStatus {
        outputs,
        unreadable_outputs: errors.iter().map(ToString::to_string).collect(),
        participants_dir: dirs.participants.clone(),
        logs_dir: dirs.logs.clone(),
        participants,
        deleted: deleted(&dirs.participants),
        pilot_sessions,
        slots,
        next_slot: counts.least_filled(),
        open_sessions,
        unreadable,
        unreadable_records,
        counts,
    }
}

impl StudyStatus {
    /// How many participants are in a state.
    pub fn count(&self, state: ParticipantState) -> usize {
        self.participants.iter().filter(|p| p.state == state).count()
    }

    /// The one line the console's setup screen shows for the study.
    pub fn summary_line(&self) -> String {
        let states = [
            ParticipantState::Completed,
            ParticipantState::InProgress,
            ParticipantState::Waiting,
            ParticipantState::DroppedOut,
            ParticipantState::Withdrawn,
        ];
        let parts: Vec<String> = states.iter().map(|&s| format!("{} {}", self.count(s), s.name())).collect();
        format!("{} registered: {}", self.participants.len(), parts.join(", "))
    }
}
