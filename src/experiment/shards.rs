//! A run split into shards for a cluster's batch scheduler (`simulate … --shard K/N`), and
//! the shards merged into what the whole run writes (`simulate … --merge DIR…`).
//!
//! A unit is one trial of one seed; every unit's rows depend only on the run's settings, its
//! seed and its trial, so a shard computes exactly the rows the whole run has for its units.
//! Each shard directory holds its `metrics.csv` and a manifest naming the run (its settings,
//! as the command checked them), the version that computed it, the shard, a SHA-256 of every
//! file it wrote and its own computing time; a merge refuses shards of another run or
//! version, a file changed since, and a set of shards with one missing or doubled.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::MetricRow;
use crate::select::SelectorKind;

/// The manifest's file name in a shard directory.
pub const SHARD_MANIFEST: &str = "shard.json";

/// What a shard directory says of itself.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShardManifest {
    /// The run: scenario, settings and seeds, as one string (equal for every shard of a run).
    pub run: String,
    /// The handover version that computed it (the package version).
    pub version: String,
    /// This shard (0-based) and the number of shards.
    pub shard: usize,
    pub of: usize,
    /// Rows in its metrics.csv.
    pub rows: usize,
    /// The SHA-256 (hex) of each file it wrote, by name.
    pub files: BTreeMap<String, String>,
    /// Its own computing time (s) and threads.
    pub seconds: f64,
    pub threads: usize,
}

/// The (seed offset, trial) units of a run of `seeds` seeds × `trials` trials that shard
/// `k` of `n` runs: unit u = seed · trials + trial when u mod n = k, so that shards are
/// disjoint, together whole, and within one trial of each other in size.
pub fn shard_units(seeds: u64, trials: usize, k: usize, n: usize) -> Vec<(u64, usize)> {
    (0..seeds)
        .flat_map(|seed| (0..trials).map(move |t| (seed, t)))
        .enumerate()
        .filter(|(u, _)| u % n == k)
        .map(|(_, unit)| unit)
        .collect()
}

/// A metrics.csv row as read back (the algorithm by name).
#[derive(Deserialize)]
struct MetricRecord {
    algorithm: String,
    seed: u64,
    trial: usize,
    iteration: usize,
    density_at_truth: f64,
    log_density_at_truth: f64,
    distance_to_truth: f64,
    test_log_likelihood: f64,
    true_cost: Option<f64>,
    query: Option<usize>,
    entropy: f64,
}

/// Reads a shard's metrics.csv (at most `max_rows` rows: the run's own size is the budget).
pub fn read_metrics(path: &Path, max_rows: usize) -> Result<Vec<MetricRow>, String> {
    let records: Vec<MetricRecord> = crate::input_file::read_csv_rows(path, max_rows)?;
    let mut rows = Vec::with_capacity(records.len());
    for (i, r) in records.into_iter().enumerate() {
        let algorithm = SelectorKind::ALL.iter().map(|k| k.name()).find(|n| *n == r.algorithm).ok_or_else(|| {
            format!("{}: row {}: algorithm '{}' is not a selector", path.display(), i + 2, r.algorithm)
        })?;
        rows.push(MetricRow {
            algorithm,
            seed: r.seed,
            trial: r.trial,
            iteration: r.iteration,
            density_at_truth: r.density_at_truth,
            log_density_at_truth: r.log_density_at_truth,
            distance_to_truth: r.distance_to_truth,
            test_log_likelihood: r.test_log_likelihood,
            true_cost: r.true_cost,
            query: r.query,
            entropy: r.entropy,
        });
    }
    Ok(rows)
}

/// Puts merged rows in the whole run's order: seed, trial, the run's algorithm order,
/// iteration.
pub fn merge_order(rows: &mut [MetricRow], algorithms: &[SelectorKind]) {
    let rank = |name: &str| algorithms.iter().position(|k| k.name() == name).unwrap_or(usize::MAX);
    rows.sort_by_key(|r| (r.seed, r.trial, rank(r.algorithm), r.iteration));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_are_disjoint_and_whole() {
        for n in [1, 2, 3, 7, 40] {
            let mut all: Vec<(u64, usize)> = (0..n).flat_map(|k| shard_units(3, 5, k, n)).collect();
            let sizes: Vec<usize> = (0..n).map(|k| shard_units(3, 5, k, n).len()).collect();
            all.sort();
            let whole: Vec<(u64, usize)> = (0..3).flat_map(|s| (0..5).map(move |t| (s, t))).collect();
            assert_eq!(all, whole, "{n} shards");
            assert!(sizes.iter().max().unwrap() - sizes.iter().min().unwrap() <= 1, "{sizes:?}");
        }
    }
}
