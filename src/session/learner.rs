//! One training condition's learner: its belief, its selector and its suggestion.

use crate::SeededRng;
use crate::belief::Observed;
use crate::belief::{Belief, CellIndex, Grid, Prior, ResamplePolicy};
use crate::ergo::{FeasibleSet, Lambda, Observation};
use crate::protocol::ObservationModel;
use crate::select::{
    OutcomeModel, Precision, Problem, QueryValue, Screen, ScreenedChoice, SelectorKind, Tradeoff, menu_values,
};

/// Settings shared by both learners of a session.
#[derive(Clone, Debug)]
pub struct LearningContext {
    pub alpha: f64,
    /// How a grasp updates the belief: the label-model configuration of the region taken,
    /// the region, or the measured arm.
    pub observation: ObservationModel,
    /// σ per joint (rad) of `measured` observations (empty otherwise).
    pub sigma: Vec<f64>,
    pub grid: Grid,
    pub jitter: Vec<f64>,
    pub policy: ResamplePolicy,
    /// Metropolis–Hastings steps per particle after each resampling (0: jitter instead).
    pub moves: usize,
    /// β of `hybrid` and ε of `budgeted`.
    pub tradeoff: Tradeoff,
    /// The label model λ: maps a grabbed region to its most likely configuration.
    pub label_model: Lambda,
    /// The prior (for the MAP estimate, recomputed from it and every observation).
    pub prior: Prior,
    /// Whether only what a plan reports is computed ([`super::Session::for_plan`]): belief
    /// summaries of the posterior mean alone ([`BeliefSummary::of`]), `passive`'s choice by
    /// expected costs alone, screened ([`crate::select::screened_passive_choice`]), float64
    /// choices of region outcomes by the float32 screen ([`LearningContext::screens`]), and
    /// no suggestion after a condition's last training trial. A logged session computes
    /// everything: its `/trial/query` carries every score.
    pub plan_only: bool,
    /// Training trials per condition (when a learner's training is over).
    pub training_trials: usize,
    /// What the selectors score ([`SessionStart::selection`](super::SessionStart)).
    pub selection: super::SelectionOutcome,
    /// The arithmetic of the selectors' set passes (protocol `learning.precision`).
    pub precision: Precision,
}

impl LearningContext {
    /// Whether a plan's float64 choices of region outcomes are made by the float32 screen
    /// ([`Screen`]): the same choices, float64's scores only where it scored.
    pub fn screens(&self) -> bool {
        self.plan_only && self.precision == Precision::Float64 && self.selection_outcomes() == OutcomeModel::Region
    }

    /// What the selectors decide from: this belief over the menu, with the session's α,
    /// outcomes and precision.
    pub fn problem<'a>(&'a self, belief: &'a Belief, menu: &'a [FeasibleSet]) -> Problem<'a> {
        Problem { belief, menu, alpha: self.alpha, outcomes: self.selection_outcomes(), precision: self.precision }
    }

    /// The outcomes the selectors score: the measured arm when the session learns from it
    /// (its information about λ estimated, `select::measured_information`), else the
    /// region (what the operator's key records, and the fallback of a trial without a
    /// measurement). Logs of formats 1 and 2 scored regions whatever they learned from.
    pub fn selection_outcomes(&self) -> OutcomeModel<'_> {
        match self.selection {
            super::SelectionOutcome::Measured => OutcomeModel::Measured { sigma: &self.sigma },
            super::SelectionOutcome::Region => OutcomeModel::Region,
        }
    }

    /// What the belief learns from a recorded trial of `set`: eq. 1 on the label model's
    /// configuration, eq. 3 on the region, or the measured likelihood
    /// Σ_q P(q | Q, λ) N(q_m; q, Σ) (docs/engine.md) — the region when no measurement came.
    pub fn observation_of(&self, set: &FeasibleSet, t: &super::TrialRecord) -> Observation {
        let region = || Observation::Region(set.regions()[t.region].clone().collect());
        match (self.observation, &t.measured) {
            (ObservationModel::Configuration, _) => Observation::Config(t.config),
            (ObservationModel::Measured, Some(m)) => {
                Observation::measured(set.configs(), &m.measurement.q_rad, &self.sigma)
                    // Checked when the grasp was recorded.
                    .unwrap_or_else(|_| region())
            }
            (ObservationModel::Region | ObservationModel::Measured, _) => region(),
        }
    }
}

