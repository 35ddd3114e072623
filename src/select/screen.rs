//! `active`'s and `passive`'s float64 choices for a region outcome, found with float32
//! passes where a proven error bound decides them (what a plan runs: it reports the choice,
//! not the scores).
//!
//! Every query is scored in float32 together with a bound E_q ≥ |I_f32 − I| + |I_f64 − I|
//! (I the exact information gain of the particles, I_f32 and I_f64 what the two passes
//! compute). A query q with I_f32(q) + E_q < I_f32(b) − E_b for the float32 best b has
//! I_f64(q) < I_f64(b), so it cannot be float64's choice; the remaining queries are scored
//! in float64 and the earliest of the largest is taken: float64's own argmax over the whole
//! menu, bit for bit. `passive` is screened the same way on the expected cost, whose float32
//! error is bounded through each particle's minimum cost ([`min_cost_error`]). One float32
//! pass serves both ([`Screen`]): a session's conditions start from the same belief.
//! docs/engine.md ("The float32 screen") derives the bounds step by step; the comments below
//! name the steps.

use rayon::prelude::*;

use super::information::{DiscretePass, Float32, Float64, chunks, discrete_passes, expected_costs};
use super::{Precision, QueryValue, argmax};
use crate::belief::{Belief, PARTICLE_CHUNK};
use crate::ergo::{FeasibleSet, cross_min_f32, weighted_norms_f32};

/// What one precision's set pass rounds.
#[derive(Clone, Copy, Debug)]
pub(super) struct Rounding {
    /// The unit roundoff of its arithmetic per configuration.
    unit: f64,
    /// The relative error of its exponential (tested over its whole range:
    /// `the_lane_exponential_matches_std_to_a_few_ulps`,
    /// `the_float32_exponential_is_within_a_few_ulps`).
    exp_error: f64,
    /// The lanes each sum of weights is accumulated in.
    lanes: usize,
}

const U64: f64 = f64::EPSILON / 2.0;
pub(super) const FLOAT64: Rounding = Rounding { unit: U64, exp_error: 1e-15, lanes: 8 };
pub(super) const FLOAT32: Rounding = Rounding { unit: f32::EPSILON as f64 / 2.0, exp_error: 4e-7, lanes: 16 };

/// The bound is doubled before it is used: a margin for the rounding of the bound's own
/// arithmetic and anything its derivation's second-order steps round up too little.
const SAFETY: f64 = 2.0;

/// γ_k = k·u / (1 − k·u): the relative error of k roundings (Higham), +∞ once it means
/// nothing.
fn gamma(k: f64, unit: f64) -> f64 {
    let ku = k * unit;
    if ku < 0.5 { ku / (1.0 - ku) } else { f64::INFINITY }
}

/// The cost rounding of one particle's pass: |Ĉ − C| ≤ ΔC(C) = γ_D·C + 2uG(1 + γ_D)·√C +
/// u²G²(1 + γ_D), G² = Σ_d g_d², g_d = 3.03·√w_d·(reach_d + |q*_d|) (step 1).
struct CostError {
    gamma: f64,
    ug: f64,
}

impl CostError {
    /// `reach_terms` = Σ_d w_d·(reach_d + |q*_d|)², so that G² = 3.03²·reach_terms.
    fn new(r: Rounding, dim: usize, reach_terms: f64) -> Self {
        CostError { gamma: gamma(dim as f64, r.unit), ug: r.unit * 3.03 * reach_terms.sqrt() }
    }

    /// ΔC(c): increasing in c.
    fn at(&self, c: f64) -> f64 {
        self.gamma * c + 2.0 * self.ug * (1.0 + self.gamma) * c.sqrt() + self.ug * self.ug * (1.0 + self.gamma)
    }

    /// The largest exact cost C whose computed cost can be ≤ x: the root of
    /// (1 − γ)y² − 2uG(1 + γ)y − (x + u²G²(1 + γ)) = 0, squared (y = √C).
    fn exact_at_most(&self, x: f64) -> f64 {
        let (g, b) = (self.gamma, self.ug * (1.0 + self.gamma));
        let y = (b + (b * b + (1.0 - g) * (x + self.ug * self.ug * (1.0 + g))).sqrt()) / (1.0 - g);
        y * y
    }
}

/// The logits a pass keeps are ≥ the cut: α(Ĉ − m̂) ≤ this over α.
fn kept_span(r: Rounding) -> f64 {
    -crate::ergo::PRUNE_LOGIT / (1.0 - gamma(3.0, r.unit))
}

