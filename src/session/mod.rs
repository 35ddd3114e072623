//! The study session as a pure state machine: `Session::apply(event)` folds one event into
//! the state, `Session::prompt()` says what the operator must do next. No terminal, file or
//! clock in here: the shells (console, dry run, replay) do the I/O.

mod ahead;
mod apply;
mod events;
mod learner;

use std::collections::BTreeMap;
use std::sync::Arc;

use rand::SeedableRng;
use rand::seq::SliceRandom;

use crate::belief::{Belief, Grid, TestExample, test_log_likelihood};
use crate::ergo::{ConfigSet, FeasibleSet};
use crate::kinematics::ArmFeasibleSet;
use crate::protocol::{ObservationModel, ResolvedQuery, Study};
use crate::select::{QueryValue, SelectorKind};
use crate::{SeededRng, derive_seed};

pub use events::{
    ArmMeasurement, Event, MeasurementSource, RobotLinkKind, RobotState, SelectionOutcome, SentPose, SessionStart,
    Stamped, VoidReason, program_letter, validate_command_id, validate_frame_id, validate_sent_pose,
};
pub use learner::{BeliefSummary, Learner, LearningContext};

/// The counterbalancing orders: slot 0 runs the protocol's conditions as listed, slot 1 reversed.
pub fn condition_order(study: &Study, slot: usize) -> Vec<SelectorKind> {
    let mut c = study.protocol.session.conditions.clone();
    if slot % 2 == 1 {
        c.reverse();
    }
    c
}

/// The choice model's view of an arm's feasible set (which must not be empty, as validated
/// protocols guarantee): its configurations, grouped by offered region.
pub fn choice_set(set: &ArmFeasibleSet) -> FeasibleSet {
    let configs = ConfigSet::from_rows(&set.rows()).expect("a non-empty set of finite IK solutions");
    FeasibleSet::with_regions(configs, &set.labels()).expect("feasible sets are grouped by region")
}

/// Why an event does not fit the session's state.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SessionError {
    #[error("{event} is not possible now: {why}")]
    NotNow { event: &'static str, why: String },
    #[error("query '{found}' presented, expected '{expected}'")]
    WrongQuery { found: String, expected: String },
    #[error("region '{region}' is not offered at query '{query}' (offered: {offered})")]
    UnknownRegion { region: String, query: String, offered: String },
    #[error("Likert item '{item}' of program {program} does not exist")]
    UnknownItem { item: String, program: usize },
    #[error("Likert value {value} is not on the scale {min}..{max}")]
    OffScale { value: i64, min: i64, max: i64 },
    #[error("program {0} does not exist")]
    UnknownProgram(usize),
    #[error("the session start does not fit the protocol: {0}")]
    BadStart(String),
    #[error("the belief cannot learn from this grasp at query '{query}': {why}")]
    Degenerate { query: String, why: String },
    #[error("the arm measurement at query '{query}' is refused: {why}")]
    BadMeasurement { query: String, why: String },
}

/// The two phases with trials.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Phase {
    Training,
    Test,
}

impl Phase {
    pub fn name(self) -> &'static str {
        match self {
            Phase::Training => "training",
            Phase::Test => "test",
        }
    }
}

/// Where a trial's query comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QueryRef {
    /// Index into the training menu.
    Training(usize),
    /// Index into the test set.
    Test(usize),
}

/// One trial as the operator sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct TrialView {
    pub phase: Phase,
    /// The training condition (never shown to the participant).
    pub condition: Option<SelectorKind>,
    /// Index of the program (0 = A) in training.
    pub program: Option<usize>,
    /// 1-based trial number within the phase (within the run for training).
    pub trial: usize,
    pub of: usize,
    pub query: QueryRef,
}

/// What the operator must do next.
#[derive(Clone, Debug, PartialEq)]
pub enum Prompt {
    /// Command the robot to the query's pose and confirm it is presented.
    Present(TrialView),
    /// Record which region the participant grabbed.
    Grasp(TrialView),
    /// Ask a Likert item about a program.
    Likert { program: usize, item: usize, index: usize, total: usize },
    /// Ask the forced choice.
    ForcedChoice,
    /// Everything is answered: end the session.
    Finish,
    /// The session is paused.
    Paused,
    /// The session is over.
    Done { completed: bool },
}

