//! `handover robot-check`: a lab's ROS 2 setup checked without moving anything. The console's
//! side joins the domain with no endpoints of its own, waits for discovery, and says, for each
//! topic the console would use, how many endpoints on the other side could exchange messages
//! with it, or why none can ([`super::discovery`]).

use std::time::Duration;

use super::discovery::{Endpoint, Side, diagnose, matching, peers};
use super::ros2::{ConsoleEndpoints, start_node};
use super::{Domain, RobotSettings};

/// One topic of the console's, as discovery found its other side.
#[derive(Clone, Debug, PartialEq)]
pub struct TopicCheck {
    pub topic: String,
    pub ros_type: &'static str,
    pub side: Side,
    /// Endpoints on the other side that match.
    pub matching: usize,
    /// Why none does (when none does).
    pub problem: Option<String>,
    /// Whether a session needs it (the trial topic is for robots that want it).
    pub required: bool,
}

/// The console's endpoints, each with whether a session needs it: the robot's topics, and
/// the arm's with `measure`.
fn console_endpoints(settings: &RobotSettings, measure: bool) -> Vec<(Endpoint, bool)> {
    let e = ConsoleEndpoints::of(&settings.ros2);
    let mut all = vec![(e.pose, true), (e.trial, false), (e.status, true)];
    if measure {
        all.push((e.joint_states, true));
    }
    all
}

/// Joins the settings' domain, waits `wait` for discovery, and checks every topic.
pub fn check_setup(
    settings: &RobotSettings,
    measure: bool,
    wait: Duration,
) -> Result<(Domain, Vec<TopicCheck>), String> {
    let started = start_node(&settings.ros2, "handover_check")?;
    std::thread::sleep(wait);
    let checks = console_endpoints(settings, measure)
        .into_iter()
        .map(|(ours, required)| {
            let others = peers(&started.participant, ours.side);
            TopicCheck {
                matching: matching(&ours, &others),
                problem: diagnose(&ours, &others, started.domain),
                topic: ours.topic,
                ros_type: ours.ros_type,
                side: ours.side,
                required,
            }
        })
        .collect();
    Ok((started.domain, checks))
}
