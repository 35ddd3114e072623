//! Exact mutual information between λ and the person's choice, and the expected cost of
//! eq. 10, computed together in one pass over particles × configurations.

use rayon::prelude::*;

use super::OutcomeModel;
use crate::belief::{Belief, PARTICLE_CHUNK};
use crate::ergo::{FeasibleSet, SetPass, xlogx};

/// What one pass over a query's feasible set yields.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QueryValue {
    /// I(λ; outcome) in nats, exact with respect to the particles.
    pub information_gain: f64,
    /// Σ_i ω_i min_q C(q; λ_i) (eq. 10, without α).
    pub expected_cost: f64,
}

struct Partial {
    marginal: Vec<f64>,
    conditional_entropy: f64,
    expected_cost: f64,
}

/// I = H[Σ_i ω_i L_i(·)] − Σ_i ω_i H[L_i(·)], where L_i is the distribution of the outcome
/// (the configuration, or the region with [`OutcomeModel::Region`]) under particle i.
/// O(N·|Q|); particles are reduced in fixed chunks so the result does not depend on the
/// number of threads.
pub fn query_value(belief: &Belief, set: &FeasibleSet, alpha: f64, outcomes: OutcomeModel) -> QueryValue {
    let d = belief.dim();
    let s = 2 * d;
    let k = match outcomes {
        OutcomeModel::Configuration => set.len(),
        OutcomeModel::Region => set.regions().len(),
    };
    let partials: Vec<Partial> = belief
        .particles()
        .par_chunks(PARTICLE_CHUNK * s)
        .zip(belief.weights().par_chunks(PARTICLE_CHUNK))
        .map(|(ps, ws)| {
            let mut scratch = SetPass::scratch(set.len());
            let mut part = Partial { marginal: vec![0.0; k], conditional_entropy: 0.0, expected_cost: 0.0 };
            let mut region_p = vec![0.0; set.regions().len()];
            for (p, &w) in ps.chunks_exact(s).zip(ws) {
                if w <= 0.0 {
                    continue;
                }
                let pass = SetPass::run(set.configs(), &p[..d], &p[d..], alpha, &mut scratch);
                part.expected_cost += w * pass.min_cost;
                let scale = w / pass.sum;
                match outcomes {
                    OutcomeModel::Configuration => {
                        scratch.add_scaled_weights(scale, &mut part.marginal);
                        part.conditional_entropy += w * pass.config_entropy();
                    }
                    OutcomeModel::Region => {
                        scratch.range_sums(set.regions(), &mut region_p);
                        let mut h = 0.0;
                        for pr in region_p.iter_mut() {
                            *pr /= pass.sum;
                            h -= xlogx(*pr);
                        }
                        for (m, pr) in part.marginal.iter_mut().zip(&region_p) {
                            *m += w * pr;
                        }
                        part.conditional_entropy += w * h;
                    }
                }
            }
            part
        })
        .collect();
    let mut marginal = vec![0.0; k];
    let (mut conditional, mut cost) = (0.0, 0.0);
    for p in &partials {
        for (m, v) in marginal.iter_mut().zip(&p.marginal) {
            *m += v;
        }
        conditional += p.conditional_entropy;
        cost += p.expected_cost;
    }
    let marginal_entropy = -marginal.iter().map(|&m| xlogx(m)).sum::<f64>();
    // Rounding can push the difference a hair outside [0, log K]; the true value is inside.
    let information_gain = (marginal_entropy - conditional).clamp(0.0, (k as f64).ln());
    QueryValue { information_gain, expected_cost: cost }
}
