//! Metropolis–Hastings moves after resampling (resample-move; Gilks and Berzuini, 2001):
//! each particle takes random-walk steps whose stationary distribution is the exact
//! posterior given the prior and every observation so far, so that duplicates made by
//! resampling spread out again without the widening that jitter adds.
//!
//! Sharp observations (a measured arm) leave few distinct particles after a handful of
//! updates; jitter then only blurs those few. A move instead re-explores the posterior, at
//! the price of one pass over the history per particle and step.

use std::sync::Arc;

use rand::{Rng, RngExt, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;

use super::{
    Belief, BeliefError, Observed, PARTICLE_CHUNK, Prior, check_observed, log_likelihood_at, reflect, scratch_for,
};
use crate::{SeededRng, derive_seed};

/// The random-walk scale per standard deviation of the particle cloud: 2.38/√d, the
/// optimal scale of a Gaussian random walk on a d-dimensional Gaussian target (Roberts,
/// Gelman and Gilks, 1997).
const SCALE: f64 = 2.38;

/// The purpose of a move chunk's random stream ([`derive_seed`]).
const PURPOSE_MOVE: u64 = 0x6d6f_7665;

/// What the moves did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MoveReport {
    /// Accepted proposals over all proposals.
    pub acceptance: f64,
}

impl Belief {
    /// `steps` Metropolis–Hastings steps for every particle of an equally weighted belief
    /// (call it after resampling), targeting p(λ) Π_t P(obs_t | Q_t, λ) (eq. 4–5, the prior
    /// and every observation in `history`). The proposal is a Gaussian random walk on the
    /// learned components, reflected into the prior's support (symmetric, so the acceptance
    /// ratio is the posterior ratio), with standard deviation per component the larger of
    /// `floor[c]` and 2.38/√d times the cloud's standard deviation. Particles go in fixed
    /// chunks with their own random streams seeded from one draw of `rng`: the result is
    /// bit-identical for any number of threads.
    pub fn move_particles<R: Rng + ?Sized>(
        &mut self,
        prior: &Prior,
        history: &[Observed],
        alpha: f64,
        steps: usize,
        floor: &[f64],
        rng: &mut R,
    ) -> Result<MoveReport, BeliefError> {
        check_observed(history, self.dim)?;
        Ok(self.move_checked(prior, history, alpha, steps, floor, rng))
    }

    /// [`Belief::move_particles`] for a history whose every observation was checked
    /// ([`check_observed`], as [`Belief::update`] checks each).
    pub(crate) fn move_checked<R: Rng + ?Sized>(
        &mut self,
        prior: &Prior,
        history: &[Observed],
        alpha: f64,
        steps: usize,
        floor: &[f64],
        rng: &mut R,
    ) -> MoveReport {
        let base: u64 = rng.random();
        if steps == 0 || self.free.is_empty() {
            return MoveReport { acceptance: 0.0 };
        }
        let s = 2 * self.dim;
        let mean = self.mean().to_vec();
        let shrink = SCALE / (self.free.len() as f64).sqrt();
        let mut scale = vec![0.0; s];
        for &c in &self.free {
            let var: f64 =
                self.particles.chunks_exact(s).zip(self.weights()).map(|(p, w)| w * (p[c] - mean[c]).powi(2)).sum();
            scale[c] = (shrink * var.sqrt()).max(floor.get(c).copied().unwrap_or(0.0));
        }
        let (free, support) = (&self.free, &self.support);
        let accepted: usize = Arc::make_mut(&mut self.particles)
            .par_chunks_mut(PARTICLE_CHUNK * s)
            .enumerate()
            .map(|(chunk, ps)| {
                let mut rng = SeededRng::seed_from_u64(derive_seed(base, chunk as u64, PURPOSE_MOVE));
                let mut scratch = scratch_for(history);
                let mut proposal = vec![0.0; s];
                let mut accepted = 0;
                for p in ps.chunks_exact_mut(s) {
                    let mut current =
                        log_likelihood_at(history, p, alpha, prior.log_density_unnormalised(p), &mut scratch);
                    for _ in 0..steps {
                        proposal.copy_from_slice(p);
                        for &c in free {
                            let z: f64 = StandardNormal.sample(&mut rng);
                            proposal[c] = reflect(p[c] + scale[c] * z, support[c]);
                        }
                        let u: f64 = rng.random();
                        let base = prior.log_density_unnormalised(&proposal);
                        let next = log_likelihood_at(history, &proposal, alpha, base, &mut scratch);
                        // −∞ → −∞ is never accepted; a finite target from −∞ always is.
                        if next > f64::NEG_INFINITY && (current == f64::NEG_INFINITY || u.ln() < next - current) {
                            p.copy_from_slice(&proposal);
                            current = next;
                            accepted += 1;
                        }
                    }
                }
                accepted
            })
            .sum();
        MoveReport { acceptance: accepted as f64 / (steps * self.len()) as f64 }
    }
}