/// Λ ≥ |ℓ̂_j − ℓ_j| for every configuration the pass keeps, ℓ_j = −α(C_j − m̂) the exact
/// logit shifted by the pass's computed minimum m̂ (any common shift leaves the
/// probabilities as they are): the cost's error at the largest exact cost a kept
/// configuration can have, and the three roundings of ℓ̂ = fl(fl(−α)·fl(Ĉ − m̂)) (step 2).
fn logit_error(r: Rounding, cost: &CostError, computed_min: f64, alpha: f64) -> f64 {
    let span = kept_span(r);
    let highest = cost.exact_at_most(computed_min + span / alpha);
    alpha * cost.at(highest) + span * gamma(3.0, r.unit)
}

/// Σ_d w_d·(reach_d + |q*_d|)² of a particle (q*, w) on a set of the given reach: G²/3.03².
pub(super) fn reach_terms(reach: &[f64], q_star: &[f64], w: &[f64]) -> f64 {
    reach.iter().zip(q_star).zip(w).map(|((r, q), w)| w * (r + q.abs()).powi(2)).sum()
}

/// Λ of a float32 pass with computed minimum `min_f32`, and Λ of the float64 pass of the
/// same particle and set, for a particle of the given [`reach_terms`]. Both grow with the
/// reach terms and the minimum, so one call at a chunk's largest of each bounds every
/// particle of the chunk. Float64's computed minimum is at most the computed cost of the
/// exactly cheapest configuration, whose exact cost is at most that of float32's cheapest.
pub(super) fn logit_errors(dim: usize, reach_terms: f64, min_f32: f64, alpha: f64) -> [f64; 2] {
    let (single, double) = (CostError::new(FLOAT32, dim, reach_terms), CostError::new(FLOAT64, dim, reach_terms));
    let exact_min = single.exact_at_most(min_f32);
    [
        logit_error(FLOAT32, &single, min_f32, alpha),
        logit_error(FLOAT64, &double, exact_min + double.at(exact_min), alpha),
    ]
}

/// A bound on |m̂_f32 − m̂_f64|, the float32 and float64 passes' computed minimum costs of
/// one particle, given its [`reach_terms`] and `min_f32` (step 1 at the minimum): with m the
/// exact minimum, each computed minimum is within ΔC of m at the exact cost of its own
/// argmin, at most X = the largest exact cost whose float32 cost can be ≤ m̂_f32 (so X ≥ m)
/// for float32, and at most the largest whose float64 cost can be ≤ X + ΔC_f64(X) for
/// float64. Increasing in both arguments: one call at a chunk's largest bounds the chunk.
pub(super) fn min_cost_error(dim: usize, reach_terms: f64, min_f32: f64) -> f64 {
    let (single, double) = (CostError::new(FLOAT32, dim, reach_terms), CostError::new(FLOAT64, dim, reach_terms));
    let x = single.exact_at_most(min_f32);
    let y = double.exact_at_most(x + double.at(x));
    single.at(x) + double.at(y)
}

/// max Σ_r t_r·|ln t_r| over K non-negative t_r of sum at most `mass` (≤ 1 up to rounding):
/// s·ln(K/s) at the best s ≤ mass, and what parts above 1 could add.
fn entropy_room(k: f64, mass: f64) -> f64 {
    let best = if mass >= k / std::f64::consts::E { k / std::f64::consts::E } else { mass * (k / mass).ln() };
    best + mass * mass.max(1.0).ln()
}

/// −x·ln x, increasing on [0, 1/e]; +∞ beyond, where the bound it serves means nothing.
fn h(x: f64) -> f64 {
    if x <= 0.0 {
        0.0
    } else if x < 1.0 / std::f64::consts::E {
        -x * x.ln()
    } else {
        f64::INFINITY
    }
}

