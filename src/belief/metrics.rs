//! The objective measures of section IV that need more than the belief itself.

use super::{Belief, BeliefError};
use crate::ergo::{FeasibleSet, Lambda, Observation, ObservationError, SetPass, log_likelihood, log_sum_exp};

/// One held-out query and what the person chose in it.
#[derive(Clone, Debug)]
pub struct TestExample {
    pub set: FeasibleSet,
    pub observation: Observation,
}

/// Σ_t log P(obs_t | Q_t, λ): the test-set log-likelihood of one λ (e.g. the mode).
pub fn test_log_likelihood(lambda: &Lambda, tests: &[TestExample], alpha: f64) -> Result<f64, ObservationError> {
    tests.iter().map(|t| log_likelihood(&t.set, lambda, alpha, &t.observation)).sum()
}

/// Σ_t log Σ_i ω_i P(obs_t | Q_t, λ_i): the posterior-predictive test log-likelihood.
pub fn posterior_predictive_log_likelihood(
    belief: &Belief,
    tests: &[TestExample],
    alpha: f64,
) -> Result<f64, BeliefError> {
    let mut total = 0.0;
    for t in tests {
        let ll = belief.log_likelihoods(&t.set, alpha, &t.observation)?;
        let terms: Vec<f64> = ll
            .iter()
            .zip(belief.weights())
            .map(|(l, &w)| if w > 0.0 { w.ln() + l } else { f64::NEG_INFINITY })
            .collect();
        total += log_sum_exp(&terms);
    }
    Ok(total)
}

/// The true cost of a query: E_{q ~ P(·|Q, λ*)} C(q; λ*), the expected cost under the
/// ground truth of the configuration the person picks.
pub fn true_cost(set: &FeasibleSet, truth: &Lambda, alpha: f64) -> f64 {
    let mut scratch = SetPass::scratch(set.len());
    let pass = SetPass::run(set.configs(), &truth.q_star, &truth.w, alpha, &mut scratch);
    let weighted: f64 = scratch.costs().iter().zip(scratch.exps()).map(|(c, e)| c * e).sum();
    weighted / pass.sum
}
