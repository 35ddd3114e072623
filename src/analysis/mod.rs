//! Post-hoc analysis of session logs: each session replayed from its events, the belief
//! after every training iteration scored on the session's own test responses.

mod stats;
mod summary;
mod verify;

use std::sync::Arc;

use crate::belief::{Belief, TestExample, posterior_predictive_log_likelihood, test_log_likelihood};
use crate::ergo::Observation;
use crate::record::{LogContents, RecordError, replay_with, study_of};
use crate::select::OutcomeModel;
use crate::session::{Applied, Phase, Session, SessionStart};

pub use stats::{Wilcoxon, mean, median, quantile, standard_error, wilcoxon_signed_rank};
pub use summary::{
    CurvePoint, DISTINCT_Q_STAR_TOLERANCE_DEG, ItemTest, LikertSummary, StudySummary, distinct_q_star, summarise,
};
pub use verify::{Difference, verify};

/// One training handover: what was offered and what was taken.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainingTrial {
    pub trial: usize,
    pub query: String,
    pub object: String,
    pub region: String,
}

/// One training condition of one session.
#[derive(Clone, Debug, PartialEq)]
pub struct RunAnalysis {
    pub program: usize,
    pub condition: String,
    pub trials: Vec<TrainingTrial>,
    /// Test-set log-likelihood of the belief's mode after each iteration 0..=N (the paper's measure).
    pub test_ll_mode: Vec<f64>,
    /// Posterior-predictive test-set log-likelihood after each iteration 0..=N.
    pub test_ll_predictive: Vec<f64>,
    /// The mode's q* after the last iteration (radians).
    pub learned_q_star: Vec<f64>,
    /// The belief after each iteration 0..=N, recomputed by replaying the events.
    pub beliefs: Vec<BeliefPoint>,
}

/// A replayed belief after one training iteration.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BeliefPoint {
    pub iteration: usize,
    pub mode: crate::ergo::Lambda,
    pub mean: crate::ergo::Lambda,
    /// Gridded entropy (nats).
    pub entropy: f64,
    pub ess: f64,
}

/// One session, replayed.
#[derive(Clone, Debug)]
pub struct SessionAnalysis {
    pub start: SessionStart,
    pub runs: Vec<RunAnalysis>,
    /// Test trials: (query, object, region).
    pub test_trials: Vec<(String, String, String)>,
    /// (program, item id, value) of the final answers.
    pub likert: Vec<(usize, String, i64)>,
    pub choice: Option<usize>,
    pub completed: bool,
    pub final_session: Session,
}

/// Replays a log and computes its per-session results.
pub fn analyse(log: &LogContents) -> Result<SessionAnalysis, RecordError> {
    let study = Arc::new(study_of(log)?);
    let runs = log.start.condition_order.len();
    // Beliefs after each training iteration, per run (index 0: the prior).
    let mut snapshots: Vec<Vec<Belief>> = Vec::new();
    let (session, _) = replay_with(Arc::clone(&study), log, |session, applied| {
        if snapshots.is_empty() {
            snapshots = session.learners().iter().map(|l| vec![l.belief.clone()]).collect();
        }
        match applied {
            Some(Applied::Responded { view, .. }) if view.phase == Phase::Training => {
                let run = view.program.expect("training has a program");
                snapshots[run].push(session.learners()[run].belief.clone());
            }
            Some(Applied::Undone { view, .. }) | Some(Applied::Voided { view, retracted: true })
                if view.phase == Phase::Training =>
            {
                snapshots[view.program.expect("training has a program")].pop();
            }
            _ => {}
        }
    })?;
    let ctx = session.context();
    let tests: Vec<TestExample> = session
        .trials()
        .iter()
        .filter(|t| t.phase == Phase::Test)
        .map(|t| {
            let set = session.set(t.query).clone();
            let observation = match ctx.observation {
                OutcomeModel::Configuration => Observation::Config(t.config),
                OutcomeModel::Region => Observation::Region(set.regions()[t.region].clone().collect()),
            };
            TestExample { set, observation }
        })
        .collect();
    let region_id = |t: &crate::session::TrialRecord| {
        let q = session.query(t.query);
        study.object(q).regions[q.regions[t.region]].id.clone()
    };
    let mut out_runs = Vec::with_capacity(runs);
    for (run, beliefs) in snapshots.iter().enumerate() {
        let modes: Vec<_> = beliefs.iter().map(|b| b.mode(&ctx.grid)).collect();
        let (test_ll_mode, test_ll_predictive) = if tests.is_empty() {
            (Vec::new(), Vec::new())
        } else {
            (
                modes.iter().map(|m| test_log_likelihood(m, &tests, ctx.alpha).expect("logged indices")).collect(),
                beliefs
                    .iter()
                    .map(|b| posterior_predictive_log_likelihood(b, &tests, ctx.alpha).expect("logged indices"))
                    .collect(),
            )
        };
        let trials = session
            .trials()
            .iter()
            .filter(|t| t.run == Some(run))
            .map(|t| {
                let q = session.query(t.query);
                TrainingTrial {
                    trial: t.trial,
                    query: q.query.id.clone(),
                    object: q.query.object.clone(),
                    region: region_id(t),
                }
            })
            .collect();
        out_runs.push(RunAnalysis {
            program: run,
            condition: session.learners()[run].condition.name().to_string(),
            trials,
            test_ll_mode,
            test_ll_predictive,
            learned_q_star: modes.last().map(|m| m.q_star.clone()).unwrap_or_default(),
            beliefs: beliefs
                .iter()
                .zip(&modes)
                .enumerate()
                .map(|(iteration, (b, m))| BeliefPoint {
                    iteration,
                    mode: m.clone(),
                    mean: b.mean(),
                    entropy: b.entropy(&ctx.grid),
                    ess: b.ess(),
                })
                .collect(),
        });
    }
    let items = &study.protocol.questionnaire.items;
    Ok(SessionAnalysis {
        start: log.start.clone(),
        runs: out_runs,
        test_trials: session
            .trials()
            .iter()
            .filter(|t| t.phase == Phase::Test)
            .map(|t| {
                let q = session.query(t.query);
                (q.query.id.clone(), q.query.object.clone(), region_id(t))
            })
            .collect(),
        likert: session.likert_answers().iter().map(|(&(p, i), &v)| (p, items[i].id.clone(), v)).collect(),
        choice: session.forced_choice(),
        completed: matches!(session.prompt(), crate::session::Prompt::Done { completed: true }),
        final_session: session,
    })
}
