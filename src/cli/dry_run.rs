//! `handover dry-run`: whole sessions answered by simulated participants, logged as pilot.

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::{Context, Result};
use clap::Args;
use handover::analysis::{
    SEED_MEASURES, SeedRun, SessionAnalysis, analyse, coverage, joint_errors, object_shares, over_seeds, paired_across,
    paired_over_seeds,
};
use handover::dryrun::{BodyPopulation, RobotDrive, drive_session, now_ns, plan_from};
use handover::ergo::Lambda;
use handover::protocol::{LambdaSpec, Study, for_body};
use handover::record::{RecordedSession, new_log_path, read_log};
use handover::robot::Robot;
use handover::session::{Session, program_letter};
use handover::study_dir::ParticipantLock;

use super::input::{
    HandArg, LogFolders, Pace, PopulationArg, PopulationFile, bad, body_height, count, load_protocol, parse_json,
    read_text,
};
use super::live::LiveArgs;
use super::robot::RobotArgs;

/// Run whole sessions with simulated participants (a rehearsal of the study, or a check of
/// the protocol). Each participant gets a pilot id and slot, a ground truth from the prior
/// (or --truth), and takes the offered objects with Boltzmann probability, reporting only
/// the grip region as a real participant does; the questionnaire is answered reproducibly.
/// Logs are flagged `pilot` and participants/ is never touched. The same seed gives the
/// same events. Bodies are drawn from adult stature (an equal mix of women, N(1.63 m,
/// 0.065), and men, N(1.77 m, 0.07), truncated to 1.50–1.95 m) with 10 % left-handed, unless
/// --body-height / --handedness fix them; each session runs the protocol fitted to its body.
#[derive(Debug, Args)]
pub struct DryRunArgs {
    /// Protocol (default: the embedded protocols/bike-handover.json).
    #[arg(long, value_name = "FILE")]
    protocol: Option<PathBuf>,
    /// Number of simulated participants.
    #[arg(long, default_value_t = 1, value_parser = count(1))]
    participants: usize,
    /// Seed of the whole dry run (ids, truths, answers).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Run N seeds (SEED, SEED+1, …) of --participants each, and report every measure as the
    /// mean with a 95 % confidence interval over the seeds' means, and the conditions'
    /// paired differences (the same participants) per iteration.
    #[arg(long, default_value_t = 1, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=1000))]
    seeds: u64,
    /// Where the pilot logs are written, as LOGS/<id>/<id>_<UTC time>.mcap.
    #[command(flatten)]
    folders: LogFolders,
    /// Every participant's body height (m) instead of a draw from adult stature.
    #[arg(long, value_name = "M")]
    body_height: Option<f64>,
    /// Every participant's dominant hand instead of a draw.
    #[arg(long, value_enum)]
    handedness: Option<HandArg>,
    /// The share of left-handed participants drawn (when --handedness is not given).
    #[arg(long, value_name = "FRACTION", default_value_t = handover::dryrun::LEFT_HANDED_SHARE)]
    left_handed_share: f64,
    /// A ground truth for every participant: {"q_star_deg": [7 angles], "w": [7 weights]}.
    #[arg(long, value_name = "FILE", conflicts_with = "population")]
    truth: Option<PathBuf>,
    /// Whom participants' λ are drawn from: `protocol` (its `population` section, or its
    /// default), `prior` (the robot's own prior, as the paper's simulations drew them), or a
    /// population file (a protocol's `population` section, as `analyze --fit-population`
    /// writes it).
    #[arg(long, default_value = "protocol")]
    population: PopulationArg,
    #[command(flatten)]
    pace: Pace,
    /// Also run the same participants (the same seeds: ids, truths and test sets) under a
    /// second protocol, and report per condition the paired difference --protocol − FILE in
    /// the distance to the true q* by iteration (and in the test log-likelihood when both
    /// protocols update on the same observation model), e.g. to compare observation models.
    #[arg(long, value_name = "FILE")]
    versus: Option<PathBuf>,
    /// A robot in the loop: each query is sent to it, and presented when it reports at_pose.
    #[command(flatten)]
    robot: RobotArgs,
    #[command(flatten)]
    live: LiveArgs,
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
    // Read once: both protocols of --versus get the same section.
    let population_file = args.population.read()?;
    let (text, study) = PopulationFile::apply(population_file.as_ref(), text, study)?;
    let study = Arc::new(study);
    let truth = args.truth.as_deref().map(load_truth).transpose()?;
    if !(0.0..=1.0).contains(&args.left_handed_share) {
        return Err(bad(format!("--left-handed-share is {}, expected a fraction from 0 to 1", args.left_handed_share)));
    }
    let population = BodyPopulation {
        height_m: args.body_height.map(|h| body_height("--body-height", h)).transpose()?,
        hand: args.handedness.map(Into::into),
        left_handed: args.left_handed_share,
    };
    // A fixed body the protocol cannot serve is bad input, named before any session runs.
    if let (Some(h), Some(hand)) = (population.height_m, population.hand) {
        for_body(&text, &study.source_name, handover::protocol::Body { height_m: Some(h), hand })
            .map_err(|e| bad(e.to_string()))?;
    }
    let versus = args
        .versus
        .as_deref()
        .map(|p| {
            load_protocol(Some(p))
                .and_then(|(text, study)| PopulationFile::apply(population_file.as_ref(), text, study))
        })
        .transpose()?;
    let dirs = args.folders.resolve();
    let protocols = 1 + u64::from(versus.is_some());
    let bar = if args.seeds > 1 || versus.is_some() {
        super::progress::bar("dry runs", protocols * args.seeds * args.participants as u64, "sessions")
    } else {
        indicatif::ProgressBar::hidden()
    };
    let report_each = args.seeds == 1 && versus.is_none();
    if versus.is_some() && args.robot.measure.is_some() {
        return Err(bad("--measure and --versus: the live arm is measured for one protocol's session at a time"));
    }
    let mut robot = args.robot.connect()?;
    let arm = args.robot.connect_arm_heard(&study)?;
    let live = args.live.start()?;
    let ctx = RunContext {
        arm: arm.as_ref(),
        args: &args,
        population: &population,
        logs: &dirs.logs,
        truth: truth.as_ref(),
        bar: &bar,
        live: live.as_ref(),
    };
    let runs = run_seeds(&study, &text, &ctx, robot.as_mut(), report_each)?;
    let second = match &versus {
        Some((text_b, study_b)) => Some(run_seeds(&Arc::new(study_b.clone()), text_b, &ctx, robot.as_mut(), false)?),
        None => None,
    };
    bar.finish_and_clear();
    let label_a =
        args.protocol.as_ref().map_or_else(|| "the embedded protocol".to_string(), |p| p.display().to_string());
    if let (Some(runs_b), Some((_, study_b)), Some(path_b)) = (&second, &versus, &args.versus) {
        let label_b = path_b.display().to_string();
        outln!("\nprotocol A = {label_a} (observation: {})", study.protocol.learning.observation.name());
        print_over_seeds(&runs, args.seed, args.seeds, args.participants)?;
        outln!("\nprotocol B = {label_b} (observation: {})", study_b.protocol.learning.observation.name());
        print_over_seeds(runs_b, args.seed, args.seeds, args.participants)?;
        let same_observation = study.protocol.learning.observation == study_b.protocol.learning.observation;
        print_across(&runs, runs_b, same_observation, args.seeds)?;
    } else if args.seeds > 1 || args.participants > 1 {
        print_over_seeds(&runs, args.seed, args.seeds, args.participants)?;
    }
    Ok(())
}

