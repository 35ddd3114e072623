//! `handover resume LOG`: continue an interrupted session from its log.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use handover::dryrun::{RobotDrive, drive_session, now_ns};
use handover::participant::{ScriptedParticipant, SimulatedPerson};
use handover::record::{
    LogContents, RecordedSession, continuation_path, is_over, lineage, log_folder, read_log, study_of,
};
use handover::study_dir::{ParticipantLock, StudyDirs};

use super::input::{Pace, bad};
use super::live::LiveArgs;
use super::robot::RobotArgs;

/// Continue an interrupted session (a crash, a kill or a quit) from its log, a truncated
/// file included. The old file is kept; a new log beside it holds all of its events and
/// the rest of the session. A log that was already continued is not continued twice: the
/// newest continuation is resumed instead (and said so), unless --fork asks to branch from
/// the given log. A completed or aborted session is opened read-only on its summary.
/// Without options it reopens the operator console where the session stopped; with
/// --no-console a simulated participant continues a dry run headless.
#[derive(Debug, Args)]
pub struct ResumeArgs {
    /// The session log (.mcap) to continue.
    #[arg(required_unless_present = "participant", conflicts_with = "participant")]
    log: Option<PathBuf>,
    /// Continue this participant's unfinished session, found in the study's logs (instead of
    /// naming its log).
    #[arg(long, value_name = "ID")]
    participant: Option<String>,
    /// Continue a dry run with its simulated participant, without the console.
    #[arg(long, alias = "dry-run")]
    no_console: bool,
    /// In the console, let the simulated participant of a dry run or rehearsal continue.
    #[arg(long, alias = "simulate", conflicts_with = "no_console")]
    simulated_participant: bool,
    /// Continue this very log even though a newer continuation of it exists (a second
    /// branch of the session; analysis keeps one log per session).
    #[arg(long)]
    fork: bool,
    /// The study directory: participant records in DIR/participants, logs in DIR/logs
    /// (default: with --participant $HANDOVER_STUDY_DIR, else the log's own study, else the
    /// current directory).
    #[arg(long, value_name = "DIR")]
    study_dir: Option<PathBuf>,
    /// Where session logs are (default: STUDY_DIR/logs); with --participant.
    #[arg(long, value_name = "DIR", requires = "participant")]
    logs: Option<PathBuf>,
    /// Where participant records live (default: STUDY_DIR/participants).
    #[arg(long = "participants-dir", value_name = "DIR")]
    participants: Option<PathBuf>,
    #[command(flatten)]
    pace: Pace,
    /// A robot in the loop, as for `run` and `dry-run`.
    #[command(flatten)]
    robot: RobotArgs,
    #[command(flatten)]
    live: LiveArgs,
}

/// The log to continue: the given one, or its newest continuation.
fn choose(given: LogContents, fork: bool) -> LogContents {
    let family = lineage(&given);
    match family.newest {
        Some(newest) if !fork => {
            errln!(
                "{} was already continued; resuming its newest continuation, {}",
                given.path.display(),
                newest.path.display()
            );
            newest
        }
        Some(newest) => {
            errln!(
                "{} was already continued (newest: {}); --fork: branching from it as asked",
                given.path.display(),
                newest.path.display()
            );
            given
        }
        None => given,
    }
}

/// The log of a participant's unfinished session in the study's logs: refused, saying what
/// there is, when there is none or more than one.
fn unfinished_of(participant: &str, dirs: &StudyDirs) -> Result<PathBuf> {
    handover::participant::validate_id(participant)
        .map_err(|e| bad(format!("--participant '{}': {e}", handover::text::printable(participant))))?;
    let folder = dirs.logs.join(participant);
    let open = handover::record::open_sessions(&folder);
    match open.as_slice() {
        [one] => Ok(one.path.clone()),
        [] => Err(bad(format!(
            "participant {participant} has no unfinished session in {} (start a new one with: handover run --participant {participant}{})",
            folder.display(),
            dirs.flags()
        ))),
        many => {
            let names: Vec<String> = many.iter().map(|l| format!("  {}", l.path.display())).collect();
            Err(bad(format!(
                "participant {participant} has {} unfinished sessions; name the one to continue (handover resume LOG):\n{}",
                many.len(),
                names.join("\n")
            )))
        }
    }
}

pub fn run(args: ResumeArgs) -> Result<()> {
    let log = match (&args.log, &args.participant) {
        (Some(log), _) => log.clone(),
        (None, Some(p)) => {
            let study = super::input::study_dir_or_env(args.study_dir.as_deref());
            unfinished_of(p, &StudyDirs::resolve(study.as_deref(), args.participants.as_deref(), args.logs.as_deref()))?
        }
        (None, None) => return Err(bad("name the session's log, or --participant ID")),
    };
    let given = read_log(&log).map_err(|e| bad(e.to_string()))?;
    let old = choose(given, args.fork);
    // The study the log belongs to decides withdrawal, whatever the current folder.
    let dirs =
        StudyDirs::for_log(args.study_dir.as_deref(), args.participants.as_deref(), &old.path, &old.start.participant);
    if is_over(&old) {
        errln!("{}: the session is over; opening it read-only (nothing is written)", old.path.display());
        if args.no_console {
            let study = study_of(&old).map_err(|e| bad(e.to_string()))?;
            let a = handover::analysis::analyse(&old)?;
            return super::dry_run::report(&study, &old.path, &a);
        }
        return super::console::summary(old, dirs);
    }
    if !args.no_console {
        if !old.start.pilot && handover::participant::has_withdrawn(&dirs.participants, &old.start.participant) {
            return Err(bad(format!(
                "{}: participant {} withdrew from the study; their session is not continued",
                old.path.display(),
                old.start.participant
            )));
        }
        return super::console::resume(
            old,
            dirs,
            args.simulated_participant,
            args.pace.in_console(),
            (&args.robot, &args.live),
        );
    }
    let Some(truth) = old.start.simulated_truth.clone() else {
        return Err(bad(format!(
            "{}: not a dry run (no simulated participant); resume it without --no-console",
            old.path.display()
        )));
    };
    let study = study_of(&old).map_err(|e| bad(e.to_string()))?;
    let _lock = ParticipantLock::acquire(&log_folder(&old.path), &old.start.participant, "resume --no-console")?;
    // Every resource first (the robot, the live view's port): a bad robot option or a busy
    // port is refused before the continuation's file exists.
    let mut robot = args.robot.connect()?;
    let arm = args.robot.connect_arm_heard(&study)?;
    let view = args.live.start()?;
    let path = continuation_path(&old, chrono::Utc::now());
    let mut rec = RecordedSession::resume(&old, &path, now_ns())?;
    if let Some(view) = view {
        rec.set_tap(Box::new(view));
    }
    errln!("resumed {} ({} events) into {}", old.path.display(), old.events.len(), rec.path().display());
    let person = SimulatedPerson { truth, alpha: study.population().alpha };
    let participant = ScriptedParticipant { person };
    let driven = drive_session(&mut rec, &participant, robot.as_mut(), arm.as_ref(), args.pace.headless())?;
    let path = rec.finish().context("cannot finish the log")?;
    if let RobotDrive::GaveUp(why) = driven {
        anyhow::bail!("the session was aborted: {why}; log: {}", path.display());
    }
    let a = handover::analysis::analyse(&read_log(&path)?)?;
    super::dry_run::report(&study, &path, &a)
}
