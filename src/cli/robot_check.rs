//! `handover robot-check`: the lab's ROS 2 setup, checked without moving anything.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::Result;
use clap::Args;
use handover::robot::discovery::Side;
use handover::robot::setup_check::check_setup;

use super::input::bad;
use super::robot::{MeasureKind, RobotArgs, RobotKind};

#[derive(Debug, Args)]
pub struct RobotCheckArgs {
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
    let (domain, checks) = check_setup(&settings, args.measure.is_some(), Duration::from_secs_f64(args.wait_s))
        .map_err(|e| anyhow::anyhow!("cannot join ROS 2: {e}"))?;
    let networks = if settings.ros2.networks.is_empty() {
        "all".to_string()
    } else {
        settings.ros2.networks.iter().map(ToString::to_string).collect::<Vec<_>>().join(", ")
    };
    outln!("ROS 2 {domain}, networks: {networks}; after {} s of discovery:", args.wait_s);
    let mut failing = 0;
    for c in &checks {
        let (direction, others) = match c.side {
            Side::Publishes => ("console →", "subscriber"),
            Side::Subscribes => ("console ←", "publisher"),
        };
        let verdict = match (&c.problem, c.required) {
            (None, _) => format!("ok: {} matching {others}{}", c.matching, if c.matching == 1 { "" } else { "s" }),
            (Some(why), true) => {
                failing += 1;
                format!("NOT READY: {why}")
            }
            (Some(why), false) => format!("optional: {why}"),
        };
        outln!("  {direction} {} ({})  {verdict}", c.topic, c.ros_type);
    }
    if failing > 0 {
        anyhow::bail!("{failing} topic(s) not ready: a session would not hear the robot or be heard by it");
    }
    Ok(())
}
