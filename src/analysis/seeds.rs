//! Dry runs over several seeds: every measure as a mean with a 95 % confidence interval over
//! the seeds' means, and active against passive by paired tests (the same simulated
//! participant, truth and test set run both conditions).

use std::collections::BTreeMap;

use serde::Serialize;

use super::SessionAnalysis;
use crate::stats::{Paired, mean, mean_ci95};

/// The sessions of one seed's dry run.
#[derive(Clone, Debug)]
pub struct SeedRun {
    pub seed: u64,
    pub sessions: Vec<SessionAnalysis>,
}

/// One measure of one condition at one iteration, over seeds.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OverSeeds {
    pub measure: &'static str,
    pub condition: String,
    pub iteration: usize,
    pub seeds: usize,
    /// Participants × seeds.
    pub n: usize,
    pub mean: f64,
    pub ci_low: f64,
    pub ci_high: f64,
}

/// The per-participant value of a measure at an iteration, for one condition.
fn values(s: &SessionAnalysis, condition: &str, measure: &str, iteration: usize) -> Option<f64> {
    let run = s.runs.iter().find(|r| r.condition == condition)?;
    match measure {
        "test_log_likelihood" => run.test_ll_estimate.get(iteration).copied(),
        "distance_to_truth_deg" => {
            let truth = s.start.simulated_truth.as_ref()?;
            let b = run.beliefs.get(iteration)?;
            Some(b.mean.q_star.iter().zip(&truth.q_star).map(|(a, t)| (a - t).to_degrees().powi(2)).sum::<f64>().sqrt())
        }
        _ => None,
    }
}

/// Measures reported per iteration.
pub const SEED_MEASURES: [&str; 2] = ["test_log_likelihood", "distance_to_truth_deg"];

/// The unit of one of [`SEED_MEASURES`].
pub fn measure_unit(measure: &str) -> &'static str {
    if measure.ends_with("_deg") { "deg" } else { "nats" }
}

/// Conditions in the order they first appear.
fn conditions(runs: &[SeedRun]) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for r in runs.iter().flat_map(|s| &s.sessions).flat_map(|s| &s.runs) {
        if !out.contains(&r.condition) {
            out.push(r.condition.clone());
        }
    }
    out
}

fn iterations(runs: &[SeedRun]) -> usize {
    runs.iter().flat_map(|s| &s.sessions).flat_map(|s| &s.runs).map(|r| r.beliefs.len()).max().unwrap_or(0)
}

/// Every measure per condition and iteration, over seeds.
pub fn over_seeds(runs: &[SeedRun]) -> Vec<OverSeeds> {
    let mut out = Vec::new();
    for measure in SEED_MEASURES {
        for c in conditions(runs) {
            for it in 0..iterations(runs) {
                let per_seed: Vec<Vec<f64>> = runs
                    .iter()
                    .map(|r| r.sessions.iter().filter_map(|s| values(s, &c, measure, it)).collect())
                    .collect();
                let means: Vec<f64> = per_seed.iter().filter(|v| !v.is_empty()).map(|v| mean(v)).collect();
                if means.is_empty() {
                    continue;
                }
                let all: Vec<f64> = per_seed.concat();
                let (_, ci_low, ci_high) = if means.len() > 1 { mean_ci95(&means) } else { mean_ci95(&all) };
                out.push(OverSeeds {
                    measure,
                    condition: c.clone(),
                    iteration: it,
                    seeds: means.len(),
                    n: all.len(),
                    mean: mean(&all),
                    ci_low,
                    ci_high,
                });
            }
        }
    }
    out
}

/// The first condition against the second on every measure at every iteration.
pub fn paired_over_seeds(runs: &[SeedRun]) -> Vec<Paired> {
    let cs = conditions(runs);
    let (Some(first), Some(second)) = (cs.first(), cs.get(1)) else { return Vec::new() };
    let mut out = Vec::new();
    for measure in SEED_MEASURES {
        for it in 0..iterations(runs) {
            let groups: Vec<Vec<f64>> = runs
                .iter()
                .map(|r| {
                    r.sessions
                        .iter()
                        .filter_map(|s| Some(values(s, first, measure, it)? - values(s, second, measure, it)?))
                        .collect()
                })
                .collect();
            if let Some(p) = Paired::over_groups(measure, it, first.clone(), second.clone(), &groups) {
                out.push(p);
            }
        }
    }
    out
}

/// The same participants run under two protocols (the same seeds, so the same ids, truths and
/// test sets): per condition, protocol A − protocol B on `measure` at every iteration.
/// `first`/`second` name the condition under each protocol (`"<label_a> <condition>"`).
/// Participants are matched by seed and id; a seed or participant missing from either side
/// is left out.
pub fn paired_across(a: &[SeedRun], b: &[SeedRun], labels: (&str, &str), measure: &'static str) -> Vec<Paired> {
    let mut out = Vec::new();
    for c in conditions(a) {
        for it in 0..iterations(a).min(iterations(b)) {
            let groups: Vec<Vec<f64>> = a
                .iter()
                .filter_map(|ra| Some((ra, b.iter().find(|rb| rb.seed == ra.seed)?)))
                .map(|(ra, rb)| {
                    ra.sessions
                        .iter()
                        .filter_map(|sa| {
                            let sb = rb.sessions.iter().find(|sb| sb.start.participant == sa.start.participant)?;
                            Some(values(sa, &c, measure, it)? - values(sb, &c, measure, it)?)
                        })
                        .collect()
                })
                .collect();
            if let Some(p) =
                Paired::over_groups(measure, it, format!("{} {c}", labels.0), format!("{} {c}", labels.1), &groups)
            {
                out.push(p);
            }
        }
    }
    out
}

