//! `handover research front`: the comfort–accuracy front of the comfort-aware selectors.

use super::figures::FigureArgs;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use handover::ergo::LearnMask;
use handover::experiment::{FrontPoint, Scenario, front, front_settings};
use handover::plot::{FrontPanel, front_plot};

use super::input::bad;
use super::sweep::{SweepArgs, SweepScenario};

/// The comfort–accuracy front (the paper's footnote 1): for sweeps of `hybrid`'s β
/// (maximise I − β·E[cost]) and `budgeted`'s ε (the most informative query whose expected
/// cost is at most (1 + ε) × the passive query's), the fraction of active's accuracy gain over
/// passive (distance of the posterior mean to the truth at the last iteration) against the
/// true cost relative to passive's, over seeds, on the same trials as active and passive.
/// Writes DIR/front.csv and DIR/front.svg (one panel per scenario and learn-mask).
#[derive(Debug, Args)]
pub struct FrontArgs {
    /// Scenarios, comma-separated.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "planar2,arm7")]
    scenarios: Vec<SweepScenario>,
    /// What is learned, comma-separated: q-star and/or weights (and both).
    #[arg(long, value_delimiter = ',', default_value = "q-star,weights")]
    learn: Vec<LearnMask>,
    /// β values of `hybrid`.
    #[arg(long, value_delimiter = ',', default_value = "0.03,0.1,0.3,1,3")]
    betas: Vec<f64>,
    /// ε values of `budgeted`.
    #[arg(long, value_delimiter = ',', default_value = "0,0.1,0.25,0.5,1")]
    epsilons: Vec<f64>,
    #[command(flatten)]
    sweep: SweepArgs,
    /// Output directory for front.csv and front.svg.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    #[command(flatten)]
    figures: FigureArgs,
}

/// The cost ratio and gain the front is judged against: at most 1.25 × passive's cost for at
/// least 80 % of active's gain over passive.
pub const TARGET: (f64, f64) = (1.25, 0.8);

