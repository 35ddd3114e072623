//! The robot options shared by `run`, `dry-run` and `resume`.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use handover::robot::{Robot, RobotSettings, hook::CommandHook, ros2::Ros2Link};

use super::input::{bad, read_text};

/// How the robot is reached.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RobotKind {
    /// ROS 2 topics over DDS (no ROS install needed).
    Ros2,
}

/// The robot in the loop (none: the operator commands the robot by hand).
#[derive(Debug, Clone, Default, Args)]
pub struct RobotArgs {
    /// Drive the robot over ROS 2: each query is published as a geometry_msgs/msg/PoseStamped
    /// on /handover/target_pose (and the trial as JSON in a std_msgs/msg/String on
    /// /handover/trial); the robot answers on /handover/robot_status (std_msgs/msg/String:
    /// moving, at_pose, failed). Domain, topics and frames: --robot-config.
    #[arg(long, value_enum, conflicts_with = "robot_command")]
    pub robot: Option<RobotKind>,
    /// Run PROGRAM for each query with the command as one line of JSON on its standard input
    /// (position in m, quaternion and roll/pitch/yaw, frame, object, grips, trial); exit
    /// status 0 means the robot holds the object there. Killed at the timeout.
    #[arg(long, value_name = "PROGRAM")]
    pub robot_command: Option<PathBuf>,
    /// The lab's robot settings (JSON; see README "With a robot"): timeout_s, present_on
    /// (operator or at_pose), shoulder_frame_id, base_frame, ros2 {domain_id, pose_topic,
    /// trial_topic, status_topic, networks, resend_s}.
    #[arg(long, value_name = "FILE")]
    pub robot_config: Option<PathBuf>,
}

impl RobotArgs {
    /// The robot, connected; none when no robot option is given.
    pub fn connect(&self) -> Result<Option<Robot>> {
        if self.robot.is_none() && self.robot_command.is_none() {
            if self.robot_config.is_some() {
                return Err(bad("--robot-config is given without --robot or --robot-command"));
            }
            return Ok(None);
        }
        let settings = match &self.robot_config {
            Some(path) => RobotSettings::from_json(&read_text(path)?, &path.display().to_string()).map_err(bad)?,
            None => RobotSettings::default(),
        };
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
}