/// A point between phases where the experimenter tells the participant what comes next
/// (the protocol's `session.transitions`) and confirms it before the next phase's first
/// query is presented; the confirmation is an event, so that a resumed console and the
/// robot operator's screen know whether it was given.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "stage", content = "program", rename_all = "kebab-case")]
pub enum Transition {
    /// The start of training program k (k ≥ 1: after another program).
    Program(usize),
    /// The start of the test phase.
    Test,
    /// The start of the questionnaire.
    Questionnaire,
}

/// One recorded trial.
#[derive(Clone, Debug, PartialEq)]
pub struct TrialRecord {
    pub phase: Phase,
    pub run: Option<usize>,
    pub trial: usize,
    pub query: QueryRef,
    /// Index into the query's offered regions.
    pub region: usize,
    /// Index of the mapped configuration in the query's feasible set (label model).
    pub config: usize,
    /// With `measured` observations: the measurement and what it implies (none: no sample in
    /// time, and the trial learned from the region).
    pub measured: Option<MeasuredGrasp>,
}

/// A voided presentation of a trial: where it was, and why (the trial itself is repeated).
#[derive(Clone, Debug, PartialEq)]
pub struct VoidRecord {
    pub phase: Phase,
    pub run: Option<usize>,
    /// 1-based trial number within the phase (within the run for training).
    pub trial: usize,
    pub query: QueryRef,
    pub reason: VoidReason,
    pub detail: String,
}

/// A grasp's measurement and the configuration it is nearest to.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasuredGrasp {
    pub measurement: ArmMeasurement,
    /// The feasible configuration of highest measurement density (the nearest in the
    /// σ-scaled metric; the lowest index on ties).
    pub nearest: usize,
    /// Its region, as an index into the query's offered regions: the region the measurement
    /// implies. When it differs from the operator's key the trial is flagged, never
    /// resolved silently: the belief learns from the measurement, the record keeps the key.
    pub implied_region: usize,
}

impl MeasuredGrasp {
    /// Whether the measurement and the operator's key name the same region.
    pub fn agrees(&self, record_region: usize) -> bool {
        self.implied_region == record_region
    }
}

/// What applying an event derived, for the recorder.
#[derive(Clone, Debug, PartialEq)]
pub enum Applied {
    Presented {
        view: TrialView,
        scores: Vec<QueryValue>,
    },
    Responded {
        view: TrialView,
        record: TrialRecord,
        belief: Option<BeliefSummary>,
    },
    Voided {
        view: TrialView,
        retracted: bool,
    },
    Undone {
        view: TrialView,
        belief: Option<BeliefSummary>,
    },
    /// A robot command for the trial `view` (its `attempt`, 1-based).
    RobotCommanded {
        view: TrialView,
        attempt: u32,
    },
    /// A robot report; `attempt` is the command of the trial under way it answers, if any
    /// (never for a stale report).
    RobotReported {
        attempt: Option<u32>,
    },
    Ended {
        completed: bool,
    },
    Other,
}

/// Which trial of the session: a training trial of a run, or a test trial.
#[derive(Clone, Copy, Debug, PartialEq)]
enum TrialSlot {
    Training { run: usize, trial: usize },
    Test { trial: usize },
}

/// The trial under way, and whether its query is presented.
#[derive(Clone, Copy, Debug, PartialEq)]
struct TrialCursor {
    slot: TrialSlot,
    presented: bool,
}

#[derive(Clone, Debug, PartialEq)]
enum Stage {
    Trial(TrialCursor),
    Questionnaire,
    Done { completed: bool },
}

/// The robot's commands for the trial under way: how many were sent, and the last report.
#[derive(Clone, Debug, PartialEq)]
pub struct RobotTrack {
    pub query: String,
    pub attempts: u32,
    /// The last command's id (none in logs before format 4).
    pub command: Option<String>,
    pub last: Option<(RobotState, String)>,
}

/// The state before the last grasp, kept so that it can be undone.
#[derive(Clone, Debug)]
struct UndoPoint {
    cursor: TrialCursor,
    learner: Option<(usize, Learner)>,
    /// How many transitions were confirmed before the grasp: one confirmed after it is
    /// undone with it (the participant is told again).
    confirmed: usize,
}