pub fn run(a: FrontArgs) -> Result<()> {
    a.figures.check()?;
    for (name, values) in [("--betas", &a.betas), ("--epsilons", &a.epsilons)] {
        if let Some(v) = values.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
            return Err(bad(format!("{name} has {v}, expected non-negative numbers")));
        }
    }
    if a.scenarios.is_empty() || a.learn.is_empty() {
        return Err(bad("--scenarios and --learn need at least one value each"));
    }
    let (pool, threads) = a.sweep.pool()?;
    if let Some(dir) = &a.out {
        handover::private_files::create_dir(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let settings = front_settings(&a.betas, &a.epsilons);
    let cases: Vec<(Box<dyn Scenario>, LearnMask)> =
        a.scenarios.iter().flat_map(|s| a.learn.iter().map(move |&l| (s.build(), l))).collect();
    let bar = a.sweep.progress("front", cases.len() as u64 * settings.len() as u64);
    let started = Instant::now();
    let mut points: Vec<FrontPoint> = Vec::new();
    let mut panels_meta = Vec::new();
    for (scenario, learn) in &cases {
        let base = a.sweep.settings(scenario.as_ref(), *learn, Vec::new());
        let p = pool.install(|| front(scenario.as_ref(), &base, a.sweep.seeds, &settings, &|| bar.inc(1)));
        panels_meta.push((scenario.name(), learn.to_string(), base.alpha, base.iterations));
        points.extend(p);
    }
    bar.finish_and_clear();
    print_table(&points, &panels_meta, &a, started.elapsed().as_secs_f64(), threads)?;
    if let Some(dir) = &a.out {
        super::simulate::write_csv(&dir.join("front.csv"), &points)?;
        let panels: Vec<FrontPanel> = panels_meta
            .iter()
            .map(|(scenario, learn, alpha, iterations)| {
                let of = |sel: &str| -> Vec<&FrontPoint> {
                    points
                        .iter()
                        .filter(|p| p.scenario == *scenario && &p.learn == learn && p.selector == sel)
                        .collect()
                };
                let line = |sel: &str| -> Vec<(f64, f64, String)> {
                    of(sel)
                        .iter()
                        .filter_map(|p| {
                            Some((p.cost_ratio, p.gain?, p.parameter.map_or(String::new(), |x| format!("{x}"))))
                        })
                        .collect()
                };
                let anchor = |sel: &str| of(sel).first().and_then(|p| Some((p.cost_ratio, p.gain?)));
                FrontPanel {
                    title: format!("{scenario}, learning {learn} (α = {alpha}, {iterations} queries)"),
                    lines: vec![
                        ("hybrid (β)".to_string(), line("hybrid")),
                        ("budgeted (ε)".to_string(), line("budgeted")),
                    ],
                    active: anchor("active"),
                    passive: anchor("passive"),
                    target: TARGET,
                }
            })
            .collect();
        let title =
            format!("Comfort–accuracy front: {} seeds × {} trials, mean over seeds", a.sweep.seeds, a.sweep.trials);
        front_plot(&dir.join("front.svg"), &a.figures.style(), &title, &panels)?;
        errln!("wrote {}/front.csv and {}", dir.display(), a.figures.style().file_names("front"));
    }
    Ok(())
}

fn print_table(
    points: &[FrontPoint],
    panels: &[(&str, String, f64, usize)],
    a: &FrontArgs,
    seconds: f64,
    threads: usize,
) -> Result<()> {
    outln!(
        "comfort–accuracy front: seeds {}–{}, {} trials each, {} particles, menu {} ({})",
        a.sweep.seed,
        a.sweep.seed + a.sweep.seeds - 1,
        a.sweep.trials,
        a.sweep.particles,
        a.sweep.menu,
        super::timing(seconds, threads),
    );
    outln!(
        "gain: fraction of active's distance gain over passive at the last iteration; cost: true cost relative to passive's; ratio of the means over seeds [Fieller's 95 % interval; unbounded: active's own gain not told from 0]"
    );
    for (scenario, learn, alpha, iterations) in panels {
        outln!("\n{scenario}, learning {learn} (α = {alpha}, {iterations} queries):");
        outln!(
            "  {:<10} {:>7} {:>10} {:>8} {:>26} {:>24}",
            "selector",
            "β / ε",
            "distance",
            "cost",
            "gain",
            "cost / passive"
        );
        let here: Vec<&FrontPoint> = points.iter().filter(|p| p.scenario == *scenario && &p.learn == learn).collect();
        for p in &here {
            let gain = match (p.gain, p.gain_ci_low, p.gain_ci_high) {
                (Some(g), Some(l), Some(h)) => format!("{:.0} % [{:.0}, {:.0}]", 100.0 * g, 100.0 * l, 100.0 * h),
                (Some(g), _, _) => format!("{:.0} % [unbounded]", 100.0 * g),
                (None, _, _) => "undefined".to_string(),
            };
            let cost = match (p.cost_ratio_ci_low, p.cost_ratio_ci_high) {
                (Some(l), Some(h)) => format!("{:.2} [{l:.2}, {h:.2}]", p.cost_ratio),
                _ => format!("{:.2} [unbounded]", p.cost_ratio),
            };
            outln!(
                "  {:<10} {:>7} {:>10.3} {:>8.3} {:>26} {:>24}",
                p.selector,
                p.parameter.map_or(String::new(), |x| format!("{x}")),
                p.distance,
                p.cost,
                gain,
                cost
            );
        }
        let best = here
            .iter()
            .filter(|p| matches!(p.selector, "hybrid" | "budgeted") && p.cost_ratio <= TARGET.0)
            .filter_map(|p| Some((p, p.gain?)))
            .max_by(|x, y| x.1.total_cmp(&y.1));
        match best {
            Some((p, g)) => outln!(
                "  best within {:.2} × passive's cost: {} {} keeps {:.0} % of active's gain ({} the target of {:.0} %)",
                TARGET.0,
                p.selector,
                p.parameter.map_or(String::new(), |x| format!("{x}")),
                100.0 * g,
                if g >= TARGET.1 { "meets" } else { "misses" },
                100.0 * TARGET.1
            ),
            None => outln!("  no comfort-aware setting stays within {:.2} × passive's cost", TARGET.0),
        }
    }
    Ok(())
}
