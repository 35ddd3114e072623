//! What happens in a session: the start record and the events folded over it.

use serde::{Deserialize, Serialize};

use crate::select::SelectorKind;

/// Everything fixed when a session starts (the log's `/session/start`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SessionStart {
    /// Random id of this session (one per session, kept across resumes).
    pub session_id: String,
    /// Pseudonymous id.
    #[schemars(regex(pattern = r"^[A-Za-z0-9-]{1,32}$"))]
    pub participant: String,
    pub protocol_name: String,
    /// SHA-256 of the protocol text as run.
    #[schemars(regex(pattern = r"^[0-9a-f]{64}$"))]
    pub protocol_sha256: String,
    pub seed: u64,
    /// The training conditions in the order run: Program A first.
    pub condition_order: Vec<SelectorKind>,
    /// The labels the participant sees for the runs, in the order run.
    pub program_labels: Vec<String>,
    pub software_version: String,
    /// A rehearsal or dry run, never mixed with real data.
    pub pilot: bool,
    /// Counterbalancing slot (index into the orders AB, BA).
    pub slot: usize,
    /// Start time, RFC 3339 UTC.
    pub started_at: String,
    /// The simulated participant's ground truth, in dry runs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub simulated_truth: Option<crate::ergo::Lambda>,
    /// The log this one continues after a crash or a quit (its file name).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resumed_from: Option<String>,
    /// The outcome the selectors score queries by. A new session takes it from its
    /// protocol ([`Session::new`](super::Session::new)); logs of formats 1 and 2 lack it and
    /// scored regions, which their reader fills in.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub selection: Option<SelectionOutcome>,
}

/// What the selectors score a query's outcomes as: the grip region taken, or the arm
/// measured (a protocol whose sessions learn from the measured arm, log format 3 on).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum SelectionOutcome {
    Region,
    Measured,
}

/// Why a trial was voided.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum VoidReason {
    /// The object was dropped.
    Dropped,
    /// The robot did not reach or hold the pose.
    RobotFault,
    /// The participant was not ready or misunderstood.
    ParticipantNotReady,
    /// Anything else (see the detail).
    Other,
}

impl VoidReason {
    pub const ALL: [VoidReason; 4] =
        [VoidReason::Dropped, VoidReason::RobotFault, VoidReason::ParticipantNotReady, VoidReason::Other];

    /// The name the log and the tables use (`robot-fault`), as serde writes it.
    pub fn name(self) -> &'static str {
        match self {
            VoidReason::Dropped => "dropped",
            VoidReason::RobotFault => "robot-fault",
            VoidReason::ParticipantNotReady => "participant-not-ready",
            VoidReason::Other => "other",
        }
    }

    /// The name the console shows.
    pub fn label(self) -> &'static str {
        match self {
            VoidReason::Dropped => "object dropped",
            VoidReason::RobotFault => "robot fault",
            VoidReason::ParticipantNotReady => "participant not ready",
            VoidReason::Other => "other",
        }
    }
}

/// How the console reaches the robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum RobotLinkKind {
    /// ROS 2 topics over DDS.
    Ros2,
    /// A program run for each command (`--robot-command`).
    Command,
}

impl RobotLinkKind {
    pub fn name(self) -> &'static str {
        match self {
            RobotLinkKind::Ros2 => "ros2",
            RobotLinkKind::Command => "command",
        }
    }
}

/// What a robot said of a command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum RobotState {
    /// On its way to the pose.
    Moving,
    /// Holding the object at the pose.
    AtPose,
    /// It could not reach or hold the pose.
    Failed,
    /// No answer within the configured time (said by the console, not the robot).
    Timeout,
    /// Anything else it said (the text is the detail).
    Other,
}

impl RobotState {
    pub fn name(self) -> &'static str {
        match self {
            RobotState::Moving => "moving",
            RobotState::AtPose => "at_pose",
            RobotState::Failed => "failed",
            RobotState::Timeout => "timeout",
            RobotState::Other => "other",
        }
    }

    /// Whether the command is over (nothing more is expected of it).
    pub fn is_final(self) -> bool {
        matches!(self, RobotState::AtPose | RobotState::Failed | RobotState::Timeout)
    }
}

/// The object's pose as sent to the robot: a frame, a position (m) and a unit quaternion
/// (x, y, z, w), as `geometry_msgs/msg/Pose` has them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct SentPose {
    pub frame: String,
    pub position: [f64; 3],
    pub orientation: [f64; 4],
}

/// Why a pose cannot be sent to a robot.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PoseProblem {
    /// Not a frame id (the id shown escaped).
    #[error("frame '{0}' is not a frame id: expected 1 to 64 characters from A–Z, a–z, 0–9, '_', '/', '.', '-'")]
    FrameId(String),
    #[error("position {0:?} is not finite within 10 m of the frame's origin")]
    Position([f64; 3]),
    #[error("orientation {0:?} is not a unit quaternion (x, y, z, w)")]
    Orientation([f64; 4]),
}

/// Checks a frame id as ROS 2 and Foxglove take one: 1 to 64 characters from A–Z, a–z, 0–9,
/// `_`, `/`, `.` and `-`.
pub fn validate_frame_id(frame: &str) -> Result<(), PoseProblem> {
    let ok = (1..=64).contains(&frame.len())
        && frame.bytes().all(|b| b.is_ascii_alphanumeric() || matches!(b, b'_' | b'/' | b'.' | b'-'));
    if ok { Ok(()) } else { Err(PoseProblem::FrameId(frame.escape_debug().to_string())) }
}

