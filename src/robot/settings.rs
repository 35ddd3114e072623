//! The lab's robot settings (`--robot-config FILE`): which frame poses are sent in, how long a
//! command may take, what confirms a presentation, and the ROS 2 topics. Untrusted input:
//! every field is checked and named in the error.

use std::net::IpAddr;
use std::time::Duration;

use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use serde::Deserialize;

use crate::session::validate_frame_id;

/// The largest settings file read.
pub(crate) const MAX_SETTINGS_BYTES: u64 = 64 << 10;

/// What makes a trial's query "presented".
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PresentOn {
    /// The operator's Enter (the default: the operator sees the robot).
    Operator,
    /// The robot's `at_pose` (or the operator's Enter, whichever comes first).
    AtPose,
}

impl PresentOn {
    /// As the screen says it.
    pub fn name(self) -> &'static str {
        match self {
            PresentOn::Operator => "the operator's Enter",
            PresentOn::AtPose => "at_pose or Enter",
        }
    }
}

/// The robot's base frame, when poses are sent in it rather than the shoulder frame: the
/// participant's shoulder frame as seen from the base (measured in the lab).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaseFrame {
    pub frame_id: String,
    /// Where the shoulder frame's origin is in the base frame (m).
    pub shoulder_position: [f64; 3],
    /// The shoulder frame's orientation in the base frame: roll, pitch, yaw (degrees,
    /// R = Rz(yaw) Ry(pitch) Rx(roll), as poses are written).
    pub shoulder_rpy_deg: [f64; 3],
}

impl BaseFrame {
    /// The transform from the shoulder frame to the base frame.
    pub fn base_from_shoulder(&self) -> Isometry3<f64> {
        let [r, p, y] = self.shoulder_rpy_deg.map(f64::to_radians);
        let [x, yy, z] = self.shoulder_position;
        Isometry3::from_parts(Translation3::new(x, yy, z), UnitQuaternion::from_euler_angles(r, p, y))
    }
}

/// The ROS 2 side: DDS domain, topic names, and the networks DDS may use.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Ros2Settings {
    /// The DDS domain (0–232); when absent, the environment's `ROS_DOMAIN_ID`, else 0.
    pub domain_id: Option<u16>,
    /// `geometry_msgs/msg/PoseStamped`: the object's pose for the robot.
    pub pose_topic: String,
    /// `std_msgs/msg/String`, JSON: the trial (phase, trial, query, object, grips, attempt).
    pub trial_topic: String,
    /// `std_msgs/msg/String`: `moving`, `at_pose`, `failed` from the robot.
    pub status_topic: String,
    /// `sensor_msgs/msg/JointState`: the participant's arm from a measuring system
    /// (`--measure ros2`).
    pub joint_states_topic: String,
    /// Local addresses whose interfaces DDS uses (all when empty).
    pub networks: Vec<IpAddr>,
    /// Seconds to wait for the robot's subscription before publishing anyway, and between
    /// re-sends of a command nothing answered.
    pub resend_s: f64,
}

/// The largest DDS domain id ROS 2 accepts (the RTPS port arithmetic's limit).
pub const MAX_DOMAIN_ID: u16 = 232;

/// The DDS domain the ROS 2 side joins, and what chose it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Domain {
    pub id: u16,
    /// `ros2.domain_id`, `ROS_DOMAIN_ID` or `default`.
    pub from: &'static str,
}

impl std::fmt::Display for Domain {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "domain {} ({})", self.id, self.from)
    }
}

impl Ros2Settings {
    /// The DDS domain, as ROS 2 nodes choose theirs: the settings' `domain_id` when given,
    /// else the environment's `ROS_DOMAIN_ID`, else 0.
    pub fn domain(&self) -> Result<Domain, SettingsError> {
        self.domain_with(std::env::var_os("ROS_DOMAIN_ID"))
    }

    /// [`Self::domain`] with `env` as `ROS_DOMAIN_ID`'s value. An empty value counts as unset
    /// (as in rcl).
    pub fn domain_with(&self, env: Option<std::ffi::OsString>) -> Result<Domain, SettingsError> {
        if let Some(id) = self.domain_id {
            return Ok(Domain { id, from: "ros2.domain_id" });
        }
        let Some(value) = env.filter(|v| !v.is_empty()) else { return Ok(Domain { id: 0, from: "default" }) };
        let text = value.to_string_lossy();
        match text.trim().parse::<u16>() {
            Ok(id) if id <= MAX_DOMAIN_ID => Ok(Domain { id, from: "ROS_DOMAIN_ID" }),
            _ => Err(SettingsError::DomainEnvironment {
                value: crate::text::printable(&text.chars().take(40).collect::<String>()).into_owned(),
            }),
        }
    }
}

impl Default for Ros2Settings {
    fn default() -> Self {
        Self {
            domain_id: None,
            pose_topic: "/handover/target_pose".into(),
            trial_topic: "/handover/trial".into(),
            status_topic: "/handover/robot_status".into(),
            joint_states_topic: "/handover/participant/joint_states".into(),
            networks: Vec::new(),
            resend_s: 2.0,
        }
    }
}

/// Everything a lab sets about its robot.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RobotSettings {
    /// Seconds a command may take to reach `at_pose` (or a program to exit) before it is
    /// reported as a timeout.
    pub timeout_s: f64,
    pub present_on: PresentOn,
    /// The frame id poses are sent in when there is no base frame.
    pub shoulder_frame_id: String,
    pub base_frame: Option<BaseFrame>,
    pub ros2: Ros2Settings,
}

