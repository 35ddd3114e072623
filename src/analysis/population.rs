//! The population of preferences, learned from a study's own sessions.
//!
//! A hierarchical model: each participant's λ is drawn from a population g_θ — per learned
//! component j a normal (mean μ_j, spread σ_j) truncated to the prior's support, the form of
//! a protocol's `population` section — and each session's observations follow eq. 1/3 (or
//! the measured arm's likelihood) given that participant's λ, with the protocol's α. θ is
//! fitted by maximum marginal likelihood over the sessions,
//!
//!   log p(D | θ) = Σ_s log ∫ L_s(λ) g_θ(λ) dλ,   L_s(λ) = Π_t P(obs_t | Q_t, λ, α),
//!
//! by stochastic-approximation EM (SAEM; Delyon, Lavielle & Moulines 1999): each
//! participant's λ is a Markov chain targeting its posterior under the current population
//! L_s g_θ (an independence step drawn from g_θ, then random-walk steps), the population's
//! sufficient statistics (per component Σ_s x and Σ_s x²) are averaged with step sizes 1
//! during a burn-in and 1/k after it, and each iteration's M-step is the truncated normal
//! with the largest likelihood given them. The intervals are Wald intervals from the
//! observed information by Louis' missing-information principle, I = −∇²Q − Σ_s Cov_s[∇ log
//! g_θ(λ)], its expectations over each participant's chain at the fit (μ on its scale, σ on
//! the log scale).

use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use serde::Serialize;

use super::SessionEvidence;
use crate::belief::{BeliefError, ComponentPrior, Prior};
use crate::ergo::{FeasibleSet, Observation};
use crate::protocol::{PopulationSpec, PriorSpec, Spread, truncated_normal};
use crate::{SeededRng, derive_seed};

/// SAEM iterations with step size 1 (the chains and θ find the fit's neighbourhood) …
pub const BURN_IN: usize = 200;
/// … then iterations whose statistics are averaged (step size 1/k).
pub const AVERAGED: usize = 300;
/// Iterations at the fit whose chains give the observed information.
const INFORMATION: usize = 600;
/// Random-walk steps per iteration, after the independence step.
const WALKS: usize = 2;
/// The acceptance rate the random walk's scale is adapted to during the burn-in.
const TARGET_ACCEPTANCE: f64 = 0.3;
/// The smallest spread fitted, as a share of the support's width (a population of exact
/// copies is not something finite data can tell from a narrow one).
const MIN_SD_SHARE: f64 = 0.002;
/// A spread this many times the support's width is flat on it (density ratios within
/// 1 − 10⁻⁸): the population that stands for a uniform prior.
const FLAT_SD: f64 = 1e4;
/// z of a two-sided 95 % normal interval.
const Z95: f64 = 1.959_963_984_540_054;

/// Seed purpose of a participant's chain (derived from the fit's seed and the session's).
const PURPOSE_CHAIN: u64 = 501;

/// Why a population could not be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PopulationError {
    #[error("{found} sessions, expected at least 2 (one person says nothing about a spread)")]
    TooFewSessions { found: usize },
    #[error("session {index}'s prior differs from the first session's; a population is fitted over one prior")]
    PriorsDiffer { index: usize },
    #[error(
        "session {index} assumed α = {alpha} and the first session α = {first}; a population is fitted over one α (its people are given it)"
    )]
    AlphasDiffer { index: usize, alpha: f64, first: f64 },
    #[error(
        "{found} of the sessions have a handover, expected at least 2: a spread is fitted from people who took something"
    )]
    TooFewHandovers { found: usize },
    #[error("the prior learns no component of λ")]
    NothingLearned,
    #[error("session {index}: {source}")]
    Belief { index: usize, source: BeliefError },
    #[error("session {index}: its observations are impossible at the population's centre")]
    Unexplained { index: usize },
}

/// The fit's seed: the chains' draws derive from it and each session's seed.
#[derive(Clone, Copy, Debug, Default)]
pub struct PopulationSettings {
    pub seed: u64,
}

/// One learned component's fitted spread over people (radians for q*).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ComponentFit {
    /// `q_star` or `w`.
    pub part: &'static str,
    /// The joint's 0-based index; written 1-based (q*1 … q*7), as every screen, table and
    /// JSON output numbers joints.
    #[serde(serialize_with = "one_based")]
    pub joint: usize,
    pub mean: f64,
    pub sd: f64,
    /// 95 % Wald intervals (σ's on the log scale), from the observed information; NaN when
    /// the information does not identify the component.
    pub mean_low: f64,
    pub mean_high: f64,
    pub sd_low: f64,
    pub sd_high: f64,
    /// The prior's support, which the population is truncated to.
    pub min: f64,
    pub max: f64,
    /// The fitted spread is at the smallest the fit allows: the data do not tell this
    /// population from a narrower one.
    pub sd_at_floor: bool,
}

impl ComponentFit {
    /// `q*4`, `w2`: the component as tables and messages name it.
    pub fn name(&self) -> String {
        if self.part == "q_star" { format!("q*{}", self.joint + 1) } else { format!("w{}", self.joint + 1) }
    }
}

/// A 0-based index written 1-based.
fn one_based<S: serde::Serializer>(index: &usize, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_u64(*index as u64 + 1)
}

/// The fitted population and how well the data determine it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PopulationFit {
    pub sessions: usize,
    pub handovers: usize,
    pub components: Vec<ComponentFit>,
    pub iterations: usize,
    /// Every parameter has an interval: none is on the edge of its range, and the observed
    /// information is positive definite (else the ones it does not identify have none).
    pub identified: bool,
    /// The random walk's acceptance rate after the burn-in: the smallest and the median
    /// over participants.
    pub min_acceptance: f64,
    pub median_acceptance: f64,
    /// The α the sessions' protocols assumed (the population's people are given it).
    pub alpha: f64,
    /// Each session's participant, in the order given.
    pub people: Vec<PersonEstimate>,
}

/// One participant's λ (learned components, in the order of [`PopulationFit::components`];
/// radians for q*): the posterior mean and sd under the fitted population (partial pooling:
/// the population as the prior) and under the protocol's prior (the session alone).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PersonEstimate {
    pub pooled_mean: Vec<f64>,
    pub pooled_sd: Vec<f64>,
    pub session_mean: Vec<f64>,
    pub session_sd: Vec<f64>,
}

