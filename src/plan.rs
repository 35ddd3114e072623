//! Planning a study before recruiting (`handover plan`): whole studies of simulated
//! participants, each session run by the session's own code and analysed as `analyze`
//! analyses a log, and the share of studies that find the protocol's effect (its power).
//!
//! A study of N participants is participants 0..N of that study's draws (bodies, λ, answers,
//! counterbalancing slot alternating), so the studies of different sizes are nested: study
//! k at N = 20 holds study k at N = 10. The sizes' powers are then compared on the same
//! people, and one study's sessions are simulated once for every size.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use serde::{Deserialize, Serialize};

use crate::analysis::{Analyser, SeedRun, SessionAnalysis, measure_unit, object_shares, paired_over_seeds};
use crate::derive_seed;
use crate::dryrun::{BodyPopulation, DryRunPlan, plan_from, simulated_seconds};
use crate::protocol::{Body, Study, for_body};
use crate::record::{LogContents, ReplayStep};
use crate::session::{Session, Stamped};

/// What a plan's studies' seeds are derived for.
const PURPOSE_STUDY: u64 = 401;

/// The log time a simulated session starts at (2026-01-01T00:00:00Z): sessions kept in
/// memory are stamped as a dry run stamps them, from a fixed start.
const START_NS: u64 = 1_767_225_600_000_000_000;

/// The seed of study `index` of a plan with seed `seed`.
pub fn study_seed(seed: u64, index: usize) -> u64 {
    derive_seed(seed, index as u64, PURPOSE_STUDY)
}

/// Why a simulated study could not be run.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    #[error("simulated participant {participant} of study {study}: {message}")]
    Participant { study: usize, participant: usize, message: String },
}

/// The protocol fitted to each body a plan has met, shared by its studies: bodies are drawn
/// to the millimetre with one of two hands, so a plan's thousands of simulated people have a
/// few hundred distinct bodies, and fitting one (the inverse kinematics of every query) is
/// about a seventh of a session's time. A fitted protocol depends on the body alone, so
/// the numbers are those of fitting every person anew.
#[derive(Default)]
pub struct FittedBodies {
    fitted: Mutex<HashMap<BodyKey, (String, Arc<Study>)>>,
}

