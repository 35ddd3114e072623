//! The robot options shared by `run`, `dry-run` and `resume`.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use handover::protocol::{ObservationModel, Study};
use handover::robot::joint_states::JointStateSource;
use handover::robot::{Robot, RobotSettings, hook::CommandHook, ros2::Ros2Link};

use super::input::{bad, read_text};

/// How long a scripted drive waits for the measuring system to be heard before its first grasp.
const ARM_WAIT: std::time::Duration = std::time::Duration::from_secs(3);

/// How the robot is reached.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RobotKind {
    /// ROS 2 topics over DDS (no ROS install needed).
    Ros2,
}

/// Where the participant's arm is measured live.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MeasureKind {
    /// A ROS 2 sensor_msgs/msg/JointState topic.
    Ros2,
}

/// The robot in the loop (none: the operator commands the robot by hand).
#[derive(Debug, Clone, Default, Args)]
pub struct RobotArgs {
    /// Drive the robot over ROS 2: each query is published as a geometry_msgs/msg/PoseStamped
    /// on /handover/target_pose (and the trial as JSON in a std_msgs/msg/String on
    /// /handover/trial); the robot answers on /handover/robot_status (std_msgs/msg/String:
    /// moving, at_pose, failed). Domain (else ROS_DOMAIN_ID, else 0), topics and frames:
    /// --robot-config.
    #[arg(long, value_enum, conflicts_with = "robot_command")]
    pub robot: Option<RobotKind>,
    /// Run PROGRAM for each query with the command as one line of JSON on its standard input
    /// (position in m, quaternion and roll/pitch/yaw, frame, object, grips, trial); exit
    /// status 0 means the robot holds the object there. Killed at the timeout.
    #[arg(long, value_name = "PROGRAM")]
    pub robot_command: Option<PathBuf>,
    /// The lab's robot settings (JSON; see docs/guide.md "With a robot"): timeout_s, present_on
    /// (operator or at_pose), shoulder_frame_id, base_frame, ros2 {domain_id, pose_topic,
    /// trial_topic, status_topic, networks, resend_s}.
    #[arg(long, value_name = "FILE")]
    pub robot_config: Option<PathBuf>,
    /// Measure the participant's arm live (a protocol with "observation": "measured"): a
    /// measuring system publishes sensor_msgs/msg/JointState on
    /// /handover/participant/joint_states (--robot-config's ros2.joint_states_topic), named
    /// as the protocol's learning.measurement.joint_names; each grasp takes the latest sample
    /// at or before it within the protocol's window, else learns from the handle.
    #[arg(long, value_enum)]
    pub measure: Option<MeasureKind>,
}

impl RobotArgs {
    /// The robot, connected; none when no robot option is given.
    pub fn connect(&self) -> Result<Option<Robot>> {
        if self.robot.is_none() && self.robot_command.is_none() {
            if self.robot_config.is_some() && self.measure.is_none() {
                return Err(bad("--robot-config is given without --robot, --robot-command or --measure"));
            }
            return Ok(None);
        }
        let settings = self.settings()?;
        let robot = match (&self.robot, &self.robot_command) {
            (Some(RobotKind::Ros2), _) => Robot::new(settings, |tx, s| Ok(Box::new(Ros2Link::new(tx, s)?)))
                .map_err(|e| anyhow::anyhow!("cannot reach the robot: {e}"))?,
            (None, Some(program)) => {
                Robot::new(settings, |tx, s| Ok(Box::new(CommandHook::new(program.clone(), tx, s)?))).map_err(bad)?
            }
            (None, None) => return Ok(None),
        };
        Ok(Some(robot))
    }

    /// The lab's settings, with the ROS 2 domain checked when ROS 2 is used (a bad
    /// `ROS_DOMAIN_ID` is refused before anything starts).
    pub fn settings(&self) -> Result<RobotSettings> {
        let settings = match &self.robot_config {
            Some(path) => RobotSettings::from_json(&read_text(path)?, &path.display().to_string())
                .map_err(|e| bad(e.to_string()))?,
            None => RobotSettings::default(),
        };
        if self.robot.is_some() || self.measure.is_some() {
            settings.ros2.domain().map_err(|e| bad(e.to_string()))?;
        }
        Ok(settings)
    }

    /// The live arm measurement, subscribed; none without --measure.
    pub fn connect_arm(&self, study: &Study) -> Result<Option<JointStateSource>> {
        let Some(MeasureKind::Ros2) = self.measure else { return Ok(None) };
        let learning = &study.protocol.learning;
        let (ObservationModel::Measured, Some(m)) = (learning.observation, &learning.measurement) else {
            return Err(bad(format!(
                "--measure needs a protocol with \"observation\": \"measured\" (this one's is '{}')",
                learning.observation.name()
            )));
        };
        let settings = self.settings()?;
        let source = JointStateSource::new(&settings.ros2, &m.joint_names)
            .map_err(|e| anyhow::anyhow!("cannot subscribe to the arm's joint states: {e}"))?;
        Ok(Some(source))
    }

    /// [`Self::connect_arm`] for a scripted drive, which reaches its first grasp within
    /// milliseconds: it waits until the measuring system is heard (DDS discovery takes a
    /// moment), at most [`ARM_WAIT`], and says so when it is not (the grasps then learn from
    /// the region until a sample comes).
    pub fn connect_arm_heard(&self, study: &Study) -> Result<Option<JointStateSource>> {
        let arm = self.connect_arm(study)?;
        if let Some(source) = &arm
            && !source.wait_until_heard(ARM_WAIT)
        {
            let why = source.diagnose().map_or_else(String::new, |why| format!(" ({why})"));
            errln!(
                "no joint state from {} within {} s{why}: grasps learn from the region until one comes",
                source.describe(),
                ARM_WAIT.as_secs()
            );
        }
        Ok(arm)
    }
}
