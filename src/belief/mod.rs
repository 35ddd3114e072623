//! The robot's belief over λ = [q*, w]: weighted particles (section III-C).

mod estimates;
mod grid;
mod metrics;
mod moves;
mod prior;

use std::sync::Arc;

use rand::{Rng, RngExt};
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::ergo::{FeasibleSet, Lambda, Observation, ObservationError, SetPass, log_sum_exp, region_weights};

pub use estimates::{CREDIBLE, Estimate, MAP_TIE, Observed};
pub use grid::{CellIndex, Grid};
pub use metrics::{TestExample, posterior_predictive_log_likelihood, test_log_likelihood, true_cost};
pub use moves::MoveReport;
pub use prior::{ComponentPrior, Prior, PriorError};

/// Particles evaluated together by one task: fixes the order of every parallel reduction,
/// so results are bit-identical for any number of threads.
pub const PARTICLE_CHUNK: usize = 64;

/// Why a belief could not be built or updated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BeliefError {
    #[error("a belief needs at least one particle")]
    NoParticles,
    #[error("particle {index}: {what}")]
    BadParticle { index: usize, what: String },
    #[error("particle {index}: weight {weight} must be finite and non-negative")]
    BadWeight { index: usize, weight: f64 },
    #[error("all particle weights are zero")]
    AllZeroWeights,
    #[error("the feasible set has {found} joints, the belief {expected}")]
    DimensionMismatch { found: usize, expected: usize },
    #[error(transparent)]
    Observation(#[from] ObservationError),
    #[error("the observation has zero likelihood under every particle")]
    Degenerate,
}

/// When to resample after an update.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum ResamplePolicy {
    /// After every update, as in the paper.
    EveryUpdate,
    /// When the effective sample size falls below `fraction` · N.
    EssBelow { fraction: f64 },
}

/// N weighted particles over λ = [q*, w] of D joints.
#[derive(Clone, Debug, PartialEq)]
pub struct Belief {
    dim: usize,
    /// Row-major: particle i is `particles[i * 2D .. (i + 1) * 2D]` = [q*, w]. Shared
    /// between copies until one of them changes it (a session is copied on every event, and
    /// at 20 000 particles × 14 components this is 2.2 MB).
    particles: Arc<Vec<f64>>,
    /// Normalised weights, shared likewise.
    weights: Arc<Vec<f64>>,
    /// Indices of the learned components.
    free: Vec<usize>,
    /// The prior's support per component, where jitter is kept.
    support: Vec<(f64, f64)>,
}

/// Checks that every set has `dim` joints and every observation fits its set.
pub(crate) fn check_observed(observed: &[Observed], dim: usize) -> Result<(), BeliefError> {
    for (set, obs) in observed {
        if set.dim() != dim {
            return Err(BeliefError::DimensionMismatch { found: set.dim(), expected: dim });
        }
        obs.check(set.len())?;
    }
    Ok(())
}

/// Scratch space for [`log_likelihood_at`], one per observed set.
pub(crate) fn scratch_for(observed: &[Observed]) -> Vec<crate::ergo::Scratch> {
    observed.iter().map(|(set, _)| SetPass::scratch(set.len())).collect()
}

/// base + Σ_t log P(obs_t | Q_t, λ) at one λ = [q*, w], for observations checked by
/// [`check_observed`]; the sum stops once it reaches −∞.
pub(crate) fn log_likelihood_at(
    observed: &[Observed],
    lambda: &[f64],
    alpha: f64,
    base: f64,
    scratch: &mut [crate::ergo::Scratch],
) -> f64 {
    let d = lambda.len() / 2;
    let mut lp = base;
    for ((set, obs), scratch) in observed.iter().zip(scratch) {
        if lp == f64::NEG_INFINITY {
            break;
        }
        let pass = SetPass::run(set.configs(), &lambda[..d], &lambda[d..], alpha, scratch);
        lp += pass.log_likelihood(obs, alpha, scratch);
    }
    lp
}

