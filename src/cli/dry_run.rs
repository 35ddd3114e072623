//! `handover dry-run`: whole sessions answered by simulated participants, logged as pilot.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, Result};
use clap::Args;
use handover::analysis::{SessionAnalysis, analyse};
use handover::dryrun::{drive, now_ns, plan};
use handover::ergo::Lambda;
use handover::protocol::{LambdaSpec, Study};
use handover::record::{RecordedSession, new_log_path, read_log};
use handover::session::{Session, program_letter};
use handover::study_dir::{ParticipantLock, StudyDirs};

use super::input::{bad, load_protocol, parse_json, read_text};

/// Run whole sessions with simulated participants (a rehearsal of the study, or a check of
/// the protocol). Each participant gets a pilot id and slot, a ground truth from the prior
/// (or --truth), and takes the offered objects with Boltzmann probability, reporting only
/// the grip region as a real participant does; the questionnaire is answered reproducibly.
/// Logs are flagged `pilot` and participants/ is never touched. The same seed gives the
/// same events.
#[derive(Debug, Args)]
pub struct DryRunArgs {
    /// Protocol (default: the embedded protocols/bike-handover.json).
    #[arg(long, value_name = "FILE")]
    protocol: Option<PathBuf>,
    /// Number of simulated participants.
    #[arg(long, default_value_t = 1)]
    participants: usize,
    /// Seed of the whole dry run (ids, truths, answers).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// The study directory (logs in DIR/logs).
    #[arg(long, value_name = "DIR")]
    study_dir: Option<PathBuf>,
    /// Where logs are written, as LOGS/<id>/<id>_<UTC time>.mcap (default: STUDY_DIR/logs).
    #[arg(long, value_name = "DIR")]
    logs: Option<PathBuf>,
    /// A ground truth for every participant: {"q_star_deg": [7 angles], "w": [7 weights]}.
    #[arg(long, value_name = "FILE")]
    truth: Option<PathBuf>,
    /// Milliseconds to wait between actions, to watch or rehearse.
    #[arg(long, value_name = "MS", default_value_t = 0)]
    pace: u64,
}

fn load_truth(path: &std::path::Path) -> Result<Lambda> {
    let name = path.display().to_string();
    let spec: LambdaSpec = parse_json(&read_text(path)?, &name)?;
    for (field, v) in [("q_star_deg", &spec.q_star_deg), ("w", &spec.w)] {
        if v.len() != 7 {
            return Err(bad(format!("{name}: {field} has {} values, expected 7 (one per joint)", v.len())));
        }
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            return Err(bad(format!("{name}: {field}[{i}] is not a finite number")));
        }
    }
    if let Some(i) = spec.w.iter().position(|w| *w < 0.0) {
        return Err(bad(format!("{name}: w[{i}] is {}, expected a non-negative weight", spec.w[i])));
    }
    Ok(spec.to_lambda())
}

pub fn run(args: DryRunArgs) -> Result<()> {
    let (text, study) = load_protocol(args.protocol.as_deref())?;
    let study = Arc::new(study);
    if args.participants == 0 {
        return Err(bad("--participants is 0, expected at least 1"));
    }
    let truth = args.truth.as_deref().map(load_truth).transpose()?;
    let dirs = StudyDirs::resolve(args.study_dir.as_deref(), None, args.logs.as_deref());
    for i in 0..args.participants {
        let now = chrono::Utc::now();
        let p = plan(&study, args.seed, i, truth.as_ref(), now.to_rfc3339_opts(chrono::SecondsFormat::Millis, true));
        let session = Session::new(Arc::clone(&study), p.start.clone()).map_err(|e| anyhow::anyhow!("{e}"))?;
        let path = new_log_path(&dirs.logs, &p.start.participant, now);
        let _lock = ParticipantLock::acquire(&dirs.logs.join(&p.start.participant), &p.start.participant, "dry-run")?;
        let mut rec = RecordedSession::create(&path, &text, session, now_ns())?;
        drive(&mut rec, &p.participant, Duration::from_millis(args.pace))?;
        let path = rec.finish()?;
        report(&study, &path)?;
    }
    Ok(())
}

/// Prints a participant's condition order, objects chosen and test log-likelihoods.
pub fn report(study: &Study, path: &std::path::Path) -> Result<()> {
    let log = read_log(path)?;
    let a: SessionAnalysis = analyse(&log).with_context(|| format!("cannot analyse {}", path.display()))?;
    outln!(
        "{} ({}): log {}",
        a.start.participant,
        if a.completed { "completed" } else { "not completed" },
        path.display()
    );
    for r in &a.runs {
        let objects: Vec<&str> = r.trials.iter().map(|t| t.object.as_str()).collect();
        let ll: Vec<String> = r.test_ll_mode.iter().map(|v| format!("{v:.1}")).collect();
        outln!(
            "  {} = {} ({}): objects [{}]; test log-likelihood by iteration [{}]",
            study
                .protocol
                .session
                .program_labels
                .get(r.program)
                .map_or_else(|| program_letter(r.program), |l| l.clone()),
            r.condition,
            program_letter(r.program),
            objects.join(", "),
            ll.join(", ")
        );
    }
    Ok(())
}
