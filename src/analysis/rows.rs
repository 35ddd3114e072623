//! Per-trial and per-note rows of a replayed session, as `trials.csv` and `notes.csv` write
//! them: every presentation with what became of it (taken, undone, voided with its reason),
//! the mapped configuration and the times.

use crate::kinematics::{ArmConfig, JOINT_NAMES};
use crate::protocol::ObservationModel;
use crate::session::{Applied, Event, RobotState, Session, Stamped, TrialView, program_letter};

/// What became of one presentation of a query.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrialStatus {
    /// The participant took the object; the response stands.
    Taken,
    /// The response was recorded, then undone (the same presentation was answered again).
    Undone,
    /// The trial was voided (before or after a response) and repeated.
    Voided,
    /// Presented, never answered (the log ends there).
    Unanswered,
}

impl TrialStatus {
    pub fn name(self) -> &'static str {
        match self {
            TrialStatus::Taken => "taken",
            TrialStatus::Undone => "undone",
            TrialStatus::Voided => "voided",
            TrialStatus::Unanswered => "unanswered",
        }
    }
}

/// One presentation of a query, or a trial voided before its query was presented (the robot
/// never reached the pose).
#[derive(Clone, Debug, PartialEq)]
pub struct TrialRow {
    /// The `/trial/query` event's index; for a trial voided before it was presented, the
    /// `/trial/void` event's.
    pub event_index: usize,
    pub phase: &'static str,
    pub condition: Option<&'static str>,
    pub program: Option<String>,
    pub trial: usize,
    pub query: String,
    pub query_label: String,
    pub object: String,
    pub object_label: String,
    pub status: TrialStatus,
    /// The region taken (id and label), and its configuration by the label model.
    pub region: Option<(String, String)>,
    pub config_index: Option<usize>,
    pub configuration: Option<ArmConfig>,
    /// None: voided before its query was presented.
    pub presented_ns: Option<u64>,
    pub responded_ns: Option<u64>,
    pub void_reason: Option<&'static str>,
    pub void_detail: String,
    /// With `measured` observations: what the trial learned from (`measured`, or `region` as
    /// the fallback), and the measurement with the region it implies and whether that is
    /// the one keyed.
    pub learned_from: Option<&'static str>,
    pub measured: Option<MeasuredColumns>,
}

/// A taken trial's arm measurement, as trials.csv has it.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasuredColumns {
    pub q_rad: Vec<f64>,
    pub offset_s: f64,
    pub implied_region: String,
    pub agrees: bool,
}

/// A note the experimenter added.
#[derive(Clone, Debug, PartialEq)]
pub struct NoteRow {
    pub event_index: usize,
    pub time_ns: u64,
    pub text: String,
}

/// One command sent to the robot, and what became of it.
#[derive(Clone, Debug, PartialEq)]
pub struct RobotRow {
    pub event_index: usize,
    pub phase: &'static str,
    pub condition: Option<&'static str>,
    pub program: Option<String>,
    pub trial: usize,
    pub query: String,
    pub attempt: u32,
    /// Its id (none in logs before format 4).
    pub command: Option<String>,
    pub link: &'static str,
    pub frame: String,
    pub commanded_ns: u64,
    /// The first `moving`, if the robot said so.
    pub moving_ns: Option<u64>,
    /// How the command ended (`at_pose`, `failed`, `timeout`; none: no final answer logged).
    pub outcome: Option<(RobotState, u64)>,
    /// The detail of the final report.
    pub detail: String,
    /// Every report logged for it.
    pub reports: usize,
    /// Stale reports logged while it was the last command (answers to other commands, or
    /// that could not be told to answer it); never counted in `reports`.
    pub stale_reports: usize,
}

impl RobotRow {
    /// Seconds from the command to its final report.
    pub fn seconds(&self) -> Option<f64> {
        self.outcome.map(|(_, t)| t.saturating_sub(self.commanded_ns) as f64 / 1e9)
    }
}

/// Collects the rows during a replay.
#[derive(Default)]
pub(crate) struct RowCollector {
    pub trials: Vec<TrialRow>,
    pub notes: Vec<NoteRow>,
    pub robot: Vec<RobotRow>,
    open: Option<usize>,
    open_robot: Option<usize>,
}

