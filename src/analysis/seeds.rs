//! Dry runs over several seeds: every measure as a mean with a 95 % confidence interval over
//! the seeds' means, and active against passive by paired tests (the same simulated
//! participant, truth and test set run both conditions).

use std::collections::BTreeMap;

use serde::Serialize;

use super::SessionAnalysis;
use crate::session::BeliefSummary;
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
        "distance_to_truth_deg" => distance_to_truth_deg(s, run.beliefs.get(iteration)?),
        _ => None,
    }
}

/// The distance (degrees) of a belief's posterior mean q* to the simulated participant's
/// true q*; `None` for a real participant.
pub fn distance_to_truth_deg(s: &SessionAnalysis, belief: &BeliefSummary) -> Option<f64> {
    let truth = s.start.simulated_truth.as_ref()?;
    Some(belief.mean.q_star.iter().zip(&truth.q_star).map(|(a, t)| (a - t).to_degrees().powi(2)).sum::<f64>().sqrt())
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

/// |posterior mean − truth| of q*'s joint `j` in degrees, for one condition at one iteration.
fn joint_error(s: &SessionAnalysis, condition: &str, iteration: usize, j: usize) -> Option<f64> {
    let truth = s.start.simulated_truth.as_ref()?.q_star.get(j)?;
    let b = s.runs.iter().find(|r| r.condition == condition)?.beliefs.get(iteration)?;
    Some((b.mean.q_star.get(j)? - truth).abs().to_degrees())
}

/// One joint's error of the posterior mean's q* at the end of training, in dry runs.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct JointError {
    /// The joint, 1-based (q*1 … q*7, as every screen and table numbers them).
    pub joint: usize,
    /// The last iteration.
    pub iteration: usize,
    /// Mean |error| (degrees) of the prior's mean (iteration 0).
    pub prior: f64,
    /// Mean |error| (degrees) per condition at `iteration`.
    pub conditions: Vec<(String, f64)>,
    /// The first condition − the second at `iteration`, paired by participant.
    pub paired: Option<Paired>,
}

/// Per joint of q*, how far the posterior mean ends from the simulated truth: where the
/// 7-D distance's difference between conditions comes from. Joints whose prior and
/// posterior means agree with the truth (q* not learned) are left out.
pub fn joint_errors(runs: &[SeedRun]) -> Vec<JointError> {
    let cs = conditions(runs);
    let Some(iteration) = iterations(runs).checked_sub(1) else { return Vec::new() };
    let sessions: Vec<&SessionAnalysis> = runs.iter().flat_map(|r| &r.sessions).collect();
    let joints =
        sessions.iter().filter_map(|s| Some(s.start.simulated_truth.as_ref()?.q_star.len())).max().unwrap_or(0);
    let mut out = Vec::new();
    for j in 0..joints {
        let at =
            |c: &str, it: usize| -> Vec<f64> { sessions.iter().filter_map(|s| joint_error(s, c, it, j)).collect() };
        let Some(first) = cs.first() else { break };
        let prior = at(first, 0);
        if prior.is_empty() || prior.iter().all(|e| *e < 1e-9) && at(first, iteration).iter().all(|e| *e < 1e-9) {
            continue;
        }
        let paired = cs.get(1).and_then(|second| {
            let groups: Vec<Vec<f64>> = runs
                .iter()
                .map(|r| {
                    r.sessions
                        .iter()
                        .filter_map(|s| {
                            Some(joint_error(s, first, iteration, j)? - joint_error(s, second, iteration, j)?)
                        })
                        .collect()
                })
                .collect();
            Paired::over_groups("abs_error_deg", iteration, first.clone(), second.clone(), &groups)
        });
        out.push(JointError {
            joint: j + 1,
            iteration,
            prior: mean(&prior),
            conditions: cs.iter().map(|c| (c.clone(), mean(&at(c, iteration)))).collect(),
            paired,
        });
    }
    out
}

/// How often one condition's logged 90 % credible intervals of q*
/// ([`crate::belief::CREDIBLE`]) held the simulated participants' true value at one
/// iteration: per joint, over every participant of every seed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Coverage {
    pub condition: String,
    pub iteration: usize,
    /// Per joint: (intervals holding the truth, intervals). A joint whose interval is a
    /// point (q* not learned) counts for nothing.
    pub per_joint: Vec<(usize, usize)>,
}

impl Coverage {
    /// Intervals holding the truth, and intervals, over every joint.
    pub fn total(&self) -> (usize, usize) {
        self.per_joint.iter().fold((0, 0), |(h, n), &(a, b)| (h + a, n + b))
    }

    /// The share of intervals holding the truth (NaN without any).
    pub fn share(&self) -> f64 {
        let (held, of) = self.total();
        held as f64 / of as f64
    }
}

/// The coverage of every condition's 90 % credible intervals of q* at every iteration, in
/// dry runs (sessions with a simulated truth). A calibrated learner's share is 0.90 when the
/// participants are drawn from its prior; from a narrower population it is higher.
pub fn coverage(runs: &[SeedRun]) -> Vec<Coverage> {
    let mut out = Vec::new();
    for c in conditions(runs) {
        for iteration in 0..iterations(runs) {
            let mut per_joint: Vec<(usize, usize)> = Vec::new();
            for s in runs.iter().flat_map(|r| &r.sessions) {
                let (Some(truth), Some(b)) = (
                    s.start.simulated_truth.as_ref(),
                    s.runs.iter().find(|r| r.condition == c).and_then(|r| r.beliefs.get(iteration)),
                ) else {
                    continue;
                };
                per_joint.resize(per_joint.len().max(truth.q_star.len()), (0, 0));
                for (j, ((t, lo), hi)) in truth.q_star.iter().zip(&b.ci_low.q_star).zip(&b.ci_high.q_star).enumerate() {
                    if lo < hi {
                        per_joint[j].1 += 1;
                        per_joint[j].0 += usize::from((lo..=hi).contains(&t));
                    }
                }
            }
            if per_joint.iter().any(|&(_, n)| n > 0) {
                out.push(Coverage { condition: c.clone(), iteration, per_joint });
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