impl PopulationFit {
    /// The fit as a protocol's `population` section (q* in degrees); components the prior
    /// does not learn get their known value with no spread.
    pub fn spec(&self, prior: &Prior) -> PopulationSpec {
        let dim = prior.dim();
        let mut spreads: Vec<Spread> = prior
            .components()
            .iter()
            .map(|c| {
                let (lo, hi) = c.support();
                Spread { mean: (lo + hi) / 2.0, sd: 0.0 }
            })
            .collect();
        for c in &self.components {
            let i = if c.part == "q_star" { c.joint } else { dim + c.joint };
            spreads[i] = Spread { mean: c.mean, sd: c.sd };
        }
        let degrees = |s: &Spread| Spread { mean: s.mean.to_degrees(), sd: s.sd.to_degrees() };
        PopulationSpec {
            q_star_deg: spreads[..dim].iter().map(degrees).collect(),
            w: spreads[dim..].to_vec(),
            alpha: None,
        }
    }

    /// The next study's prior from this fit, as a protocol's `learning.prior` section (q*
    /// in degrees): each learned component a normal at the fitted mean, truncated to the
    /// support `written` (the sessions' prior, as their protocol wrote it) gives it. Its sd is
    /// never narrower than the data resolve: the larger of the spread's 95 % interval's upper
    /// end (the widest population the data allow) and the median over people of their
    /// session's own posterior sd (what one person's handovers resolve: a population fitted
    /// narrower than that is the fit's shrinkage as much as the people, and a prior that
    /// narrow would outweigh the next person's own data). So a pilot whose people happened to
    /// fit alike cannot make the robot sure of a joint it has barely seen. Only where the data
    /// determine the component (its mean and spread each have an interval, the spread above
    /// the floor) and that sd is narrower than the support (a wider normal is about flat on
    /// it); the other components, and the ones not learned, keep `written`'s prior.
    pub fn prior_spec(&self, written: &PriorSpec) -> PriorSpec {
        let mut next = written.clone();
        for (j, c) in self.components.iter().enumerate() {
            let resolved: Vec<f64> = self.people.iter().filter_map(|p| p.session_sd.get(j).copied()).collect();
            let resolved = if resolved.is_empty() { 0.0 } else { crate::stats::median(&resolved) };
            let sd = c.sd_high.max(resolved);
            let determined = !c.sd_at_floor
                && [c.mean_low, c.mean_high, c.sd_low, c.sd_high].iter().all(|v| v.is_finite())
                && sd < c.max - c.min;
            if !determined {
                continue;
            }
            let (slot, scale) = if c.part == "q_star" {
                (next.q_star_deg.get_mut(c.joint), 180.0 / std::f64::consts::PI)
            } else {
                (next.w.get_mut(c.joint), 1.0)
            };
            if let Some(slot) = slot {
                let (min, max) = slot.support();
                *slot = ComponentPrior::Gaussian { mean: c.mean * scale, sd: sd * scale, min, max };
            }
        }
        next
    }
}

/// One learned component's support.
#[derive(Clone, Copy, Debug)]
struct Support {
    min: f64,
    max: f64,
}

impl Support {
    fn width(self) -> f64 {
        self.max - self.min
    }
    fn min_sd(self) -> f64 {
        MIN_SD_SHARE * self.width()
    }
}

/// A population over the learned components: (μ_j, σ_j).
type Theta = Vec<(f64, f64)>;

/// One participant's chain: its λ (the learned components), ln L_s there, the random walk's
/// scale (a multiple of the population's spread) and its acceptance count.
struct Chain<'a> {
    evidence: &'a SessionEvidence,
    observed: Vec<(&'a FeasibleSet, &'a Observation)>,
    /// The whole λ = [q*, w] with the known components in place.
    lambda: Vec<f64>,
    ll: f64,
    log_scale: f64,
    walks: usize,
    accepted: usize,
    rng: SeededRng,
    scratch: Vec<crate::ergo::Scratch>,
}

impl<'a> Chain<'a> {
    fn new(
        evidence: &'a SessionEvidence,
        free: &[usize],
        theta: &Theta,
        seed: u64,
        index: usize,
    ) -> Result<Self, PopulationError> {
        let observed = evidence.observed();
        let mut rng = SeededRng::seed_from_u64(derive_seed(seed, evidence.seed, PURPOSE_CHAIN));
        let mut lambda = evidence.prior.sample(&mut rng);
        for (&i, &(m, _)) in free.iter().zip(theta) {
            lambda[i] = m;
        }
        // The observations are checked against their sets once, here.
        crate::belief::check_observed(&observed, evidence.prior.dim())
            .map_err(|source| PopulationError::Belief { index, source })?;
        let mut scratch = crate::belief::scratch_for(&observed);
        let ll = crate::belief::log_likelihood_at(&observed, &lambda, evidence.alpha, 0.0, &mut scratch);
        if !ll.is_finite() {
            return Err(PopulationError::Unexplained { index });
        }
        Ok(Self { evidence, observed, lambda, ll, log_scale: 0.0, walks: 0, accepted: 0, rng, scratch })
    }

    /// ln L_s at a whole λ.
    fn log_likelihood(&mut self, lambda: &[f64]) -> f64 {
        crate::belief::log_likelihood_at(&self.observed, lambda, self.evidence.alpha, 0.0, &mut self.scratch)
    }

    /// One iteration: an independence step from g_θ, then [`WALKS`] random-walk steps
    /// (adapting their scale while `adapt`). Returns the mean of x and x² per component over
    /// the states visited.
    fn step(&mut self, free: &[usize], supports: &[Support], theta: &Theta, adapt: Option<usize>) -> Vec<(f64, f64)> {
        let mut stats = vec![(0.0, 0.0); free.len()];
        let record = |lambda: &[f64], stats: &mut Vec<(f64, f64)>| {
            for ((a, b), &i) in stats.iter_mut().zip(free) {
                *a += lambda[i] / (WALKS + 1) as f64;
                *b += lambda[i] * lambda[i] / (WALKS + 1) as f64;
            }
        };
        // Independence: y ~ g_θ; the population's density cancels, L(y)/L(x) remains.
        let mut y = self.lambda.clone();
        for ((&i, &(m, sd)), &s) in free.iter().zip(theta).zip(supports) {
            y[i] = draw(m, sd, s, &mut self.rng);
        }
        let ly = self.log_likelihood(&y);
        if accept(ly - self.ll, &mut self.rng) {
            (self.lambda, self.ll) = (y, ly);
        }
        record(&self.lambda, &mut stats);
        for _ in 0..WALKS {
            let scale = self.log_scale.exp();
            let mut y = self.lambda.clone();
            let mut inside = true;
            let mut log_prior_ratio = 0.0;
            for ((&i, &(m, sd)), s) in free.iter().zip(theta).zip(supports) {
                let z: f64 = StandardNormal.sample(&mut self.rng);
                y[i] = self.lambda[i] + scale * sd.min(s.width()) * z;
                inside &= (s.min..=s.max).contains(&y[i]);
                log_prior_ratio += ((self.lambda[i] - m) / sd).powi(2) / 2.0 - ((y[i] - m) / sd).powi(2) / 2.0;
            }
            let taken = inside && {
                let ly = self.log_likelihood(&y);
                let ok = accept(ly - self.ll + log_prior_ratio, &mut self.rng);
                if ok {
                    (self.lambda, self.ll) = (y, ly);
                }
                ok
            };
            self.walks += 1;
            self.accepted += usize::from(taken);
            if let Some(t) = adapt {
                let rate = if taken { 1.0 } else { 0.0 };
                self.log_scale += (rate - TARGET_ACCEPTANCE) / ((t + 1) as f64).powf(0.6);
            }
            record(&self.lambda, &mut stats);
        }
        stats
    }
}