/// A body as the cache tells bodies apart: the bits of its height (m) and its hand's name.
type BodyKey = (Option<u64>, &'static str);

/// Bodies kept at most (a fitted default protocol holds about 1 MB of feasible sets).
const FITTED_BODIES: usize = 2048;

impl FittedBodies {
    /// The protocol `text` fitted to `body`: its text, as a log embeds it, and its study.
    pub fn fit(&self, text: &str, study: &Study, body: Body) -> Result<(String, Arc<Study>), String> {
        let key = (body.height_m.map(f64::to_bits), body.hand.name());
        if let Some(hit) = self.fitted.lock().unwrap_or_else(|e| e.into_inner()).get(&key) {
            return Ok(hit.clone());
        }
        // Fitted outside the lock: two threads may fit the same body once each, to the same.
        let (text, fitted) = for_body(text, &study.source_name, body).map_err(|e| e.to_string())?;
        let fitted = (text, Arc::new(fitted));
        let mut map = self.fitted.lock().unwrap_or_else(|e| e.into_inner());
        if map.len() < FITTED_BODIES {
            map.insert(key, fitted.clone());
        }
        Ok(fitted)
    }
}

/// Simulated participant `index` of a study with seed `seed`: the protocol fitted to the
/// participant's body (its text, as a log embeds it) and the session's plan. The person's λ
/// is drawn from the protocol's population, or with `from_prior` from the robot's prior.
pub fn participant(
    text: &str,
    study: &Study,
    seed: u64,
    index: usize,
    from_prior: bool,
    bodies: &FittedBodies,
) -> Result<(String, Arc<Study>, DryRunPlan), String> {
    let body = BodyPopulation::default().draw(seed, index);
    let (text, fitted) = bodies.fit(text, study, body)?;
    let people = if from_prior { fitted.prior_population() } else { fitted.population() };
    let p = plan_from(&fitted, &people, seed, index, None, crate::analysis::rfc3339_ms(START_NS));
    Ok((text, fitted, p))
}

/// A simulated participant's whole session, driven by the session's own code and kept in
/// memory as the log `analyze` would read (stamped as a dry run without a pace stamps it);
/// `visit` sees every state as a replay of that log would ([`replay_with`]'s order).
/// With `plan_only` the session computes only what a plan reports ([`Session::for_plan`]).
///
/// [`replay_with`]: crate::record::replay_with
pub(crate) fn drive_in_memory(
    text: String,
    study: Arc<Study>,
    p: &DryRunPlan,
    plan_only: bool,
    mut visit: impl FnMut(&Session, Option<ReplayStep>),
) -> Result<(LogContents, Session), String> {
    let start = p.start.clone();
    let made = if plan_only { Session::for_plan(study, start) } else { Session::new(study, start) };
    let mut session = made.map_err(|e| e.to_string())?;
    visit(&session, None);
    let mut events = Vec::new();
    let mut time_ns = START_NS;
    while let Some(event) = p.participant.respond(&session) {
        time_ns += simulated_seconds(&event) * 1_000_000_000;
        let stamped = Stamped { time_ns, event };
        let applied = session.apply(&stamped.event).map_err(|e| e.to_string())?;
        visit(&session, Some((events.len() + 1, &stamped, &applied)));
        events.push(stamped);
    }
    let log = LogContents {
        path: PathBuf::from(format!("(in memory) {}", p.start.participant)),
        protocol_text: text,
        start: p.start.clone(),
        start_time_ns: START_NS,
        format: crate::record::LOG_FORMAT,
        events,
        messages: Vec::new(),
        finished: true,
        cut_tail: false,
        integrity: Vec::new(),
    };
    Ok((log, session))
}

/// [`drive_in_memory`] without looking on: the log alone.
pub fn session_in_memory(text: String, study: Arc<Study>, p: &DryRunPlan) -> Result<LogContents, String> {
    drive_in_memory(text, study, p, false, |_, _| {}).map(|(log, _)| log)
}

/// Study `index` of a plan: its first `participants` simulated sessions, each analysed as it
/// is driven, as `analyze` analyses its log (without the posterior predictive and the MAP
/// estimates, which the plan does not use). `from_prior`: as [`participant`].
pub fn simulate_study(
    text: &str,
    study: &Study,
    seed: u64,
    index: usize,
    participants: usize,
    from_prior: bool,
    bodies: &FittedBodies,
) -> Result<Vec<SessionAnalysis>, PlanError> {
    let s = study_seed(seed, index);
    (0..participants)
        .map(|i| {
            let err = |message: String| PlanError::Participant { study: index, participant: i + 1, message };
            let (text, fitted, p) = participant(text, study, s, i, from_prior, bodies).map_err(err)?;
            let mut analyser = Analyser::new(START_NS, false, false);
            let (log, session) =
                drive_in_memory(text, Arc::clone(&fitted), &p, true, |s, step| analyser.visit(s, step)).map_err(err)?;
            analyser.finish(&session, &fitted, &log).map_err(|e| err(e.to_string()))
        })
        .collect()
}

/// A session's length in log time (s): what the stated times per action add up to.
pub fn session_seconds(log: &LogContents) -> f64 {
    log.events.last().map_or(0.0, |e| (e.time_ns - log.start_time_ns) as f64 / 1e9)
}

/// One study at one size: the paired comparison of the two conditions on one measure at one
/// iteration (`studies.csv`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct StudyRow {
    pub study: usize,
    pub participants: usize,
    pub measure: String,
    pub iteration: usize,
    /// Differences are first − second, per participant.
    pub first: String,
    pub second: String,
    pub mean_difference: f64,
    /// Two-sided Wilcoxon signed-rank p over the participants; empty when every difference
    /// is zero (the test is not defined, and the study finds nothing).
    pub p_value: Option<f64>,
}

/// One study at one size: the share of a condition's training offers that were of an object
/// (`study_objects.csv`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct StudyObjectRow {
    pub study: usize,
    pub participants: usize,
    pub condition: String,
    pub object: String,
    pub share: f64,
}

/// The rows of one study's sessions at each size (the first N of them); `objects` are the
/// protocol's object ids (a condition that never offered one has a share of 0 in it).
pub fn study_rows(
    index: usize,
    sessions: &[SessionAnalysis],
    sizes: &[usize],
    objects: &[String],
) -> (Vec<StudyRow>, Vec<StudyObjectRow>) {
    let mut rows = Vec::new();
    let mut out_objects = Vec::new();
    for &n in sizes {
        let run = [SeedRun { seed: index as u64, sessions: sessions[..n.min(sessions.len())].to_vec() }];
        for p in paired_over_seeds(&run) {
            rows.push(StudyRow {
                study: index,
                participants: n,
                measure: p.measure.to_string(),
                iteration: p.iteration,
                first: p.first,
                second: p.second,
                mean_difference: p.mean_difference,
                p_value: p.p_value,
            });
        }
        for (condition, shares) in object_shares(&run) {
            for object in objects {
                let share = shares.get(object).map_or(0.0, |s| s.0);
                out_objects.push(StudyObjectRow {
                    study: index,
                    participants: n,
                    condition: condition.clone(),
                    object: object.clone(),
                    share,
                });
            }
        }
    }
    (rows, out_objects)
}

/// The significance level the power is the share of studies below.
pub const SIGNIFICANCE: f64 = 0.05;