/// What every protocol's run of a dry run shares.
struct RunContext<'a> {
    args: &'a DryRunArgs,
    population: &'a BodyPopulation,
    logs: &'a std::path::Path,
    truth: Option<&'a Lambda>,
    bar: &'a indicatif::ProgressBar,
    live: Option<&'a handover::live::LiveView>,
    arm: Option<&'a handover::robot::joint_states::JointStateSource>,
}

/// Every seed's participants under one protocol, each session logged, replayed and analysed,
/// each run for its participant's body; with a robot, each query goes through it.
fn run_seeds(
    study: &Arc<Study>,
    text: &str,
    ctx: &RunContext,
    mut robot: Option<&mut Robot>,
    report_each: bool,
) -> Result<Vec<SeedRun>> {
    let RunContext { args, population, logs, truth, bar, live, arm } = *ctx;
    let mut runs = Vec::new();
    let bodies = handover::plan::FittedBodies::default();
    for k in 0..args.seeds {
        let seed = args.seed + k;
        let mut sessions = Vec::new();
        for i in 0..args.participants {
            let now = chrono::Utc::now();
            let body = population.draw(seed, i);
            let (text, fitted) = bodies
                .fit(text, study, body)
                .map_err(|e| bad(format!("simulated participant {} of seed {seed}: {e}", i + 1)))?;
            let people = match args.population {
                PopulationArg::Protocol | PopulationArg::File(_) => fitted.population(),
                PopulationArg::Prior => fitted.prior_population(),
            };
            let started = now.to_rfc3339_opts(chrono::SecondsFormat::Millis, true);
            let p = plan_from(&fitted, &people, seed, i, truth, started);
            let session = Session::new(Arc::clone(&fitted), p.start.clone()).map_err(|e| anyhow::anyhow!("{e}"))?;
            let path = new_log_path(logs, &p.start.participant, now);
            let _lock = ParticipantLock::acquire(&logs.join(&p.start.participant), &p.start.participant, "dry-run")?;
            let mut rec = RecordedSession::create(&path, &text, session, now_ns())?;
            if let Some(view) = live {
                rec.set_tap(Box::new(view.clone()));
            }
            let driven = drive_session(&mut rec, &p.participant, robot.as_deref_mut(), arm, args.pace.headless())?;
            let path = rec.finish()?;
            if let RobotDrive::GaveUp(why) = driven {
                anyhow::bail!("{}: the session was aborted: {why}; log: {}", p.start.participant, path.display());
            }
            let analysis = analysed(&path)?;
            if report_each {
                report(&fitted, &path, &analysis)?;
            }
            sessions.push(analysis);
            bar.inc(1);
        }
        runs.push(SeedRun { seed, sessions });
    }
    Ok(runs)
}

