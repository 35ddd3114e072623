//! The paper's approximate information gain (eq. 6–8): the maximum-likelihood outcome is
//! substituted for the inner expectation, and entropies are taken on a grid.

use rayon::prelude::*;

use super::OutcomeModel;
use crate::belief::{Belief, CellIndex, Grid, PARTICLE_CHUNK};
use crate::ergo::{FeasibleSet, SetPass, cost, log_sum_exp};

/// E[ΔH] = H(P(λ)) − Σ_i ω_i H(P(λ | argmax_o P(o | λ_i), Q)) (eq. 8), with H the gridded
/// entropy of eq. 6 (sign restored). Ties in the maximum-likelihood outcome go to the
/// lowest index.
pub fn information_gain_paper(
    belief: &Belief,
    set: &FeasibleSet,
    alpha: f64,
    outcomes: OutcomeModel,
    grid: &Grid,
) -> f64 {
    // A measurement's most likely value is the most likely configuration: the paper's
    // substitution of the maximum-likelihood outcome takes it noise-free.
    let outcomes = match outcomes {
        OutcomeModel::Measured { .. } => OutcomeModel::Configuration,
        o => o,
    };
    let d = belief.dim();
    let s = 2 * d;
    // Each particle's maximum-likelihood outcome and log normaliser.
    let per_particle: Vec<(usize, f64)> = belief
        .particles()
        .par_chunks(PARTICLE_CHUNK * s)
        .flat_map_iter(|ps| {
            let mut scratch = SetPass::scratch(set.len());
            let mut region_sums = vec![0.0; set.regions().len()];
            ps.chunks_exact(s)
                .map(|p| {
                    let pass = SetPass::run(set.configs(), &p[..d], &p[d..], alpha, &mut scratch);
                    let outcome = match outcomes {
                        OutcomeModel::Configuration | OutcomeModel::Measured { .. } => pass.argmin(&scratch),
                        OutcomeModel::Region => {
                            scratch.range_sums(set.regions(), &mut region_sums);
                            let mut best = (0, f64::NEG_INFINITY);
                            for (r, &m) in region_sums.iter().enumerate() {
                                if m > best.1 {
                                    best = (r, m);
                                }
                            }
                            best.0
                        }
                    };
                    (outcome, pass.log_norm(alpha))
                })
                .collect::<Vec<_>>()
        })
        .collect();

    let cells = CellIndex::new(belief, grid);
    let prior_entropy = cells.entropy(belief.weights());
    let mut distinct: Vec<usize> = per_particle.iter().map(|p| p.0).collect();
    distinct.sort_unstable();
    distinct.dedup();

    let expected_posterior_entropy: f64 = distinct
        .par_iter()
        .map(|&o| {
            let chosen: Vec<Vec<f64>> = match outcomes {
                OutcomeModel::Configuration | OutcomeModel::Measured { .. } => vec![set.configs().config(o)],
                OutcomeModel::Region => set.regions()[o].clone().map(|j| set.configs().config(j)).collect(),
            };
            let mut logits = vec![0.0; chosen.len()];
            let log_post: Vec<f64> = (0..belief.len())
                .map(|k| {
                    let w = belief.weights()[k];
                    if w <= 0.0 {
                        return f64::NEG_INFINITY;
                    }
                    let p = belief.particle(k);
                    for (l, q) in logits.iter_mut().zip(&chosen) {
                        *l = -alpha * cost(q, &p[..d], &p[d..]);
                    }
                    w.ln() + log_sum_exp(&logits) - per_particle[k].1
                })
                .collect();
            let z = log_sum_exp(&log_post);
            let post: Vec<f64> = log_post.iter().map(|l| (l - z).exp()).collect();
            let mass: f64 = per_particle.iter().zip(belief.weights()).filter(|(p, _)| p.0 == o).map(|(_, w)| w).sum();
            mass * cells.entropy(&post)
        })
        .collect::<Vec<f64>>()
        .iter()
        .sum();
    prior_entropy - expected_posterior_entropy
}