impl RowCollector {
    /// Takes one replayed event.
    pub fn visit(&mut self, session: &Session, index: usize, stamped: &Stamped, applied: &Applied) {
        match applied {
            Applied::Presented { view, .. } => {
                self.trials.push(TrialRow::opened(session, view, index, Some(stamped.time_ns)));
                self.open = Some(self.trials.len() - 1);
            }
            Applied::Responded { record, .. } => {
                if let Some(row) = self.open.map(|i| &mut self.trials[i]) {
                    let q = session.query(record.query);
                    let region = &session.study().object(q).regions[q.regions[record.region]];
                    row.status = TrialStatus::Taken;
                    row.region = Some((region.id.clone(), region.label.clone()));
                    row.config_index = Some(record.config);
                    row.configuration = q.feasible.configs.get(record.config).map(|c| c.q);
                    row.responded_ns = Some(stamped.time_ns);
                    if session.context().observation == ObservationModel::Measured {
                        row.learned_from = Some(if record.measured.is_some() { "measured" } else { "region" });
                    }
                    row.measured = record.measured.as_ref().map(|g| MeasuredColumns {
                        q_rad: g.measurement.q_rad.clone(),
                        offset_s: g.measurement.offset_s,
                        implied_region: session.study().object(q).regions[q.regions[g.implied_region]].id.clone(),
                        agrees: g.agrees(record.region),
                    });
                }
            }
            Applied::Undone { .. } => {
                if let Some(i) = self.open {
                    self.trials[i].status = TrialStatus::Undone;
                    // The same presentation waits for its answer again.
                    let mut again = self.trials[i].clone();
                    again.status = TrialStatus::Unanswered;
                    (again.region, again.config_index, again.configuration, again.responded_ns) =
                        (None, None, None, None);
                    (again.learned_from, again.measured) = (None, None);
                    self.trials.push(again);
                    self.open = Some(self.trials.len() - 1);
                }
            }
            Applied::Voided { view, .. } => {
                let Event::TrialVoided { reason, detail } = &stamped.event else { return };
                // The presentation under way (answered or not); with none, the trial the robot
                // was sent to and never presented gets a row of its own.
                let i = self.open.take().unwrap_or_else(|| {
                    self.trials.push(TrialRow::opened(session, view, index, None));
                    self.trials.len() - 1
                });
                let row = &mut self.trials[i];
                row.status = TrialStatus::Voided;
                row.void_reason = Some(reason.name());
                row.void_detail = detail.clone();
            }
            Applied::RobotCommanded { view, attempt } => {
                let Event::RobotCommanded { query, link, pose, command } = &stamped.event else { return };
                // The robot moves on: the last presentation is closed (its grasp can no longer
                // be undone or voided).
                self.open = None;
                self.robot.push(RobotRow {
                    event_index: index,
                    phase: view.phase.name(),
                    condition: view.condition.map(|c| c.name()),
                    program: view.program.map(program_letter),
                    trial: view.trial,
                    query: query.clone(),
                    attempt: *attempt,
                    command: command.clone(),
                    link: link.name(),
                    frame: pose.frame.clone(),
                    commanded_ns: stamped.time_ns,
                    moving_ns: None,
                    outcome: None,
                    detail: String::new(),
                    reports: 0,
                    stale_reports: 0,
                });
                self.open_robot = Some(self.robot.len() - 1);
            }
            Applied::RobotReported { attempt: Some(attempt) } => {
                let Event::RobotReported { query, state, detail, .. } = &stamped.event else { return };
                let Some(row) = self.open_robot.map(|i| &mut self.robot[i]) else { return };
                if row.query != *query || row.attempt != *attempt || row.outcome.is_some() {
                    return;
                }
                row.reports += 1;
                if *state == RobotState::Moving && row.moving_ns.is_none() {
                    row.moving_ns = Some(stamped.time_ns);
                }
                if state.is_final() {
                    row.outcome = Some((*state, stamped.time_ns));
                    row.detail = detail.clone();
                }
            }
            Applied::RobotReported { attempt: None } => {
                if let Event::RobotReported { stale: true, .. } = &stamped.event
                    && let Some(i) = self.open_robot
                {
                    self.robot[i].stale_reports += 1;
                }
            }
            Applied::Ended { .. } | Applied::Other => {
                if let Event::Note { text } = &stamped.event {
                    self.notes.push(NoteRow { event_index: index, time_ns: stamped.time_ns, text: text.clone() });
                }
            }
        }
    }
}

impl TrialRow {
    /// A row for the trial `view` shows, opened by event `index` (presented at `presented_ns`,
    /// or never presented), and not yet answered.
    fn opened(session: &Session, view: &TrialView, index: usize, presented_ns: Option<u64>) -> Self {
        let q = session.query(view.query);
        let object = session.study().object(q);
        TrialRow {
            event_index: index,
            phase: view.phase.name(),
            condition: view.condition.map(|c| c.name()),
            program: view.program.map(program_letter),
            trial: view.trial,
            query: q.query.id.clone(),
            query_label: q.query.label.clone(),
            object: object.id.clone(),
            object_label: object.label.clone(),
            status: TrialStatus::Unanswered,
            region: None,
            config_index: None,
            configuration: None,
            presented_ns,
            responded_ns: None,
            void_reason: None,
            void_detail: String::new(),
            learned_from: None,
            measured: None,
        }
    }
}