/// A draw of component N(m, sd²) truncated to its support: uniform on the support when the
/// spread is so wide that the normal is flat there (a uniform prior as a population).
fn draw(m: f64, sd: f64, s: Support, rng: &mut SeededRng) -> f64 {
    if sd >= FLAT_SD * s.width() {
        s.min + s.width() * rng.random::<f64>()
    } else {
        truncated_normal(m, sd, (s.min, s.max), rng)
    }
}

/// Metropolis acceptance of a move with log ratio `log_ratio`.
fn accept(log_ratio: f64, rng: &mut SeededRng) -> bool {
    log_ratio >= 0.0 || rng.random::<f64>().ln() < log_ratio
}

/// Fits the population to the sessions (at least two, one prior).
pub fn fit_population(
    evidence: &[SessionEvidence],
    settings: PopulationSettings,
) -> Result<PopulationFit, PopulationError> {
    if evidence.len() < 2 {
        return Err(PopulationError::TooFewSessions { found: evidence.len() });
    }
    let prior = &evidence[0].prior;
    if let Some(index) = evidence.iter().position(|e| e.prior != *prior) {
        return Err(PopulationError::PriorsDiffer { index });
    }
    let first = evidence[0].alpha;
    if let Some((index, e)) = evidence.iter().enumerate().find(|(_, e)| e.alpha != first) {
        return Err(PopulationError::AlphasDiffer { index, alpha: e.alpha, first });
    }
    // A session without a handover leaves its person's λ where the population puts it: it
    // says nothing of the spread, and a fit of such sessions alone collapses to the floor.
    let with_handovers = evidence.iter().filter(|e| !e.handovers.is_empty()).count();
    if with_handovers < 2 {
        return Err(PopulationError::TooFewHandovers { found: with_handovers });
    }
    let free = prior.free();
    if free.is_empty() {
        return Err(PopulationError::NothingLearned);
    }
    let supports: Vec<Support> = free
        .iter()
        .map(|&i| {
            let (min, max) = prior.components()[i].support();
            Support { min, max }
        })
        .collect();
    let n = evidence.len() as f64;
    let mut theta: Theta = supports.iter().map(|s| ((s.min + s.max) / 2.0, s.width() / 6.0)).collect();
    let mut chains: Vec<Chain> = evidence
        .iter()
        .enumerate()
        .map(|(index, e)| Chain::new(e, &free, &theta, settings.seed, index))
        .collect::<Result<_, _>>()?;
    // The population's sufficient statistics: per component Σ_s E[x], Σ_s E[x²].
    let mut sums = vec![(0.0, 0.0); free.len()];
    for t in 0..BURN_IN + AVERAGED {
        let adapt = (t < BURN_IN).then_some(t);
        let per_chain: Vec<Vec<(f64, f64)>> =
            chains.par_iter_mut().map(|c| c.step(&free, &supports, &theta, adapt)).collect();
        let gamma = if t < BURN_IN { 1.0 } else { 1.0 / (t + 1 - BURN_IN) as f64 };
        for (j, sum) in sums.iter_mut().enumerate() {
            let (a, b) = per_chain.iter().fold((0.0, 0.0), |(a, b), c| (a + c[j].0, b + c[j].1));
            sum.0 += gamma * (a - sum.0);
            sum.1 += gamma * (b - sum.1);
        }
        theta = theta.iter().zip(&supports).zip(&sums).map(|((&old, &s), &(a, b))| m_step(n, a, b, s, old)).collect();
        if t + 1 == BURN_IN {
            for c in &mut chains {
                (c.walks, c.accepted) = (0, 0);
            }
        }
    }
    let mut acceptance: Vec<f64> = chains.iter().map(|c| c.accepted as f64 / c.walks.max(1) as f64).collect();
    acceptance.sort_by(f64::total_cmp);
    let (covariance, pooled) = covariance_at(&mut chains, &free, &supports, &theta, &sums, n);
    let session = session_posteriors(evidence, prior, &free, &supports, settings.seed)?;
    let people = pooled
        .into_iter()
        .zip(session)
        .map(|(pooled, session)| PersonEstimate {
            pooled_mean: pooled.iter().map(|p| p.0).collect(),
            pooled_sd: pooled.iter().map(|p| p.1).collect(),
            session_mean: session.iter().map(|p| p.0).collect(),
            session_sd: session.iter().map(|p| p.1).collect(),
        })
        .collect();
    let dim = prior.dim();
    let components: Vec<ComponentFit> = free
        .iter()
        .enumerate()
        .map(|(j, &i)| {
            let (mean, sd) = theta[j];
            let se_log_sd = covariance[(2 * j + 1, 2 * j + 1)].sqrt();
            // A mean's interval given a spread the data do not determine (collapsed to the
            // floor, most often) would be too narrow: none is given.
            let se_mean = if se_log_sd.is_finite() { covariance[(2 * j, 2 * j)].sqrt() } else { f64::NAN };
            ComponentFit {
                part: if i < dim { "q_star" } else { "w" },
                joint: i % dim,
                mean,
                sd,
                // NaN stays NaN (f64::max would drop it).
                mean_low: if se_mean.is_nan() { f64::NAN } else { (mean - Z95 * se_mean).max(supports[j].min) },
                mean_high: if se_mean.is_nan() { f64::NAN } else { (mean + Z95 * se_mean).min(supports[j].max) },
                sd_low: sd * (-Z95 * se_log_sd).exp(),
                sd_high: sd * (Z95 * se_log_sd).exp(),
                min: supports[j].min,
                max: supports[j].max,
                sd_at_floor: sd <= supports[j].min_sd() * (1.0 + 1e-9),
            }
        })
        .collect();
    Ok(PopulationFit {
        sessions: evidence.len(),
        handovers: evidence.iter().map(|e| e.handovers.len()).sum(),
        components,
        iterations: BURN_IN + AVERAGED,
        identified: (0..2 * free.len()).all(|k| covariance[(k, k)].is_finite()),
        min_acceptance: acceptance[0],
        median_acceptance: crate::stats::median(&acceptance),
        alpha: evidence[0].alpha,
        people,
    })
}