/// A bound on |Î − I| for one set's pass in rounding `r` over `particles` particles of
/// weights summing to `weight_sum`, given Λ, the largest logit error over the particles;
/// the set has `n` configurations in `k` regions.
pub(super) fn information_gain_error(
    r: Rounding,
    logit_error: f64,
    n: usize,
    k: usize,
    particles: usize,
    weight_sum: f64,
) -> f64 {
    // Step 3: a kept weight is within η relative of exact; a sum of them within σ more
    // (each lane adds ⌈n/lanes⌉ of them, the lanes and a range's ends are added in f64).
    let eta = logit_error.exp() * (1.0 + r.exp_error) - 1.0;
    let sigma = (1.0 + gamma(n.div_ceil(r.lanes) as f64, r.unit)) * (1.0 + gamma(3.0 * r.lanes as f64, U64)) - 1.0;
    let kappa = (1.0 + eta) * (1.0 + sigma) - 1.0;
    // (A NaN κ gives no bound either.)
    if kappa.is_nan() || kappa >= 0.25 {
        return f64::INFINITY;
    }
    // Step 4: a region's probability ŝ_r/Ŝ is within ρ relative of the kept weights' exact
    // ratio, which is within τ of the exact probability (a pruned weight is below
    // e^(cut + Λ), and the exact normaliser at least e^(−Λ)).
    let rho = (1.0 + kappa) * (1.0 + U64) / (1.0 - kappa) - 1.0;
    let tau = 2.0 * n as f64 * (crate::ergo::PRUNE_LOGIT + 2.0 * logit_error).exp();
    // Step 5: entropies. h(p(1 + δ)) − h(p) ≤ ρ·p|ln p| + p(1 + ρ)ρ/(1 − ρ); a shift by at
    // most τ changes h by at most h(τ) (Fannes); x ln x and the sum over regions round.
    let kf = k as f64;
    let one = entropy_room(kf, 1.0);
    let entropy_error = |rho: f64, mass: f64, tau: f64| {
        let room = entropy_room(kf, mass);
        rho * room + (1.0 + rho) * rho / (1.0 - rho) * mass + kf * h(tau) + (3.0 * U64 + gamma(kf, U64)) * (room + 1.0)
    };
    let particle = entropy_error(rho, 1.0, tau);
    // Step 6: over the particles. The marginal's sums (within a chunk, then over chunks) add
    // γ_N; the conditional entropy is the weighted sum of the particles' errors plus its own
    // rounding; the final difference rounds once.
    let w = weight_sum;
    let gamma_n = gamma((PARTICLE_CHUNK + particles.div_ceil(PARTICLE_CHUNK) + 2) as f64, U64);
    let rho_m = (1.0 + rho) * (1.0 + gamma_n) - 1.0;
    let marginal = entropy_error(rho_m, w, w * tau);
    let conditional = w * particle + gamma_n * w * (one + particle);
    marginal + conditional + 2.0 * U64 * (entropy_room(kf, w) + w * one)
}

/// A selector's choice by the float32 screen, and what it cost.
#[derive(Clone, Debug, PartialEq)]
pub struct ScreenedChoice {
    /// The query the full-precision scores choose (the earliest of the best): float64's, or
    /// for `passive` the protocol's precision's.
    pub index: usize,
    /// The full-precision information gain and expected cost of every query so scored; NaN
    /// for the queries the screen left out, and for all when the screen alone decided
    /// (`passive`'s information gain is NaN: it is not computed).
    pub values: Vec<QueryValue>,
    /// Queries scored in full precision (0 when the screen alone decided).
    pub scored: usize,
}

/// One belief's float32 passes over a menu with their error bounds, for a region outcome:
/// what `active`'s and `passive`'s screened choices are made from.
pub struct Screen<'a> {
    belief: &'a Belief,
    menu: &'a [FeasibleSet],
    alpha: f64,
    passes: Vec<DiscretePass>,
    /// Particles of positive weight, and their weights' sum.
    particles: usize,
    weight_sum: f64,
}

impl<'a> Screen<'a> {
    /// The float32 passes of every query of `menu` for `belief`.
    pub fn new(belief: &'a Belief, menu: &'a [FeasibleSet], alpha: f64) -> Self {
        let sets: Vec<&FeasibleSet> = menu.iter().collect();
        let passes = discrete_passes::<Float32>(belief, &sets, alpha, true, true);
        let (particles, weight_sum) = kept(belief);
        Screen { belief, menu, alpha, passes, particles, weight_sum }
    }

    /// `active`'s choice: the same index as the argmax of float64's
    /// [`super::menu_query_values`] (module docs).
    pub fn active(&self) -> ScreenedChoice {
        let bounds: Vec<f64> = self
            .passes
            .iter()
            .zip(self.menu)
            .map(|(pass, set)| {
                let (n, k) = (set.len(), set.regions().len());
                let error = |r, logit| information_gain_error(r, logit, n, k, self.particles, self.weight_sum);
                SAFETY * (error(FLOAT32, pass.logit_errors[0]) + error(FLOAT64, pass.logit_errors[1]))
            })
            .collect();
        let gains: Vec<f64> = self.passes.iter().map(|p| p.information_gain).collect();
        let candidates = contenders(&gains, &bounds);
        if candidates.len() == 1 {
            return self.decided(candidates[0]);
        }
        let double_sets: Vec<&FeasibleSet> = candidates.iter().map(|&q| &self.menu[q]).collect();
        let double = discrete_passes::<Float64>(self.belief, &double_sets, self.alpha, true, false);
        let mut values = self.unknown();
        for (&q, pass) in candidates.iter().zip(&double) {
            values[q] = QueryValue { information_gain: pass.information_gain, expected_cost: pass.expected_cost };
        }
        // Candidates are in menu order, so the earliest of the largest among them is float64's.
        let index = candidates[argmax(&double.iter().map(|p| p.information_gain).collect::<Vec<_>>())];
        ScreenedChoice { index, values, scored: candidates.len() }
    }