/// [`log_likelihood_at`] of one region observation for each particle of `ps` (row-major),
/// the same numbers: particles go four at a time, so that their regions' sums of weights
/// are added together ([`region_weights`]).
fn region_log_likelihoods(
    set: &FeasibleSet,
    idx: &[usize],
    ps: &[f64],
    stride: usize,
    alpha: f64,
    base: &impl Fn(&[f64]) -> f64,
) -> Vec<f64> {
    const K: usize = 4;
    let d = stride / 2;
    let mut scratch: [crate::ergo::Scratch; K] = std::array::from_fn(|_| SetPass::scratch(set.len()));
    let mut out = Vec::with_capacity(ps.len() / stride);
    for group in ps.chunks(K * stride) {
        let mut passes = [None; K];
        let mut bases = [0.0; K];
        for (k, (p, sc)) in group.chunks_exact(stride).zip(&mut scratch).enumerate() {
            bases[k] = base(p);
            if bases[k] != f64::NEG_INFINITY {
                passes[k] = Some(SetPass::run(set.configs(), &p[..d], &p[d..], alpha, sc));
            }
        }
        let sums = region_weights::<K>(std::array::from_fn(|k| scratch[k].exps()), idx);
        for k in 0..group.len() / stride {
            out.push(match passes[k] {
                Some(pass) => bases[k] + pass.region_log_likelihood(idx, sums[k], alpha, &scratch[k]),
                None => bases[k],
            });
        }
    }
    out
}

impl Belief {
    /// N equally weighted draws from the prior.
    pub fn from_prior<R: Rng + ?Sized>(prior: &Prior, n: usize, rng: &mut R) -> Result<Self, BeliefError> {
        if n == 0 {
            return Err(BeliefError::NoParticles);
        }
        let mut particles = Vec::with_capacity(n * 2 * prior.dim());
        for _ in 0..n {
            particles.extend(prior.sample(rng));
        }
        Ok(Self {
            dim: prior.dim(),
            particles: Arc::new(particles),
            weights: Arc::new(vec![1.0 / n as f64; n]),
            free: prior.free(),
            support: prior.components().iter().map(|c| c.support()).collect(),
        })
    }

    /// Explicit particles with (unnormalised, non-negative) weights; every component is
    /// treated as learned and unbounded.
    pub fn from_particles(lambdas: &[Lambda], weights: &[f64]) -> Result<Self, BeliefError> {
        let first = lambdas.first().ok_or(BeliefError::NoParticles)?;
        let dim = first.dim();
        let mut particles = Vec::with_capacity(lambdas.len() * 2 * dim);
        for (index, l) in lambdas.iter().enumerate() {
            if l.q_star.len() != dim || l.w.len() != dim {
                return Err(BeliefError::BadParticle {
                    index,
                    what: format!("q_star has {} and w {} components, expected {dim}", l.q_star.len(), l.w.len()),
                });
            }
            if let Some(v) = l.q_star.iter().chain(&l.w).find(|v| !v.is_finite()) {
                return Err(BeliefError::BadParticle { index, what: format!("{v} is not a finite number") });
            }
            particles.extend(l.to_vec());
        }
        if weights.len() != lambdas.len() {
            return Err(BeliefError::BadParticle {
                index: weights.len().min(lambdas.len()),
                what: format!("{} weights for {} particles", weights.len(), lambdas.len()),
            });
        }
        if let Some((index, &weight)) = weights.iter().enumerate().find(|(_, w)| !(w.is_finite() && **w >= 0.0)) {
            return Err(BeliefError::BadWeight { index, weight });
        }
        let total: f64 = weights.iter().sum();
        if total <= 0.0 {
            return Err(BeliefError::AllZeroWeights);
        }
        Ok(Self {
            dim,
            particles: Arc::new(particles),
            weights: Arc::new(weights.iter().map(|w| w / total).collect()),
            free: (0..2 * dim).collect(),
            support: vec![(f64::NEG_INFINITY, f64::INFINITY); 2 * dim],
        })
    }

