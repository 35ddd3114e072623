//! `handover analyze`: the paper's user-study results (Fig. 10, Table I) from session logs.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use handover::analysis::{
    AlphaFit, AlphaSummary, Analysed, Collected, EVIDENCE_PARTICLES, MAX_EVIDENCE_PARTICLES, SUPPORT_DROP,
    SessionAnalysis, StudySummary, WithdrawnLeftOut, alpha_summary, collect, write_tables,
};
use handover::output_dir::{self, HeldSession};
use handover::plot::{FigureStyle, LinePlot, PooledEvidence, Series, alpha_plot, bar_chart, mean_se_plot};
use handover::record::{LogContents, mcap_files_reporting};
use handover::session::program_letter;
use handover::study_dir::StudyDirs;
use serde::Serialize;

use super::analyze_measured::{MeasuredArgs, RefitReport};
use super::analyze_population::{PopulationArgs, PopulationReport};
use super::analyze_report::{table, table1_markdown};
use super::figures::FigureArgs;
use super::input::bad;

/// Analyse session logs: per session the order, the queries each condition chose, the
/// belief after each training iteration (replayed from the events) scored on the
/// session's own test responses, and the questionnaire; across sessions the paper's Fig. 10,
/// the objects each condition chose, and Table I with Wilcoxon signed-rank tests (also
/// split by condition order). Pilot (dry-run) logs are reported separately. A resumed
/// session counts once. Exit status 1 if a file was skipped or --verify found a difference.
#[derive(Debug, Args)]
pub struct AnalyzeArgs {
    /// Session logs (.mcap) or directories searched recursively (default with --study-dir,
    /// --logs or $HANDOVER_STUDY_DIR: the study's logs).
    #[arg(value_name = "LOG|DIR")]
    paths: Vec<PathBuf>,
    /// Write sessions.csv, trials.csv (every presentation: taken, undone or voided),
    /// notes.csv, robot.csv (sessions with a robot: every command and its timing),
    /// test_log_likelihood.csv, fig10_tests.csv, beliefs.csv (long),
    /// belief_summary.csv, objects_by_body.csv,
    /// questionnaire.csv, alpha.csv, alpha_curve.csv, fig10.svg, objects.svg, alpha.svg,
    /// table1.md (and with --fit-population population.json, prior.json, population.csv and pooled.csv) here
    /// (pilot sessions under DIR/pilot/).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Recompute every derived value in each log (mapped configurations, beliefs, scores)
    /// from its events and report any difference.
    #[arg(long)]
    verify: bool,
    /// Output on stdout.
    #[arg(long, value_enum, default_value_t = Format::Table)]
    format: Format,
    /// Prior draws of λ over which each session's evidence for α is integrated (the α
    /// estimate; more draws, less downward bias at large α, proportionally slower).
    #[arg(long, value_name = "N", default_value_t = EVIDENCE_PARTICLES)]
    alpha_particles: usize,
    /// The study directory, whose participants/ says who withdrew (their sessions are left
    /// out); with no LOG|DIR, its logs/ are analysed (default: $HANDOVER_STUDY_DIR when no
    /// LOG|DIR is named, else each log's own study).
    #[arg(long, value_name = "DIR")]
    study_dir: Option<PathBuf>,
    /// Where participant records live (default: STUDY_DIR/participants).
    #[arg(long = "participants-dir", value_name = "DIR")]
    participants: Option<PathBuf>,
    /// Where session logs live (default: STUDY_DIR/logs).
    #[arg(long, value_name = "DIR")]
    logs: Option<PathBuf>,
    #[command(flatten)]
    measured: MeasuredArgs,
    #[command(flatten)]
    population: PopulationArgs,
    #[command(flatten)]
    figures: FigureArgs,
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq)]
enum Format {
    Table,
    Json,
}

#[derive(Serialize)]
struct JsonSession<'a> {
    session_id: &'a str,
    participant: &'a str,
    pilot: bool,
    log: String,
    completed: bool,
    truncated: bool,
    condition_order: Vec<&'static str>,
    program_labels: &'a [String],
    runs: Vec<JsonRun<'a>>,
    test_trials: &'a [(String, String, String)],
    likert: &'a [(usize, String, i64)],
    forced_choice: Option<String>,
    /// The robot's timings (sessions with a robot only).
    #[serde(skip_serializing_if = "Option::is_none")]
    robot: Option<handover::analysis::RobotTimings>,
}