/// Checks a pose sent to a robot: a frame id, a finite position within 10 m of the frame's
/// origin, and a unit quaternion (to 1e-6).
pub fn validate_sent_pose(pose: &SentPose) -> Result<(), PoseProblem> {
    validate_frame_id(&pose.frame)?;
    if !pose.position.iter().all(|v| v.is_finite() && v.abs() <= 10.0) {
        return Err(PoseProblem::Position(pose.position));
    }
    let norm = pose.orientation.iter().map(|v| v * v).sum::<f64>().sqrt();
    if !pose.orientation.iter().all(|v| v.is_finite()) || (norm - 1.0).abs() > 1e-6 {
        return Err(PoseProblem::Orientation(pose.orientation));
    }
    Ok(())
}

/// Why a text is not a command id.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error(
    "command '{0}' is not a command id: expected seconds, '.', 9 digits of nanoseconds (e.g. 1765130000.123456789)"
)]
pub struct CommandIdProblem(pub String);

/// A command id: the time it was issued, `SEC.NANOSEC` since the Unix epoch (1 to 12 digits,
/// '.', 9 digits), as the pose's `header.stamp` carries it.
pub fn validate_command_id(id: &str) -> Result<(), CommandIdProblem> {
    let ok = id.split_once('.').is_some_and(|(sec, nsec)| {
        (1..=12).contains(&sec.len()) && nsec.len() == 9 && sec.bytes().chain(nsec.bytes()).all(|b| b.is_ascii_digit())
    });
    if ok { Ok(()) } else { Err(CommandIdProblem(id.escape_debug().to_string())) }
}

/// Where a measurement of the arm came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum MeasurementSource {
    /// A simulated participant's configuration plus the protocol's noise (dry runs).
    Simulated,
    /// A ROS 2 `sensor_msgs/msg/JointState` topic.
    Ros2,
    /// A measurements file aligned to the log afterwards (`analyze --measurements`); never in
    /// a log.
    File,
}

impl MeasurementSource {
    pub fn name(self) -> &'static str {
        match self {
            MeasurementSource::Simulated => "simulated",
            MeasurementSource::Ros2 => "ros2",
            MeasurementSource::File => "file",
        }
    }
}

/// The arm's joint angles as a measuring system reported them at a grasp.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ArmMeasurement {
    /// Joint angles (rad), in the arm model's joint order.
    pub q_rad: Vec<f64>,
    pub source: MeasurementSource,
    /// The sample's time minus the grasp's (s); within the protocol's window.
    pub offset_s: f64,
}

impl ArmMeasurement {
    /// The one rule that takes a grasp's sample, live and post hoc alike: the latest sample
    /// stamped at or before the grasp's time, no more than `window_s` before it (none: the
    /// grasp learns from the region). Samples are (ns since the Unix epoch, angles), in any
    /// order; of samples stamped alike, the last.
    pub fn pick<'a>(
        samples: impl IntoIterator<Item = &'a (u64, [f64; crate::kinematics::JOINTS])>,
        time_ns: u64,
        window_s: f64,
        source: MeasurementSource,
    ) -> Option<Self> {
        let mut best: Option<&(u64, [f64; crate::kinematics::JOINTS])> = None;
        for s in samples {
            if s.0 <= time_ns && best.is_none_or(|b| s.0 >= b.0) {
                best = Some(s);
            }
        }
        let (t, q) = best?;
        let offset_s = -((time_ns - t) as f64 / 1e9);
        (-offset_s <= window_s).then(|| Self { q_rad: q.to_vec(), source, offset_s })
    }
}

/// One thing that happened, as the operator (or a simulated participant) reports it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case")]
pub enum Event {
    /// The robot holds the suggested query's object at its pose.
    QueryPresented {
        query: String,
    },
    /// The participant took the object by this grip region (the operator's key), and, with
    /// `measured` observations, the arm as measured at the grasp (none: no sample in time).
    GraspRecorded {
        region: String,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        measured: Option<ArmMeasurement>,
    },
    /// The current trial does not count and is repeated; a grasp just recorded is retracted.
    TrialVoided {
        reason: VoidReason,
        detail: String,
    },
    /// The last recorded grasp is taken back (until the next query is presented).
    GraspUndone,
    Note {
        text: String,
    },
    Paused,
    Resumed,
    /// An answer to a Likert item about a program (0 = Program A).
    LikertAnswered {
        program: usize,
        item: String,
        value: i64,
    },
    /// The program preferred in the forced choice.
    ForcedChoice {
        program: usize,
    },
    /// The session is complete.
    Ended,
    /// The session stops early.
    Aborted {
        reason: String,
    },
    /// The robot was sent the waiting query's pose (again, for a second attempt).
    RobotCommanded {
        query: String,
        link: RobotLinkKind,
        pose: SentPose,
        /// The command's id ([`validate_command_id`]); none in logs before format 4.
        command: Option<String>,
    },
    /// The robot (or the console's timeout) reported on a command for `query`.
    RobotReported {
        query: String,
        state: RobotState,
        detail: String,
        /// The command it answers, or (stale) the one it names; none in logs before format
        /// 4, and for a stale status that names no command.
        command: Option<String>,
        /// It answers a command other than the one under way, or cannot be told to answer
        /// it: logged, and nothing in the session moves on it.
        stale: bool,
    },
    /// The experimenter told the participant what comes next and goes on.
    TransitionConfirmed {
        transition: super::Transition,
    },
}

/// An event with the time it happened (ns since the Unix epoch), stamped by the shell.
#[derive(Clone, Debug, PartialEq)]
pub struct Stamped {
    pub time_ns: u64,
    pub event: Event,
}

/// A program's letter: 0 → "A".
pub fn program_letter(program: usize) -> String {
    char::from(b'A' + program as u8).to_string()
}
