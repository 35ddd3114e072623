//! What measuring the arm buys (the paper's footnote 2): the same trials learned from the region
//! taken, from the configuration, and from the configuration measured with Gaussian noise of
//! several σ, by each selector, over seeds.
//!
//! Every observation model runs on the same trials (truth, menu, test set and starting belief
//! depend only on the seed and the trial), so its difference from the region's is paired by
//! seed and trial. The learner that measures is compared with the one that sees only the
//! region, because that is what a lab has without a measuring system.

use serde::Serialize;

use super::{MetricRow, Scenario, Settings, SimObservation, simulate};
use crate::stats::{Paired, mean, mean_ci95};

/// The measures compared, as named in metrics.csv.
pub const OBSERVATION_MEASURES: [&str; 2] = ["distance_to_truth", "test_log_likelihood"];

/// The observation models of a sweep: the region, the configuration, then measured at every
/// σ (degrees) in the order given.
pub fn observation_settings(sigmas_deg: &[f64]) -> Vec<SimObservation> {
    let mut v = vec![SimObservation::Region, SimObservation::Configuration];
    v.extend(sigmas_deg.iter().map(|d| SimObservation::Measured { sigma_rad: d.to_radians() }));
    v
}

/// The model's name and σ (degrees) for the CSV, and a label for tables and legends.
pub fn observation_label(o: SimObservation) -> (&'static str, Option<f64>, String) {
    match o {
        SimObservation::Region => ("region", None, "region".to_string()),
        SimObservation::Configuration => ("configuration", None, "configuration".to_string()),
        SimObservation::Measured { sigma_rad } => {
            let deg = sigma_rad.to_degrees();
            ("measured", Some(deg), format!("measured σ = {deg}°"))
        }
    }
}

/// One measure of one observation model and selector at one iteration (tidy: one measure per
/// row).
#[derive(Clone, Debug, PartialEq, Serialize, Default)]
pub struct ObservationRow {
    pub scenario: &'static str,
    pub learn: String,
    /// region, configuration or measured.
    pub observation: &'static str,
    /// The measurement noise per joint (measured only), degrees.
    pub sigma_deg: Option<f64>,
    pub algorithm: &'static str,
    pub iteration: usize,
    pub measure: &'static str,
    pub seeds: usize,
    /// Trials × seeds.
    pub n: usize,
    pub mean: f64,
    /// 95 % interval of the mean over the seeds' means (Student's t).
    pub ci_low: f64,
    pub ci_high: f64,
    /// Paired difference from the region observation (same selector, seed, trial and
    /// iteration): its mean, 95 % interval over the seeds' means, and the two-sided Wilcoxon
    /// signed-rank p over every pair. Empty for the region itself, and for iteration 0 (the
    /// prior, the same for every model).
    pub minus_region: Option<f64>,
    pub minus_region_ci_low: Option<f64>,
    pub minus_region_ci_high: Option<f64>,
    pub minus_region_p: Option<f64>,
}

fn value(r: &MetricRow, measure: &str) -> f64 {
    match measure {
        "distance_to_truth" => r.distance_to_truth,
        _ => r.test_log_likelihood,
    }
}