#[derive(Serialize)]
struct JsonRun<'a> {
    program: String,
    condition: &'a str,
    queries: Vec<(&'a str, &'a str, &'a str)>,
    test_log_likelihood_estimate: &'a [f64],
    test_log_likelihood_predictive: &'a [f64],
    learned_q_star_deg: Vec<f64>,
    beliefs: &'a [handover::session::BeliefSummary],
}

#[derive(Serialize)]
struct JsonOut<'a> {
    sessions: Vec<JsonSession<'a>>,
    real: Option<StudySummary>,
    pilot: Option<StudySummary>,
    real_alpha: Option<AlphaSummary>,
    pilot_alpha: Option<AlphaSummary>,
    withdrawn_left_out: WithdrawnLeftOut,
    /// With --measurements: each session re-fitted with the measured arm.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    measured_refits: Vec<RefitReport>,
    /// With --fit-population: the population fitted to the real sessions, and the pilots'.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    populations: Vec<PopulationReport>,
    skipped: &'a [String],
    warnings: &'a [String],
    differences: &'a [String],
}

pub fn run(args: AnalyzeArgs) -> Result<()> {
    if !(1..=MAX_EVIDENCE_PARTICLES).contains(&args.alpha_particles) {
        return Err(bad(format!(
            "--alpha-particles is {}, expected 1 to {MAX_EVIDENCE_PARTICLES} (a budget: memory and time grow with it)",
            args.alpha_particles
        )));
    }
    args.measured.check()?;
    args.figures.check()?;
    let mut files = Vec::new();
    let paths = if args.paths.is_empty() {
        let study = super::input::study_dir_or_env(args.study_dir.as_deref());
        if study.is_none() && args.logs.is_none() {
            return Err(bad(
                "name the logs to analyse (LOG|DIR), or the study: --study-dir DIR, --logs DIR or HANDOVER_STUDY_DIR",
            ));
        }
        vec![StudyDirs::resolve(study.as_deref(), args.participants.as_deref(), args.logs.as_deref()).logs]
    } else {
        args.paths.clone()
    };
    let mut unlistable = Vec::new();
    for p in &paths {
        if !p.exists() {
            return Err(bad(format!("{}: no such file or directory", p.display())));
        }
        let (found, cannot) = mcap_files_reporting(p);
        files.extend(found);
        unlistable.extend(cannot);
    }
    if files.is_empty() {
        return Err(bad("no .mcap files found in the given paths"));
    }
    // Each log's study is the one given, else the log's own (`<study>/logs/<id>/`), else the
    // current folder's: the same participants are left out from any folder.
    let mut collected = collect(&files, args.verify, |l: &LogContents| {
        StudyDirs::for_log(args.study_dir.as_deref(), args.participants.as_deref(), &l.path, &l.start.participant)
    });
    // A folder that cannot be listed is a skip like an unreadable log: named, and exit 1.
    collected.skipped.extend(unlistable.iter().map(|(dir, why)| format!("skipped {}: {why}", dir.display())));
    for note in &collected.notes {
        errln!("{note}");
    }
    let (real, pilot) = (collected.summary(false), collected.summary(true));
    let bar = super::progress::bar("α evidence", collected.analysed.len() as u64, "sessions");
    let alpha_of = |pilot: bool| -> Result<Option<AlphaSummary>> {
        let group: Vec<&SessionAnalysis> = collected.group(pilot).into_iter().map(|a| &a.analysis).collect();
        if group.is_empty() {
            return Ok(None);
        }
        Ok(Some(alpha_summary(&group, args.alpha_particles, &|| bar.inc(1)).context("cannot estimate α")?))
    };
    let (real_alpha, pilot_alpha) = (alpha_of(false)?, alpha_of(true)?);
    bar.finish_and_clear();
    let refits = args.measured.run(&collected.analysed)?;
    // The folder says which sessions made it; an earlier analysis's files there are removed.
    let held: Vec<HeldSession> = collected
        .analysed
        .iter()
        .map(|a| HeldSession {
            session_id: a.log.start.session_id.clone(),
            participant: a.log.start.participant.clone(),
            pilot: a.log.start.pilot,
        })
        .collect();
    if let Some(dir) = &args.out {
        output_dir::prepare(dir, "analyze", None, &held).map_err(super::input::output_dir_error)?;
        super::analyze_measured::write_csv(dir, &refits)?;
    }
    let populations = args.population.run(&collected.group(false), &collected.group(true))?;
    if let Some(dir) = &args.out {
        for (is_pilot, summary, alpha) in [(false, &real, &real_alpha), (true, &pilot, &pilot_alpha)] {
            let (Some(summary), Some(alpha)) = (summary, alpha) else { continue };
            let d = if is_pilot { dir.join("pilot") } else { dir.clone() };
            write_outputs(&d, &args.figures.style(), &collected.group(is_pilot), summary, alpha)
                .with_context(|| format!("cannot write into {}", d.display()))?;
            for report in populations.iter().filter(|r| r.pilot == is_pilot) {
                super::analyze_population::write(&d, report, &collected.group(is_pilot))
                    .with_context(|| format!("cannot write into {}", d.display()))?;
            }
            errln!("wrote {}", d.display());
        }
        output_dir::finish(dir, "analyze", None, &held)?;
    }
    match args.format {
        Format::Json => {
            let out = JsonOut {
                sessions: collected.analysed.iter().map(json_session).collect(),
                real,
                pilot,
                real_alpha,
                pilot_alpha,
                withdrawn_left_out: collected.left_out,
                measured_refits: refits,
                populations,
                skipped: &collected.skipped,
                warnings: &collected.warnings,
                differences: &collected.differences,
            };
            outln!("{}", serde_json::to_string_pretty(&out)?);
        }
        Format::Table => {
            for (label, is_pilot, summary, alpha) in [
                ("REAL SESSIONS", false, &real, &real_alpha),
                ("PILOT SESSIONS (dry runs, rehearsals)", true, &pilot, &pilot_alpha),
            ] {
                if let (Some(s), Some(alpha)) = (summary, alpha) {
                    out!("{}", table(label, &collected.group(is_pilot), s, alpha));
                }
            }
            if args.measured.given() {
                out!("{}", super::analyze_measured::table(&refits));
            }
            for report in &populations {
                out!("{}", super::analyze_population::table(report));
            }
        }
    }
    let Collected { skipped, warnings, differences, .. } = &collected;
    for w in warnings {
        errln!("warning: {w}");
    }
    for s in skipped {
        errln!("{s}");
    }
    if args.verify {
        if differences.is_empty() {
            errln!("verify: every derived value matches its recomputation");
        }
        for d in differences {
            errln!("verify: {d}");
        }
    }
    if !differences.is_empty() {
        anyhow::bail!("--verify: {} difference(s) between the logs and their recomputation", differences.len());
    }
    if !skipped.is_empty() {
        anyhow::bail!("{} file(s) skipped", skipped.len());
    }
    Ok(())
}

