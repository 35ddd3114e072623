//! `handover research simulate`: the paper's simulation studies (sections V and VI, Fig. 2–4 and 8).

use super::figures::FigureArgs;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use handover::belief::Estimate;
use handover::ergo::LearnMask;
use handover::experiment::{
    self, Arm7, Planar2, Scenario, Settings, SimObservation, SummaryRow, paired_tests, summarise,
};
use handover::output_dir;
use handover::plot::{LinePlot, Series, line_grid, mean_se_plot};
use handover::select::{DEFAULT_BUDGET_EPSILON, DEFAULT_HYBRID_BETA, Precision, SelectorKind, Tradeoff};

use super::input::{bad, count};

/// Reproduce the paper's simulation studies: a simulated person with a ground truth drawn
/// from the prior answers every algorithm's queries; each algorithm is measured after every
/// iteration (0 = the prior) on density at the truth, distance of the mode to the truth,
/// test-set log-likelihood of the mode and the true cost of the chosen query.
///
/// Writes DIR/metrics.csv (one row per algorithm × trial × iteration), DIR/summary.csv (mean
/// and standard error), one SVG per measure, and a table on stdout. `two-sets` runs the
/// Fig. 3/4 experiment instead: which of two synthetic feasible sets the active selector
/// offers at each iteration.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// planar2 (section V), arm7 (section VI) or two-sets (Fig. 3/4).
    #[arg(value_enum)]
    scenario: ScenarioName,
    /// What is learned: q-star (w known), weights (q* known) or both.
    #[arg(long, default_value = "q-star")]
    learn: LearnMask,
    /// Number of trials (each with its own ground truth, menu and test set).
    #[arg(long, default_value_t = 20, value_parser = count(1))]
    trials: usize,
    /// Number of queries on each trial's menu.
    #[arg(long, default_value_t = 8, value_parser = count(1))]
    menu: usize,
    /// Queries per algorithm and trial [default: planar2 5, arm7 10, two-sets 8].
    #[arg(long, value_parser = count(1))]
    iterations: Option<usize>,
    /// Number of random test queries answered by the simulated person per trial.
    #[arg(long, default_value_t = 300, value_parser = count(1))]
    test_size: usize,
    /// Number of particles in the belief.
    #[arg(long, default_value_t = 1000, value_parser = count(1))]
    particles: usize,
    /// Rationality α of the simulated person and of the model [default: planar2 10;
    /// arm7 40 for q-star, 10 for weights and both; two-sets 2].
    #[arg(long)]
    alpha: Option<f64>,
    /// Comma-separated algorithms to compare.
    #[arg(long, value_delimiter = ',', default_value = "active,active-paper,passive,random,hybrid")]
    algorithms: Vec<SelectorKind>,
    /// β of `hybrid` (maximises information gain − β · expected cost).
    #[arg(long, default_value_t = DEFAULT_HYBRID_BETA)]
    beta: f64,
    /// ε of `budgeted` (the most informative query whose expected cost is at most (1 + ε) ×
    /// the passive query's).
    #[arg(long, default_value_t = DEFAULT_BUDGET_EPSILON)]
    epsilon: f64,
    /// The point estimate that distance and test log-likelihood are measured on: the
    /// posterior mean, the MAP particle (exact unnormalised posterior), or the paper's
    /// gridded mode (to reproduce its figures; grid noise in 7-D).
    #[arg(long, default_value = "mean")]
    estimate: Estimate,
    /// What the learner observes of each choice: the configuration (the paper's simulations),
    /// the region (arm7: the grip taken, as in the user study; planar2: the connected piece
    /// of the object taken; queries scored by their information about the region), or the configuration measured with Gaussian noise of
    /// --sigma-deg on every joint (a motion capture or body tracker; queries are still scored
    /// by their information about the configuration).
    #[arg(long, value_enum, default_value = "configuration")]
    observation: ObservationArg,
    /// The measurement noise's standard deviation per joint, in degrees (with --observation
    /// measured).
    #[arg(long, value_name = "DEG")]
    sigma_deg: Option<f64>,
    /// The arithmetic of the selectors' information gain and expected cost: float64, or
    /// float32 (about twice as fast; its tolerance in docs/engine.md). Beliefs are float64.
    #[arg(long, value_enum, default_value_t = Precision::Float64)]
    precision: Precision,
    /// Seed of every random draw; the same seed gives byte-identical CSV for any --threads.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Run N seeds (SEED, SEED+1, …), 1 to 1000: every measure is then reported as the mean
    /// with a 95 % confidence interval over the seeds' means, and each algorithm is compared
    /// with `active` by a paired test (same truth, menu and test set), in tests.csv.
    #[arg(long, default_value_t = 5, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=1000))]
    seeds: u64,
    /// Worker threads [default: all cores]; the numbers do not depend on it.
    #[arg(long, value_parser = count(1))]
    threads: Option<usize>,
    /// Output directory for CSV and SVG (created if missing); without it only the table is printed.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Run only shard K of N (0-based) of the seeds × trials, as one task of a batch
    /// scheduler's job array: writes DIR/metrics.csv and DIR/shard.json (--out DIR), to be
    /// joined by --merge.
    #[arg(long, value_name = "K/N", conflicts_with = "merge")]
    shard: Option<String>,
    /// Join the shard directories of this same command (the same options, each run with
    /// --shard) into exactly what the whole run writes to --out, without running anything.
    #[arg(long, value_name = "DIR", num_args = 1.., conflicts_with = "shard")]
    merge: Vec<PathBuf>,
    #[command(flatten)]
    figures: FigureArgs,
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq)]
enum ObservationArg {
    Configuration,
    Region,
    Measured,
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq)]
enum ScenarioName {
    Planar2,
    Arm7,
    TwoSets,
}