/// Runs every observation model on `seeds` seeds from `base.seed` with `base.algorithms`, and
/// summarises; `progress` is called after every trial of every run.
pub fn observation_sweep(
    scenario: &dyn Scenario,
    base: &Settings,
    seeds: u64,
    observations: &[SimObservation],
    progress: &(dyn Fn() + Sync),
) -> Vec<ObservationRow> {
    let runs: Vec<Vec<MetricRow>> = observations
        .iter()
        .map(|&observation| {
            (0..seeds)
                .flat_map(|k| {
                    simulate(scenario, &Settings { seed: base.seed + k, observation, ..base.clone() }, progress)
                })
                .collect()
        })
        .collect();
    let region = observations.iter().position(|o| *o == SimObservation::Region);
    let seed_list: Vec<u64> = (0..seeds).map(|k| base.seed + k).collect();
    let mut out = Vec::new();
    for (o, rows) in observations.iter().zip(&runs) {
        let (name, sigma_deg, _) = observation_label(*o);
        for &algorithm in &base.algorithms {
            for iteration in 0..=base.iterations {
                for measure in OBSERVATION_MEASURES {
                    let at = |rows: &[MetricRow], seed: u64| -> Vec<(usize, f64)> {
                        rows.iter()
                            .filter(|r| r.algorithm == algorithm.name() && r.iteration == iteration && r.seed == seed)
                            .map(|r| (r.trial, value(r, measure)))
                            .collect()
                    };
                    let per_seed: Vec<Vec<(usize, f64)>> = seed_list.iter().map(|&s| at(rows, s)).collect();
                    let all: Vec<f64> = per_seed.iter().flatten().map(|x| x.1).collect();
                    let seed_means: Vec<f64> =
                        per_seed.iter().map(|v| mean(&v.iter().map(|x| x.1).collect::<Vec<_>>())).collect();
                    let (_, ci_low, ci_high) = mean_ci95(&seed_means);
                    let paired = region.filter(|&r| iteration > 0 && observations[r] != *o).and_then(|r| {
                        let groups: Vec<Vec<f64>> = seed_list
                            .iter()
                            .zip(&per_seed)
                            .map(|(&seed, mine)| {
                                let theirs = at(&runs[r], seed);
                                mine.iter()
                                    .filter_map(|(t, v)| theirs.iter().find(|x| x.0 == *t).map(|x| v - x.1))
                                    .collect()
                            })
                            .collect();
                        Paired::over_groups(measure, iteration, name, "region", &groups)
                    });
                    out.push(ObservationRow {
                        scenario: scenario.name(),
                        learn: base.learn.to_string(),
                        observation: name,
                        sigma_deg,
                        algorithm: algorithm.name(),
                        iteration,
                        measure,
                        seeds: seed_list.len(),
                        n: all.len(),
                        mean: mean(&all),
                        ci_low,
                        ci_high,
                        minus_region: paired.as_ref().map(|g| g.mean_difference),
                        minus_region_ci_low: paired.as_ref().map(|g| g.ci_low),
                        minus_region_ci_high: paired.as_ref().map(|g| g.ci_high),
                        minus_region_p: paired.as_ref().and_then(|g| g.p_value),
                    });
                }
            }
        }
    }
    out
}

/// The first iteration at which a model's mean distance to λ* is at most the region's at the
/// last iteration (same scenario and selector), if any: the queries it needs to learn what the
/// region learns in all of them.
pub fn iterations_to_match_region(rows: &[ObservationRow], of: &ObservationRow) -> Option<usize> {
    let distance = |r: &&ObservationRow| {
        r.scenario == of.scenario
            && r.learn == of.learn
            && r.algorithm == of.algorithm
            && r.measure == "distance_to_truth"
    };
    let last = rows.iter().filter(distance).map(|r| r.iteration).max()?;
    let target = rows.iter().filter(distance).find(|r| r.observation == "region" && r.iteration == last)?.mean;
    rows.iter()
        .filter(distance)
        .filter(|r| r.observation == of.observation && r.sigma_deg == of.sigma_deg && r.mean <= target)
        .map(|r| r.iteration)
        .min()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::Planar2;
    use crate::select::SelectorKind;

    #[test]
    fn every_model_runs_on_the_same_trials_and_is_paired_with_the_region() {
        let scenario = Planar2::default();
        let base = Settings {
            learn: crate::ergo::LearnMask::QStar,
            trials: 3,
            menu: 4,
            iterations: 2,
            test_size: 20,
            particles: 150,
            alpha: 10.0,
            algorithms: vec![SelectorKind::Active, SelectorKind::Passive],
            seed: 5,
            tradeoff: Default::default(),
            numerics: Default::default(),
            estimate: crate::belief::Estimate::Mean,
            observation: SimObservation::Configuration,
            precision: Default::default(),
        };
        let rows = observation_sweep(&scenario, &base, 2, &observation_settings(&[5.0]), &|| {});
        // 3 models × 2 selectors × 3 iterations × 2 measures.
        assert_eq!(rows.len(), 36);
        for r in &rows {
            assert_eq!((r.seeds, r.n), (2, 6), "{r:?}");
            assert!(r.mean.is_finite() && r.ci_low <= r.mean && r.mean <= r.ci_high, "{r:?}");
            let paired = r.observation != "region" && r.iteration > 0;
            assert_eq!(r.minus_region.is_some(), paired, "{r:?}");
        }
        // Iteration 0 is the prior on the same test set: the same for every model.
        for measure in OBSERVATION_MEASURES {
            let prior: Vec<f64> =
                rows.iter().filter(|r| r.iteration == 0 && r.measure == measure).map(|r| r.mean).collect();
            assert!(prior.windows(2).all(|w| w[0] == w[1]), "{measure}: {prior:?}");
        }
        // The region reaches its own last distance at the last iteration at the latest.
        let region_last =
            rows.iter().find(|r| r.observation == "region" && r.algorithm == "active" && r.iteration == 2).unwrap();
        assert!(iterations_to_match_region(&rows, region_last).is_some_and(|i| i <= 2));
    }
}
