//! Post-hoc analysis of session logs: each session replayed from its events, the belief
//! after every training iteration scored on the session's own test responses.

mod alpha;
mod collect;
mod measured;
mod population;
mod rows;
mod seeds;
mod summary;
mod tables;
mod verify;

use std::sync::Arc;

use crate::belief::{Belief, posterior_predictive_log_likelihood};
use crate::protocol::Study;
use crate::record::{LogContents, RecordError, ReplayStep, replay_with, study_of};
use crate::session::{Applied, BeliefSummary, Phase, Session, SessionStart};

pub use crate::stats::{Wilcoxon, mean, median, quantile, standard_error, wilcoxon_signed_rank};
pub use alpha::{
    ALPHA_RANGE, AlphaFit, AlphaSummary, EVIDENCE_PARTICLES, MAX_EVIDENCE_PARTICLES, SUPPORT_DROP, SessionAlpha,
    alpha_grid, alpha_summary, fit_alpha,
};
pub use collect::{Analysed, Collected, WithdrawnLeftOut, collect};
pub use measured::{
    MAX_MEASUREMENT_BYTES, MAX_MEASUREMENT_SAMPLES, MeasuredRefit, MeasurementFileError, MeasurementSeries, RefitRun,
    refit,
};
pub use population::{
    AVERAGED, BURN_IN, ComponentFit, PersonEstimate, PopulationError, PopulationFit, PopulationSettings, fit_population,
};
pub use rows::{NoteRow, RobotRow, RobotTimings, TrialRow, TrialStatus, rfc3339_ms, robot_timings, trial_columns};
pub use seeds::{
    Coverage, HEIGHT_BANDS_M, JointError, ObjectsByBody, OverSeeds, SEED_MEASURES, SeedRun, coverage, joint_errors,
    measure_unit, object_shares, objects_by_body, over_seeds, paired_across, paired_over_seeds,
};
pub use summary::{CurvePoint, ItemTest, LikertSummary, StudySummary, distinct_q_star, summarise};
pub use tables::write_tables;
pub use verify::Difference;
use verify::Verifier;

/// What one session says about its participant: every handover (both training runs and the
/// test phase), with the protocol's prior (radians) and the α it assumed. α's evidence uses
/// the regions taken, the population's fit what the session learned from.
#[derive(Clone, Debug)]
pub struct SessionEvidence {
    pub prior: crate::belief::Prior,
    pub alpha: f64,
    /// The session's seed (the draws of α's evidence and of the population's chains derive
    /// from it).
    pub seed: u64,
    pub handovers: Vec<Handover>,
}

/// One handover: the feasible set offered, the index of the region taken, and the
/// observation the session learned from (the region, the label model's configuration or the
/// measured arm).
#[derive(Clone, Debug)]
pub struct Handover {
    pub set: crate::ergo::FeasibleSet,
    pub region: usize,
    pub observation: crate::ergo::Observation,
}

impl SessionEvidence {
    /// Each handover as (set, observation), as the belief's likelihoods take them.
    pub(crate) fn observed(&self) -> Vec<crate::belief::Observed<'_>> {
        self.handovers.iter().map(|h| (&h.set, &h.observation)).collect()
    }
}

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
    /// Test-set log-likelihood of the belief's posterior-mean estimate after each iteration
    /// 0..=N (the paper's measure used its gridded mode, which in 7-D is grid noise).
    pub test_ll_estimate: Vec<f64>,
    /// Posterior-predictive test-set log-likelihood after each iteration 0..=N.
    pub test_ll_predictive: Vec<f64>,
    /// The posterior mean's q* after the last iteration (radians).
    pub learned_q_star: Vec<f64>,
    /// The belief after each iteration 0..=N, recomputed by replaying the events.
    pub beliefs: Vec<BeliefSummary>,
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
    /// Every handover, with the prior: α's evidence ([`alpha_summary`]) and the population's
    /// ([`fit_population`]).
    pub evidence: SessionEvidence,
    /// The body the session was run for (from the protocol as logged).
    pub body: crate::protocol::Body,
    /// Every presentation of a query and what became of it, in order.
    pub trial_rows: Vec<TrialRow>,
    /// The experimenter's notes, in order.
    pub notes: Vec<NoteRow>,
    /// Every command sent to the robot and how it ended (none without a robot).
    pub robot: Vec<RobotRow>,
}

/// Replays a log and computes its per-session results.
pub fn analyse(log: &LogContents) -> Result<SessionAnalysis, RecordError> {
    analyse_and_verify(log, false).map(|(a, _)| a)
}

/// [`analyse`], and with `verify` also the differences between the log's derived messages
/// and their recomputation ([`verify`]), from one replay.
pub fn analyse_and_verify(log: &LogContents, verify: bool) -> Result<(SessionAnalysis, Vec<Difference>), RecordError> {
    let study = Arc::new(study_of(log)?);
    let mut analyser = Analyser::new(log.start_time_ns, verify, true);
    let session = replay_with(Arc::clone(&study), log, |session, step| analyser.visit(session, step))?;
    let differences = if verify { analyser.verifier.differences(log) } else { Vec::new() };
    Ok((analyser.finish(&session, &study, log)?, differences))
}

