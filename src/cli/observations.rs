//! `handover research observations`: what measuring the arm buys over the region taken.

use super::figures::FigureArgs;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use handover::ergo::LearnMask;
use handover::experiment::{
    ObservationRow, Scenario, iterations_to_match_region, observation_label, observation_settings, observation_sweep,
};
use handover::plot::{LinePlot, Series, line_grid};
use handover::select::SelectorKind;

use super::input::bad;
use super::sweep::{SweepArgs, SweepScenario};

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
    #[arg(long, alias = "sigmas-deg", value_delimiter = ',', default_value = "2,5,10,20", value_name = "DEG,…")]
    sigma_deg: Vec<f64>,
    /// Selectors, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "active,passive")]
    algorithms: Vec<SelectorKind>,
    /// What is learned: q-star, weights or both.
    #[arg(long, default_value = "q-star")]
    learn: LearnMask,
    #[command(flatten)]
    sweep: SweepArgs,
    /// Output directory for observations.csv and observations.svg.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    #[command(flatten)]
    figures: FigureArgs,
}

pub fn run(a: ObservationsArgs) -> Result<()> {
    a.figures.check()?;
    let (min, max) = handover::ergo::SIGMA_DEG;
    if let Some(s) = a.sigma_deg.iter().find(|s| !(s.is_finite() && (min..=max).contains(*s))) {
        return Err(bad(format!("--sigma-deg has {s}, expected {min} to {max:.1} degrees")));
    }
    if a.scenarios.is_empty() || a.algorithms.is_empty() {
        return Err(bad("--scenarios and --algorithms need at least one value each"));
    }
    let algorithms = super::input::first_occurrences(&a.algorithms);
    let (pool, threads) = a.sweep.pool()?;
    if let Some(dir) = &a.out {
        handover::private_files::create_dir(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let observations = observation_settings(&a.sigma_deg);
    let scenarios: Vec<Box<dyn Scenario>> = a.scenarios.iter().map(|s| s.build()).collect();
    let sw = &a.sweep;
    let bar = sw.progress("observations", scenarios.len() as u64 * observations.len() as u64);
    let started = Instant::now();
    let mut rows: Vec<ObservationRow> = Vec::new();
    let mut meta = Vec::new();
    for scenario in &scenarios {
        let base = sw.settings(scenario.as_ref(), a.learn, algorithms.clone());
        rows.extend(
            pool.install(|| observation_sweep(scenario.as_ref(), &base, sw.seeds, &observations, &|| bar.inc(1))),
        );
        meta.push((scenario.name(), base.alpha, base.iterations));
    }
    bar.finish_and_clear();
    print_table(&rows, &meta, &a, started.elapsed().as_secs_f64(), threads)?;
    if let Some(dir) = &a.out {
        super::simulate::write_csv(&dir.join("observations.csv"), &rows)?;
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
                    floor: (*measure == "distance_to_truth").then_some(0.0),
                    series,
                }
            })
            .collect();
        let title = format!(
            "Learning from the region, the configuration, or the arm measured with noise σ: {} seeds × {} trials, learning {}",
            sw.seeds, sw.trials, a.learn
        );
        // The panels of one scenario and measure (a row: one per algorithm) share a y axis.
        let groups: Vec<usize> = (0..plots.len()).map(|k| k / algorithms.len()).collect();
        let style = a.figures.style();
        line_grid(&dir.join("observations.svg"), &style, &title, &plots, algorithms.len(), Some(&groups))?;
        errln!("wrote {}/observations.csv and {}", dir.display(), style.file_names("observations"));
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
        "observation models: learning {}, seeds {}–{}, {} trials each, {} particles, menu {}, test set {} ({})",
        a.learn,
        a.sweep.seed,
        a.sweep.seed + a.sweep.seeds - 1,
        a.sweep.trials,
        a.sweep.particles,
        a.sweep.menu,
        a.sweep.test_size,
        super::timing(seconds, threads),
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
                    "{d:+.3} [{l:+.3}, {h:+.3}] {}",
                    r.minus_region_p.map_or("p –".to_string(), super::simulate::format_p)
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