/// Measures plotted, with their axis labels.
const PLOTTED: [(&str, &str); 5] = [
    ("density_at_truth", "P(λ*): kernel density of the belief at the truth"),
    ("log_density_at_truth", "log P(λ*) (nats)"),
    ("distance_to_truth", "‖estimate − λ*‖ (rad; weights unitless)"),
    ("test_log_likelihood", "test-set log-likelihood of the estimate (nats)"),
    ("true_cost", "true cost of the query answered (eq. 2, rad²)"),
];

struct Checked {
    scenario: Box<dyn Scenario>,
    settings: Settings,
}

fn check(a: &SimulateArgs) -> Result<Checked> {
    let scenario: Box<dyn Scenario> = match a.scenario {
        ScenarioName::Planar2 => Box::new(Planar2::default()),
        _ => Box::new(Arm7::default()),
    };
    if a.algorithms.is_empty() {
        return Err(bad(
            "--algorithms is empty, expected at least one of active, active-paper, passive, random, hybrid, budgeted",
        ));
    }
    let alpha = a.alpha.unwrap_or_else(|| scenario.default_alpha(a.learn));
    if !(alpha.is_finite() && alpha > 0.0) {
        return Err(bad(format!("--alpha is {alpha}, expected a positive number")));
    }
    if !(a.beta.is_finite() && a.beta >= 0.0) {
        return Err(bad(format!("--beta is {}, expected a non-negative number", a.beta)));
    }
    if !(a.epsilon.is_finite() && a.epsilon >= 0.0) {
        return Err(bad(format!("--epsilon is {}, expected a non-negative number", a.epsilon)));
    }
    let observation = match (a.observation, a.sigma_deg) {
        (ObservationArg::Configuration, None) => SimObservation::Configuration,
        (ObservationArg::Region, None) => SimObservation::Region,
        (ObservationArg::Configuration | ObservationArg::Region, Some(_)) => {
            return Err(bad("--sigma-deg is given without --observation measured"));
        }
        (ObservationArg::Measured, None) => return Err(bad("--observation measured needs --sigma-deg")),
        (ObservationArg::Measured, Some(deg)) => {
            let (min, max) = handover::ergo::SIGMA_DEG;
            if !(deg.is_finite() && (min..=max).contains(&deg)) {
                return Err(bad(format!("--sigma-deg is {deg}, expected {min} to {max:.1} degrees")));
            }
            SimObservation::Measured { sigma_rad: deg.to_radians() }
        }
    };
    let algorithms = super::input::first_occurrences(&a.algorithms);
    let settings = Settings {
        learn: a.learn,
        trials: a.trials,
        menu: a.menu,
        iterations: a.iterations.unwrap_or_else(|| scenario.default_iterations()),
        test_size: a.test_size,
        particles: a.particles,
        alpha,
        algorithms,
        seed: a.seed,
        tradeoff: Tradeoff { beta: a.beta, epsilon: a.epsilon },
        numerics: Default::default(),
        estimate: a.estimate,
        observation,
        precision: a.precision,
    };
    Ok(Checked { scenario, settings })
}