/// Protocol A − protocol B for the same participants, per condition and iteration.
fn print_across(a: &[SeedRun], b: &[SeedRun], same_observation: bool, seeds: u64) -> Result<()> {
    outln!(
        "\nA − B for the same participants (paired; 95 % confidence interval over the seeds' means; two-sided Wilcoxon over all):"
    );
    let measures: &[&'static str] = if same_observation { &SEED_MEASURES } else { &["distance_to_truth_deg"] };
    for measure in measures {
        let tests = paired_across(a, b, ("A", "B"), measure);
        outln!("  {}, by iteration:", measure_label(measure));
        let mut conditions: Vec<String> = Vec::new();
        for t in &tests {
            let c = t.first.trim_start_matches("A ").to_string();
            if !conditions.contains(&c) {
                conditions.push(c);
            }
        }
        let mut head = format!("  {:>9}", "iteration");
        for c in &conditions {
            head += &format!(" {:>34}", format!("{c}: A − B (p)"));
        }
        outln!("{head}");
        let iterations = tests.iter().map(|t| t.iteration).max().unwrap_or(0);
        for it in 0..=iterations {
            let mut line = format!("  {it:>9}");
            for c in &conditions {
                line += &match tests.iter().find(|t| t.iteration == it && t.first == format!("A {c}")) {
                    Some(t) => format!(" {:>34}", paired_cell(t)),
                    None => format!(" {:>34}", "—"),
                };
            }
            outln!("{line}");
        }
        for c in &conditions {
            if let Some(last) = tests.iter().rfind(|t| t.first == format!("A {c}")) {
                outln!("  ({c}: at the last iteration A − B {})", spread(last));
            }
            if let Some(last) = tests.iter().rfind(|t| t.first == format!("A {c}"))
                && seeds > 1
            {
                outln!(
                    "  ({c}: at the last iteration A − B alone is significant in {} seed(s) with A higher, {} with A lower, of {})",
                    last.seeds_first_higher,
                    last.seeds_first_lower,
                    last.seeds
                );
            }
        }
    }
    if !same_observation {
        outln!("  (the test log-likelihoods are of different observations under the two models and are not compared)");
    }
    Ok(())
}

/// Beside a paired difference's mean: its median and the share of participants with the
/// first higher.
fn spread(t: &handover::stats::Paired) -> String {
    format!(
        "median {:+.2}, {:.0} % of {} participants with the first higher",
        t.median_difference,
        100.0 * t.share_first_higher,
        t.n
    )
}

/// "mean [low, high] (p)" of a paired difference.
fn paired_cell(t: &handover::stats::Paired) -> String {
    let p = t.p_value.map_or("no difference".to_string(), super::wilcoxon_p);
    format!("{:+.1} [{:+.1}, {:+.1}] ({p})", t.mean_difference, t.ci_low, t.ci_high)
}

fn measure_label(measure: &str) -> &'static str {
    match measure {
        "test_log_likelihood" => "test log-likelihood of the posterior mean",
        _ => "distance of the posterior mean to the true q* (degrees)",
    }
}

