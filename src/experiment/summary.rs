//! Mean and standard error per algorithm × iteration × measure.

use super::MetricRow;

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
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SummaryRow {
    pub algorithm: &'static str,
    pub iteration: usize,
    pub measure: &'static str,
    pub n: usize,
    pub mean: f64,
    /// Standard error of the mean (sample standard deviation / √n; 0 for n = 1).
    pub se: f64,
}

/// Summarises rows in the order algorithms and iterations first appear.
pub fn summarise(rows: &[MetricRow]) -> Vec<SummaryRow> {
    let mut keys: Vec<(&'static str, usize)> = Vec::new();
    for r in rows {
        if !keys.contains(&(r.algorithm, r.iteration)) {
            keys.push((r.algorithm, r.iteration));
        }
    }
    let mut out = Vec::new();
    for (algorithm, iteration) in keys {
        for measure in MEASURES {
            let v: Vec<f64> = rows
                .iter()
                .filter(|r| r.algorithm == algorithm && r.iteration == iteration)
                .filter_map(|r| value(r, measure))
                .collect();
            if v.is_empty() {
                continue;
            }
            let n = v.len();
            let mean = v.iter().sum::<f64>() / n as f64;
            let se = if n > 1 {
                (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt() / (n as f64).sqrt()
            } else {
                0.0
            };
            out.push(SummaryRow { algorithm, iteration, measure, n, mean, se });
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
