//! One training condition's learner: its belief, its selector and its suggestion.

use crate::SeededRng;
use crate::belief::{Belief, Grid, ResamplePolicy};
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
#[derive(Clone, Debug, PartialEq)]
pub struct BeliefSummary {
    pub iteration: usize,
    pub mode: Lambda,
    pub mean: Lambda,
    pub entropy: f64,
    pub ess: f64,
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
}

impl Learner {
    pub fn new(
        condition: SelectorKind,
        belief: Belief,
        rng: SeededRng,
        menu: &[FeasibleSet],
        ctx: &LearningContext,
    ) -> Self {
        let entropy = belief.entropy(&ctx.grid);
        let mut l =
            Self { condition, belief, rng, iteration: 0, suggestion: 0, scores: Vec::new(), entropies: vec![entropy] };
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
    pub fn learn(&mut self, set: &FeasibleSet, obs: &Observation, menu: &[FeasibleSet], ctx: &LearningContext) {
        self.belief.update(set, ctx.alpha, obs).expect("an offered configuration has positive likelihood");
        self.belief.maybe_resample(ctx.policy, &ctx.jitter, &mut self.rng);
        self.iteration += 1;
        self.entropies.push(self.belief.entropy(&ctx.grid));
        self.suggest(menu, ctx);
    }

    pub fn summary(&self, ctx: &LearningContext) -> BeliefSummary {
        BeliefSummary {
            iteration: self.iteration,
            mode: self.belief.mode(&ctx.grid),
            mean: self.belief.mean(),
            entropy: *self.entropies.last().expect("the prior's entropy"),
            ess: self.belief.ess(),
        }
    }
}