/// A session: the fold of the protocol, the start record and the events.
#[derive(Clone, Debug)]
pub struct Session {
    study: Arc<Study>,
    start: SessionStart,
    menu: Arc<Vec<FeasibleSet>>,
    tests: Arc<Vec<FeasibleSet>>,
    ctx: LearningContext,
    learners: Vec<Learner>,
    test_order: Vec<usize>,
    stage: Stage,
    paused: bool,
    undo: Option<Box<UndoPoint>>,
    trials: Vec<TrialRecord>,
    likert: BTreeMap<(usize, usize), i64>,
    choice: Option<usize>,
    notes: Vec<String>,
    voids: Vec<VoidRecord>,
    /// The transitions confirmed, in order.
    confirmed: Vec<Transition>,
    /// The robot's commands for the trial under way (none without a robot).
    robot: Option<RobotTrack>,
    events: usize,
    /// How many of `events` were the robot's or confirmed a transition.
    side_events: usize,
    /// Learners computed ahead for the presented query ([`Session::speculate`]); shared by
    /// copies of the session, never logged.
    ahead: Option<Arc<ahead::Ahead>>,
    /// Responses that adopted a learner computed ahead.
    adopted_ahead: usize,
}

mod purpose {
    pub const PARTICLES: u64 = 101;
    pub(crate) const LEARNER: u64 = 102;
    pub(crate) const TEST_ORDER: u64 = 103;
}

impl Session {
    /// A new session at its first prompt.
    /// A session without a `selection` scores what its protocol's sessions learn from (the
    /// measured arm, or the region); one with it (a log's) scores what it says.
    pub fn new(study: Arc<Study>, start: SessionStart) -> Result<Self, SessionError> {
        Self::build(study, start, false)
    }

    /// A new session that computes only what a plan reports: belief summaries of the
    /// posterior mean alone ([`BeliefSummary::of`]), `passive`'s expected costs without the
    /// information gain, float64 choices of region outcomes by the float32 screen
    /// ([`crate::select::Screen`]: one screen of the prior belief serves both conditions'
    /// first choices, then `active`'s), and no suggestion once a condition's training is
    /// over. The same queries are chosen and the same beliefs learned as by [`Session::new`];
    /// a logged session computes everything (its `/trial/query` carries every score).
    pub fn for_plan(study: Arc<Study>, start: SessionStart) -> Result<Self, SessionError> {
        Self::build(study, start, true)
    }

    fn build(study: Arc<Study>, mut start: SessionStart, plan_only: bool) -> Result<Self, SessionError> {
        let spec = &study.protocol.session;
        if start.condition_order.len() != spec.conditions.len()
            || spec.conditions.iter().any(|c| !start.condition_order.contains(c))
        {
            return Err(SessionError::BadStart(format!(
                "condition order {:?} is not an order of the protocol's conditions {:?}",
                start.condition_order, spec.conditions
            )));
        }
        let learning = &study.protocol.learning;
        let measured = learning.observation == ObservationModel::Measured && learning.measurement.is_some();
        let selection = *start.selection.get_or_insert(if measured {
            SelectionOutcome::Measured
        } else {
            SelectionOutcome::Region
        });
        if selection == SelectionOutcome::Measured && !measured {
            return Err(SessionError::BadStart(
                "selection is measured, but the protocol's sessions do not learn from a measured arm".into(),
            ));
        }
        let prior = study.prior.clone();
        let supports: Vec<(f64, f64)> = prior.components().iter().map(|c| c.support()).collect();
        let ctx = LearningContext {
            alpha: learning.alpha,
            observation: learning.observation,
            sigma: learning.measurement.as_ref().map_or_else(Vec::new, |m| m.sigma_rad()),
            grid: Grid::over_supports(&supports, learning.grid_boxes),
            jitter: learning.jitter(prior.dim()),
            policy: learning.resampling,
            moves: learning.moves,
            tradeoff: crate::select::Tradeoff { beta: learning.hybrid_beta, epsilon: learning.budget_epsilon },
            label_model: learning.label_model.to_lambda(),
            prior: prior.clone(),
            plan_only,
            training_trials: spec.trials_per_condition,
            selection,
            precision: learning.precision,
        };
        let menu: Arc<Vec<FeasibleSet>> = Arc::new(study.training.iter().map(|q| choice_set(&q.feasible)).collect());
        let tests: Arc<Vec<FeasibleSet>> = Arc::new(study.test.iter().map(|q| choice_set(&q.feasible)).collect());
        // Both conditions start from the same draw of the prior.
        let mut particle_rng = SeededRng::seed_from_u64(derive_seed(start.seed, 0, purpose::PARTICLES));
        let belief = Belief::from_prior(&prior, learning.particles, &mut particle_rng)
            .map_err(|e| SessionError::BadStart(e.to_string()))?;
        let rngs = (0..start.condition_order.len())
            .map(|run| SeededRng::seed_from_u64(derive_seed(start.seed, run as u64, purpose::LEARNER)));
        let learners = Learner::first(&start.condition_order, belief, rngs, &menu, &ctx);
        let mut test_order: Vec<usize> = (0..study.test.len()).collect();
        if spec.shuffle_test {
            test_order.shuffle(&mut SeededRng::seed_from_u64(derive_seed(start.seed, 0, purpose::TEST_ORDER)));
        }
        Ok(Self {
            study,
            start,
            menu,
            tests,
            ctx,
            learners,
            test_order,
            stage: Stage::Trial(TrialCursor { slot: TrialSlot::Training { run: 0, trial: 0 }, presented: false }),
            paused: false,
            undo: None,
            trials: Vec::new(),
            likert: BTreeMap::new(),
            choice: None,
            notes: Vec::new(),
            voids: Vec::new(),
            confirmed: Vec::new(),
            robot: None,
            events: 0,
            side_events: 0,
            ahead: None,
            adopted_ahead: 0,
        })
    }

