//! `handover run` (and a bare `handover`) and `handover resume LOG`: the operator console.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Result;
use clap::Args;
use handover::participant::validate_id;
use handover::protocol::Body;
use handover::record::{LogContents, SharedTap, study_of};
use handover::study_dir::StudyDirs;
use handover::tui::{App, AppConfig, Outcome, run_terminal};

use super::input::{HandArg, Pace, StudyFolders, bad, body_height as checked_height, load_protocol};
use super::live::LiveArgs;
use super::robot::RobotArgs;

/// Open the operator console and run a study session: setup, the training runs (blinded
/// as Program A / B), the test phase, the questionnaire and a summary. Every event is on
/// disk before the screen shows its consequence; `q` leaves a resumable session.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// Protocol (default: the embedded protocols/bike-handover.json).
    #[arg(long, value_name = "FILE")]
    protocol: Option<PathBuf>,
    /// An existing participant's id, or `new` for a new pseudonymous one.
    #[arg(long, value_name = "ID|new", default_value = "new")]
    participant: String,
    /// The study's folders (counterbalancing counts the sessions and participants there).
    #[command(flatten)]
    folders: StudyFolders,
    /// Let a simulated participant answer (a rehearsal under its own `pilot-` id; the log is
    /// flagged pilot), never a registered participant's.
    #[arg(long, alias = "simulate", conflicts_with = "participant")]
    simulated_participant: bool,
    /// A pilot with a real person (a colleague, a dress rehearsal): its own `pilot-` id and no
    /// participant record; the log is flagged pilot, so analyze reports it apart and
    /// counterbalancing never counts it.
    #[arg(long, conflicts_with_all = ["simulated_participant", "participant"])]
    pilot: bool,
    /// With --pilot: the person's body height (m), as `participant new` records it for a
    /// participant (the arm and the poses are scaled to it).
    #[arg(long, value_name = "M", requires = "pilot")]
    body_height: Option<f64>,
    /// With --pilot: the person's dominant hand (a left hand: the mirrored arm and poses).
    #[arg(long, value_enum, requires = "pilot")]
    handedness: Option<HandArg>,
    /// A rehearsal to practise on: a simulated participant chooses, the status line says
    /// what they did, and you press every key (the log is flagged pilot).
    #[arg(long, conflicts_with_all = ["simulated_participant", "pilot", "participant"])]
    practice: bool,
    #[command(flatten)]
    pace: Pace,
    /// The session seed, 0 to 2^53 − 1 (random by default; recorded in the log).
    #[arg(long, value_parser = clap::value_parser!(u64).range(0..=handover::MAX_SESSION_SEED))]
    seed: Option<u64>,
    /// A robot in the loop: `s` sends each query's pose to it (see docs/guide.md "With a robot").
    #[command(flatten)]
    robot: RobotArgs,
    #[command(flatten)]
    live: LiveArgs,
}

impl RunArgs {
    /// The defaults of `handover run`, for a bare `handover`.
    pub fn default_for_bare() -> Self {
        Self {
            protocol: None,
            participant: "new".into(),
            folders: StudyFolders::default(),
            simulated_participant: false,
            pilot: false,
            body_height: None,
            handedness: None,
            practice: false,
            pace: Pace::default(),
            seed: None,
            robot: RobotArgs::default(),
            live: LiveArgs::default(),
        }
    }
}

pub fn require_terminal() -> Result<()> {
    use std::io::IsTerminal;
    if !std::io::stdout().is_terminal() || !std::io::stdin().is_terminal() {
        return Err(bad("the console needs an interactive terminal (for scripted sessions use `handover dry-run`)"));
    }
    Ok(())
}

fn finish(result: Result<Outcome, String>) -> Result<()> {
    let outcome = result.map_err(|e| anyhow::anyhow!("console: {e}"))?;
    if let Some(msg) = outcome.message {
        errln!("{msg}");
    }
    if let Some(sig) = outcome.signal {
        errln!("handover: stopped by signal {sig}; the terminal is restored and the session can be resumed");
        std::process::exit(128 + sig);
    }
    Ok(())
}

pub fn run(args: RunArgs) -> Result<()> {
    let RunArgs {
        protocol,
        participant,
        folders,
        simulated_participant,
        pilot,
        body_height,
        handedness,
        practice,
        pace,
        seed,
        robot,
        live,
    } = args;
    if participant != "new" {
        validate_id(&participant).map_err(|e| bad(format!("--participant: {e}")))?;
    }
    let (protocol_text, study) = load_protocol(protocol.as_deref())?;
    // A pilot has no record to hold a body: the flags give it.
    let pilot_body = Body {
        height_m: body_height.map(|h| checked_height("--body-height", h)).transpose()?,
        hand: handedness.map(Into::into).unwrap_or_default(),
    };
    let study = Arc::new(study);
    let config = AppConfig {
        study,
        protocol_text,
        dirs: folders.resolve(),
        participant,
        simulate: simulated_participant || practice,
        pilot,
        pilot_body,
        practice,
        pace: pace.in_console(),
        seed,
        tap: None,
    };
    let app = App::new(config);
    if let Some(e) = app.plan.as_ref().and_then(|p| p.error.clone()) {
        return Err(bad(format!("--participant: {e}")));
    }
    require_terminal()?;
    let arm = robot.connect_arm(&app.config.study)?;
    let robot = robot.connect()?;
    let mut app = app.with_robot(robot).with_arm(arm);
    if let Some(view) = live.start()? {
        app.config.tap = Some(SharedTap(Box::new(view.clone())));
        app.status = format!("Live view: {}", view.url());
    }
    finish(run_terminal(app))
}

/// The console on an interrupted session's log.
fn config_of(old: &LogContents, dirs: StudyDirs, simulate: bool, pace: Duration) -> Result<AppConfig> {
    let study = Arc::new(study_of(old).map_err(|e| bad(e.to_string()))?);
    Ok(AppConfig {
        study,
        protocol_text: old.protocol_text.clone(),
        dirs,
        participant: old.start.participant.clone(),
        simulate,
        pilot: old.start.pilot && old.start.simulated_truth.is_none(),
        // A resumed session runs the protocol its log embeds, already fitted to the body.
        pilot_body: Body::default(),
        practice: false,
        pace,
        seed: Some(old.start.seed),
        tap: None,
    })
}

pub fn resume(
    old: LogContents,
    dirs: StudyDirs,
    simulate: bool,
    pace: Duration,
    extra: (&RobotArgs, &LiveArgs),
) -> Result<()> {
    let (robot, live) = extra;
    let mut config = config_of(&old, dirs, simulate, pace)?;
    require_terminal()?;
    let arm = robot.connect_arm(&config.study)?;
    let robot = robot.connect()?;
    let view = live.start()?;
    config.tap = view.as_ref().map(|v| SharedTap(Box::new(v.clone())));
    let mut app = App::resume(config, &old)?.with_robot(robot).with_arm(arm);
    if let Some(v) = view {
        app.status = format!("{}; live view: {}", app.status, v.url());
    }
    finish(run_terminal(app))
}

/// A finished session, read-only on the summary screen.
pub fn summary(old: LogContents, dirs: StudyDirs) -> Result<()> {
    let config = config_of(&old, dirs, false, Duration::ZERO)?;
    require_terminal()?;
    finish(run_terminal(App::summary_of(config, &old)))
}