/// The replayed results of a finished log.
fn analysed(path: &std::path::Path) -> Result<SessionAnalysis> {
    let log = read_log(path)?;
    analyse(&log).with_context(|| format!("cannot analyse {}", path.display()))
}

/// Every measure over seeds, and the conditions' paired differences.
fn print_over_seeds(runs: &[SeedRun], seed: u64, seeds: u64, participants: usize) -> Result<()> {
    let rows = over_seeds(runs);
    let tests = paired_over_seeds(runs);
    let over = if seeds > 1 { "over the seeds' means" } else { "over participants" };
    outln!(
        "\n{participants} participants × {seeds} seed(s) ({}): mean [95 % confidence interval {over}]",
        if seeds > 1 { format!("seeds {seed}–{}", seed + seeds - 1) } else { format!("seed {seed}") }
    );
    for (c, objects) in object_shares(runs) {
        let parts: Vec<String> = objects
            .iter()
            .map(|(o, (m, lo, hi))| {
                // A share's interval is cut to [0, 100] %.
                if lo.is_finite() {
                    format!("{o} {:.0} % [{:.0}, {:.0}]", 100.0 * m, 100.0 * lo.max(0.0), 100.0 * hi.min(1.0))
                } else {
                    format!("{o} {:.0} %", 100.0 * m)
                }
            })
            .collect();
        outln!("  {c} offered: {}", parts.join(", "));
    }
    print_by_body(runs)?;
    for measure in SEED_MEASURES {
        outln!("  {}, by iteration:", measure_label(measure));
        let conditions: Vec<&str> = {
            let mut v: Vec<&str> = Vec::new();
            for r in rows.iter().filter(|r| r.measure == measure) {
                if !v.contains(&r.condition.as_str()) {
                    v.push(&r.condition);
                }
            }
            v
        };
        let mut head = format!("  {:>9}", "iteration");
        for c in &conditions {
            head += &format!(" {:>26}", c);
        }
        head += &format!(" {:>34}", "paired difference (p)");
        outln!("{head}");
        let iterations = rows.iter().filter(|r| r.measure == measure).map(|r| r.iteration).max().unwrap_or(0);
        for it in 0..=iterations {
            let mut line = format!("  {it:>9}");
            for c in &conditions {
                line += &match rows.iter().find(|r| r.measure == measure && r.condition == *c && r.iteration == it) {
                    Some(r) if r.ci_low.is_finite() => {
                        format!(" {:>26}", format!("{:.1} [{:.1}, {:.1}]", r.mean, r.ci_low, r.ci_high))
                    }
                    Some(r) => format!(" {:>26}", format!("{:.1}", r.mean)),
                    None => format!(" {:>26}", "—"),
                };
            }
            if let Some(t) = tests.iter().find(|t| t.measure == measure && t.iteration == it) {
                line += &format!(" {:>34}", paired_cell(t));
            }
            outln!("{line}");
        }
        if let Some(first) = tests.iter().find(|t| t.measure == measure) {
            let last = tests.iter().rfind(|t| t.measure == measure).unwrap_or(first);
            outln!("  ({} − {} at the last iteration: {})", first.first, first.second, spread(last));
            if seeds > 1 {
                outln!(
                    "  ({} − {}; at the last iteration the difference alone is significant in {} seed(s) with {} higher, {} with it lower, of {})",
                    first.first,
                    first.second,
                    last.seeds_first_higher,
                    first.first,
                    last.seeds_first_lower,
                    last.seeds
                );
            }
        }
    }
    print_joint_errors(runs)?;
    print_coverage(runs)
}

