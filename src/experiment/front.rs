//! The comfort–accuracy front (the paper's footnote 1): how much of active's accuracy gain
//! over passive a comfort-aware selector keeps, against how much it costs relative to
//! passive, for sweeps of `hybrid`'s β and `budgeted`'s ε.
//!
//! Per seed, every selector runs on the same trials (truth, menu, test set). With D the
//! distance of the estimate to the truth at the last iteration and C the mean true cost of
//! the chosen queries over the iterations (each a mean over the trials):
//! gain = (D_passive − D) / (D_passive − D_active) and cost ratio = C / C_passive. A point is
//! the ratio of the means over seeds, with Fieller's 95 % interval for a ratio of paired means
//! (the seeds are the pairs): a t-interval over the seeds' own ratios explodes whenever one
//! seed's active gains little, and says nothing true about the ratio. Where the denominator's
//! mean is not told from 0 the interval is unbounded and left empty. The gain is undefined
//! when active is not closer to the truth than passive.

use serde::Serialize;

use super::{MetricRow, Scenario, Settings, simulate};
use crate::select::{SelectorKind, Tradeoff};
use crate::stats::fieller_ratio_ci95;

/// One selector setting on the front.
#[derive(Clone, Debug, PartialEq, Serialize, Default)]
pub struct FrontPoint {
    pub scenario: &'static str,
    pub learn: String,
    pub selector: &'static str,
    /// β (hybrid) or ε (budgeted); empty for active and passive.
    pub parameter: Option<f64>,
    pub seeds: usize,
    /// Mean distance to the truth at the last iteration, and mean true cost per query.
    pub distance: f64,
    pub cost: f64,
    /// Fraction of active's distance gain over passive (None: active gains nothing).
    pub gain: Option<f64>,
    /// Fieller's 95 % interval (None: unbounded, or no gain).
    pub gain_ci_low: Option<f64>,
    pub gain_ci_high: Option<f64>,
    /// Cost relative to passive's, with Fieller's 95 % interval.
    pub cost_ratio: f64,
    pub cost_ratio_ci_low: Option<f64>,
    pub cost_ratio_ci_high: Option<f64>,
}

/// (distance at the last iteration, mean true cost over the iterations), averaged over trials.
fn outcome(rows: &[MetricRow], algorithm: &str, iterations: usize) -> (f64, f64) {
    let last: Vec<f64> = rows
        .iter()
        .filter(|r| r.algorithm == algorithm && r.iteration == iterations)
        .map(|r| r.distance_to_truth)
        .collect();
    let costs: Vec<f64> = rows.iter().filter(|r| r.algorithm == algorithm).filter_map(|r| r.true_cost).collect();
    (crate::stats::mean(&last), crate::stats::mean(&costs))
}

/// A selector setting to run: its kind and β / ε.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrontSetting {
    pub kind: SelectorKind,
    pub parameter: Option<f64>,
}

/// active, passive, then hybrid for every β and budgeted for every ε.
pub fn front_settings(betas: &[f64], epsilons: &[f64]) -> Vec<FrontSetting> {
    let mut v = vec![
        FrontSetting { kind: SelectorKind::Active, parameter: None },
        FrontSetting { kind: SelectorKind::Passive, parameter: None },
    ];
    v.extend(betas.iter().map(|&b| FrontSetting { kind: SelectorKind::Hybrid, parameter: Some(b) }));
    v.extend(epsilons.iter().map(|&e| FrontSetting { kind: SelectorKind::Budgeted, parameter: Some(e) }));
    v
}

/// Runs every setting on `seeds` seeds from `base.seed` and returns one point per setting;
/// `progress` is called after every trial of every run.
pub fn front(
    scenario: &dyn Scenario,
    base: &Settings,
    seeds: u64,
    settings: &[FrontSetting],
    progress: &(dyn Fn() + Sync),
) -> Vec<FrontPoint> {
    // outcomes[setting][seed] = (distance, cost)
    let mut outcomes: Vec<Vec<(f64, f64)>> = vec![Vec::new(); settings.len()];
    for k in 0..seeds {
        for (i, f) in settings.iter().enumerate() {
            let tradeoff = match f.kind {
                SelectorKind::Hybrid => Tradeoff { beta: f.parameter.unwrap_or(0.0), ..base.tradeoff },
                SelectorKind::Budgeted => Tradeoff { epsilon: f.parameter.unwrap_or(0.0), ..base.tradeoff },
                _ => base.tradeoff,
            };
            let run = Settings { seed: base.seed + k, algorithms: vec![f.kind], tradeoff, ..base.clone() };
            let rows = simulate(scenario, &run, progress);
            outcomes[i].push(outcome(&rows, f.kind.name(), base.iterations));
        }
    }
    let index = |kind| settings.iter().position(|f| f.kind == kind && f.parameter.is_none());
    let (Some(a), Some(p)) = (index(SelectorKind::Active), index(SelectorKind::Passive)) else {
        return Vec::new();
    };
    let mean_of =
        |v: &[(f64, f64)], pick: fn(&(f64, f64)) -> f64| crate::stats::mean(&v.iter().map(pick).collect::<Vec<_>>());
    let (d_a, d_p) = (mean_of(&outcomes[a], |x| x.0), mean_of(&outcomes[p], |x| x.0));
    let c_p = mean_of(&outcomes[p], |x| x.1);
    settings
        .iter()
        .zip(&outcomes)
        .map(|(f, o)| {
            let (d, c) = (mean_of(o, |x| x.0), mean_of(o, |x| x.1));
            let gain = (d_p - d_a > 0.0).then(|| (d_p - d) / (d_p - d_a));
            // Per seed: passive's distance less this setting's, over passive's less active's.
            let kept: Vec<f64> = outcomes[p].iter().zip(o).map(|(q, x)| q.0 - x.0).collect();
            let active_gain: Vec<f64> = outcomes[p].iter().zip(&outcomes[a]).map(|(q, x)| q.0 - x.0).collect();
            let gain_ci = gain.and(fieller_ratio_ci95(&kept, &active_gain));
            let costs: Vec<f64> = o.iter().map(|x| x.1).collect();
            let passive_costs: Vec<f64> = outcomes[p].iter().map(|x| x.1).collect();
            let cost_ci = fieller_ratio_ci95(&costs, &passive_costs);
            FrontPoint {
                scenario: scenario.name(),
                learn: base.learn.to_string(),
                selector: f.kind.name(),
                parameter: f.parameter,
                seeds: o.len(),
                distance: d,
                cost: c,
                gain,
                gain_ci_low: gain_ci.map(|x| x.0),
                gain_ci_high: gain_ci.map(|x| x.1),
                cost_ratio: c / c_p,
                cost_ratio_ci_low: cost_ci.map(|x| x.0),
                cost_ratio_ci_high: cost_ci.map(|x| x.1),
            }
        })
        .collect()
}