    /// Number of particles N.
    pub fn len(&self) -> usize {
        self.weights.len()
    }

    pub fn is_empty(&self) -> bool {
        self.weights.is_empty()
    }

    /// Number of joints D.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Normalised weights.
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// All particles, row-major with stride 2D.
    pub fn particles(&self) -> &[f64] {
        &self.particles
    }

    /// Particle i as [q*, w].
    pub fn particle(&self, i: usize) -> &[f64] {
        let s = 2 * self.dim;
        &self.particles[i * s..(i + 1) * s]
    }

    /// Indices into [q*, w] of the learned components.
    pub fn free(&self) -> &[usize] {
        &self.free
    }

    /// The prior's support [min, max] of each component of [q*, w].
    pub fn support(&self) -> &[(f64, f64)] {
        &self.support
    }

    /// Bayes update with one observation (eq. 4–5), in log space: each particle's
    /// likelihood is normalised over the feasible set with its own normaliser.
    pub fn update(&mut self, set: &FeasibleSet, alpha: f64, obs: &Observation) -> Result<(), BeliefError> {
        let ll = self.log_likelihoods(set, alpha, obs)?;
        let log_post: Vec<f64> =
            self.weights.iter().zip(&ll).map(|(w, l)| if *w > 0.0 { w.ln() + l } else { f64::NEG_INFINITY }).collect();
        let z = log_sum_exp(&log_post);
        if !z.is_finite() {
            return Err(BeliefError::Degenerate);
        }
        self.weights = Arc::new(log_post.iter().map(|lp| (lp - z).exp()).collect());
        Ok(())
    }

    /// log P(obs | Q, λ_i) for every particle (eq. 3 / its region form).
    pub fn log_likelihoods(&self, set: &FeasibleSet, alpha: f64, obs: &Observation) -> Result<Vec<f64>, BeliefError> {
        self.per_particle_log_likelihoods(&[(set, obs)], alpha, |_| 0.0)
    }

    /// base(λ_i) + Σ_t log P(obs_t | Q_t, λ_i) for every particle, after checking every
    /// set's dimension and observation; particles go in fixed chunks, so the result is
    /// bit-identical for any number of threads. A particle whose sum reaches −∞ stops there.
    pub(crate) fn per_particle_log_likelihoods(
        &self,
        observed: &[Observed],
        alpha: f64,
        base: impl Fn(&[f64]) -> f64 + Sync,
    ) -> Result<Vec<f64>, BeliefError> {
        check_observed(observed, self.dim)?;
        let s = 2 * self.dim;
        let chunks: Vec<Vec<f64>> = self
            .particles
            .par_chunks(PARTICLE_CHUNK * s)
            .map(|ps| match observed {
                [(set, Observation::Region(idx))] => region_log_likelihoods(set, idx, ps, s, alpha, &base),
                _ => {
                    let mut scratch = scratch_for(observed);
                    ps.chunks_exact(s).map(|p| log_likelihood_at(observed, p, alpha, base(p), &mut scratch)).collect()
                }
            })
            .collect();
        Ok(chunks.concat())
    }

    /// Effective sample size 1 / Σ ω_i².
    pub fn ess(&self) -> f64 {
        1.0 / self.weights.iter().map(|w| w * w).sum::<f64>()
    }

    /// Resamples if `policy` says so; returns whether it did.
    pub fn maybe_resample<R: Rng + ?Sized>(&mut self, policy: ResamplePolicy, jitter: &[f64], rng: &mut R) -> bool {
        let due = match policy {
            ResamplePolicy::EveryUpdate => true,
            ResamplePolicy::EssBelow { fraction } => self.ess() < fraction * self.len() as f64,
        };
        if due {
            self.resample(jitter, rng);
        }
        due
    }

