//! `handover robot-check`: the lab's ROS 2 setup, checked without moving anything.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::Result;
use clap::Args;
use handover::robot::discovery::Side;
use handover::robot::setup_check::{Checked, check_setup};

use super::input::bad;
use super::robot::{MeasureKind, RobotArgs, RobotKind};

/// Checks the robot's topics (`--robot ros2`, the default), the measuring system's
/// (`--measure ros2`), or both.
#[derive(Debug, Args)]
pub struct RobotCheckArgs {
    /// Check the robot's topics (the default unless only --measure is given).
    #[arg(long, value_enum)]
    robot: Option<RobotKind>,
    /// The lab's robot settings, as `run --robot-config` takes them (domain, topics, networks).
    #[arg(long, value_name = "FILE")]
    robot_config: Option<PathBuf>,
    /// Check the measuring system's joint-state topic too (as `run --measure ros2` uses it).
    #[arg(long, value_enum)]
    measure: Option<MeasureKind>,
    /// Seconds to wait for DDS discovery before reporting.
    #[arg(long, value_name = "S", default_value_t = 3.0)]
    wait_s: f64,
}

pub fn run(args: RobotCheckArgs) -> Result<()> {
    if !(args.wait_s.is_finite() && (0.5..=60.0).contains(&args.wait_s)) {
        return Err(bad(format!("--wait-s is {}, expected 0.5 to 60 seconds", args.wait_s)));
    }
    let robot = RobotArgs {
        robot: Some(RobotKind::Ros2),
        robot_config: args.robot_config.clone(),
        measure: args.measure,
        ..RobotArgs::default()
    };
    let settings = robot.settings()?;
    // A lab that measures the arm and moves the robot by hand has no robot topics.
    let checked = Checked { robot: args.robot.is_some() || args.measure.is_none(), measure: args.measure.is_some() };
    let report = check_setup(&settings, checked, Duration::from_secs_f64(args.wait_s))
        .map_err(|e| anyhow::anyhow!("cannot join ROS 2: {e}"))?;
    let (domain, checks) = (report.domain, &report.checks);
    let networks = if settings.ros2.networks.is_empty() {
        "all".to_string()
    } else {
        settings.ros2.networks.iter().map(ToString::to_string).collect::<Vec<_>>().join(", ")
    };
    outln!("ROS 2 {domain}, networks: {networks}; after {} s of discovery:", args.wait_s);
    let mut failing = 0;
    for c in checks {
        let (direction, others) = match c.side {
            Side::Publishes => ("console →", "subscriber"),
            Side::Subscribes => ("console ←", "publisher"),
        };
        let verdict = match (&c.problem, c.required) {
            (None, _) => {
                let on = if c.found_on.is_empty() { String::new() } else { format!(", on {}", c.found_on.join(", ")) };
                format!("ok: {} matching {others}{}{on}", c.matching, if c.matching == 1 { "" } else { "s" })
            }
            (Some(why), true) => {
                failing += 1;
                format!("NOT READY: {why}")
            }
            (Some(why), false) => format!("optional: {why}"),
        };
        outln!("  {direction} {} ({})  {verdict}", c.topic, c.ros_type);
    }
    let heard = if report.heard_on.is_empty() { "none".to_string() } else { report.heard_on.join(", ") };
    outln!("  other ROS 2 participants heard on: {heard}");
    if !report.excluded.is_empty() {
        let add: Vec<String> = report.excluded.iter().map(ToString::to_string).collect();
        outln!(
            "  ros2.networks leaves out the interface(s) they were heard on: add {} to ros2.networks",
            add.join(", ")
        );
    }
    if failing > 0 {
        anyhow::bail!("{failing} topic(s) not ready: a session would not hear the robot or be heard by it");
    }
    Ok(())
}