/// Power and effect at one size, measure and iteration, over studies (`power.csv`).
#[derive(Clone, Debug, PartialEq, Serialize, Default)]
pub struct PowerRow {
    pub participants: usize,
    pub measure: String,
    /// The measure's unit (`nats`, `deg`): the unit of the effect columns.
    pub unit: &'static str,
    pub iteration: usize,
    pub first: String,
    pub second: String,
    pub studies: usize,
    /// Share of studies with p < .05 (two-sided, either direction).
    pub power: f64,
    /// 95 % Wilson score interval of the power.
    pub power_low: f64,
    pub power_high: f64,
    /// Share of studies with p < .05 and first > second.
    pub power_first_higher: f64,
    /// Mean over studies of the study's mean difference, and its spread over studies (none
    /// with one study).
    pub mean_effect: f64,
    pub effect_sd: Option<f64>,
    pub effect_q025: f64,
    pub effect_q975: f64,
}

/// The 95 % Wilson score interval of `k` successes in `n` trials.
pub(crate) fn wilson_interval(k: usize, n: usize) -> (f64, f64) {
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let z = 1.959_963_984_540_054_f64;
    let (n, p) = (n as f64, k as f64 / n as f64);
    let denom = 1.0 + z * z / n;
    let centre = (p + z * z / (2.0 * n)) / denom;
    let half = z * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt() / denom;
    // At 0 and n the interval's end is exactly 0 or 1 (the formula leaves rounding there).
    let low = if k == 0 { 0.0 } else { (centre - half).max(0.0) };
    let high = if k as f64 == n { 1.0 } else { (centre + half).min(1.0) };
    (low, high)
}

