//! One training condition's learner: its belief, its selector and its suggestion.

use crate::SeededRng;
use crate::belief::{Belief, CellIndex, Grid, ResamplePolicy};
use crate::ergo::{FeasibleSet, Lambda, Observation};
use crate::select::{OutcomeModel, Problem, QueryValue, SelectorKind, menu_values};

/// Settings shared by both learners of a session.
#[derive(Clone, Debug)]
pub struct LearningContext {
    pub alpha: f64,
    /// How a grabbed region updates the belief: its label-model configuration, or the region.
    pub observation: OutcomeModel,
    pub grid: Grid,
    pub jitter: Vec<f64>,
    pub policy: ResamplePolicy,
    pub beta: f64,
    /// The label model λ: maps a grabbed region to its most likely configuration.
    pub label_model: Lambda,
}

/// A summary of a belief, as logged on `/belief`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BeliefSummary {
    pub iteration: usize,
    pub mode: Lambda,
    pub mean: Lambda,
    pub entropy: f64,
    pub ess: f64,
}

impl BeliefSummary {
    /// Summarises a belief after `iteration` updates (one pass over the grid cells gives
    /// both the mode and the entropy).
    pub fn of(belief: &Belief, iteration: usize, grid: &Grid) -> Self {
        let cells = CellIndex::new(belief, grid);
        BeliefSummary {
            iteration,
            mode: cells.mode(belief),
            mean: belief.mean(),
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
    /// The current belief's summary (kept, as the console shows it on every frame).
    pub summary: BeliefSummary,
}

impl Learner {
    pub fn new(
        condition: SelectorKind,
        belief: Belief,
        rng: SeededRng,
        menu: &[FeasibleSet],
        ctx: &LearningContext,
    ) -> Self {
        let summary = BeliefSummary::of(&belief, 0, &ctx.grid);
        let entropies = vec![summary.entropy];
        let mut l =
            Self { condition, belief, rng, iteration: 0, suggestion: 0, scores: Vec::new(), entropies, summary };
        l.suggest(menu, ctx);
        l
    }

    fn suggest(&mut self, menu: &[FeasibleSet], ctx: &LearningContext) {
        // Only the handle taken is observed in a session, so selection scores the
        // information and cost of region outcomes, whatever the observation model.
        let problem = Problem { belief: &self.belief, menu, alpha: ctx.alpha, outcomes: OutcomeModel::Region };
        self.scores = menu_values(&problem);
        self.suggestion = match crate::select::choose_from_values(self.condition, &self.scores, ctx.beta) {
            Some(i) => i,
            None => self.condition.build(&ctx.grid, ctx.beta).select(&problem, &mut self.rng).index,
        };
    }

    /// Updates with one observation, resamples by the policy and suggests the next query.
    /// A degenerate update (every particle gives the observation zero likelihood) is an
    /// error, and the learner is left as it was.
    pub fn learn(
        &mut self,
        set: &FeasibleSet,
        obs: &Observation,
        menu: &[FeasibleSet],
        ctx: &LearningContext,
    ) -> Result<(), crate::belief::BeliefError> {
        self.belief.update(set, ctx.alpha, obs)?;
        self.belief.maybe_resample(ctx.policy, &ctx.jitter, &mut self.rng);
        self.iteration += 1;
        self.summary = BeliefSummary::of(&self.belief, self.iteration, &ctx.grid);
        self.entropies.push(self.summary.entropy);
        self.suggest(menu, ctx);
        Ok(())
    }
}