fn deg(v: &[f64]) -> Vec<f64> {
    v.iter().map(|x| (x.to_degrees() * 10.0).round() / 10.0).collect()
}

fn json_session(a: &Analysed) -> JsonSession<'_> {
    let s = &a.analysis;
    JsonSession {
        session_id: &s.start.session_id,
        participant: &s.start.participant,
        pilot: s.start.pilot,
        log: a.log.path.display().to_string(),
        completed: s.completed,
        truncated: !a.log.finished,
        condition_order: s.start.condition_order.iter().map(|c| c.name()).collect(),
        program_labels: &s.start.program_labels,
        runs: s
            .runs
            .iter()
            .map(|r| JsonRun {
                program: program_letter(r.program),
                condition: &r.condition,
                queries: r.trials.iter().map(|t| (t.query.as_str(), t.object.as_str(), t.region.as_str())).collect(),
                test_log_likelihood_estimate: &r.test_ll_estimate,
                test_log_likelihood_predictive: &r.test_ll_predictive,
                learned_q_star_deg: deg(&r.learned_q_star),
                beliefs: &r.beliefs,
            })
            .collect(),
        test_trials: &s.test_trials,
        likert: &s.likert,
        forced_choice: s.choice.map(program_letter),
        robot: handover::analysis::robot_timings(&s.robot),
    }
}