impl Default for RobotSettings {
    fn default() -> Self {
        Self {
            timeout_s: 60.0,
            present_on: PresentOn::Operator,
            shoulder_frame_id: "shoulder".into(),
            base_frame: None,
            ros2: Ros2Settings::default(),
        }
    }
}

/// Why robot settings cannot be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SettingsError {
    #[error("{file}: {bytes} bytes, over the budget of {MAX_SETTINGS_BYTES} for robot settings")]
    TooLarge { file: String, bytes: usize },
    /// Not JSON of the settings' shape: where the reading stopped and why.
    #[error("{file}: {path}: {message}")]
    Shape { file: String, path: String, message: String },
    #[error("{file}: {problem}")]
    Field { file: String, problem: FieldProblem },
    /// The environment's `ROS_DOMAIN_ID` (printable, cut to 40 characters) is not a domain.
    #[error(
        "ROS_DOMAIN_ID is '{value}', expected a whole number from 0 to {MAX_DOMAIN_ID} (or set ros2.domain_id in the robot settings)"
    )]
    DomainEnvironment { value: String },
}

/// A settings field out of its range: its path and what it is against what was expected.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{field}: {problem}")]
pub struct FieldProblem {
    pub field: String,
    pub problem: String,
}

/// A name that is not a ROS 2 topic name (shown escaped).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("'{0}' is not a ROS 2 topic name: expected '/' and segments of A–Z, a–z, 0–9, '_' (not starting with a digit)")]
pub struct TopicNameError(pub String);

/// A ROS 2 topic name as ROS 2 takes it: absolute, segments of letters, digits and `_`
/// not starting with a digit, at most 200 characters.
pub fn validate_topic(name: &str) -> Result<(), TopicNameError> {
    let segment_ok = |s: &str| {
        !s.is_empty()
            && !s.starts_with(|c: char| c.is_ascii_digit())
            && s.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_')
    };
    if name.len() <= 200 && name.starts_with('/') && name[1..].split('/').all(segment_ok) {
        Ok(())
    } else {
        Err(TopicNameError(name.escape_debug().to_string()))
    }
}

impl RobotSettings {
    /// Parses and checks a settings file's text (`name` names it in errors).
    pub fn from_json(text: &str, name: &str) -> Result<Self, SettingsError> {
        let file = name.to_string();
        if text.len() as u64 > MAX_SETTINGS_BYTES {
            return Err(SettingsError::TooLarge { file, bytes: text.len() });
        }
        let de = &mut serde_json::Deserializer::from_str(text);
        let settings: Self = serde_path_to_error::deserialize(&mut *de).map_err(|e| SettingsError::Shape {
            file: file.clone(),
            path: e.path().to_string(),
            message: e.inner().to_string(),
        })?;
        de.end().map_err(|e| SettingsError::Shape {
            file: file.clone(),
            path: ".".into(),
            message: format!("{e}: expected nothing after the settings' one JSON document"),
        })?;
        settings.validate().map_err(|problem| SettingsError::Field { file, problem })?;
        Ok(settings)
    }

    /// Checks every field against its range.
    pub fn validate(&self) -> Result<(), FieldProblem> {
        let problem = |field: &str, problem: String| Err(FieldProblem { field: field.to_string(), problem });
        if !(self.timeout_s.is_finite() && (1.0..=600.0).contains(&self.timeout_s)) {
            return problem("timeout_s", format!("is {}, expected 1 to 600 seconds", self.timeout_s));
        }
        if let Err(e) = validate_frame_id(&self.shoulder_frame_id) {
            return problem("shoulder_frame_id", e.to_string());
        }
        if let Some(b) = &self.base_frame {
            if let Err(e) = validate_frame_id(&b.frame_id) {
                return problem("base_frame.frame_id", e.to_string());
            }
            if !b.shoulder_position.iter().all(|v| v.is_finite() && v.abs() <= 5.0) {
                return problem("base_frame.shoulder_position", "expected 3 finite numbers within 5 m".into());
            }
            if !b.shoulder_rpy_deg.iter().all(|v| v.is_finite() && v.abs() <= 360.0) {
                return problem("base_frame.shoulder_rpy_deg", "expected 3 finite angles within ±360°".into());
            }
        }
        let r = &self.ros2;
        if let Some(id) = r.domain_id.filter(|&id| id > MAX_DOMAIN_ID) {
            return problem("ros2.domain_id", format!("is {id}, expected 0 to {MAX_DOMAIN_ID}"));
        }
        for (field, topic) in [
            ("ros2.pose_topic", &r.pose_topic),
            ("ros2.trial_topic", &r.trial_topic),
            ("ros2.status_topic", &r.status_topic),
            ("ros2.joint_states_topic", &r.joint_states_topic),
        ] {
            if let Err(e) = validate_topic(topic) {
                return problem(field, e.to_string());
            }
        }
        if r.networks.len() > 16 {
            return problem("ros2.networks", format!("has {} addresses, expected at most 16", r.networks.len()));
        }
        if !(r.resend_s.is_finite() && (0.1..=60.0).contains(&r.resend_s)) {
            return problem("ros2.resend_s", format!("is {}, expected 0.1 to 60 seconds", r.resend_s));
        }
        Ok(())
    }

    pub fn timeout(&self) -> Duration {
        Duration::from_secs_f64(self.timeout_s)
    }

    /// The frame poses are sent in.
    pub fn frame_id(&self) -> &str {
        self.base_frame.as_ref().map_or(&self.shoulder_frame_id, |b| &b.frame_id)
    }
}