/// Per learned component (E x, E x²) of a participant's chain.
type Moments = Vec<(f64, f64)>;

/// (mean, sd) from (E x, E x²).
fn mean_sd(moments: Moments) -> Vec<(f64, f64)> {
    moments.into_iter().map(|(a, b)| (a, (b - a * a).max(0.0).sqrt())).collect()
}

/// Each participant's posterior mean and sd per learned component under the prior alone,
/// from every handover of their session: the per-session estimate the pooled one is set
/// beside. The same chains, with the prior as the population (a uniform component as a flat
/// normal, a Gaussian one as itself), [`BURN_IN`] adapting iterations and [`INFORMATION`]
/// recorded ones.
fn session_posteriors(
    evidence: &[SessionEvidence],
    prior: &Prior,
    free: &[usize],
    supports: &[Support],
    seed: u64,
) -> Result<Vec<Vec<(f64, f64)>>, PopulationError> {
    let theta: Theta = free
        .iter()
        .zip(supports)
        .map(|(&i, s)| match prior.components()[i] {
            crate::belief::ComponentPrior::Gaussian { mean, sd, .. } => (mean, sd),
            _ => ((s.min + s.max) / 2.0, FLAT_SD * s.width()),
        })
        .collect();
    let mut chains: Vec<Chain> = evidence
        .iter()
        .enumerate()
        .map(|(index, e)| Chain::new(e, free, &theta, derive_seed(seed, 1, PURPOSE_CHAIN), index))
        .collect::<Result<_, _>>()?;
    Ok(chains
        .par_iter_mut()
        .map(|c| {
            for t in 0..BURN_IN {
                c.step(free, supports, &theta, Some(t));
            }
            let mut moments = vec![(0.0, 0.0); free.len()];
            for _ in 0..INFORMATION {
                for (m, s) in moments.iter_mut().zip(c.step(free, supports, &theta, None)) {
                    m.0 += s.0 / INFORMATION as f64;
                    m.1 += s.1 / INFORMATION as f64;
                }
            }
            mean_sd(moments)
        })
        .collect())
}

/// The covariance of (μ_j, ln σ_j) at the fit: the inverse of the observed information by
/// Louis' principle, −∇²Q(θ) − Σ_s Cov_s[∇ ln g_θ(λ_s)], with each participant's posterior
/// covariance of the score from [`INFORMATION`] further iterations of its chain. NaN for a
/// parameter on the edge of its range and for one the data do not identify. Also each
/// participant's posterior mean and sd per component under the fitted population (the
/// partially pooled estimate), from the same iterations.
fn covariance_at(
    chains: &mut [Chain],
    free: &[usize],
    supports: &[Support],
    theta: &Theta,
    sums: &[(f64, f64)],
    n: f64,
) -> (DMatrix<f64>, Vec<Vec<(f64, f64)>>) {
    let f = free.len();
    let p = 2 * f;
    // The score of ln g_θ(λ) in (μ_j, ln σ_j): ((x − μ)/σ², (x − μ)²/σ²) up to constants
    // that do not depend on λ (and so do not vary within a participant's posterior).
    let score = |c: &Chain| -> Vec<f64> {
        free.iter()
            .zip(theta)
            .flat_map(|(&i, &(m, sd))| {
                let d = c.lambda[i] - m;
                [d / (sd * sd), d * d / (sd * sd)]
            })
            .collect()
    };
    let (covariances, moments): (Vec<DMatrix<f64>>, Vec<Moments>) = chains
        .par_iter_mut()
        .map(|c| {
            let (mut mean, mut outer) = (DVector::zeros(p), DMatrix::zeros(p, p));
            let mut moments = vec![(0.0, 0.0); f];
            for _ in 0..INFORMATION {
                for (m, s) in moments.iter_mut().zip(c.step(free, supports, theta, None)) {
                    m.0 += s.0 / INFORMATION as f64;
                    m.1 += s.1 / INFORMATION as f64;
                }
                let v = DVector::from_vec(score(c));
                outer += &v * v.transpose();
                mean += v;
            }
            let k = INFORMATION as f64;
            let mean = mean / k;
            (outer / k - &mean * mean.transpose(), moments)
        })
        .unzip();
    let people = moments.into_iter().map(mean_sd).collect();
    let mut information = DMatrix::zeros(p, p);
    for (j, (&(m, sd), &s)) in theta.iter().zip(supports).enumerate() {
        let (a, b) = sums[j];
        let q = |m: f64, t: f64| -> f64 { -m_step_objective(n, a, b, s, m, t) };
        let t = sd.ln();
        let (hm, ht) = (1e-4 * s.width(), 1e-4);
        let h_mm = (q(m + hm, t) - 2.0 * q(m, t) + q(m - hm, t)) / (hm * hm);
        let h_tt = (q(m, t + ht) - 2.0 * q(m, t) + q(m, t - ht)) / (ht * ht);
        let h_mt = (q(m + hm, t + ht) - q(m + hm, t - ht) - q(m - hm, t + ht) + q(m - hm, t - ht)) / (4.0 * hm * ht);
        information[(2 * j, 2 * j)] += h_mm;
        information[(2 * j + 1, 2 * j + 1)] += h_tt;
        information[(2 * j, 2 * j + 1)] += h_mt;
        information[(2 * j + 1, 2 * j)] += h_mt;
    }
    for c in covariances {
        information -= c;
    }
    // A parameter on the edge of its range (σ at the floor or the width, μ at a support's
    // end) is not a regular maximum: it is left out and the others' covariance given.
    let mut kept: Vec<usize> = (0..p)
        .filter(|&k| {
            let (j, s) = (k / 2, supports[k / 2]);
            let (m, sd) = theta[j];
            let near = |a: f64, b: f64| (a - b).abs() <= 1e-6 * s.width();
            if k % 2 == 0 { !near(m, s.min) && !near(m, s.max) } else { !near(sd, s.min_sd()) && !near(sd, s.width()) }
        })
        .collect();
    // While the information of the parameters kept is not positive definite, the one the
    // data say least about (the smallest information left after the others) is left out:
    // the others still get intervals.
    loop {
        let sub = DMatrix::from_fn(kept.len(), kept.len(), |a, b| information[(kept[a], kept[b])]);
        if let Some(c) = sub.clone().cholesky() {
            let inverse = c.inverse();
            let mut covariance = DMatrix::from_element(p, p, f64::NAN);
            for (a, &ka) in kept.iter().enumerate() {
                for (b, &kb) in kept.iter().enumerate() {
                    covariance[(ka, kb)] = inverse[(a, b)];
                }
            }
            return (covariance, people);
        }
        if kept.len() <= 1 {
            return (DMatrix::from_element(p, p, f64::NAN), people);
        }
        let worst = (0..kept.len())
            .min_by(|&a, &b| {
                let own =
                    |k: usize| sub[(k, k)] / sub.row(k).iter().map(|v| v.abs()).sum::<f64>().max(f64::MIN_POSITIVE);
                own(a).total_cmp(&own(b))
            })
            .unwrap_or(0);
        kept.remove(worst);
    }
}