    pub fn study(&self) -> &Study {
        &self.study
    }

    pub fn start(&self) -> &SessionStart {
        &self.start
    }

    pub fn learners(&self) -> &[Learner] {
        &self.learners
    }

    pub fn context(&self) -> &LearningContext {
        &self.ctx
    }

    pub fn trials(&self) -> &[TrialRecord] {
        &self.trials
    }

    pub fn notes(&self) -> &[String] {
        &self.notes
    }

    /// Every trial voided, in order (shown in the phase's history with its reason).
    pub fn voids(&self) -> &[VoidRecord] {
        &self.voids
    }

    pub fn likert_answers(&self) -> &BTreeMap<(usize, usize), i64> {
        &self.likert
    }

    pub fn forced_choice(&self) -> Option<usize> {
        self.choice
    }

    /// The robot's commands for the trial under way, if it was sent any.
    pub fn robot(&self) -> Option<&RobotTrack> {
        self.robot.as_ref()
    }

    /// Number of events applied.
    pub fn event_count(&self) -> usize {
        self.events
    }

    /// Events applied other than the robot's commands and reports and the experimenter's
    /// confirmations of transitions: what a simulated participant's draws are keyed on, so
    /// that a robot in the loop, or a console that confirms transitions, changes no answer.
    pub fn participant_events(&self) -> usize {
        self.events - self.side_events
    }

    /// Whether `GraspUndone` is possible now.
    pub fn can_undo(&self) -> bool {
        self.undo.is_some() && !self.paused
    }

    /// The test responses so far, as what the belief would observe of them.
    pub fn test_examples(&self) -> Vec<TestExample> {
        self.trials
            .iter()
            .filter(|t| t.phase == Phase::Test)
            .map(|t| {
                let set = self.set(t.query).clone();
                let observation = self.ctx.observation_of(&set, t);
                TestExample { set, observation }
            })
            .collect()
    }

    /// The test-set log-likelihood (eq. 1 summed over `tests`, nats) of run `run`'s
    /// posterior-mean estimate after each of its iterations (index 0: the prior); empty
    /// without test responses.
    pub fn test_log_likelihoods(&self, run: usize, tests: &[TestExample]) -> Vec<f64> {
        if tests.is_empty() {
            return Vec::new();
        }
        // The examples are the session's own records, whose indices were checked when made.
        self.learners[run].estimates.iter().filter_map(|m| test_log_likelihood(m, tests, self.ctx.alpha).ok()).collect()
    }

    /// The feasible set of a query.
    pub fn set(&self, q: QueryRef) -> &FeasibleSet {
        match q {
            QueryRef::Training(i) => &self.menu[i],
            QueryRef::Test(i) => &self.tests[i],
        }
    }

    /// The protocol's query.
    pub fn query(&self, q: QueryRef) -> &ResolvedQuery {
        match q {
            QueryRef::Training(i) => &self.study.training[i],
            QueryRef::Test(i) => &self.study.test[i],
        }
    }

    fn trials_per_run(&self) -> usize {
        self.study.protocol.session.trials_per_condition
    }

    fn view(&self, cursor: TrialCursor) -> TrialView {
        match cursor.slot {
            TrialSlot::Training { run, trial } => TrialView {
                phase: Phase::Training,
                condition: Some(self.learners[run].condition),
                program: Some(run),
                trial: trial + 1,
                of: self.trials_per_run(),
                query: QueryRef::Training(self.learners[run].suggestion),
            },
            TrialSlot::Test { trial } => TrialView {
                phase: Phase::Test,
                condition: None,
                program: None,
                trial: trial + 1,
                of: self.test_order.len(),
                query: QueryRef::Test(self.test_order[trial]),
            },
        }
    }

