//! Mean and standard error per algorithm × iteration × measure.

use super::MetricRow;
use crate::stats::{Paired, mean, mean_ci95, standard_error};

/// The measures summarised, as named in metrics.csv.
pub const MEASURES: [&str; 6] =
    ["density_at_truth", "log_density_at_truth", "distance_to_truth", "test_log_likelihood", "true_cost", "entropy"];

fn value(row: &MetricRow, measure: &str) -> Option<f64> {
    match measure {
        "density_at_truth" => Some(row.density_at_truth),
        "log_density_at_truth" => Some(row.log_density_at_truth),
        "distance_to_truth" => Some(row.distance_to_truth),
        "test_log_likelihood" => Some(row.test_log_likelihood),
        "true_cost" => row.true_cost,
        "entropy" => Some(row.entropy),
        _ => None,
    }
}

/// One line of summary.csv (tidy: one measure per row).
#[derive(Clone, Debug, PartialEq, serde::Serialize, Default)]
pub struct SummaryRow {
    pub algorithm: &'static str,
    pub iteration: usize,
    pub measure: &'static str,
    /// Values: trials × seeds.
    pub n: usize,
    pub mean: f64,
    /// Standard error of the mean over all values (sample standard deviation / √n; 0 for n = 1).
    pub se: f64,
    pub seeds: usize,
    /// 95 % confidence interval of the mean: over the per-seed means (Student's t, seeds − 1
    /// degrees of freedom) when there are several seeds, else over the trials.
    pub ci_low: f64,
    pub ci_high: f64,
}

/// The seeds of rows, in order of appearance.
fn seeds_of(rows: &[MetricRow]) -> Vec<u64> {
    let mut seeds = Vec::new();
    for r in rows {
        if !seeds.contains(&r.seed) {
            seeds.push(r.seed);
        }
    }
    seeds
}

/// Summarises rows in the order algorithms and iterations first appear.
pub fn summarise(rows: &[MetricRow]) -> Vec<SummaryRow> {
    let mut keys: Vec<(&'static str, usize)> = Vec::new();
    for r in rows {
        if !keys.contains(&(r.algorithm, r.iteration)) {
            keys.push((r.algorithm, r.iteration));
        }
    }
    let seeds = seeds_of(rows);
    let mut out = Vec::new();
    for (algorithm, iteration) in keys {
        let these: Vec<&MetricRow> =
            rows.iter().filter(|r| r.algorithm == algorithm && r.iteration == iteration).collect();
        for measure in MEASURES {
            let v: Vec<f64> = these.iter().filter_map(|r| value(r, measure)).collect();
            if v.is_empty() {
                continue;
            }
            let (_, mut ci_low, mut ci_high) = mean_ci95(&v);
            if seeds.len() > 1 {
                let per_seed: Vec<f64> = seeds
                    .iter()
                    .map(|&seed| {
                        mean(
                            &these
                                .iter()
                                .filter(|r| r.seed == seed)
                                .filter_map(|r| value(r, measure))
                                .collect::<Vec<_>>(),
                        )
                    })
                    .collect();
                (_, ci_low, ci_high) = mean_ci95(&per_seed);
            }
            out.push(SummaryRow {
                algorithm,
                iteration,
                measure,
                n: v.len(),
                mean: mean(&v),
                se: standard_error(&v),
                seeds: seeds.len(),
                ci_low,
                ci_high,
            });
        }
    }
    out
}

/// Paired tests of every algorithm against `against` on `measures` at `iteration`.
pub fn paired_tests(
    rows: &[MetricRow],
    against: &'static str,
    iteration: usize,
    measures: &[&'static str],
) -> Vec<Paired> {
    let seeds = seeds_of(rows);
    let mut algorithms: Vec<&'static str> = Vec::new();
    for r in rows {
        if !algorithms.contains(&r.algorithm) && r.algorithm != against {
            algorithms.push(r.algorithm);
        }
    }
    let at = |alg: &str, seed: u64, m: &str| -> Vec<(usize, f64)> {
        rows.iter()
            .filter(|r| r.algorithm == alg && r.iteration == iteration && r.seed == seed)
            .filter_map(|r| value(r, m).map(|v| (r.trial, v)))
            .collect()
    };
    let mut out = Vec::new();
    for &measure in measures {
        for &algorithm in &algorithms {
            let groups: Vec<Vec<f64>> = seeds
                .iter()
                .map(|&seed| {
                    let base = at(against, seed, measure);
                    at(algorithm, seed, measure)
                        .into_iter()
                        .filter_map(|(t, v)| base.iter().find(|(bt, _)| *bt == t).map(|(_, b)| v - b))
                        .collect()
                })
                .collect();
            // The same truth, menu and test set (trial and seed): the differences are paired.
            if let Some(p) = Paired::over_groups(measure, iteration, algorithm, against, &groups) {
                out.push(p);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(iteration: usize, d: f64) -> MetricRow {
        MetricRow {
            algorithm: "active",
            seed: 0,
            trial: 0,
            iteration,
            density_at_truth: 1.0,
            log_density_at_truth: 0.0,
            distance_to_truth: d,
            test_log_likelihood: -1.0,
            true_cost: (iteration > 0).then_some(2.0),
            query: None,
            entropy: 0.0,
        }
    }

    #[test]
    fn mean_and_standard_error_by_hand() {
        let rows = [row(1, 1.0), row(1, 3.0), row(0, 5.0)];
        let s = summarise(&rows);
        let d = s.iter().find(|r| r.iteration == 1 && r.measure == "distance_to_truth").unwrap();
        assert_eq!((d.n, d.mean), (2, 2.0));
        assert!((d.se - 1.0).abs() < 1e-15, "sd √2, se √2/√2 = 1");
        assert!(!s.iter().any(|r| r.iteration == 0 && r.measure == "true_cost"), "no cost before a query");
    }
}