pub fn run(args: SimulateArgs) -> Result<()> {
    args.figures.check()?;
    if args.scenario == ScenarioName::TwoSets
        && (args.observation != ObservationArg::Configuration || args.sigma_deg.is_some())
    {
        return Err(bad("--observation measured and --sigma-deg are for planar2 and arm7, not two-sets"));
    }
    let (pool, threads) = super::progress::worker_pool(args.threads)?;
    if args.scenario == ScenarioName::TwoSets {
        return pool.install(|| run_two_sets(&args));
    }
    let Checked { scenario, settings } = check(&args)?;
    let fingerprint = format!("{} {settings:?} seeds {}", scenario.name(), args.seeds);
    let shard = args.shard.as_deref().map(super::shards::parse_shard).transpose()?;
    // The folder is this run's (its options, and the shard): another run's is refused, a
    // rerun of this one replaces its files.
    let run_id = match shard {
        Some((k, n)) => format!("{fingerprint}; shard {k}/{n}"),
        None => fingerprint.clone(),
    };
    if let Some(dir) = &args.out {
        output_dir::prepare(dir, "simulate", Some(&run_id), &[]).map_err(super::input::output_dir_error)?;
    }
    let bar = super::progress::bar(
        &format!("simulate {} {}", scenario.name(), settings.learn),
        settings.trials as u64 * args.seeds,
        "trials × seeds",
    );
    let started = Instant::now();
    if let Some((k, n)) = shard {
        let dir = args.out.as_ref().ok_or_else(|| bad("--shard needs --out DIR for the shard's files"))?;
        let units = experiment::shard_units(args.seeds, settings.trials, k, n);
        bar.set_length(units.len() as u64);
        let mut rows = Vec::new();
        for seed in 0..args.seeds {
            let trials: Vec<usize> = units.iter().filter(|u| u.0 == seed).map(|u| u.1).collect();
            let run = Settings { seed: settings.seed + seed, ..settings.clone() };
            rows.extend(pool.install(|| experiment::simulate_trials(scenario.as_ref(), &run, &trials, &|| bar.inc(1))));
        }
        bar.finish_and_clear();
        write_csv(&dir.join("metrics.csv"), &rows)?;
        let seconds = started.elapsed().as_secs_f64();
        let manifest =
            super::shards::manifest(dir, fingerprint, (k, n), rows.len(), &["metrics.csv"], seconds, threads)?;
        super::shards::write_manifest(dir, &manifest)?;
        output_dir::finish(dir, "simulate", Some(&run_id), &[])?;
        errln!(
            "shard {k}/{n}: {} of {} trials × seeds, {} rows in {:.1} s; wrote {}/metrics.csv and {}",
            units.len(),
            settings.trials as u64 * args.seeds,
            rows.len(),
            started.elapsed().as_secs_f64(),
            dir.display(),
            experiment::SHARD_MANIFEST
        );
        return Ok(());
    }
    let (rows, shards) = if args.merge.is_empty() {
        let mut rows = Vec::new();
        for k in 0..args.seeds {
            let run = Settings { seed: settings.seed + k, ..settings.clone() };
            rows.extend(pool.install(|| experiment::simulate(scenario.as_ref(), &run, &|| bar.inc(1))));
        }
        (rows, None)
    } else {
        let (rows, manifests) = merge_shards(&args.merge, &fingerprint, &settings, args.seeds)?;
        (rows, Some(manifests))
    };
    bar.finish_and_clear();
    let elapsed = started.elapsed().as_secs_f64();
    let timing = match &shards {
        None => super::timing(elapsed, threads),
        Some(manifests) => super::shards::merged_timing(manifests, elapsed),
    };
    let summary = summarise(&rows);
    let tests = paired_tests(&rows, "active", settings.iterations, &COMPARED);
    print_table(scenario.name(), &settings, args.seeds, &summary, &tests, &timing)?;
    if let Some(dir) = &args.out {
        write_csv(&dir.join("metrics.csv"), &rows)?;
        write_csv(&dir.join("summary.csv"), &summary)?;
        write_csv(&dir.join("tests.csv"), &tests)?;
        for (measure, label) in PLOTTED {
            let series: Vec<Series> = settings
                .algorithms
                .iter()
                .map(|k| Series {
                    name: k.name(),
                    points: summary
                        .iter()
                        .filter(|r| r.algorithm == k.name() && r.measure == measure)
                        .map(|r| (r.iteration as f64, r.mean, ci_half_width(r)))
                        .collect(),
                })
                .collect();
            // The prior's test log-likelihood is far below every later one: from iteration 1
            // the differences between algorithms are visible (iteration 0 is in summary.csv).
            let from = if measure == "test_log_likelihood" { 1.0 } else { 0.0 };
            let series: Vec<Series> = series
                .into_iter()
                .map(|s| Series { name: s.name, points: s.points.into_iter().filter(|p| p.0 >= from).collect() })
                .collect();
            let title = format!(
                "{}{} — simulated {}, learning {}, {} trials × {} seeds, estimate: {}",
                measure.replace('_', " "),
                if from > 0.0 { " (from iteration 1)" } else { "" },
                scenario.name(),
                settings.learn,
                settings.trials,
                args.seeds,
                settings.estimate.name()
            );
            let band = if args.seeds > 1 { "95 % CI over the seeds' means" } else { "95 % CI over trials" };
            // Distances, costs and densities cannot be negative; log-densities and
            // log-likelihoods have no least value.
            let floor = (!measure.contains("log")).then_some(0.0);
            let path = dir.join(format!("{measure}.svg"));
            let x_label = "iteration (queries answered)";
            if series.len() <= 2 {
                let plot = LinePlot { title: &title, x_label, y_label: label, band, floor, series };
                mean_se_plot(&path, &args.figures.style(), &plot)?;
                continue;
            }
            // More bands than one axis can show apart: small multiples, each algorithm beside
            // the first (active, the one the tests compare against), two bands a panel.
            let titles: Vec<String> =
                series[1..].iter().map(|s| format!("{} and {}", s.name, series[0].name)).collect();
            let plots: Vec<LinePlot> = series[1..]
                .iter()
                .zip(&titles)
                .map(|(s, panel)| LinePlot {
                    title: panel,
                    x_label,
                    y_label: label,
                    band,
                    floor,
                    series: vec![
                        Series { name: series[0].name, points: series[0].points.clone() },
                        Series { name: s.name, points: s.points.clone() },
                    ],
                })
                .collect();
            line_grid(&path, &args.figures.style(), &title, &plots, 2, Some(&vec![0; plots.len()]))?;
        }
        output_dir::finish(dir, "simulate", Some(&run_id), &[])?;
        errln!(
            "wrote {}/{{metrics,summary,tests}}.csv and {} per measure",
            dir.display(),
            args.figures.style().file_names("MEASURE")
        );
    }
    Ok(())
}

