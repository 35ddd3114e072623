//! `handover observations`: what measuring the arm buys over the region taken.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use handover::belief::Estimate;
use handover::ergo::LearnMask;
use handover::experiment::{
    Arm7, ObservationRow, Planar2, Scenario, Settings, SimObservation, iterations_to_match_region, observation_label,
    observation_settings, observation_sweep,
};
use handover::plot::{LinePlot, Series, line_grid};
use handover::select::{SelectorKind, Tradeoff};
use indicatif::{ProgressBar, ProgressStyle};

use super::input::bad;

/// Region, configuration and measured observations side by side (the paper's footnote 2:
/// the user study observed only the grip taken). Every model learns on the same trials
/// (truth, menu, test set) with each selector, over seeds: the distance of the posterior mean
/// to λ* and the test log-likelihood per iteration, each model's paired difference from the
/// region's, and how many queries each needs to learn what the region learns in all of them.
/// Writes DIR/observations.csv (tidy) and DIR/observations.svg.
#[derive(Debug, Args)]
pub struct ObservationsArgs {
    /// Scenarios, comma-separated (planar2's region is the connected piece of the object
    /// taken, arm7's the grip).
    #[arg(long, value_enum, value_delimiter = ',', default_value = "planar2,arm7")]
    scenarios: Vec<SweepScenario>,
    /// Measurement noise levels σ per joint, degrees, comma-separated (0.01 to 57.3).
    #[arg(long, value_delimiter = ',', default_value = "2,5,10,20", value_name = "DEG,…")]
    sigmas_deg: Vec<f64>,
    /// Selectors, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "active,passive")]
    algorithms: Vec<SelectorKind>,
    /// What is learned: q-star, weights or both.
    #[arg(long, default_value = "q-star")]
    learn: LearnMask,
    /// Seeds (SEED, SEED+1, …); at least 2, for the intervals.
    #[arg(long, default_value_t = 5)]
    seeds: u64,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Trials per seed (each with its own truth, menu and test set).
    #[arg(long, default_value_t = 20)]
    trials: usize,
    /// Queries on each trial's menu.
    #[arg(long, default_value_t = 8)]
    menu: usize,
    /// Queries per selector and trial [default: planar2 5, arm7 10].
    #[arg(long)]
    iterations: Option<usize>,
    /// Test-set size per trial.
    #[arg(long, default_value_t = 100)]
    test_size: usize,
    /// Particles in the belief.
    #[arg(long, default_value_t = 1000)]
    particles: usize,
    /// Worker threads [default: all cores]; the numbers do not depend on it.
    #[arg(long)]
    threads: Option<usize>,
    /// Output directory for observations.csv and observations.svg.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq)]
enum SweepScenario {
    Planar2,
    Arm7,
}

pub fn run(a: ObservationsArgs) -> Result<()> {
    if !(2..=1000).contains(&a.seeds) {
        return Err(bad(format!("--seeds is {}, expected 2 to 1000 (intervals are over seeds)", a.seeds)));
    }
    for (name, v) in
        [("--trials", a.trials), ("--menu", a.menu), ("--test-size", a.test_size), ("--particles", a.particles)]
    {
        if v == 0 {
            return Err(bad(format!("{name} is 0, expected a positive count")));
        }
    }
    let (min, max) = handover::ergo::SIGMA_DEG;
    if let Some(s) = a.sigmas_deg.iter().find(|s| !(s.is_finite() && (min..=max).contains(*s))) {
        return Err(bad(format!("--sigmas-deg has {s}, expected {min} to {max:.1} degrees")));
    }
    if a.scenarios.is_empty() || a.algorithms.is_empty() {
        return Err(bad("--scenarios and --algorithms need at least one value each"));
    }
    if a.iterations == Some(0) || a.threads == Some(0) {
        return Err(bad("--iterations and --threads must be at least 1"));
    }
    let mut algorithms = a.algorithms.clone();
    algorithms.dedup();
    let threads = a.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().context("cannot start worker threads")?;
    if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let observations = observation_settings(&a.sigmas_deg);
    let scenarios: Vec<Box<dyn Scenario>> = a
        .scenarios
        .iter()
        .map(|s| -> Box<dyn Scenario> {
            match s {
                SweepScenario::Planar2 => Box::new(Planar2::default()),
                SweepScenario::Arm7 => Box::new(Arm7::default()),
            }
        })
        .collect();
    let bar = ProgressBar::new(scenarios.len() as u64 * a.seeds * observations.len() as u64 * a.trials as u64);
    bar.set_style(
        ProgressStyle::with_template("observations [{bar:40}] {pos}/{len} trials, {elapsed} elapsed, ETA {eta}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let started = Instant::now();
    let mut rows: Vec<ObservationRow> = Vec::new();
    let mut meta = Vec::new();
    for scenario in &scenarios {
        let base = Settings {
            learn: a.learn,
            trials: a.trials,
            menu: a.menu,
            iterations: a.iterations.unwrap_or_else(|| scenario.default_iterations()),
            test_size: a.test_size,
            particles: a.particles,
            alpha: scenario.default_alpha(a.learn),
            algorithms: algorithms.clone(),
            seed: a.seed,
            tradeoff: Tradeoff::default(),
            grid_boxes: 10,
            jitter_fraction: 0.01,
            bandwidth_fraction: 0.05,
            estimate: Estimate::Mean,
            observation: SimObservation::Configuration,
        };
        rows.extend(
            pool.install(|| observation_sweep(scenario.as_ref(), &base, a.seeds, &observations, &|| bar.inc(1))),
        );
        meta.push((scenario.name(), base.alpha, base.iterations));
    }
    bar.finish_and_clear();
    print_table(&rows, &meta, &a, started.elapsed().as_secs_f64(), threads)?;
    if let Some(dir) = &a.out {
        let path = dir.join("observations.csv");
        let mut w = csv::Writer::from_path(&path).with_context(|| format!("cannot write {}", path.display()))?;
        for r in &rows {
            w.serialize(r)?;
        }
        w.flush()?;
        let labels: Vec<String> = observations.iter().map(|o| observation_label(*o).2).collect();
        let mut panels: Vec<(String, &str, &str, &str)> = Vec::new();
        for (scenario, alpha, _) in &meta {
            for measure in handover::experiment::OBSERVATION_MEASURES {
                for alg in &algorithms {
                    panels.push((format!("{scenario}, {} (α = {alpha})", alg.name()), scenario, alg.name(), measure));
                }
            }
        }
        let y_label = |measure: &str| {
            if measure == "distance_to_truth" { "distance of the posterior mean to λ*" } else { "test log-likelihood" }
        };
        let plots: Vec<LinePlot> = panels
            .iter()
            .map(|(title, scenario, algorithm, measure)| {
                let series = observations
                    .iter()
                    .zip(&labels)
                    .map(|(o, label)| {
                        let (name, sigma, _) = observation_label(*o);
                        let points = rows
                            .iter()
                            .filter(|r| {
                                r.scenario == *scenario
                                    && r.algorithm == *algorithm
                                    && r.measure == *measure
                                    && r.observation == name
                                    && r.sigma_deg == sigma
                            })
                            .map(|r| (r.iteration as f64, r.mean, (r.ci_high - r.ci_low) / 2.0))
                            .collect();
                        Series { name: label.as_str(), points }
                    })
                    .collect();
                LinePlot {
                    title: title.as_str(),
                    x_label: "queries",
                    y_label: y_label(measure),
                    band: "95 % interval over seeds",
                    series,
                }
            })
            .collect();
        let title = format!(
            "Learning from the region, the configuration, or the arm measured with noise σ: {} seeds × {} trials, learning {}",
            a.seeds, a.trials, a.learn
        );
        line_grid(&dir.join("observations.svg"), &title, &plots, algorithms.len()).map_err(anyhow::Error::msg)?;
        eprintln!("wrote {}/observations.csv and observations.svg", dir.display());
    }
    Ok(())
}

fn print_table(
    rows: &[ObservationRow],
    meta: &[(&str, f64, usize)],
    a: &ObservationsArgs,
    seconds: f64,
    threads: usize,
) -> Result<()> {
    outln!(
        "observation models: learning {}, seeds {}–{}, {} trials each, {} particles, menu {}, test set {} ({seconds:.1} s on {threads} threads)",
        a.learn,
        a.seed,
        a.seed + a.seeds - 1,
        a.trials,
        a.particles,
        a.menu,
        a.test_size
    );
    outln!(
        "at the last query: mean [95 % interval over seeds]; − region: paired difference (same trials) [95 % interval], Wilcoxon p; queries: the first at which the mean distance is at most the region's after all of them"
    );
    for (scenario, alpha, iterations) in meta {
        outln!("\n{scenario} (α = {alpha}, {iterations} queries):");
        outln!(
            "  {:<9} {:<22} {:>22} {:>30} {:>24} {:>8}",
            "selector",
            "observation",
            "distance",
            "− region",
            "test log-likelihood",
            "queries"
        );
        for r in rows
            .iter()
            .filter(|r| r.scenario == *scenario && r.iteration == *iterations && r.measure == "distance_to_truth")
        {
            let ll = rows
                .iter()
                .find(|x| {
                    x.scenario == r.scenario
                        && x.algorithm == r.algorithm
                        && x.observation == r.observation
                        && x.sigma_deg == r.sigma_deg
                        && x.iteration == r.iteration
                        && x.measure == "test_log_likelihood"
                })
                .map_or(String::new(), |x| format!("{:.2} [{:.2}, {:.2}]", x.mean, x.ci_low, x.ci_high));
            let diff = match (r.minus_region, r.minus_region_ci_low, r.minus_region_ci_high) {
                (Some(d), Some(l), Some(h)) => format!(
                    "{d:+.3} [{l:+.3}, {h:+.3}] p {}",
                    r.minus_region_p.map_or("–".to_string(), |p| {
                        // Below f64's resolution near 1 the normal tail reads 0.
                        if p < 1e-15 { "< 1e-15".to_string() } else { format!("{p:.2e}") }
                    })
                ),
                _ => String::new(),
            };
            let label = match r.sigma_deg {
                Some(s) => format!("measured σ = {s}°"),
                None => r.observation.to_string(),
            };
            outln!(
                "  {:<9} {:<22} {:>22} {:>30} {:>24} {:>8}",
                r.algorithm,
                label,
                format!("{:.3} [{:.3}, {:.3}]", r.mean, r.ci_low, r.ci_high),
                diff,
                ll,
                iterations_to_match_region(rows, r).map_or("not".to_string(), |i| i.to_string())
            );
        }
    }
    Ok(())
}