    /// `passive`'s choice: the same index as the argmax of −[`super::menu_expected_costs`]
    /// in float64 (the earliest of the lowest expected costs). A particle's float32 and
    /// float64 minimum costs differ by at most its [`min_cost_error`], so the two expected
    /// costs by at most their weighted sum, plus the rounding of the two sums
    /// ([`passive_choice`]).
    pub fn passive(&self) -> ScreenedChoice {
        let screened: Vec<(f64, f64)> =
            self.passes.iter().map(|p| (p.expected_cost, self.weight_sum * p.min_cost_error)).collect();
        passive_choice(self.belief, self.menu, &screened, Precision::Float64)
    }

    fn unknown(&self) -> Vec<QueryValue> {
        unknown(self.menu.len())
    }

    fn decided(&self, index: usize) -> ScreenedChoice {
        ScreenedChoice { index, values: self.unknown(), scored: 0 }
    }
}

/// The particles of positive weight: how many, and their weights' sum.
fn kept(belief: &Belief) -> (usize, f64) {
    belief.weights().iter().filter(|&&w| w > 0.0).fold((0, 0.0), |(n, s), w| (n + 1, s + w))
}

/// Scores of `n` queries not computed.
fn unknown(n: usize) -> Vec<QueryValue> {
    vec![QueryValue { information_gain: f64::NAN, expected_cost: f64::NAN }; n]
}

/// The queries that may be float64's argmax, in menu order, given float32's scores (the
/// larger the better) and their bounds: all but those whose ceiling is below the float32
/// best's floor. A NaN anywhere keeps a query (and a NaN floor keeps every one).
fn contenders(scores: &[f64], bounds: &[f64]) -> Vec<usize> {
    let best = argmax(scores);
    let floor = scores[best] - bounds[best];
    (0..scores.len())
        .filter(|&q| q == best || (scores[q] + bounds[q]).partial_cmp(&floor) != Some(std::cmp::Ordering::Less))
        .collect()
}

/// A bound on |m̃ − m̂| for one particle of [`reach_terms`] R, m̃ its minimum cost from
/// [`cross_min_f32`] plus Σ_d w_d·q*_d² in f64 and m̂ the minimum cost of a pass in rounding
/// `r`: every term of A_j − 2Σ_d w_d q*_d q_jd is at most R in size, so its rounding (the
/// inputs to f32, D fused multiply-adds) is within γ_{D+4}·R in f32; Σ_d w_d q*_d² ≤ R and
/// the last addition round in f64; and the pass's cost is within ΔC(R) of the exact one,
/// every cost being at most R.
fn cross_min_error(dim: usize, reach_terms: f64, r: Rounding) -> f64 {
    let f64_rounding = 2.0 * gamma(dim as f64 + 3.0, U64);
    (gamma(dim as f64 + 4.0, FLOAT32.unit) + f64_rounding) * reach_terms
        + CostError::new(r, dim, reach_terms).at(reach_terms)
}

/// `passive`'s choice from `menu`: the same index as the argmax of
/// −[`super::menu_expected_costs`] in `precision` (the earliest of the lowest expected
/// costs). When every particle has the same w (q* alone learned), each particle's minimum
/// cost is screened in float32 in the cross-term form ([`cross_min_f32`], half the
/// arithmetic of a cost) within [`cross_min_error`], and only the queries the bound cannot
/// rule out are costed in `precision`; otherwise every query is.
pub fn screened_passive_choice(belief: &Belief, menu: &[FeasibleSet], precision: Precision) -> ScreenedChoice {
    let d = belief.dim();
    let particles = belief.particles();
    let w = &particles[d..2 * d];
    let same = |p: &[f64]| p[d..].iter().zip(w).all(|(a, b)| a.to_bits() == b.to_bits());
    if !particles.chunks_exact(2 * d).all(same) {
        // Nothing screened: an unbounded error keeps every query.
        return passive_choice(belief, menu, &vec![(0.0, f64::INFINITY); menu.len()], precision);
    }
    let rounding = match precision {
        Precision::Float64 => FLOAT64,
        Precision::Float32 => FLOAT32,
    };
    let norms: Vec<_> = menu.iter().map(|set| weighted_norms_f32(set.configs(), w)).collect();
    let reaches: Vec<&[f64]> = menu.iter().map(|set| set.configs().reach()).collect();
    // Each chunk's Σ ω m̃ and largest reach terms for every query, added over chunks in order.
    let partials: Vec<Vec<(f64, f64)>> = chunks(belief)
        .map(|chunk| {
            // Each particle's q*, weight and Σ_d w_d·q*_d², the same for every query.
            let chunk: Vec<(&[f64], f64, f64)> = chunk
                .map(|(p, weight)| {
                    let q = &p[..d];
                    (q, weight, q.iter().zip(w).map(|(q, w)| w * q * q).sum())
                })
                .collect();
            menu.iter()
                .zip(&norms)
                .zip(&reaches)
                .map(|((set, norms), reach)| {
                    let (mut cost, mut widest) = (0.0, 0.0f64);
                    for &(q, weight, base) in &chunk {
                        cost += weight * (base + f64::from(cross_min_f32(set.configs(), norms, q, w)));
                        widest = widest.max(reach_terms(reach, q, w));
                    }
                    (cost, widest)
                })
                .collect()
        })
        .collect();
    let (_, weight_sum) = kept(belief);
    let screened: Vec<(f64, f64)> = (0..menu.len())
        .map(|q| {
            let (cost, widest) = partials.iter().map(|c| c[q]).fold((0.0, 0.0f64), |(s, m), (c, r)| (s + c, m.max(r)));
            (cost, weight_sum * cross_min_error(d, widest, rounding))
        })
        .collect();
    passive_choice(belief, menu, &screened, precision)
}