/// Per joint, the posterior mean's error at the end of training against the prior's, and
/// the conditions' paired difference.
fn print_joint_errors(runs: &[SeedRun]) -> Result<()> {
    let rows = joint_errors(runs);
    let Some(first) = rows.first() else { return Ok(()) };
    outln!(
        "  mean |error| of the posterior mean's q* per joint at iteration {} (degrees; prior: iteration 0):",
        first.iteration
    );
    let mut head = format!("  {:>9} {:>8}", "joint", "prior");
    for (c, _) in &first.conditions {
        head += &format!(" {c:>10}");
    }
    if let Some(p) = &first.paired {
        head += &format!(" {:>34}", format!("{} − {} (p)", p.first, p.second));
    }
    outln!("{head}");
    for r in &rows {
        let mut line = format!("  {:>9} {:>8.1}", format!("q*{}", r.joint), r.prior);
        for (_, e) in &r.conditions {
            line += &format!(" {e:>10.1}");
        }
        if let Some(p) = &r.paired {
            line += &format!(" {:>34}", paired_cell(p));
        }
        outln!("{line}");
    }
    Ok(())
}

/// How often each condition's 90 % credible intervals held the true q*, by iteration, and
/// per joint at the last.
fn print_coverage(runs: &[SeedRun]) -> Result<()> {
    let rows = coverage(runs);
    let mut conditions: Vec<&str> = Vec::new();
    for r in &rows {
        if !conditions.contains(&r.condition.as_str()) {
            conditions.push(&r.condition);
        }
    }
    let Some(of) = rows.first().map(|r| r.total().1) else { return Ok(()) };
    outln!("  90 % credible intervals of q* holding the true value (of {of} participant-joints), by iteration:");
    let mut head = format!("  {:>9}", "iteration");
    for c in &conditions {
        head += &format!(" {c:>10}");
    }
    outln!("{head}");
    let iterations = rows.iter().map(|r| r.iteration).max().unwrap_or(0);
    for it in 0..=iterations {
        let mut line = format!("  {it:>9}");
        for c in &conditions {
            line += &match rows.iter().find(|r| r.condition == *c && r.iteration == it) {
                Some(r) => format!(" {:>8.1} %", 100.0 * r.share()),
                None => format!(" {:>10}", "—"),
            };
        }
        outln!("{line}");
    }
    for c in &conditions {
        if let Some(last) = rows.iter().rfind(|r| r.condition == *c) {
            let joints: Vec<String> = last
                .per_joint
                .iter()
                .enumerate()
                .filter(|(_, (_, n))| *n > 0)
                .map(|(j, (h, n))| format!("q*{} {:.0} %", j + 1, 100.0 * *h as f64 / *n as f64))
                .collect();
            outln!("  ({c} at iteration {}, by joint: {})", last.iteration, joints.join(", "));
        }
    }
    outln!(
        "  (0.90 is calibrated when participants are drawn from the robot's prior: `--population prior`, or a prior that is the population)"
    );
    Ok(())
}

/// The object finding per height band and hand, when the sessions span more than one.
fn print_by_body(runs: &[SeedRun]) -> Result<()> {
    let sessions: Vec<&SessionAnalysis> = runs.iter().flat_map(|r| &r.sessions).collect();
    for line in super::by_body::lines(&sessions) {
        outln!("  {line}");
    }
    Ok(())
}

/// Prints a participant's condition order, objects chosen and test log-likelihoods.
pub fn report(study: &Study, path: &std::path::Path, a: &SessionAnalysis) -> Result<()> {
    outln!(
        "{} ({}; {}): log {}",
        a.start.participant,
        if a.completed { "completed" } else { "not completed" },
        a.body,
        path.display()
    );
    for r in &a.runs {
        let objects: Vec<&str> = r.trials.iter().map(|t| t.object.as_str()).collect();
        let ll: Vec<String> = r.test_ll_estimate.iter().map(|v| format!("{v:.1}")).collect();
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
    let taken: Vec<_> = a.trial_rows.iter().filter(|r| r.learned_from.is_some()).collect();
    if !taken.is_empty() {
        let measured: Vec<_> = taken.iter().filter_map(|r| r.measured.as_ref()).collect();
        let disagree = measured.iter().filter(|m| !m.agrees).count();
        outln!(
            "  arm measured at {} of {} grasps ({} learned from the region); {disagree} measurement(s) implied another grip than the key",
            measured.len(),
            taken.len(),
            taken.len() - measured.len()
        );
    }
    Ok(())
}