    /// How many statements [`Self::likert_order`] lists, without listing them.
    pub fn likert_count(&self) -> usize {
        self.learners.len() * self.study.protocol.questionnaire.items.len()
    }

    /// The questionnaire's items in the order asked: every item about Program A, then B.
    pub fn likert_order(&self) -> Vec<(usize, usize)> {
        let items = self.study.protocol.questionnaire.items.len();
        (0..self.learners.len()).flat_map(|p| (0..items).map(move |i| (p, i))).collect()
    }

    /// The transition to confirm before the session goes on: the first trial of a training
    /// program after another, of the test phase, or the first statement of the
    /// questionnaire, before anything of it is recorded and unless it was confirmed. (Logs
    /// of format 1 carry no confirmations: for them it ends when the next phase begins.)
    pub fn transition(&self) -> Option<Transition> {
        let t = match self.prompt() {
            Prompt::Present(v) if v.trial == 1 => {
                let begun = self.voids.iter().any(|x| x.phase == v.phase && x.run == v.program);
                match (v.phase, v.program) {
                    _ if begun => return None,
                    (Phase::Training, Some(k)) if k > 0 => Transition::Program(k),
                    (Phase::Test, _) => Transition::Test,
                    _ => return None,
                }
            }
            Prompt::Likert { index: 0, .. } if self.likert.is_empty() && self.choice.is_none() => {
                Transition::Questionnaire
            }
            _ => return None,
        };
        (!self.confirmed.contains(&t)).then_some(t)
    }

    /// What the operator must do next.
    pub fn prompt(&self) -> Prompt {
        match &self.stage {
            Stage::Done { completed } => Prompt::Done { completed: *completed },
            _ if self.paused => Prompt::Paused,
            Stage::Trial(c) if c.presented => Prompt::Grasp(self.view(*c)),
            Stage::Trial(c) => Prompt::Present(self.view(*c)),
            Stage::Questionnaire => {
                let order = self.likert_order();
                match order.iter().position(|k| !self.likert.contains_key(k)) {
                    Some(index) => {
                        let (program, item) = order[index];
                        Prompt::Likert { program, item, index, total: order.len() }
                    }
                    None if self.choice.is_none() => Prompt::ForcedChoice,
                    None => Prompt::Finish,
                }
            }
        }
    }

    /// The stage after the trial at `slot` is complete.
    fn next_stage(&self, slot: TrialSlot) -> Stage {
        let trial = |slot| Stage::Trial(TrialCursor { slot, presented: false });
        match slot {
            TrialSlot::Training { run, trial: t } if t + 1 < self.trials_per_run() => {
                trial(TrialSlot::Training { run, trial: t + 1 })
            }
            TrialSlot::Training { run, .. } if run + 1 < self.learners.len() => {
                trial(TrialSlot::Training { run: run + 1, trial: 0 })
            }
            TrialSlot::Training { .. } if !self.test_order.is_empty() => trial(TrialSlot::Test { trial: 0 }),
            TrialSlot::Test { trial: t } if t + 1 < self.test_order.len() => trial(TrialSlot::Test { trial: t + 1 }),
            _ => Stage::Questionnaire,
        }
    }
}

/// Builds what a session of `study` builds (the prior's particles, both learners' first
/// suggestions over every feasible set) and takes one learning step, so that a protocol
/// `protocol check` accepts is known to run.
pub fn check_runs(study: Arc<Study>) -> Result<(), SessionError> {
    let start = SessionStart {
        session_id: "protocol-check".into(),
        participant: "protocol-check".into(),
        protocol_name: study.protocol.name.clone(),
        protocol_sha256: study.sha256.clone(),
        seed: 0,
        condition_order: condition_order(&study, 0),
        program_labels: study.protocol.session.program_labels.clone(),
        software_version: env!("CARGO_PKG_VERSION").into(),
        pilot: true,
        slot: 0,
        started_at: "1970-01-01T00:00:00Z".into(),
        simulated_truth: None,
        resumed_from: None,
        selection: None,
    };
    let mut session = Session::new(study, start)?;
    let Prompt::Present(view) = session.prompt() else {
        return Err(SessionError::BadStart("the session does not start with a trial".into()));
    };
    let q = session.query(view.query);
    let query = q.query.id.clone();
    let region = session.study().object(q).regions[q.regions[0]].id.clone();
    session.apply(&Event::QueryPresented { query })?;
    session.apply(&Event::GraspRecorded { region, measured: None })?;
    Ok(())
}

#[cfg(test)]
mod tests;