/// A summary of a belief, as logged on `/belief`: the well-defined estimates (posterior
/// mean, MAP, 90 % credible interval), the paper's gridded mode (for its figures only: in
/// 7-D it is grid noise, see docs/engine.md), the gridded entropy and the ESS.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BeliefSummary {
    pub iteration: usize,
    pub mean: Lambda,
    pub map: Lambda,
    /// The 5 % and 95 % posterior quantiles of every component.
    pub ci_low: Lambda,
    pub ci_high: Lambda,
    /// The paper's mode: the mean of the heaviest grid cell.
    pub grid_mode: Lambda,
    pub entropy: f64,
    pub ess: f64,
}

impl BeliefSummary {
    /// Summarises a belief after `iteration` updates, given the observations it was
    /// updated with (one pass over the grid cells gives both the mode and the entropy).
    /// In a plan ([`LearningContext::plan_only`]) only the posterior mean is computed, all
    /// a plan reports of a belief: the MAP estimate is the mean, and the interval, the mode,
    /// the entropy and the ESS are NaN.
    pub fn of(belief: &Belief, iteration: usize, ctx: &LearningContext, history: &[Observed]) -> Self {
        let mean = belief.mean();
        if ctx.plan_only {
            let unknown = Lambda { q_star: vec![f64::NAN; mean.dim()], w: vec![f64::NAN; mean.dim()] };
            return BeliefSummary {
                iteration,
                map: mean.clone(),
                mean,
                ci_low: unknown.clone(),
                ci_high: unknown.clone(),
                grid_mode: unknown,
                entropy: f64::NAN,
                ess: f64::NAN,
            };
        }
        let cells = CellIndex::new(belief, &ctx.grid);
        let (ci_low, ci_high) = belief.credible_interval();
        BeliefSummary {
            iteration,
            // The history's observations index their own sets (checked when observed).
            map: belief.map_estimate(&ctx.prior, history, ctx.alpha).unwrap_or_else(|_| mean.clone()),
            mean,
            ci_low,
            ci_high,
            grid_mode: cells.mode(belief),
            entropy: cells.entropy(belief.weights()),
            ess: belief.ess(),
        }
    }
}

/// A learner: belief, RNG (resampling, random selection), and the next suggestion.
#[derive(Clone, Debug)]
pub struct Learner {
    pub condition: SelectorKind,
    pub belief: Belief,
    rng: SeededRng,
    /// Updates so far.
    pub iteration: usize,
    /// Menu index of the query to present next.
    pub suggestion: usize,
    /// Information gain and expected cost of every menu item for the current belief.
    pub scores: Vec<QueryValue>,
    /// Gridded entropy after each iteration (index 0: the prior).
    pub entropies: Vec<f64>,
    /// The posterior mean after each iteration (index 0: the prior's).
    pub estimates: Vec<Lambda>,
    /// The current belief's summary (kept, as the console shows it on every frame).
    pub summary: BeliefSummary,
    /// Every observation learned from: (menu index, observation).
    pub history: Vec<(usize, Observation)>,
    /// Names this state: new for every learner made or updated in this process, kept by
    /// its copies (what a learner computed ahead is checked against, [`super::Session::speculate`]).
    generation: u64,
}

/// A new learner state's [`Learner::generation`].
fn next_generation() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

impl Learner {
    pub fn new(
        condition: SelectorKind,
        belief: Belief,
        rng: SeededRng,
        menu: &[FeasibleSet],
        ctx: &LearningContext,
    ) -> Self {
        let summary = BeliefSummary::of(&belief, 0, ctx, &[]);
        let entropies = vec![summary.entropy];
        let estimates = vec![summary.mean.clone()];
        let mut l = Self {
            condition,
            belief,
            rng,
            iteration: 0,
            suggestion: 0,
            scores: Vec::new(),
            entropies,
            estimates,
            summary,
            history: Vec::new(),
            generation: next_generation(),
        };
        l.suggest(menu, ctx);
        l
    }