/// The M-step's objective for one component: Σ_s E ln TN(x_s; μ, e^t) given Σ E x = a and
/// Σ E x² = b over n participants (up to the constant −n ln √(2π)).
fn m_step_objective(n: f64, a: f64, b: f64, s: Support, m: f64, t: f64) -> f64 {
    let sd = t.exp();
    -(n * t + (b - 2.0 * m * a + m * m * n) / (2.0 * sd * sd) + n * log_truncation_mass(m, sd, s.min, s.max))
}

/// The M-step of one component: the truncated normal on its support with the largest
/// weighted log-likelihood given n sessions' weights' Σ r x = a and Σ r x² = b, over μ in
/// the support and σ from the floor to the width (Nelder–Mead in (μ, ln σ), from `old`; the
/// old value is kept unless the new one is better).
fn m_step(n: f64, a: f64, b: f64, s: Support, old: (f64, f64)) -> (f64, f64) {
    let clamp = |p: [f64; 2]| [p[0].clamp(s.min, s.max), p[1].clamp(s.min_sd().ln(), s.width().ln())];
    let objective = |p: [f64; 2]| {
        let [m, t] = clamp(p);
        m_step_objective(n, a, b, s, m, t)
    };
    let start = [old.0, old.1.ln()];
    let best = clamp(nelder_mead(objective, start, [0.05 * s.width(), 0.2]));
    if objective(best) > objective(clamp(start)) { (best[0], best[1].exp()) } else { old }
}

/// Maximises f over two parameters by Nelder–Mead from `start` with initial steps `step`
/// (a fixed number of iterations at most: it stops when the simplex's values agree).
fn nelder_mead(f: impl Fn([f64; 2]) -> f64, start: [f64; 2], step: [f64; 2]) -> [f64; 2] {
    let mut simplex = [start, [start[0] + step[0], start[1]], [start[0], start[1] + step[1]]];
    let mut values = simplex.map(&f);
    for _ in 0..200 {
        let mut order = [0, 1, 2];
        order.sort_by(|&i, &j| values[j].total_cmp(&values[i]));
        let (best, mid, worst) = (order[0], order[1], order[2]);
        if (values[best] - values[worst]).abs() <= 1e-12 * (1.0 + values[best].abs()) {
            break;
        }
        let centroid = [(simplex[best][0] + simplex[mid][0]) / 2.0, (simplex[best][1] + simplex[mid][1]) / 2.0];
        let towards = |t: f64| {
            [centroid[0] + t * (simplex[worst][0] - centroid[0]), centroid[1] + t * (simplex[worst][1] - centroid[1])]
        };
        let reflected = towards(-1.0);
        let fr = f(reflected);
        if fr > values[best] {
            let expanded = towards(-2.0);
            let fe = f(expanded);
            (simplex[worst], values[worst]) = if fe > fr { (expanded, fe) } else { (reflected, fr) };
        } else if fr > values[mid] {
            (simplex[worst], values[worst]) = (reflected, fr);
        } else {
            let contracted = towards(0.5);
            let fc = f(contracted);
            if fc > values[worst] {
                (simplex[worst], values[worst]) = (contracted, fc);
            } else {
                for i in [mid, worst] {
                    simplex[i] = [
                        simplex[best][0] + 0.5 * (simplex[i][0] - simplex[best][0]),
                        simplex[best][1] + 0.5 * (simplex[i][1] - simplex[best][1]),
                    ];
                    values[i] = f(simplex[i]);
                }
            }
        }
    }
    let best = (0..3).max_by(|&i, &j| values[i].total_cmp(&values[j])).unwrap_or(0);
    simplex[best]
}

/// ln(Φ((max − μ)/σ) − Φ((min − μ)/σ)): the share of N(μ, σ²) inside [min, max] (0 for
/// an unbounded support).
fn log_truncation_mass(mean: f64, sd: f64, min: f64, max: f64) -> f64 {
    if !(min.is_finite() && max.is_finite()) {
        return 0.0;
    }
    let phi = |z: f64| 0.5 * statrs::function::erf::erfc(-z / std::f64::consts::SQRT_2);
    let (lo, hi) = ((min - mean) / sd, (max - mean) / sd);
    // Subtract in the tail where both terms are small.
    let mass = if lo > 0.0 { phi(-lo) - phi(-hi) } else { phi(hi) - phi(lo) };
    mass.max(f64::MIN_POSITIVE).ln()
}