/// `passive`'s choice in `precision` from each query's screened expected cost and the
/// weighted sum of its particles' minimum-cost error bounds (`screened`, per query): the
/// two sums' rounding (step 6's γ) is added and the whole doubled; a query whose screened
/// cost less its bound is above the screened best's plus its bound costs more in
/// `precision`, and the rest are costed in `precision`, the earliest of the lowest taken.
fn passive_choice(
    belief: &Belief,
    menu: &[FeasibleSet],
    screened: &[(f64, f64)],
    precision: Precision,
) -> ScreenedChoice {
    let (particles, _) = kept(belief);
    let gamma_n = gamma((PARTICLE_CHUNK + particles.div_ceil(PARTICLE_CHUNK) + 2) as f64, U64);
    // −E, so that the best is the largest, as for the information gain.
    let (scores, bounds): (Vec<f64>, Vec<f64>) = screened
        .iter()
        .map(|&(cost, spread)| (-cost, SAFETY * (spread + gamma_n * (2.0 * cost.abs() + spread))))
        .unzip();
    let candidates = contenders(&scores, &bounds);
    if candidates.len() == 1 {
        return ScreenedChoice { index: candidates[0], values: unknown(menu.len()), scored: 0 };
    }
    let sets: Vec<&FeasibleSet> = candidates.iter().map(|&q| &menu[q]).collect();
    let costs = expected_costs(belief, &sets, precision);
    let mut values = unknown(menu.len());
    for (&q, &expected_cost) in candidates.iter().zip(&costs) {
        values[q] = QueryValue { information_gain: f64::NAN, expected_cost };
    }
    let index = candidates[argmax(&costs.iter().map(|c| -c).collect::<Vec<_>>())];
    ScreenedChoice { index, values, scored: candidates.len() }
}

