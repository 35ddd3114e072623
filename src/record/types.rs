//! The `handover.*` messages: one struct per topic. The JSON a log holds is these structs
//! serialised; their JSON Schemas are derived from them ([`super::schema`]); the reader reads
//! events back through them. Field meanings: `docs/log-format.md`.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::ergo::Lambda;
use crate::session::{MeasurementSource, RobotLinkKind, RobotState, SentPose, SessionStart, VoidReason};

/// `/session/start`: the session's fixed settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "handover.SessionStart")]
pub struct SessionStartMessage {
    /// Always 0.
    pub event_index: u32,
    #[serde(flatten)]
    pub start: SessionStart,
    /// The seed as a decimal string: JavaScript readers (Foxglove) round integers above 2^53.
    /// Logs written before it lack it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(regex(pattern = r"^[0-9]{1,20}$"))]
    pub seed_decimal: Option<String>,
    /// The log format ([`super::LOG_FORMAT`]); logs of format 1 lack it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = 2))]
    pub log_format: Option<u32>,
}

/// The phase of a trial.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum PhaseName {
    Training,
    Test,
}

impl From<crate::session::Phase> for PhaseName {
    fn from(p: crate::session::Phase) -> Self {
        match p {
            crate::session::Phase::Training => PhaseName::Training,
            crate::session::Phase::Test => PhaseName::Test,
        }
    }
}

/// The fields every trial message has.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct TrialFields {
    pub event_index: u32,
    pub phase: PhaseName,
    /// The training condition (absent in the test phase).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub condition: Option<String>,
    /// The program letter, `A` or `B` (absent in the test phase).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(regex(pattern = r"^[A-Z]$"))]
    pub program: Option<String>,
    /// 1-based within the run or the test phase.
    #[schemars(range(min = 1))]
    pub trial: u32,
    pub query: String,
    pub object: String,
}

/// A pose as the protocol writes it: position (m) and roll–pitch–yaw (degrees).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct RobotPose {
    pub frame: String,
    pub position: [f64; 3],
    pub rpy_deg: [f64; 3],
}

/// One menu item's selection scores.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct QueryScore {
    pub query: String,
    /// Nats, over the outcomes the belief is updated with.
    pub information_gain: f64,
    /// Eq. 10.
    pub expected_cost: f64,
}

/// `/trial/query`: the robot presented a query. An event.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "handover.TrialQuery")]
pub struct TrialQuery {
    #[serde(flatten)]
    pub trial: TrialFields,
    /// The pose's name.
    pub label: String,
    pub robot_pose: RobotPose,
    /// Ids of the grip regions offered.
    pub regions: Vec<String>,
    /// Their labels as the protocol writes them (logs before them lack them).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub region_labels: Vec<String>,
    pub scores: Vec<QueryScore>,
}

/// `/trial/response`: the participant took the object. An event.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "handover.TrialResponse")]
pub struct TrialResponse {
    #[serde(flatten)]
    pub trial: TrialFields,
    /// The grip region taken (its id).
    pub region: String,
    /// Its label (logs before it lack it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub region_label: Option<String>,
    /// Index of the label model's configuration in the query's feasible set.
    pub config_index: u32,
    /// Its 7 joint angles (rad).
    pub configuration: Vec<f64>,
    /// With `measured` observations: what the trial learned from, `measured`, or `region` when
    /// no measurement came within the protocol's window (the fallback). Absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub learned_from: Option<LearnedFrom>,
    /// The measurement, when there was one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measured: Option<MeasuredResponse>,
}

/// What a trial of a `measured` protocol learned from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum LearnedFrom {
    Measured,
    Region,
}

/// A grasp's arm measurement and the region it implies.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct MeasuredResponse {
    /// The measured joint angles (rad), in the model's order.
    pub q_rad: Vec<f64>,
    pub source: MeasurementSource,
    /// The sample's time minus the grasp's (s).
    pub offset_s: f64,
    /// The feasible configuration nearest to it (highest measurement density).
    pub nearest_config_index: u32,
    /// Its region (id): the region the measurement implies.
    pub implied_region: String,
    /// Whether that is the region the operator keyed; when not, the belief still learns from
    /// the measurement and the trial is flagged here and on screen.
    pub agrees: bool,
}

/// `/trial/void`: the trial did not count. An event.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "handover.TrialVoid")]
pub struct TrialVoid {
    #[serde(flatten)]
    pub trial: TrialFields,
    pub reason: VoidReason,
    pub detail: String,
    /// Whether a grasp just recorded was taken back with it.
    pub retracted: bool,
}

/// `/trial/undo`: the last grasp was taken back. An event.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "handover.TrialUndo")]
pub struct TrialUndo {
    #[serde(flatten)]
    pub trial: TrialFields,
}

/// A credible interval of λ.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Interval {
    pub low: Lambda,
    pub high: Lambda,
}

/// `/belief/<condition>`: the belief of one training condition. Derived.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "handover.Belief")]
pub struct BeliefMessage {
    pub event_index: u32,
    pub condition: String,
    #[schemars(regex(pattern = r"^[A-Z]$"))]
    pub program: String,
    /// Updates so far (0: the prior).
    pub iteration: u32,
    /// `region` or `configuration`.
    pub observation: String,
    pub mean: Lambda,
    pub map: Lambda,
    pub ci90: Interval,
    pub grid_mode: Lambda,
    /// Gridded entropy, nats (eq. 6 with its minus sign).
    pub entropy: f64,
    /// Effective sample size.
    pub ess: f64,
}