/// ln of the density of N(μ, σ²) truncated to [min, max] at x (−∞ outside).
#[cfg(test)]
fn log_truncated_normal(x: f64, mean: f64, sd: f64, min: f64, max: f64) -> f64 {
    if !(min..=max).contains(&x) {
        return f64::NEG_INFINITY;
    }
    let z = (x - mean) / sd;
    -0.5 * z * z - sd.ln() - 0.5 * (2.0 * std::f64::consts::PI).ln() - log_truncation_mass(mean, sd, min, max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::Handover;
    use crate::belief::{Belief, ComponentPrior};
    use crate::ergo::ConfigSet;
    use crate::ergo::Lambda;
    use crate::participant::SimulatedPerson;
    use crate::protocol::{Population, Study};
    use crate::session::choice_set;
    use rand_distr::Normal;

    /// A handover of `set` in which configuration `j` was taken: observed as the arm
    /// measured with noise σ (degrees), or as the region it lies in.
    fn handover(set: &FeasibleSet, j: usize, sigma_deg: Option<f64>, rng: &mut SeededRng) -> Handover {
        let region = set.regions().iter().position(|r| r.contains(&j)).unwrap();
        let observation = match sigma_deg {
            Some(s) => {
                let d = set.dim();
                let noise = Normal::new(0.0, s.to_radians()).unwrap();
                let q_m: Vec<f64> = (0..d).map(|k| set.configs().joint(k)[j] + noise.sample(rng)).collect();
                Observation::measured(set.configs(), &q_m, &vec![s.to_radians(); d]).unwrap()
            }
            None => Observation::Region(set.regions()[region].clone().collect()),
        };
        Handover { set: set.clone(), region, observation }
    }

    /// People drawn from `population`, each offered `handovers` training queries of the
    /// default study at random.
    fn people(
        population: &Population,
        n: usize,
        handovers: usize,
        sigma_deg: Option<f64>,
        seed: u64,
    ) -> Vec<SessionEvidence> {
        let study = Study::default_study();
        let sets: Vec<FeasibleSet> = study.training.iter().map(|q| choice_set(&q.feasible)).collect();
        (0..n)
            .map(|i| {
                let person = SimulatedPerson { truth: population.draw(seed, i), alpha: population.alpha };
                let mut rng = SeededRng::seed_from_u64(derive_seed(seed, i as u64, 9));
                let handovers = (0..handovers)
                    .map(|_| {
                        let set = &sets[rng.random_range(0..sets.len())];
                        let j = person.choose(set, &mut rng);
                        handover(set, j, sigma_deg, &mut rng)
                    })
                    .collect();
                SessionEvidence { prior: study.prior.clone(), alpha: population.alpha, seed: i as u64, handovers }
            })
            .collect()
    }

    fn population(sd_deg: f64) -> (Population, PopulationSpec) {
        let study = Study::default_study();
        let spec = PopulationSpec {
            q_star_deg: [20.0, 15.0, 10.0, 90.0, 10.0, -5.0, -5.0].map(|mean| Spread { mean, sd: sd_deg }).to_vec(),
            w: vec![Spread { mean: 1.0, sd: 0.0 }; 7],
            alpha: None,
        };
        (Population::new(Some(&spec), &study.prior, study.protocol.learning.alpha), spec)
    }

    /// Sessions a population cannot be fitted over are refused before any work, naming why:
    /// fewer than two with a handover (none at all, or one), or protocols of different α.
    #[test]
    fn a_fit_without_handovers_or_over_different_alphas_is_refused() {
        let (pop, _) = population(10.0);
        let settings = PopulationSettings::default();
        for with_handovers in [0, 1] {
            let mut evidence = people(&pop, 4, 3, None, 7);
            for e in &mut evidence[with_handovers..] {
                e.handovers.clear();
            }
            assert_eq!(
                fit_population(&evidence, settings),
                Err(PopulationError::TooFewHandovers { found: with_handovers })
            );
        }
        let mut evidence = people(&pop, 4, 3, None, 7);
        evidence[2].alpha = 20.0;
        let e = fit_population(&evidence, settings).unwrap_err();
        assert_eq!(e, PopulationError::AlphasDiffer { index: 2, alpha: 20.0, first: pop.alpha });
        assert!(e.to_string().contains("α = 20"), "{e}");
    }

    #[test]
    fn the_fit_and_its_interval_match_the_marginal_likelihood_by_quadrature() {
        // One learned joint, three configurations in two regions, 40 people from
        // TN(0.8, 0.5) on [−1, 3], each seen 6 times: the exact log marginal likelihood by a
        // trapezoid rule over λ, maximised over a fine grid of θ, and its curvature.
        let set = FeasibleSet::with_regions(ConfigSet::from_rows(&[[0.0], [1.0], [2.5]]).unwrap(), &[0, 1, 1]).unwrap();
        let prior = Prior::new(
            vec![ComponentPrior::Uniform { min: -1.0, max: 3.0 }],
            vec![ComponentPrior::Fixed { value: 1.0 }],
        )
        .unwrap();
        let mut rng = SeededRng::seed_from_u64(5);
        let evidence: Vec<SessionEvidence> = (0..40)
            .map(|i| {
                let truth = Lambda { q_star: vec![truncated_normal(0.8, 0.5, (-1.0, 3.0), &mut rng)], w: vec![1.0] };
                let person = SimulatedPerson { truth, alpha: 3.0 };
                let handovers = (0..6)
                    .map(|t| {
                        let j = person.choose(&set, &mut rng);
                        handover(&set, j, (t % 2 == 0).then_some(30.0), &mut rng)
                    })
                    .collect();
                SessionEvidence { prior: prior.clone(), alpha: 3.0, seed: i, handovers }
            })
            .collect();
        let n = 2000;
        let grid: Vec<f64> = (0..=n).map(|i| -1.0 + 4.0 * i as f64 / n as f64).collect();
        let lambdas: Vec<Lambda> = grid.iter().map(|&q| Lambda { q_star: vec![q], w: vec![1.0] }).collect();
        let beliefs = Belief::from_particles(&lambdas, &vec![1.0; n + 1]).unwrap();
        let likelihoods: Vec<Vec<f64>> = evidence
            .iter()
            .map(|e| {
                let pairs = e.observed();
                beliefs.per_particle_log_likelihoods(&pairs, 3.0, |_| 0.0).unwrap().iter().map(|l| l.exp()).collect()
            })
            .collect();
        let h = 4.0 / n as f64;
        let log_marginal = |m: f64, t: f64| -> f64 {
            let g: Vec<f64> = grid.iter().map(|&x| log_truncated_normal(x, m, t.exp(), -1.0, 3.0).exp()).collect();
            likelihoods
                .iter()
                .map(|l| {
                    let f: Vec<f64> = l.iter().zip(&g).map(|(a, b)| a * b).collect();
                    (h * (f.iter().sum::<f64>() - 0.5 * (f[0] + f[n]))).ln()
                })
                .sum()
        };
        let mut best = (f64::NEG_INFINITY, 0.0, 0.0);
        for i in 0..=160 {
            for k in 0..=80 {
                let (m, t) = (0.0 + 0.01 * i as f64, (0.1f64).ln() + 0.025 * k as f64);
                let v = log_marginal(m, t);
                if v > best.0 {
                    best = (v, m, t);
                }
            }
        }
        let (_, m, t) = best;
        let (hm, ht) = (0.01, 0.02);
        let h_mm = -(log_marginal(m + hm, t) - 2.0 * log_marginal(m, t) + log_marginal(m - hm, t)) / (hm * hm);
        let h_tt = -(log_marginal(m, t + ht) - 2.0 * log_marginal(m, t) + log_marginal(m, t - ht)) / (ht * ht);
        let h_mt = -(log_marginal(m + hm, t + ht) - log_marginal(m + hm, t - ht) - log_marginal(m - hm, t + ht)
            + log_marginal(m - hm, t - ht))
            / (4.0 * hm * ht);
        let det = h_mm * h_tt - h_mt * h_mt;
        let (se_m, se_t) = ((h_tt / det).sqrt(), (h_mm / det).sqrt());
        let fit = fit_population(&evidence, PopulationSettings { seed: 2 }).unwrap();
        let c = &fit.components[0];
        let (fit_se_m, fit_se_t) = ((c.mean_high - c.mean_low) / (2.0 * Z95), (c.sd_high / c.sd).ln() / Z95);
        eprintln!(
            "quadrature μ {m:.3} ± {se_m:.3}, σ {:.3} (ln σ ± {se_t:.3}); fit μ {:.3} ± {fit_se_m:.3}, σ {:.3} (ln σ ± {fit_se_t:.3})",
            t.exp(),
            c.mean,
            c.sd
        );
        assert!((c.mean - m).abs() < 0.25 * se_m + 0.01, "μ: fit {} vs {m}", c.mean);
        assert!((c.sd.ln() - t).abs() < 0.25 * se_t + 0.025, "σ: fit {} vs {}", c.sd, t.exp());
        assert!((fit_se_m / se_m - 1.0).abs() < 0.25, "se(μ): fit {fit_se_m} vs {se_m}");
        assert!((fit_se_t / se_t - 1.0).abs() < 0.25, "se(ln σ): fit {fit_se_t} vs {se_t}");
        // Each participant's posterior mean alone (uniform prior) and pooled (the fitted
        // population as prior), against quadrature, within a fifth of the posterior's sd.
        let moments = |l: &[f64], g: &dyn Fn(f64) -> f64| -> (f64, f64) {
            let w: Vec<f64> = l.iter().zip(&grid).map(|(l, &x)| l * g(x)).collect();
            let z: f64 = w.iter().sum();
            let m = w.iter().zip(&grid).map(|(w, x)| w * x).sum::<f64>() / z;
            (m, (w.iter().zip(&grid).map(|(w, x)| w * (x - m).powi(2)).sum::<f64>() / z).sqrt())
        };
        for (person, l) in fit.people.iter().zip(&likelihoods).take(5) {
            let (m, sd) = moments(l, &|_| 1.0);
            assert!((person.session_mean[0] - m).abs() < 0.2 * sd, "alone: {} vs {m} ± {sd}", person.session_mean[0]);
            assert!((person.session_sd[0] / sd - 1.0).abs() < 0.2, "alone sd: {} vs {sd}", person.session_sd[0]);
            let (m, sd) = moments(l, &|x| log_truncated_normal(x, c.mean, c.sd, -1.0, 3.0).exp());
            assert!((person.pooled_mean[0] - m).abs() < 0.2 * sd, "pooled: {} vs {m} ± {sd}", person.pooled_mean[0]);
            assert!((person.pooled_sd[0] / sd - 1.0).abs() < 0.2, "pooled sd: {} vs {sd}", person.pooled_sd[0]);
        }
    }

    #[test]
    fn the_next_prior_is_the_fitted_population_where_the_data_determine_it() {
        let study = Study::default_study();
        let written = study.protocol.learning.prior.clone();
        let component = |joint: usize, mean_deg: f64, sd_deg: f64, sd_at_floor: bool, interval: bool| {
            let end = |v: f64| if interval { v.to_radians() } else { f64::NAN };
            ComponentFit {
                part: "q_star",
                joint,
                mean: mean_deg.to_radians(),
                sd: sd_deg.to_radians(),
                mean_low: end(mean_deg - 3.0),
                mean_high: end(mean_deg + 3.0),
                sd_low: end(sd_deg / 2.0),
                sd_high: end(sd_deg * 2.0),
                min: 0.0,
                max: 1.0,
                sd_at_floor,
            }
        };
        let fit = PopulationFit {
            sessions: 2,
            handovers: 10,
            components: vec![
                component(3, 88.0, 12.0, false, true),
                component(5, 1.0, 0.2, true, false),
                // A spread without an interval: a few people fitted near the floor.
                component(6, -8.0, 0.1, false, false),
                // A pilot whose people were alike by chance (seed 31022's q*1: 2.1° fitted,
                // 11.7° true, interval [0.01°, 287°]): the data allow a population wider than
                // the support, so the next prior stays as written, not a 2° normal.
                ComponentFit {
                    sd_low: 0.01f64.to_radians(),
                    sd_high: 287f64.to_radians(),
                    ..component(0, 20.0, 2.1, false, true)
                },
            ],
            iterations: 1,
            identified: false,
            min_acceptance: 0.3,
            median_acceptance: 0.3,
            alpha: 5.0,
            people: Vec::new(),
        };
        let next = fit.prior_spec(&written);
        // Three people whose own sessions resolved joint 4 to 30°, 40° and 50°: the median,
        // 40°, is wider than the spread's interval's end (24°), and is the next prior's sd.
        let person = |sd_deg: f64| PersonEstimate {
            pooled_mean: vec![0.0; 4],
            pooled_sd: vec![0.0; 4],
            session_mean: vec![0.0; 4],
            session_sd: vec![sd_deg.to_radians(), 0.0, 0.0, 0.0],
        };
        let resolved = PopulationFit { people: vec![person(30.0), person(50.0), person(40.0)], ..fit.clone() };
        match resolved.prior_spec(&written).q_star_deg[3] {
            ComponentPrior::Gaussian { sd, .. } => assert!((sd - 40.0).abs() < 1e-9, "{sd}"),
            ref other => panic!("joint 4: {other:?}"),
        }
        let (min, max) = written.q_star_deg[3].support();
        match next.q_star_deg[3] {
            ComponentPrior::Gaussian { mean, sd, min: lo, max: hi } => {
                // The spread's interval's upper end (2 × 12° here), not the estimate.
                assert!((mean - 88.0).abs() < 1e-9 && (sd - 24.0).abs() < 1e-9, "{mean} {sd}");
                assert_eq!((lo, hi), (min, max), "the written support");
            }
            ref other => panic!("joint 4: {other:?}"),
        }
        // At the floor, without an interval, wider than the support, and every component not
        // fitted: as written.
        for j in (0..7).filter(|&j| j != 3) {
            assert_eq!(next.q_star_deg[j], written.q_star_deg[j], "joint {}", j + 1);
        }
        assert_eq!(next.w, written.w);
        // A protocol with it is valid, and its prior is the fitted normal.
        let mut protocol = study.protocol.clone();
        protocol.learning.prior = next;
        let text = serde_json::to_string(&protocol).unwrap();
        let next_study = Study::from_json(&text, "next").unwrap();
        assert!(matches!(next_study.prior.components()[3], ComponentPrior::Gaussian { .. }));
    }

    #[test]
    fn truncated_normal_maximum_likelihood_recovers_its_parameters() {
        // Many exact draws: the M-step alone.
        let s = Support { min: -1.0, max: 2.0 };
        let mut rng = SeededRng::seed_from_u64(3);
        for (m, sd) in [(0.5, 0.3), (-0.8, 0.6), (1.5, 2.0)] {
            let x: Vec<f64> = (0..20_000).map(|_| truncated_normal(m, sd, (s.min, s.max), &mut rng)).collect();
            let (a, b) = (x.iter().sum::<f64>(), x.iter().map(|v| v * v).sum::<f64>());
            let mut fit = (0.5, 0.5);
            for _ in 0..50 {
                fit = m_step(x.len() as f64, a, b, s, fit);
            }
            assert!((fit.0 - m).abs() < 0.05 * sd.max(0.5) && (fit.1 / sd - 1.0).abs() < 0.1, "({m}, {sd}): {fit:?}");
        }
    }

    /// A known population is recovered from measured arms (σ = 5°, 30 handovers each) of
    /// consistent people (α = 20, as the fit assumes): a wide one's means within their 95 %
    /// intervals (6 of 7 at least) and its spreads (5 of 7: one study's draw of 24 people),
    /// a narrow one fitted narrow and centred.
    #[test]
    fn a_known_population_is_recovered_from_measured_arms() {
        for (sd_deg, people_n) in [(15.0, 24), (5.0, 24)] {
            let (mut pop, spec) = population(sd_deg);
            pop.alpha = 20.0;
            let mut evidence = people(&pop, people_n, 30, Some(5.0), 11);
            for e in &mut evidence {
                e.alpha = pop.alpha;
            }
            let fit = fit_population(&evidence, PopulationSettings { seed: 1 }).unwrap();
            let (mut means, mut spreads) = (0, 0);
            for (c, truth) in fit.components.iter().zip(&spec.q_star_deg) {
                let (m, sd) = (c.mean.to_degrees(), c.sd.to_degrees());
                eprintln!(
                    "sd {sd_deg}° n {people_n} joint {}: mean {m:.1} [{:.1}, {:.1}] (truth {}), sd {sd:.1} [{:.1}, {:.1}]",
                    c.joint,
                    c.mean_low.to_degrees(),
                    c.mean_high.to_degrees(),
                    truth.mean,
                    c.sd_low.to_degrees(),
                    c.sd_high.to_degrees()
                );
                if sd_deg > 10.0 {
                    // A component without an interval (its spread not determined) is not
                    // counted as recovered.
                    means += usize::from((c.mean_low..=c.mean_high).contains(&truth.mean.to_radians()));
                    spreads += usize::from((c.sd_low..=c.sd_high).contains(&truth.sd.to_radians()));
                } else {
                    means += usize::from((m - truth.mean).abs() < 8.0);
                    spreads += usize::from(sd < 10.0);
                }
            }
            assert!(means >= 6 && spreads >= 5, "sd {sd_deg}°: {means} means and {spreads} spreads of 7 recovered");
        }
    }

    /// How many participants a population fit takes: errors of the fitted means, the fitted
    /// spreads and the means' interval coverage over studies, by size, α and spread
    /// (measured arms, σ = 5°, and regions; 26 random training handovers each, as a default
    /// session has). Minutes in a release build:
    /// `cargo test --release --lib population_recovery_by_size -- --ignored --nocapture`.
    /// `HANDOVER_RECOVERY_STUDIES` studies per row (default 2), the people of study k drawn
    /// with seed `HANDOVER_RECOVERY_SEED` + k (default 7000); `benches/readme_results.py`
    /// runs it on fresh seeds.
    #[test]
    #[ignore]
    fn population_recovery_by_size() {
        let setting = |name: &str, default: u64| {
            std::env::var(name).map_or(default, |v| v.parse().unwrap_or_else(|_| panic!("{name}={v}: not a number")))
        };
        let (first_seed, studies) = (setting("HANDOVER_RECOVERY_SEED", 7000), setting("HANDOVER_RECOVERY_STUDIES", 2));
        println!(
            "observation,alpha,sd_deg,participants,study,seed,mean_abs_error_deg,median_fitted_sd_deg,means_with_interval,means_covered,sds_with_interval,sds_covered,identified"
        );
        for (observation, alpha, sd_deg, sizes) in [
            ("measured", 5.0, 15.0, vec![12, 48]),
            ("measured", 20.0, 15.0, vec![12, 48]),
            ("measured", 5.0, 5.0, vec![12, 48]),
            ("measured", 20.0, 5.0, vec![12, 48]),
            ("region", 5.0, 15.0, vec![48]),
        ] {
            for n in sizes {
                for study in 0..studies {
                    let (mut pop, spec) = population(sd_deg);
                    pop.alpha = alpha;
                    let sigma = (observation == "measured").then_some(5.0);
                    let mut evidence = people(&pop, n, 26, sigma, first_seed + study);
                    for e in &mut evidence {
                        e.alpha = alpha;
                    }
                    let fit = fit_population(&evidence, PopulationSettings { seed: study }).unwrap();
                    let errors: Vec<f64> = fit
                        .components
                        .iter()
                        .zip(&spec.q_star_deg)
                        .map(|(c, t)| (c.mean.to_degrees() - t.mean).abs())
                        .collect();
                    let sds: Vec<f64> = fit.components.iter().map(|c| c.sd.to_degrees()).collect();
                    // (components with an interval, intervals holding the truth) of one
                    // parameter: its (low, high) and the true value in degrees.
                    let coverage = |pick: fn(&ComponentFit, &Spread) -> (f64, f64, f64)| {
                        let picked: Vec<_> =
                            fit.components.iter().zip(&spec.q_star_deg).map(|(c, t)| pick(c, t)).collect();
                        let with = picked.iter().filter(|(low, _, _)| low.is_finite()).count();
                        (with, picked.iter().filter(|(low, high, t)| (*low..=*high).contains(&t.to_radians())).count())
                    };
                    let (with_interval, covered) = coverage(|c, t| (c.mean_low, c.mean_high, t.mean));
                    let (sds_with_interval, sds_covered) = coverage(|c, t| (c.sd_low, c.sd_high, t.sd));
                    println!(
                        "{observation},{alpha},{sd_deg},{n},{study},{},{:.1},{:.1},{with_interval},{covered},{sds_with_interval},{sds_covered},{}",
                        first_seed + study,
                        crate::stats::mean(&errors),
                        crate::stats::median(&sds),
                        fit.identified
                    );
                }
            }
        }
    }
}