/// Power rows from every study's rows, per size, measure and iteration in first-seen order.
pub fn power(rows: &[StudyRow]) -> Vec<PowerRow> {
    let mut keys: Vec<(usize, &str, usize)> = Vec::new();
    for r in rows {
        let key = (r.participants, r.measure.as_str(), r.iteration);
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    keys.into_iter()
        .map(|(n, measure, iteration)| {
            let group: Vec<&StudyRow> = rows
                .iter()
                .filter(|r| r.participants == n && r.measure == measure && r.iteration == iteration)
                .collect();
            let significant = |r: &&&StudyRow| r.p_value.is_some_and(|p| p < SIGNIFICANCE);
            let k = group.iter().filter(significant).count();
            let higher = group.iter().filter(significant).filter(|r| r.mean_difference > 0.0).count();
            let effects: Vec<f64> = group.iter().map(|r| r.mean_difference).collect();
            let m = crate::stats::mean(&effects);
            let sd = (effects.len() > 1)
                .then(|| (effects.iter().map(|e| (e - m).powi(2)).sum::<f64>() / (effects.len() - 1) as f64).sqrt());
            let (low, high) = wilson_interval(k, group.len());
            PowerRow {
                participants: n,
                measure: measure.to_string(),
                unit: measure_unit(measure),
                iteration,
                first: group[0].first.clone(),
                second: group[0].second.clone(),
                studies: group.len(),
                power: k as f64 / group.len() as f64,
                power_low: low,
                power_high: high,
                power_first_higher: higher as f64 / group.len() as f64,
                mean_effect: m,
                effect_sd: sd,
                effect_q025: crate::stats::quantile(&effects, 0.025),
                effect_q975: crate::stats::quantile(&effects, 0.975),
            }
        })
        .collect()
}

/// Mean share of each condition's offers per object at each size, over studies
/// (`objects.csv`).
#[derive(Clone, Debug, PartialEq, Serialize, Default)]
pub struct ObjectShareRow {
    pub participants: usize,
    pub condition: String,
    pub object: String,
    pub studies: usize,
    pub mean_share: f64,
    pub share_q025: f64,
    pub share_q975: f64,
}

/// Object shares over studies, per size, condition and object in first-seen order.
pub fn object_share_rows(rows: &[StudyObjectRow]) -> Vec<ObjectShareRow> {
    let mut keys: Vec<(usize, &str, &str)> = Vec::new();
    for r in rows {
        let key = (r.participants, r.condition.as_str(), r.object.as_str());
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    keys.into_iter()
        .map(|(n, condition, object)| {
            let v: Vec<f64> = rows
                .iter()
                .filter(|r| r.participants == n && r.condition == condition && r.object == object)
                .map(|r| r.share)
                .collect();
            ObjectShareRow {
                participants: n,
                condition: condition.to_string(),
                object: object.to_string(),
                studies: v.len(),
                mean_share: crate::stats::mean(&v),
                share_q025: crate::stats::quantile(&v, 0.025),
                share_q975: crate::stats::quantile(&v, 0.975),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_intervals_hold_their_known_values() {
        // 5 of 100: Wilson 95 % interval [0.0215, 0.1118].
        let (lo, hi) = wilson_interval(5, 100);
        assert!((lo - 0.02154).abs() < 1e-4 && (hi - 0.11175).abs() < 1e-4, "{lo} {hi}");
        assert_eq!(wilson_interval(0, 10).0, 0.0);
        assert_eq!(wilson_interval(10, 10).1, 1.0);
    }

    /// A body met again gets the protocol fitted the first time: the same study, shared, and
    /// the same text and feasible sets as fitting it anew.
    #[test]
    fn a_body_met_again_is_not_fitted_again() {
        let study = Study::default_study();
        let text = crate::protocol::DEFAULT_PROTOCOL;
        let bodies = FittedBodies::default();
        let body = BodyPopulation::default().draw(5, 0);
        let (t1, s1) = bodies.fit(text, &study, body).unwrap();
        let (t2, s2) = bodies.fit(text, &study, body).unwrap();
        assert!(Arc::ptr_eq(&s1, &s2), "fitted once");
        let (t0, s0) = for_body(text, &study.source_name, body).unwrap();
        assert_eq!((t1, t2), (t0.clone(), t0));
        let sets = |s: &Study| s.training.iter().map(|q| q.feasible.clone()).collect::<Vec<_>>();
        assert_eq!(sets(&s1), sets(&s0));
        // Another body is fitted for itself.
        let other = crate::protocol::Body { height_m: Some(1.9), ..body };
        assert!(!Arc::ptr_eq(&bodies.fit(text, &study, other).unwrap().1, &s1));
    }

    #[test]
    fn a_session_analysed_as_it_is_driven_is_its_log_replayed_and_analysed() {
        let study = Study::default_study();
        let text = crate::protocol::DEFAULT_PROTOCOL;
        let (text, fitted, p) =
            participant(text, &study, study_seed(3, 0), 0, false, &FittedBodies::default()).unwrap();
        let mut analyser = Analyser::new(START_NS, false, true);
        let (log, session) =
            drive_in_memory(text, Arc::clone(&fitted), &p, false, |s, step| analyser.visit(s, step)).unwrap();
        let driven = analyser.finish(&session, &fitted, &log).unwrap();
        let replayed = crate::analysis::analyse(&log).unwrap();
        assert!(replayed.completed && driven.completed);
        assert_eq!(replayed.runs.len(), 2);
        for (d, r) in driven.runs.iter().zip(&replayed.runs) {
            assert_eq!(d.test_ll_estimate, r.test_ll_estimate);
            assert_eq!(d.test_ll_predictive, r.test_ll_predictive);
            assert_eq!(d.trials, r.trials);
            assert_eq!(d.learned_q_star, r.learned_q_star);
        }
        assert_eq!(driven.trial_rows, replayed.trial_rows);
        assert!(session_seconds(&log) > 60.0);
    }

    #[test]
    fn a_plan_only_session_chooses_and_learns_what_a_whole_one_does() {
        let study = Study::default_study();
        let bodies = FittedBodies::default();
        for index in 0..3 {
            let (text, fitted, p) =
                participant(crate::protocol::DEFAULT_PROTOCOL, &study, study_seed(9, 0), index, false, &bodies)
                    .unwrap();
            let drive = |plan_only: bool| {
                let mut analyser = Analyser::new(START_NS, false, false);
                let (log, session) = drive_in_memory(text.clone(), Arc::clone(&fitted), &p, plan_only, |s, step| {
                    analyser.visit(s, step)
                })
                .unwrap();
                let analysed = analyser.finish(&session, &fitted, &log).unwrap();
                (log, session, analysed)
            };
            let (whole_log, whole, whole_analysis) = drive(false);
            let (plan_log, plan, plan_analysis) = drive(true);
            assert_eq!(plan_log.events, whole_log.events, "the same events, so the same queries chosen");
            for (a, b) in plan.learners().iter().zip(whole.learners()) {
                assert_eq!(a.belief, b.belief, "the same beliefs, bit for bit");
                assert_eq!(a.estimates, b.estimates);
            }
            for (a, b) in plan_analysis.runs.iter().zip(&whole_analysis.runs) {
                assert_eq!(a.test_ll_estimate, b.test_ll_estimate);
                // A plan's summaries hold the posterior mean alone, the prior's included.
                let means = |v: &[crate::session::BeliefSummary]| {
                    v.iter().map(|b| (b.iteration, b.mean.clone())).collect::<Vec<_>>()
                };
                assert_eq!(means(&a.beliefs), means(&b.beliefs));
                assert!(a.beliefs.iter().all(|b| b.map == b.mean && b.entropy.is_nan()));
            }
            // What was left out: a finished learner's last scores.
            assert!(plan.learners().iter().all(|l| l.scores.is_empty()));
            assert!(whole.learners().iter().all(|l| !l.scores.is_empty()));
        }
    }
}