/// "4.7 [3.2, 6.9]", with open ends as "≤ 0.25" / "≥ 256".
fn write_outputs(
    dir: &Path,
    style: &FigureStyle,
    group: &[&Analysed],
    s: &StudySummary,
    alpha: &AlphaSummary,
) -> Result<()> {
    handover::private_files::create_dir(dir)?;
    write_tables(dir, group, s, alpha)?;
    let conditions: Vec<String> = s.distinct_q_star.keys().cloned().collect();
    for (file, predictive) in [("fig10.svg", false), ("fig10_predictive.svg", true)] {
        let series: Vec<Series> = conditions
            .iter()
            .map(|c| Series {
                name: c,
                points: s
                    .fig10
                    .iter()
                    .filter(|p| &p.condition == c)
                    .map(|p| {
                        if predictive {
                            (p.iteration as f64, p.predictive_mean, p.predictive_se)
                        } else {
                            (p.iteration as f64, p.estimate_mean, p.estimate_se)
                        }
                    })
                    .collect(),
            })
            .collect();
        let kind = if group.first().is_some_and(|a| a.log.start.pilot) { "pilot (simulated)" } else { "real" };
        let measure = if predictive { "Posterior-predictive" } else { "Posterior mean's" };
        // The figure says what it shows; the data it comes from is in the legend.
        let title = format!("{measure} test log-likelihood by training iteration");
        // Short enough for a one-column figure's height; the title says which estimate.
        let y_label = "test-set log-likelihood (nats)";
        let band = format!("± 1 s.e. over {} {kind} session{}", s.sessions, if s.sessions == 1 { "" } else { "s" });
        let plot = LinePlot {
            title: &title,
            x_label: "training iteration (handovers learned from)",
            y_label,
            band: &band,
            floor: None,
            series,
        };
        mean_se_plot(&dir.join(file), style, &plot)?;
    }
    let objects: Vec<String> = {
        let mut v: Vec<String> = s.objects.values().flat_map(|m| m.keys().cloned()).collect();
        v.sort();
        v.dedup();
        v
    };
    // Shares, not counts: every session offers each condition's training trials, so the
    // share over all offers is the mean of the participants' shares.
    let groups: Vec<(String, Vec<f64>)> = conditions
        .iter()
        .map(|c| {
            let total = s.objects[c].values().sum::<usize>().max(1) as f64;
            (c.clone(), objects.iter().map(|o| s.objects[c].get(o).copied().unwrap_or(0) as f64 / total).collect())
        })
        .collect();
    let kind = if group.first().is_some_and(|a| a.log.start.pilot) { "pilot (simulated)" } else { "real" };
    let title = format!(
        "Objects offered in training, by condition — {} {kind} session{}",
        s.sessions,
        if s.sessions == 1 { "" } else { "s" }
    );
    let y_label = "share of the condition's training offers";
    bar_chart(&dir.join("objects.svg"), style, &title, y_label, &objects, &groups)?;
    handover::private_files::write_output(
        &dir.join("table1.md"),
        format!("# Table I — {} sessions\n\n{}", s.sessions, table1_markdown(s)).as_bytes(),
    )?;
    write_alpha_plot(dir, style, alpha, kind)
}

/// alpha.svg.
fn write_alpha_plot(dir: &Path, style: &FigureStyle, a: &AlphaSummary, kind: &str) -> Result<()> {
    let sessions: Vec<Vec<(f64, f64)>> = a.sessions.iter().filter_map(|s| s.fit.as_ref()).map(relative_curve).collect();
    let pooled = a.pooled.as_ref().map(|f| PooledEvidence {
        curve: relative_curve(f),
        alpha: f.alpha,
        low: f.low,
        high: f.high,
    });
    let protocol: Vec<f64> = a.protocol_alphas.iter().map(|(x, _)| *x).collect();
    let n = a.sessions.len();
    let title = format!("α by maximum marginal likelihood — {n} {kind} session{}", if n == 1 { "" } else { "s" });
    alpha_plot(&dir.join("alpha.svg"), style, &title, &sessions, pooled.as_ref(), &protocol, SUPPORT_DROP)?;
    Ok(())
}

/// A fit's curve relative to its maximum.
fn relative_curve(f: &AlphaFit) -> Vec<(f64, f64)> {
    f.curve.iter().map(|(x, y)| (*x, y - f.max_log_evidence)).collect()
}
