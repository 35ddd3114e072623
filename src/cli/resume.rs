//! `handover resume LOG`: continue an interrupted session from its log.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, Result};
use clap::Args;
use handover::dryrun::{drive, now_ns};
use handover::participant::{ScriptedParticipant, SimulatedPerson};
use handover::record::{RecordedSession, new_log_path, read_log, study_of};

use super::input::bad;

/// Continue an interrupted session (a crash or a quit) from its log, a truncated file
/// included. The old file is kept; a new log holds all of its events and the rest of the
/// session. Without options it reopens the operator console where the session stopped;
/// with --dry-run a simulated participant continues a dry run headless.
#[derive(Debug, Args)]
pub struct ResumeArgs {
    /// The session log (.mcap) to continue.
    log: PathBuf,
    /// Continue a dry run with its simulated participant, without the console.
    #[arg(long)]
    dry_run: bool,
    /// In the console, let the simulated participant of a dry run or rehearsal continue.
    #[arg(long, conflicts_with = "dry_run")]
    simulate: bool,
    /// Milliseconds to wait between simulated actions.
    #[arg(long, value_name = "MS", default_value_t = 0)]
    pace: u64,
}

pub fn run(args: ResumeArgs) -> Result<()> {
    let old = read_log(&args.log).map_err(|e| bad(e.to_string()))?;
    if !args.dry_run {
        return super::console::resume(old, args.simulate, args.pace);
    }
    let Some(truth) = old.start.simulated_truth.clone() else {
        return Err(bad(format!(
            "{}: not a dry run (no simulated participant); resume it without --dry-run",
            args.log.display()
        )));
    };
    let study = study_of(&old)?;
    let logs = args.log.parent().and_then(|d| d.parent()).map(PathBuf::from).unwrap_or_else(|| PathBuf::from("."));
    let path = new_log_path(&logs, &old.start.participant, chrono::Utc::now());
    let mut rec = RecordedSession::resume(&old, &path, now_ns())?;
    eprintln!("resumed {} ({} events) into {}", args.log.display(), old.events.len(), path.display());
    let person = SimulatedPerson { truth, alpha: study.protocol.learning.alpha };
    drive(&mut rec, &ScriptedParticipant { person }, Duration::from_millis(args.pace))?;
    let path = rec.finish().context("cannot finish the log")?;
    super::dry_run::report(&study, &path)
}
