//! `handover follow LOG`: the robot operator's read-only screen.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use handover::record::Follower;

use super::input::bad;

/// Follow a session's log from a second terminal, read-only: the robot operator's screen.
/// It shows only what the robot must do now — the object, the pose, its position and
/// orientation in the participant's shoulder frame — large, with the robot's status when a
/// robot is in the loop, and follows the session into its continuation when it is resumed.
/// It never writes, locks or changes anything; q leaves.
#[derive(Debug, Args)]
pub struct FollowArgs {
    /// The session log (.mcap) being written by the console.
    log: PathBuf,
}

pub fn run(args: FollowArgs) -> Result<()> {
    let follower = Follower::open(&args.log).map_err(|e| bad(e.to_string()))?;
    super::console::require_terminal()?;
    let signal = handover::tui::run_follow(follower).map_err(|e| anyhow::anyhow!("follow: {e}"))?;
    if let Some(sig) = signal {
        std::process::exit(128 + sig);
    }
    Ok(())
}