/// The rows of every shard of this run, checked (the same run, each shard once, all there)
/// and in the whole run's order, and the shards' manifests.
fn merge_shards(
    dirs: &[PathBuf],
    fingerprint: &str,
    s: &Settings,
    seeds: u64,
) -> Result<(Vec<experiment::MetricRow>, Vec<experiment::ShardManifest>)> {
    let per_unit = s.algorithms.len() * (s.iterations + 1);
    let expected = seeds as usize * s.trials * per_unit;
    let mut rows = Vec::with_capacity(expected);
    let mut manifests = Vec::new();
    for (dir, m) in super::shards::checked_shards(dirs, fingerprint, &["metrics.csv"])? {
        let shard_rows = experiment::read_metrics(&dir.join("metrics.csv"), expected).map_err(bad)?;
        super::shards::check_rows(dir, "metrics.csv", shard_rows.len(), &m)?;
        rows.extend(shard_rows);
        manifests.push(m);
    }
    if rows.len() != expected {
        return Err(bad(format!("the shards hold {} rows, the run has {expected}", rows.len())));
    }
    experiment::merge_order(&mut rows, &s.algorithms);
    Ok((rows, manifests))
}

/// Writes `rows` as a tidy table (owner-only; the header also when there are none).
pub(super) fn write_csv<T: serde::Serialize + Default + Clone>(path: &Path, rows: &[T]) -> Result<()> {
    Ok(handover::private_files::write_csv(path, rows.iter().cloned())?)
}

