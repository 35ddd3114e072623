//! `handover follow LOG`: the robot operator's read-only screen.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::Result;
use clap::Args;
use handover::record::Follower;

use super::input::bad;

/// Follow a session's log from a second terminal, read-only: the robot operator's screen.
/// It shows only what the robot must do now — the object, the pose, its position and
/// orientation in the participant's shoulder frame — large, with the robot's status when a
/// robot is in the loop, and follows the session into its continuation when it is resumed.
/// It never writes, locks or changes anything; q leaves. Started with the log path the
/// console's setup screen shows, before the session starts, it waits for the log to appear.
#[derive(Debug, Args)]
pub struct FollowArgs {
    /// The session log (.mcap) being written by the console.
    log: PathBuf,
}

/// How long `follow` waits for a log that does not exist yet (the console's setup screen
/// names it before Enter creates it).
const WAIT_FOR_LOG: Duration = Duration::from_secs(30 * 60);

pub fn run(args: FollowArgs) -> Result<()> {
    let mut follower = Follower::open(&args.log);
    if wait_for_log(&args.log)? {
        // Just created: the console writes its start a moment later.
        let since = Instant::now();
        while follower.is_err() && since.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(200));
            follower = Follower::open(&args.log);
        }
    }
    let follower = follower.map_err(|e| bad(e.to_string()))?;
    super::console::require_terminal()?;
    let signal = handover::tui::run_follow(follower).map_err(|e| anyhow::anyhow!("follow: {e}"))?;
    if let Some(sig) = signal {
        std::process::exit(128 + sig);
    }
    Ok(())
}

/// Waits, at most [`WAIT_FOR_LOG`], for a log that the console has named but not yet created:
/// a log file name (`ID_TIME.mcap`) whose folder's parent exists (the study's `logs/`; the
/// participant's own folder is made with the log). Anything else that is not there is an
/// error at once, as before. Whether it waited.
fn wait_for_log(log: &Path) -> Result<bool> {
    if std::fs::symlink_metadata(log).is_ok() {
        return Ok(false);
    }
    let name = log.file_name().and_then(|n| n.to_str()).unwrap_or_default();
    let logs = log.parent().and_then(Path::parent).filter(|p| p.as_os_str().is_empty() || p.is_dir());
    if !handover::record::is_log_file_name(name) || logs.is_none() {
        return Ok(false); // Follower::open names what is wrong.
    }
    errln!(
        "{}: not there yet; waiting for the console to start the session (at most {} min; Ctrl+C stops)",
        handover::text::printable(&log.display().to_string()),
        WAIT_FOR_LOG.as_secs() / 60
    );
    let since = Instant::now();
    while since.elapsed() < WAIT_FOR_LOG {
        std::thread::sleep(Duration::from_millis(200));
        if std::fs::symlink_metadata(log).is_ok() {
            return Ok(true);
        }
    }
    Err(bad(format!("{}: no such log after {} min of waiting", log.display(), WAIT_FOR_LOG.as_secs() / 60)))
}