/// The share of each condition's training offers that were of each object: per seed, then
/// the mean with a 95 % confidence interval over seeds. condition → object → (mean, low, high).
pub fn object_shares(runs: &[SeedRun]) -> BTreeMap<String, BTreeMap<String, (f64, f64, f64)>> {
    let mut out = BTreeMap::new();
    for c in conditions(runs) {
        let mut objects: Vec<String> = Vec::new();
        for t in runs
            .iter()
            .flat_map(|r| &r.sessions)
            .flat_map(|s| &s.runs)
            .filter(|r| r.condition == c)
            .flat_map(|r| &r.trials)
        {
            if !objects.contains(&t.object) {
                objects.push(t.object.clone());
            }
        }
        let mut per_object = BTreeMap::new();
        for o in objects {
            let shares: Vec<f64> = runs
                .iter()
                .filter_map(|r| {
                    let trials: Vec<_> = r
                        .sessions
                        .iter()
                        .flat_map(|s| &s.runs)
                        .filter(|x| x.condition == c)
                        .flat_map(|x| &x.trials)
                        .collect();
                    (!trials.is_empty())
                        .then(|| trials.iter().filter(|t| t.object == o).count() as f64 / trials.len() as f64)
                })
                .collect();
            per_object.insert(o, mean_ci95(&shares));
        }
        out.insert(c, per_object);
    }
    out
}

/// The height bands of [`objects_by_body`] (m): [low, high), the last one closed.
pub const HEIGHT_BANDS_M: [(f64, f64); 4] = [(1.50, 1.60), (1.60, 1.70), (1.70, 1.80), (1.80, 1.95)];

/// The object finding for one height band and hand: the share of each condition's training
/// offers that were of `object`, per session, summarised over the band's sessions (each a
/// different simulated participant), and the paired difference first − second.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ObjectsByBody {
    /// `1.50–1.60` (m), or `unstated` for sessions run with the protocol's arm lengths.
    pub band: String,
    pub hand: &'static str,
    pub object: String,
    pub sessions: usize,
    pub first: String,
    pub first_share: (f64, f64, f64),
    pub second: String,
    pub second_share: (f64, f64, f64),
    /// first − second: mean, 95 % interval over sessions, two-sided Wilcoxon p.
    pub difference: (f64, f64, f64),
    pub p_value: Option<f64>,
}

fn band_of(height: Option<f64>) -> String {
    let Some(h) = height else { return "unstated".into() };
    let last = HEIGHT_BANDS_M.len() - 1;
    HEIGHT_BANDS_M
        .iter()
        .enumerate()
        .find(|(i, (lo, hi))| h >= *lo && (h < *hi || (*i == last && h <= *hi)))
        .map_or_else(
            || format!("outside {:.2}–{:.2}", HEIGHT_BANDS_M[0].0, HEIGHT_BANDS_M[last].1),
            |(_, (lo, hi))| format!("{lo:.2}–{hi:.2}"),
        )
}

/// The share of a session's training offers under `condition` that were of `object`.
fn share(s: &SessionAnalysis, condition: &str, object: &str) -> Option<f64> {
    let trials: Vec<_> = s.runs.iter().filter(|r| r.condition == condition).flat_map(|r| &r.trials).collect();
    (!trials.is_empty()).then(|| trials.iter().filter(|t| t.object == object).count() as f64 / trials.len() as f64)
}

/// The object finding (which object each condition offers) per height band and hand, over
/// the given sessions (every session of every seed of a dry run, or a study's logs). Bands
/// and hands without a session are left out.
pub fn objects_by_body(sessions: &[&SessionAnalysis]) -> Vec<ObjectsByBody> {
    let mut cs: Vec<&str> = Vec::new();
    for r in sessions.iter().flat_map(|s| &s.runs) {
        if !cs.contains(&r.condition.as_str()) {
            cs.push(&r.condition);
        }
    }
    let (Some(&first), Some(&second)) = (cs.first(), cs.get(1)) else { return Vec::new() };
    let mut objects: Vec<String> = Vec::new();
    for t in sessions.iter().flat_map(|s| &s.runs).flat_map(|r| &r.trials) {
        if !objects.contains(&t.object) {
            objects.push(t.object.clone());
        }
    }
    let mut bands: Vec<String> = HEIGHT_BANDS_M.iter().map(|(lo, hi)| format!("{lo:.2}–{hi:.2}")).collect();
    for s in sessions {
        let b = band_of(s.body.height_m);
        if !bands.contains(&b) {
            bands.push(b);
        }
    }
    let mut out = Vec::new();
    for band in &bands {
        for hand in [crate::kinematics::Hand::Right, crate::kinematics::Hand::Left] {
            let group: Vec<&SessionAnalysis> =
                sessions.iter().copied().filter(|s| band_of(s.body.height_m) == *band && s.body.hand == hand).collect();
            if group.is_empty() {
                continue;
            }
            for object in &objects {
                let a: Vec<f64> = group.iter().filter_map(|s| share(s, first, object)).collect();
                let b: Vec<f64> = group.iter().filter_map(|s| share(s, second, object)).collect();
                let d: Vec<f64> =
                    group.iter().filter_map(|s| Some(share(s, first, object)? - share(s, second, object)?)).collect();
                let Some(g) = Paired::over_groups("share", 0, first, second, &[d]) else { continue };
                out.push(ObjectsByBody {
                    band: band.clone(),
                    hand: hand.name(),
                    object: object.clone(),
                    sessions: group.len(),
                    first: first.to_string(),
                    first_share: mean_ci95(&a),
                    second: second.to_string(),
                    second_share: mean_ci95(&b),
                    difference: (g.mean_difference, g.ci_low, g.ci_high),
                    p_value: g.p_value,
                });
            }
        }
    }
    out
}