    /// Systematic resampling to N equally weighted particles, then Gaussian jitter with
    /// standard deviation `jitter[c]` on each learned component c, reflected back into the
    /// prior's support.
    pub fn resample<R: Rng + ?Sized>(&mut self, jitter: &[f64], rng: &mut R) {
        let n = self.len();
        let s = 2 * self.dim;
        let step = 1.0 / n as f64;
        let mut u = rng.random::<f64>() * step;
        let mut cumulative = self.weights[0];
        let mut i = 0;
        let mut next = Vec::with_capacity(self.particles.len());
        for _ in 0..n {
            while u > cumulative && i + 1 < n {
                i += 1;
                cumulative += self.weights[i];
            }
            next.extend_from_slice(&self.particles[i * s..(i + 1) * s]);
            u += step;
        }
        for p in next.chunks_exact_mut(s) {
            for &c in &self.free {
                let h = jitter.get(c).copied().unwrap_or(0.0);
                if h > 0.0 {
                    let z: f64 = StandardNormal.sample(rng);
                    p[c] = reflect(p[c] + h * z, self.support[c]);
                }
            }
        }
        self.particles = Arc::new(next);
        self.weights = Arc::new(vec![step; n]);
    }

    /// Posterior mean of λ.
    pub fn mean(&self) -> Lambda {
        let s = 2 * self.dim;
        let mut m = vec![0.0; s];
        for (p, w) in self.particles.chunks_exact(s).zip(self.weights()) {
            for c in 0..s {
                m[c] += w * p[c];
            }
        }
        Lambda::from_slice(&m)
    }

    /// Entropy of the belief on a grid (eq. 6, with the minus sign the paper drops):
    /// H = −Σ_cells P(cell) log P(cell), with 0 log 0 = 0.
    pub fn entropy(&self, grid: &Grid) -> f64 {
        CellIndex::new(self, grid).entropy(&self.weights)
    }

    /// The mode: the weighted mean of the particles in the grid cell of highest mass.
    pub fn mode(&self, grid: &Grid) -> Lambda {
        CellIndex::new(self, grid).mode(self)
    }

    /// Gaussian kernel density of the belief at λ* over the learned components, with one
    /// bandwidth per component of [q*, w].
    pub fn density_at(&self, truth: &Lambda, bandwidth: &[f64]) -> f64 {
        self.log_density_at(truth, bandwidth).exp()
    }

    /// log of [`Belief::density_at`].
    pub fn log_density_at(&self, truth: &Lambda, bandwidth: &[f64]) -> f64 {
        let t = truth.to_vec();
        let s = 2 * self.dim;
        let log_norm: f64 = self.free.iter().map(|&c| -(bandwidth[c] * (2.0 * std::f64::consts::PI).sqrt()).ln()).sum();
        let terms: Vec<f64> = self
            .particles
            .chunks_exact(s)
            .zip(self.weights())
            .map(|(p, &w)| {
                if w <= 0.0 {
                    return f64::NEG_INFINITY;
                }
                let e: f64 = self.free.iter().map(|&c| -0.5 * ((t[c] - p[c]) / bandwidth[c]).powi(2)).sum();
                w.ln() + e
            })
            .collect();
        log_sum_exp(&terms) + log_norm
    }

    /// Euclidean distance between λ and λ* over the learned components.
    pub fn distance(&self, estimate: &Lambda, truth: &Lambda) -> f64 {
        let (a, b) = (estimate.to_vec(), truth.to_vec());
        self.free.iter().map(|&c| (a[c] - b[c]).powi(2)).sum::<f64>().sqrt()
    }
}

/// Reflects x into [lo, hi] (repeatedly, for jumps larger than the window).
fn reflect(mut x: f64, (lo, hi): (f64, f64)) -> f64 {
    for _ in 0..8 {
        if x < lo {
            x = 2.0 * lo - x;
        } else if x > hi {
            x = 2.0 * hi - x;
        } else {
            return x;
        }
    }
    x.clamp(lo, hi)
}

#[cfg(test)]
mod tests;