/// The analysis of a session as it is driven, step by step, rather than replayed from its
/// log: `visit` is called as [`replay_with`] calls it (once with no step at the start, then
/// after every event applied), and `finish` gives what [`analyse`] gives for the log of
/// those events — the same code on the same states. Without `predictive`, the posterior
/// predictive test log-likelihoods (the costliest part, which `plan` does not use) are left
/// empty.
pub struct Analyser {
    verifier: Verifier,
    verify: bool,
    predictive: bool,
    rows: rows::RowCollector,
    /// Beliefs (and their summaries) after each training iteration, per run (index 0: the prior).
    snapshots: Vec<Vec<(Belief, BeliefSummary)>>,
}

impl Analyser {
    pub fn new(start_time_ns: u64, verify: bool, predictive: bool) -> Self {
        Self {
            verifier: Verifier::new(start_time_ns),
            verify,
            predictive,
            rows: rows::RowCollector::default(),
            snapshots: Vec::new(),
        }
    }

    /// One step of the session (None: its start).
    pub fn visit(&mut self, session: &Session, step: Option<ReplayStep>) {
        if self.verify {
            self.verifier.visit(session, step);
        }
        if let Some((index, stamped, applied)) = step {
            self.rows.visit(session, index, stamped, applied);
        }
        let snapshot = |session: &Session, run: usize| {
            let l = &session.learners()[run];
            (l.belief.clone(), l.summary.clone())
        };
        if self.snapshots.is_empty() {
            self.snapshots = (0..session.learners().len()).map(|run| vec![snapshot(session, run)]).collect();
        }
        // A training step's snapshot, kept per run (training views carry their run).
        let training_run = |view: &crate::session::TrialView| match (view.phase, view.program) {
            (Phase::Training, Some(run)) if run < self.snapshots.len() => Some(run),
            _ => None,
        };
        match step.map(|(_, _, applied)| applied) {
            Some(Applied::Responded { view, .. }) => {
                if let Some(run) = training_run(view) {
                    let point = snapshot(session, run);
                    self.snapshots[run].push(point);
                }
            }
            Some(Applied::Undone { view, .. }) | Some(Applied::Voided { view, retracted: true }) => {
                if let Some(run) = training_run(view) {
                    self.snapshots[run].pop();
                }
            }
            _ => {}
        }
    }

    /// The session's results, from its final state and its log's start.
    pub fn finish(self, session: &Session, study: &Study, log: &LogContents) -> Result<SessionAnalysis, RecordError> {
        let runs = log.start.condition_order.len();
        let Self { rows, snapshots, predictive, .. } = self;
        let ctx = session.context();
        let tests = session.test_examples();
        let region_id = |t: &crate::session::TrialRecord| {
            let q = session.query(t.query);
            study.object(q).regions[q.regions[t.region]].id.clone()
        };
        let mut out_runs = Vec::with_capacity(runs);
        for (run, points) in snapshots.into_iter().enumerate() {
            let (beliefs, summaries): (Vec<Belief>, Vec<BeliefSummary>) = points.into_iter().unzip();
            let modes: Vec<_> = summaries.iter().map(|b| b.mean.clone()).collect();
            let (test_ll_estimate, test_ll_predictive) = if tests.is_empty() {
                (Vec::new(), Vec::new())
            } else {
                (
                    session.test_log_likelihoods(run, &tests),
                    if predictive {
                        beliefs
                            .iter()
                            .map(|b| posterior_predictive_log_likelihood(b, &tests, ctx.alpha))
                            .collect::<Result<_, _>>()
                            .map_err(|e| RecordError::NotALog {
                                path: log.path.clone(),
                                why: format!("its test trials cannot be scored by the belief: {e}"),
                            })?
                    } else {
                        Vec::new()
                    },
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
                test_ll_estimate,
                test_ll_predictive,
                learned_q_star: modes.last().map(|m| m.q_star.clone()).unwrap_or_default(),
                beliefs: summaries,
            });
        }
        let evidence = SessionEvidence {
            prior: ctx.prior.clone(),
            alpha: ctx.alpha,
            seed: log.start.seed,
            handovers: session
                .trials()
                .iter()
                .map(|t| {
                    let set = session.set(t.query);
                    Handover { set: set.clone(), region: t.region, observation: ctx.observation_of(set, t) }
                })
                .collect(),
        };
        let items = &study.protocol.questionnaire.items;
        let completed = matches!(session.prompt(), crate::session::Prompt::Done { completed: true });
        Ok(SessionAnalysis {
            body: crate::protocol::Body { height_m: study.protocol.arm.body_height_m, hand: study.arm.side },
            trial_rows: rows.trials,
            notes: rows.notes,
            robot: rows.robot,
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
            completed,
            evidence,
        })
    }
}