/// `/human/joints`: the 7 joint angles of the configuration a response maps to, by name,
/// for plotting. Derived.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "handover.JointAngles")]
pub struct JointAngles {
    #[serde(flatten)]
    pub trial: TrialFields,
    pub config_index: u32,
    /// Degrees, by joint name (`docs/kinematics.md`).
    pub deg: JointValues,
    /// Radians, by joint name.
    pub rad: JointValues,
}

/// One value per joint of the arm model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct JointValues {
    pub shoulder_flexion: f64,
    pub shoulder_abduction: f64,
    pub shoulder_internal_rotation: f64,
    pub elbow_flexion: f64,
    pub forearm_pronation: f64,
    pub wrist_flexion: f64,
    pub wrist_radial_deviation: f64,
}

impl From<[f64; 7]> for JointValues {
    fn from(q: [f64; 7]) -> Self {
        let [a, b, c, d, e, f, g] = q;
        Self {
            shoulder_flexion: a,
            shoulder_abduction: b,
            shoulder_internal_rotation: c,
            elbow_flexion: d,
            forearm_pronation: e,
            wrist_flexion: f,
            wrist_radial_deviation: g,
        }
    }
}

/// `/test/log_likelihood/<condition>`: after the session ends, one per training condition:
/// the test-set log-likelihood of its posterior-mean estimate after each iteration, as
/// `analyze` computes it. An array indexed by iteration, so that Foxglove's Plot panel draws it against the
/// index. Derived.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "handover.TestLogLikelihood")]
pub struct TestLogLikelihood {
    pub event_index: u32,
    pub condition: String,
    #[schemars(regex(pattern = r"^[A-Z]$"))]
    pub program: String,
    /// Σ over test trials of log P(taken | query, posterior mean) after iteration i
    /// (0: the prior), nats.
    pub log_likelihood: Vec<f64>,
    /// Test trials answered.
    pub test_trials: u32,
}

/// `/questionnaire/likert`: an answer to a statement. An event.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "handover.LikertAnswer")]
pub struct LikertAnswer {
    pub event_index: u32,
    #[schemars(regex(pattern = r"^[A-Z]$"))]
    pub program: String,
    pub program_label: String,
    pub condition: String,
    pub item: String,
    pub statement: String,
    pub value: i64,
    pub label: String,
}

/// `/questionnaire/choice`: the program preferred. An event.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "handover.ForcedChoice")]
pub struct ForcedChoice {
    pub event_index: u32,
    #[schemars(regex(pattern = r"^[A-Z]$"))]
    pub program: String,
    pub program_label: String,
    pub condition: String,
    pub question: String,
}

/// `/session/pause` and `/session/resume`. Events.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "handover.SessionMark")]
pub struct SessionMark {
    pub event_index: u32,
}

/// Which transition between phases was confirmed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum TransitionName {
    Program,
    Test,
    Questionnaire,
}

/// `/session/transition`: the experimenter told the participant what comes next and went
/// on; the next phase's first query is presented only after it. Event.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "handover.SessionTransition")]
pub struct SessionTransition {
    pub event_index: u32,
    /// `program` (a training program after another), `test` or `questionnaire`.
    pub transition: TransitionName,
    /// The program letter that begins (only for `program`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(regex(pattern = r"^[A-Z]$"))]
    pub program: Option<String>,
}

/// How a session ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum EndStatus {
    Completed,
    Aborted,
}

/// `/session/end`. An event.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "handover.SessionEnd")]
pub struct SessionEnd {
    pub event_index: u32,
    pub status: EndStatus,
    /// Aborted only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
}

/// `/robot/command`: the object's pose sent to the robot for a trial. An event.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "handover.RobotCommand")]
pub struct RobotCommand {
    #[serde(flatten)]
    pub trial: TrialFields,
    /// The pose's name.
    pub label: String,
    /// 1-based: the trial's first command, or a re-send.
    #[schemars(range(min = 1))]
    pub attempt: u32,
    /// How it was sent: `ros2` or `command`.
    pub link: RobotLinkKind,
    /// The command's id, `SEC.NANOSEC` (when it was issued; the pose's `header.stamp`), which
    /// the robot's statuses name (format 4 on).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(regex(pattern = r"^[0-9]{1,12}\.[0-9]{9}$"))]
    pub command: Option<String>,
    /// The pose as sent: the frame, position (m) and orientation (quaternion x, y, z, w).
    pub pose: SentPose,
    /// The same orientation as roll, pitch, yaw (degrees).
    pub rpy_deg: [f64; 3],
    /// The commanded pose in the participant's shoulder frame (as `/trial/query` has it).
    pub shoulder_pose: RobotPose,
    /// Ids of the grip regions offered, and their labels.
    pub regions: Vec<String>,
    pub region_labels: Vec<String>,
}

/// `/robot/status`: what the robot said of a command (or the console's timeout). An event.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "handover.RobotStatus")]
pub struct RobotStatus {
    pub event_index: u32,
    /// The query whose command it answers.
    pub query: String,
    /// The command of the trial under way it answers (absent when the trial has moved on, and
    /// for a stale status).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub attempt: Option<u32>,
    /// The id of the command it answers or, stale, names (format 4 on; absent for a stale
    /// status that names none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(regex(pattern = r"^[0-9]{1,12}\.[0-9]{9}$"))]
    pub command: Option<String>,
    /// It answers another command than the one under way, or cannot be told to answer it:
    /// nothing moved on it (format 4 on; written only when true).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub stale: bool,
    pub state: RobotState,
    /// The robot's words (an unknown status text, a program's exit status and error output).
    pub detail: String,
}

/// The run index of a program letter (`A` is 0).
pub fn program_index(letter: &str) -> Option<usize> {
    let c = letter.bytes().next()?;
    (letter.len() == 1 && c.is_ascii_uppercase()).then(|| (c - b'A') as usize)
}