/// The measures compared with `active` by paired tests at the last iteration.
const COMPARED: [&str; 3] = ["distance_to_truth", "test_log_likelihood", "true_cost"];

/// A p-value as printed: below what the normal approximation resolves, a bound.
pub(super) fn format_p(p: f64) -> String {
    if p < 1e-15 { "p<1e-15".to_string() } else { format!("p={p:.2e}") }
}

/// Half the width of a row's 95 % confidence interval (0 where it is not defined).
fn ci_half_width(r: &SummaryRow) -> f64 {
    let h = (r.ci_high - r.ci_low) / 2.0;
    if h.is_finite() { h } else { 0.0 }
}

fn print_table(
    name: &str,
    s: &Settings,
    seeds: u64,
    summary: &[SummaryRow],
    tests: &[handover::stats::Paired],
    timing: &str,
) -> Result<()> {
    let seed_text =
        if seeds > 1 { format!("seeds {}–{}", s.seed, s.seed + seeds - 1) } else { format!("seed {}", s.seed) };
    outln!(
        "{name}: learning {}, observing {}, {} trials × {} iterations, {} particles, menu {}, test set {}, α = {}, estimate {}, {seed_text} ({})",
        s.learn,
        match s.observation {
            SimObservation::Configuration => "the configuration".to_string(),
            SimObservation::Region if name == "planar2" => "the region (connected piece) taken".to_string(),
            SimObservation::Region => "the region (grip) taken".to_string(),
            SimObservation::Measured { sigma_rad } =>
                format!("the configuration measured with σ = {:.3}° per joint", sigma_rad.to_degrees()),
        },
        s.trials,
        s.iterations,
        s.particles,
        s.menu,
        s.test_size,
        s.alpha,
        s.estimate.name(),
        timing,
    );
    let over = if seeds > 1 { "over seeds" } else { "over trials" };
    outln!(
        "mean [95 % confidence interval {over}] at the last iteration; p: paired Wilcoxon signed-rank against active"
    );
    let get = |alg: &str, it: usize, m: &str| {
        summary.iter().find(|r| r.algorithm == alg && r.iteration == it && r.measure == m)
    };
    let cell = |r: Option<&SummaryRow>| {
        r.map_or("—".to_string(), |r| {
            if r.ci_low.is_finite() {
                format!("{:.3} [{:.3}, {:.3}]", r.mean, r.ci_low, r.ci_high)
            } else {
                format!("{:.3}", r.mean)
            }
        })
    };
    let p = |alg: &str, m: &str| {
        tests
            .iter()
            .find(|t| t.first == alg && t.measure == m)
            .map_or("".to_string(), |t| t.p_value.map_or("—".to_string(), format_p))
    };
    let iterations = s.iterations;
    let cost_last = |alg: &str| {
        // The mean true cost over the iterations 1..=N of the chosen queries.
        let costs: Vec<&SummaryRow> =
            summary.iter().filter(|r| r.algorithm == alg && r.measure == "true_cost").collect();
        if costs.is_empty() {
            "—".to_string()
        } else {
            format!("{:.3}", costs.iter().map(|r| r.mean).sum::<f64>() / costs.len() as f64)
        }
    };
    outln!(
        "{:<12} {:>8} {:>28} {:>10} {:>34} {:>10} {:>10} {:>10}",
        "algorithm",
        "dist(0)",
        "distance (last)",
        "p",
        "test log-lik (last)",
        "p",
        "true cost",
        "p"
    );
    for k in &s.algorithms {
        let alg = k.name();
        outln!(
            "{:<12} {:>8.3} {:>28} {:>10} {:>34} {:>10} {:>10} {:>10}",
            alg,
            get(alg, 0, "distance_to_truth").map_or(f64::NAN, |r| r.mean),
            cell(get(alg, iterations, "distance_to_truth")),
            p(alg, "distance_to_truth"),
            cell(get(alg, iterations, "test_log_likelihood")),
            p(alg, "test_log_likelihood"),
            cost_last(alg),
            p(alg, "true_cost"),
        );
    }
    if seeds > 1 {
        outln!(
            "seeds in which the paired difference from active alone is significant (p < .05), better / worse than active:"
        );
        for k in s.algorithms.iter().filter(|k| k.name() != "active") {
            let alg = k.name();
            let part = |m: &str, lower_is_better: bool| {
                tests.iter().find(|t| t.first == alg && t.measure == m).map_or("—".to_string(), |t| {
                    let (better, worse) = if lower_is_better {
                        (t.seeds_first_lower, t.seeds_first_higher)
                    } else {
                        (t.seeds_first_higher, t.seeds_first_lower)
                    };
                    format!("{better}/{worse} of {}", t.seeds)
                })
            };
            outln!(
                "  {alg:<12} distance {:>10}   test log-lik {:>10}   true cost {:>10}",
                part("distance_to_truth", true),
                part("test_log_likelihood", false),
                part("true_cost", true)
            );
        }
    }
    Ok(())
}

