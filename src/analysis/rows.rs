//! Per-trial and per-note rows of a replayed session, as `trials.csv` and `notes.csv` write
//! them: every presentation with what became of it (taken, undone, voided with its reason),
//! the mapped configuration and the times.

use crate::kinematics::{ArmConfig, JOINT_NAMES};
use crate::session::{Applied, Event, Session, Stamped, program_letter};

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

/// One presentation of a query.
#[derive(Clone, Debug, PartialEq)]
pub struct TrialRow {
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
    pub presented_ns: u64,
    pub responded_ns: Option<u64>,
    pub void_reason: Option<&'static str>,
    pub void_detail: String,
}

/// A note the experimenter added.
#[derive(Clone, Debug, PartialEq)]
pub struct NoteRow {
    pub event_index: usize,
    pub time_ns: u64,
    pub text: String,
}

/// Collects the rows during a replay.
#[derive(Default)]
pub(crate) struct RowCollector {
    pub trials: Vec<TrialRow>,
    pub notes: Vec<NoteRow>,
    open: Option<usize>,
}

impl RowCollector {
    /// Takes one replayed event.
    pub fn visit(&mut self, session: &Session, index: usize, stamped: &Stamped, applied: &Applied) {
        match applied {
            Applied::Presented { view, .. } => {
                let q = session.query(view.query);
                let object = session.study().object(q);
                self.trials.push(TrialRow {
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
                    presented_ns: stamped.time_ns,
                    responded_ns: None,
                    void_reason: None,
                    void_detail: String::new(),
                });
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
                    self.trials.push(again);
                    self.open = Some(self.trials.len() - 1);
                }
            }
            Applied::Voided { .. } => {
                if let (Some(i), Event::TrialVoided { reason, detail }) = (self.open.take(), &stamped.event) {
                    let row = &mut self.trials[i];
                    row.status = TrialStatus::Voided;
                    row.void_reason = Some(reason.label());
                    row.void_detail = detail.clone();
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
    h.extend(["presented_at", "responded_at", "void_reason", "void_detail"].map(String::from));
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
            rfc3339_ms(self.presented_ns),
            opt(self.responded_ns.map(rfc3339_ms)),
            opt(self.void_reason.map(String::from)),
            self.void_detail.clone(),
        ]);
        v
    }
}