    /// The learners of a session's conditions, in order, all from the same draw of the prior
    /// (`belief`), each with its own random stream: the prior's summary and the menu's scores
    /// are the same numbers for every condition, so they are computed once; only the choice
    /// is each one's own (what [`Learner::new`] would choose). In a plan whose choices are
    /// screened ([`LearningContext::screens`]) one float32 [`Screen`] of the prior gives
    /// `active`'s and `passive`'s first choices.
    pub(super) fn first(
        conditions: &[SelectorKind],
        belief: Belief,
        rngs: impl Iterator<Item = SeededRng>,
        menu: &[FeasibleSet],
        ctx: &LearningContext,
    ) -> Vec<Self> {
        let summary = BeliefSummary::of(&belief, 0, ctx, &[]);
        let screenable = |c: SelectorKind| ctx.screens() && matches!(c, SelectorKind::Active | SelectorKind::Passive);
        let screen = conditions.iter().any(|&c| screenable(c)).then(|| Screen::new(&belief, menu, ctx.alpha));
        let mut shared: Option<Vec<QueryValue>> = None;
        let mut learners = Vec::with_capacity(conditions.len());
        for (&condition, rng) in conditions.iter().zip(rngs) {
            let mut l = Self {
                condition,
                belief: belief.clone(),
                rng,
                iteration: 0,
                suggestion: 0,
                scores: Vec::new(),
                entropies: vec![summary.entropy],
                estimates: vec![summary.mean.clone()],
                summary: summary.clone(),
                history: Vec::new(),
                generation: next_generation(),
            };
            match (&screen, condition) {
                (Some(screen), SelectorKind::Active) => l.adopt(screen.active()),
                (Some(screen), SelectorKind::Passive) => l.adopt(screen.passive()),
                _ => {
                    l.scores = shared.get_or_insert_with(|| menu_values(&ctx.problem(&belief, menu))).clone();
                    l.choose(menu, ctx);
                }
            }
            learners.push(l);
        }
        learners
    }

    /// Takes a screened choice: float64's scores where it scored, NaN elsewhere.
    fn adopt(&mut self, screened: ScreenedChoice) {
        self.scores = screened.values;
        self.suggestion = screened.index;
    }

    fn suggest(&mut self, menu: &[FeasibleSet], ctx: &LearningContext) {
        if ctx.screens() && self.condition == SelectorKind::Active {
            // Float64's choice, scored in float32 where a proven bound decides it.
            self.adopt(Screen::new(&self.belief, menu, ctx.alpha).active());
            return;
        }
        if ctx.plan_only && self.condition == SelectorKind::Passive {
            // The choice in the protocol's precision, from the expected costs alone (no
            // information gain), screened by float32 minimum costs where a proven bound
            // decides it.
            self.adopt(crate::select::screened_passive_choice(&self.belief, menu, ctx.precision));
            return;
        }
        self.scores = menu_values(&ctx.problem(&self.belief, menu));
        self.choose(menu, ctx);
    }

    /// The next query from the scores (or by the selector's own rule).
    fn choose(&mut self, menu: &[FeasibleSet], ctx: &LearningContext) {
        self.suggestion = match crate::select::choose_from_values(self.condition, &self.scores, ctx.tradeoff) {
            Some(i) => i,
            None => {
                let problem = ctx.problem(&self.belief, menu);
                self.condition.build(&ctx.grid, ctx.tradeoff).select(&problem, &mut self.rng).index
            }
        };
    }

    /// Updates with one observation, resamples by the policy and suggests the next query.
    /// A degenerate update (every particle gives the observation zero likelihood) is an
    /// error, and the learner is left as it was.
    pub fn learn(
        &mut self,
        query: usize,
        obs: &Observation,
        menu: &[FeasibleSet],
        ctx: &LearningContext,
    ) -> Result<(), crate::belief::BeliefError> {
        let set = &menu[query];
        // An update that fails leaves the belief as it was; every observation it accepts is
        // checked, so the moves over the history cannot fail.
        self.belief.update(set, ctx.alpha, obs)?;
        self.history.push((query, obs.clone()));
        let history: Vec<Observed> = self.history.iter().map(|(q, o)| (&menu[*q], o)).collect();
        if ctx.moves == 0 {
            self.belief.maybe_resample(ctx.policy, &ctx.jitter, &mut self.rng);
        } else if self.belief.maybe_resample(ctx.policy, &[], &mut self.rng) {
            self.belief.move_checked(&ctx.prior, &history, ctx.alpha, ctx.moves, &ctx.jitter, &mut self.rng);
        }
        self.iteration += 1;
        self.summary = BeliefSummary::of(&self.belief, self.iteration, ctx, &history);
        self.entropies.push(self.summary.entropy);
        self.estimates.push(self.summary.mean.clone());
        if !ctx.plan_only || self.iteration < ctx.training_trials {
            self.suggest(menu, ctx);
        } else {
            self.scores.clear();
        }
        self.generation = next_generation();
        Ok(())
    }

    /// This state's name: equal for a learner and its copies, never for two states.
    pub fn generation(&self) -> u64 {
        self.generation
    }
}