fn run_two_sets(args: &SimulateArgs) -> Result<()> {
    let alpha = args.alpha.unwrap_or(2.0);
    if !(alpha.is_finite() && alpha > 0.0) {
        return Err(bad(format!("--alpha is {alpha}, expected a positive number")));
    }
    let steps = experiment::two_sets(args.seed, args.iterations.unwrap_or(8), args.particles, alpha);
    outln!("two-sets: set A spreads along joint 1, set B along joint 2; the active selector's choice per iteration");
    outln!(
        "{:>9} {:>8} {:>8} {:>6} {:>18} {:>18} {:>8}",
        "iteration",
        "I(A)",
        "I(B)",
        "chosen",
        "response",
        "mean q*",
        "entropy"
    );
    for s in &steps {
        outln!(
            "{:>9} {:>8.4} {:>8.4} {:>6} {:>18} {:>18} {:>8.3}",
            s.iteration,
            s.information_gain_a,
            s.information_gain_b,
            s.chosen,
            format!("({:.2}, {:.2})", s.response_1, s.response_2),
            format!("({:.2}, {:.2})", s.mean_q_star_1, s.mean_q_star_2),
            s.entropy
        );
    }
    if let Some(dir) = &args.out {
        handover::private_files::create_dir(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        write_csv(&dir.join("two_sets.csv"), &steps)?;
    }
    Ok(())
}