/// `active`'s choice from `menu` for a region outcome ([`Screen::active`]).
pub fn screened_active_choice(belief: &Belief, menu: &[FeasibleSet], alpha: f64) -> ScreenedChoice {
    Screen::new(belief, menu, alpha).active()
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};

    use super::*;
    use crate::SeededRng;
    use crate::ergo::{ConfigSet, Lambda, Observation, ScratchF32, min_cost_f32};
    use crate::select::{OutcomeModel, Precision, menu_query_values};

    fn default_menu() -> (crate::protocol::Study, Vec<FeasibleSet>) {
        let study = crate::protocol::Study::default_study();
        let menu = study.training.iter().map(|q| crate::session::choice_set(&q.feasible)).collect();
        (study, menu)
    }

    /// Beliefs of the default protocol: from the prior and after 1–4 region observations of
    /// a simulated person, three people.
    fn beliefs(study: &crate::protocol::Study, menu: &[FeasibleSet], particles: usize, seed: u64) -> Vec<Belief> {
        let alpha = study.protocol.learning.alpha;
        let mut rng = SeededRng::seed_from_u64(seed);
        let mut out = Vec::new();
        for person in 0..3 {
            let mut belief = Belief::from_prior(&study.prior, particles, &mut rng).unwrap();
            let truth = Lambda::from_slice(&study.prior.sample(&mut rng));
            let someone = crate::participant::SimulatedPerson { truth, alpha };
            for step in 0..5 {
                out.push(belief.clone());
                let q = (person + 3 * step) % menu.len();
                let j = someone.choose(&menu[q], &mut rng);
                let region = menu[q].regions()[menu[q].region_of(j)].clone().collect();
                belief.update(&menu[q], alpha, &Observation::Region(region)).unwrap();
                belief.maybe_resample(crate::belief::ResamplePolicy::EveryUpdate, &[0.02; 7], &mut rng);
            }
        }
        out
    }

    /// Sets made to stress the bound: far from every particle's q* (large costs), a region
    /// whose every configuration is pruned, one configuration, repeated configurations
    /// (exact ties), joints near ±π.
    fn hard_sets(rng: &mut SeededRng) -> Vec<FeasibleSet> {
        let mut sets = Vec::new();
        for (n, spread, centre) in [(1, 0.0, 0.5), (2, 0.01, 0.0), (40, 0.3, 3.0), (300, 1.5, 0.0), (1000, 0.05, -2.5)]
        {
            let rows: Vec<Vec<f64>> =
                (0..n).map(|_| (0..7).map(|_| centre + spread * (rng.random::<f64>() - 0.5)).collect()).collect();
            let labels: Vec<usize> = (0..n).map(|j| usize::from(j >= n / 2)).collect();
            sets.push(FeasibleSet::with_regions(ConfigSet::from_rows(&rows).unwrap(), &labels).unwrap());
        }
        // Two far apart regions: under a sharp α the far one's weights are all pruned.
        let mut rows: Vec<Vec<f64>> = (0..64).map(|j| vec![0.01 * j as f64; 7]).collect();
        rows.extend((0..64).map(|j| vec![2.0 + 0.01 * j as f64; 7]));
        let labels: Vec<usize> = (0..128).map(|j| usize::from(j >= 64)).collect();
        sets.push(FeasibleSet::with_regions(ConfigSet::from_rows(&rows).unwrap(), &labels).unwrap());
        // The same configuration many times, three regions.
        let rows = vec![vec![0.3; 7]; 90];
        let labels: Vec<usize> = (0..90).map(|j| j / 30).collect();
        sets.push(FeasibleSet::with_regions(ConfigSet::from_rows(&rows).unwrap(), &labels).unwrap());
        sets
    }

    /// Beliefs of particles spread wide (q* in ±3 rad, w up to 10): large costs and reach.
    fn wide_belief(rng: &mut SeededRng, particles: usize) -> Belief {
        let lambdas: Vec<Lambda> = (0..particles)
            .map(|_| Lambda {
                q_star: (0..7).map(|_| 6.0 * rng.random::<f64>() - 3.0).collect(),
                w: (0..7).map(|_| 10.0 * rng.random::<f64>()).collect(),
            })
            .collect();
        let weights: Vec<f64> = (0..particles).map(|_| rng.random::<f64>()).collect();
        Belief::from_particles(&lambdas, &weights).unwrap()
    }

    /// Beliefs with q* spread wide (±3 rad) and one w for every particle (up to 10 a joint),
    /// as when q* alone is learned.
    fn shared_w_belief(rng: &mut SeededRng, particles: usize) -> Belief {
        let w: Vec<f64> = (0..7).map(|_| 10.0 * rng.random::<f64>()).collect();
        let lambdas: Vec<Lambda> = (0..particles)
            .map(|_| Lambda { q_star: (0..7).map(|_| 6.0 * rng.random::<f64>() - 3.0).collect(), w: w.clone() })
            .collect();
        let weights: Vec<f64> = (0..particles).map(|_| rng.random::<f64>()).collect();
        Belief::from_particles(&lambdas, &weights).unwrap()
    }

    /// A particle's minimum cost in the cross-term form (float32, plus Σ w q*² in f64) is
    /// within [`cross_min_error`] of float64's and of float32's, for stressing sets and the
    /// default menu.
    #[test]
    fn a_cross_term_minimum_is_within_its_bound() {
        let (_, menu) = default_menu();
        let mut rng = SeededRng::seed_from_u64(46);
        let (mut worst, mut checked) = (0.0f64, 0);
        for set in hard_sets(&mut rng).iter().chain(&menu) {
            let belief = shared_w_belief(&mut rng, 200);
            let d = belief.dim();
            let w = &belief.particles()[d..2 * d];
            let norms = weighted_norms_f32(set.configs(), w);
            for p in belief.particles().chunks_exact(2 * d) {
                let q = &p[..d];
                let base: f64 = q.iter().zip(w).map(|(q, w)| w * q * q).sum();
                let single = base + f64::from(cross_min_f32(set.configs(), &norms, q, w));
                let one = Belief::from_particles(&[Lambda::from_slice(p)], &[1.0]).unwrap();
                let r = reach_terms(set.configs().reach(), q, w);
                for (precision, rounding) in [(Precision::Float64, FLOAT64), (Precision::Float32, FLOAT32)] {
                    let pass = crate::select::expected_cost(&one, set, precision);
                    let bound = cross_min_error(d, r, rounding);
                    assert!((single - pass).abs() <= bound, "{precision:?}: {single} {pass} {bound}");
                    worst = worst.max((single - pass).abs() / bound);
                    checked += 1;
                }
            }
        }
        println!("cross-term minimum cost: worst error {worst:.3} of its bound over {checked} comparisons");
    }

    /// `passive`'s screened choice is that of its precision's expected costs (the earliest of
    /// the lowest), float64's and float32's, on the default menu (beliefs from the prior and
    /// after handovers), on menus with the chosen query repeated ahead of itself, on stressing
    /// sets with one w (screened) and with a w per particle (all costed in the precision);
    /// the screen alone decides most default-menu choices.
    #[test]
    fn a_screened_passive_choice_is_that_of_its_precision() {
        let (study, menu) = default_menu();
        let mut rng = SeededRng::seed_from_u64(47);
        for precision in [Precision::Float64, Precision::Float32] {
            let check = |belief: &Belief, menu: &[FeasibleSet]| {
                let costs = crate::select::menu_expected_costs(belief, menu, precision);
                let got = screened_passive_choice(belief, menu, precision);
                assert_eq!(got.index, argmax(&costs.iter().map(|c| -c).collect::<Vec<_>>()), "{precision:?}");
                for (g, c) in got.values.iter().zip(&costs) {
                    assert!(g.expected_cost.is_nan() || g.expected_cost == *c, "a cost scored is the precision's");
                }
                got
            };
            let (mut alone, mut total) = (0, 0);
            for belief in beliefs(&study, &menu, 1000, 48) {
                let got = check(&belief, &menu);
                total += 1;
                alone += usize::from(got.scored == 0);
                let mut repeated = menu.clone();
                repeated.insert(0, menu[got.index].clone());
                assert!(check(&belief, &repeated).scored >= 2);
            }
            for _ in 0..4 {
                check(&shared_w_belief(&mut rng, 300), &hard_sets(&mut rng));
                let everyone = check(&wide_belief(&mut rng, 300), &hard_sets(&mut rng));
                assert_eq!(everyone.scored, everyone.values.len(), "a w per particle: all in the precision");
            }
            println!("screened passive choices, {precision:?}, default menu: {alone} of {total} decided by the screen");
            assert!(alone * 2 > total, "{alone} of {total}");
        }
    }

    /// The bound of one set's float32 pass and float64 pass, and the two values.
    fn bounded(belief: &Belief, set: &FeasibleSet, alpha: f64) -> (f64, f64, f64) {
        let single = &discrete_passes::<Float32>(belief, &[set], alpha, true, true)[0];
        let double = &discrete_passes::<Float64>(belief, &[set], alpha, true, false)[0];
        let particles = belief.weights().iter().filter(|&&w| w > 0.0).count();
        let weight_sum: f64 = belief.weights().iter().sum();
        let error = |r, logit| information_gain_error(r, logit, set.len(), set.regions().len(), particles, weight_sum);
        let bound = error(FLOAT32, single.logit_errors[0]) + error(FLOAT64, single.logit_errors[1]);
        (single.information_gain, double.information_gain, bound)
    }

    /// Step 1 alone: a float32 pass's minimum cost is within ΔC of float64's (itself within
    /// float64's ΔC of the exact one), for sets and particles far and near.
    #[test]
    fn a_float32_minimum_cost_is_within_its_bound() {
        let mut rng = SeededRng::seed_from_u64(41);
        let (mut worst, mut checked) = (0.0f64, 0);
        for set in hard_sets(&mut rng) {
            let belief = wide_belief(&mut rng, 200);
            let mut scratch = ScratchF32::new(set.len());
            let d = belief.dim();
            for p in belief.particles().chunks_exact(2 * d) {
                let (q, w) = (&p[..d], &p[d..]);
                let single = min_cost_f32(set.configs(), q, w, &mut scratch);
                let double = crate::select::expected_cost(
                    &Belief::from_particles(&[Lambda::from_slice(p)], &[1.0]).unwrap(),
                    &set,
                    Precision::Float64,
                );
                let reach_terms = reach_terms(set.configs().reach(), q, w);
                let allowed = CostError::new(FLOAT32, d, reach_terms).at(double)
                    + CostError::new(FLOAT64, d, reach_terms).at(double);
                worst = worst.max((single - double).abs() / allowed);
                // What the screen uses, from the float32 minimum alone, is wider still.
                let screened = min_cost_error(d, reach_terms, single);
                assert!(screened >= allowed && (single - double).abs() <= screened, "{single} {double} {screened}");
                checked += 1;
            }
        }
        println!("float32 minimum cost: worst error {worst:.3} of its bound over {checked} particles");
        assert!(worst <= 1.0, "{worst}");
    }

    /// The bound holds: |I_f32 − I_f64| ≤ E_f32 + E_f64 (without the safety factor) on the
    /// default protocol's menu for beliefs from the prior and after handovers, and on sets
    /// made to stress it, at α from 0.5 to 50.
    #[test]
    fn float32_and_float64_information_gains_are_within_the_bound() {
        let (study, menu) = default_menu();
        let mut rng = SeededRng::seed_from_u64(42);
        let (mut worst, mut widest, mut checked) = (0.0f64, 0.0f64, 0);
        let mut check = |belief: &Belief, set: &FeasibleSet, alpha: f64| {
            let (single, double, bound) = bounded(belief, set, alpha);
            assert!((single - double).abs() <= bound, "α {alpha}: {single} {double} bound {bound}");
            if bound > 0.0 {
                worst = worst.max((single - double).abs() / bound);
            }
            widest = widest.max(bound);
            checked += 1;
        };
        for belief in beliefs(&study, &menu, 500, 43).iter().step_by(2) {
            for alpha in [0.5, 5.0, 50.0] {
                for set in &menu {
                    check(belief, set, alpha);
                }
            }
        }
        for set in hard_sets(&mut rng) {
            let belief = wide_belief(&mut rng, 300);
            for alpha in [0.5, 5.0, 50.0] {
                check(&belief, &set, alpha);
            }
        }
        println!(
            "screen bound: {checked} passes, worst error {worst:.2e} of the bound, widest bound {widest:.2e} nats"
        );
        assert!(widest.is_finite());
    }

    /// The screen chooses float64's argmax for `active` (the largest information gain) and
    /// for `passive` (the lowest expected cost), from one float32 pass, on the default menu
    /// (beliefs from the prior and after handovers), on a menu with the chosen query
    /// repeated (a tie the earlier one wins) and on menus of stressing sets; float32 alone
    /// decides most of the default menu's choices.
    #[test]
    fn the_screened_choices_are_float64s() {
        let (study, menu) = default_menu();
        let alpha = study.protocol.learning.alpha;
        let mut rng = SeededRng::seed_from_u64(44);
        let check = |belief: &Belief, menu: &[FeasibleSet], alpha: f64| {
            let full = menu_query_values(belief, menu, alpha, OutcomeModel::Region, Precision::Float64);
            let screen = Screen::new(belief, menu, alpha);
            let (active, passive) = (screen.active(), screen.passive());
            let gains: Vec<f64> = full.iter().map(|v| v.information_gain).collect();
            assert_eq!(active.index, argmax(&gains), "active, α {alpha}");
            for (g, f) in active.values.iter().zip(&full) {
                assert!(g.information_gain.is_nan() || g == f, "a value scored in float64 is float64's");
            }
            let costs = crate::select::menu_expected_costs(belief, menu, Precision::Float64);
            assert_eq!(passive.index, argmax(&costs.iter().map(|c| -c).collect::<Vec<_>>()), "passive, α {alpha}");
            for (g, c) in passive.values.iter().zip(&costs) {
                assert!(g.expected_cost.is_nan() || g.expected_cost == *c, "a cost scored in float64 is float64's");
            }
            (active, passive)
        };
        let (mut alone, mut total) = ([0, 0], 0);
        for belief in beliefs(&study, &menu, 1000, 45) {
            let (active, passive) = check(&belief, &menu, alpha);
            total += 1;
            alone[0] += usize::from(active.scored == 0);
            alone[1] += usize::from(passive.scored == 0);
            // Each chosen query repeated ahead of itself: both stay, the earlier is chosen.
            for (which, index) in [(0, active.index), (1, passive.index)] {
                let mut repeated = menu.clone();
                repeated.insert(0, menu[index].clone());
                let again = check(&belief, &repeated, alpha);
                assert!([again.0, again.1][which].scored >= 2);
            }
        }
        for _ in 0..4 {
            let belief = wide_belief(&mut rng, 300);
            for alpha in [0.5, 5.0, 50.0] {
                check(&belief, &hard_sets(&mut rng), alpha);
            }
        }
        println!("screened choices on the default menu: of {total}, float32 alone decided {alone:?} (active, passive)");
        assert!(alone.iter().all(|&a| a * 2 > total), "{alone:?} of {total}");
    }
}