/// RFC 3339 UTC with milliseconds, as pandas and R parse it.
pub fn rfc3339_ms(ns: u64) -> String {
    let secs = (ns / 1_000_000_000) as i64;
    let nanos = (ns % 1_000_000_000) as u32;
    chrono::DateTime::from_timestamp(secs, nanos)
        .map(|t| t.to_rfc3339_opts(chrono::SecondsFormat::Millis, true))
        .unwrap_or_default()
}

/// The columns of `trials.csv` after `session_id` and `participant`.
pub fn trial_columns() -> Vec<String> {
    let mut h: Vec<String> = [
        "event_index",
        "phase",
        "condition",
        "program",
        "trial",
        "query",
        "query_label",
        "object",
        "object_label",
        "status",
        "region",
        "region_label",
        "config_index",
    ]
    .map(String::from)
    .to_vec();
    h.extend(JOINT_NAMES.iter().map(|j| format!("q_{j}_rad")));
    h.extend(["presented_at", "responded_at", "void_reason", "void_detail", "learned_from"].map(String::from));
    h.extend(JOINT_NAMES.iter().map(|j| format!("measured_{j}_rad")));
    h.extend(["measurement_offset_s", "measurement_implied_region", "measurement_agrees"].map(String::from));
    h
}

impl TrialRow {
    /// The row's values in the order of [`trial_columns`] (empty for what does not apply).
    pub fn values(&self) -> Vec<String> {
        let opt = |v: Option<String>| v.unwrap_or_default();
        let mut v = vec![
            self.event_index.to_string(),
            self.phase.to_string(),
            opt(self.condition.map(String::from)),
            opt(self.program.clone()),
            self.trial.to_string(),
            self.query.clone(),
            self.query_label.clone(),
            self.object.clone(),
            self.object_label.clone(),
            self.status.name().to_string(),
            opt(self.region.as_ref().map(|r| r.0.clone())),
            opt(self.region.as_ref().map(|r| r.1.clone())),
            opt(self.config_index.map(|c| c.to_string())),
        ];
        v.extend((0..JOINT_NAMES.len()).map(|j| opt(self.configuration.map(|q| q[j].to_string()))));
        v.extend([
            opt(self.presented_ns.map(rfc3339_ms)),
            opt(self.responded_ns.map(rfc3339_ms)),
            opt(self.void_reason.map(String::from)),
            self.void_detail.clone(),
            opt(self.learned_from.map(String::from)),
        ]);
        let m = self.measured.as_ref();
        v.extend((0..JOINT_NAMES.len()).map(|j| opt(m.and_then(|m| m.q_rad.get(j)).map(|q| q.to_string()))));
        v.extend([
            opt(m.map(|m| m.offset_s.to_string())),
            opt(m.map(|m| m.implied_region.clone())),
            opt(m.map(|m| crate::private_files::bool_text(m.agrees).to_string())),
        ]);
        v
    }
}

/// The robot's timings over sessions: how its commands ended, and the seconds from a command
/// to `at_pose` (median and range).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RobotTimings {
    pub commands: usize,
    pub at_pose: usize,
    pub failed: usize,
    pub timeout: usize,
    /// Commands with no final report in the log (superseded, or the log ends).
    pub unanswered: usize,
    /// Stale reports (answers to another command than the one under way), over all commands.
    pub stale: usize,
    /// Seconds from command to `at_pose`: median, minimum, maximum (none without an `at_pose`).
    pub to_at_pose_s: Option<[f64; 3]>,
}

/// [`RobotTimings`] of the commands in `rows` (none without any).
pub fn robot_timings<'a>(rows: impl IntoIterator<Item = &'a RobotRow>) -> Option<RobotTimings> {
    let rows: Vec<&RobotRow> = rows.into_iter().collect();
    if rows.is_empty() {
        return None;
    }
    let ended = |s: RobotState| rows.iter().filter(|r| r.outcome.is_some_and(|(o, _)| o == s)).count();
    let secs: Vec<f64> = rows
        .iter()
        .filter(|r| r.outcome.is_some_and(|(o, _)| o == RobotState::AtPose))
        .filter_map(|r| r.seconds())
        .collect();
    let range = (!secs.is_empty()).then(|| {
        let min = secs.iter().copied().fold(f64::INFINITY, f64::min);
        let max = secs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        [crate::stats::median(&secs), min, max]
    });
    Some(RobotTimings {
        commands: rows.len(),
        at_pose: ended(RobotState::AtPose),
        failed: ended(RobotState::Failed),
        timeout: ended(RobotState::Timeout),
        unanswered: rows.iter().filter(|r| r.outcome.is_none()).count(),
        stale: rows.iter().map(|r| r.stale_reports).sum(),
        to_at_pose_s: range,
    })
}
