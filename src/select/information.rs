//! Exact mutual information between λ and the person's choice, and the expected cost of
//! eq. 10, computed together in one pass over particles × configurations.

use rayon::prelude::*;

use super::{OutcomeModel, Precision};
use crate::belief::{Belief, PARTICLE_CHUNK};
use crate::ergo::{ConfigSet, FeasibleSet, Scratch, ScratchF32, SetPass, xlogx};

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
    /// Bounds on the float32 and float64 passes' logit errors for every particle of the
    /// chunk ([`super::screen::logit_errors`] at the chunk's largest reach and minimum cost),
    /// when asked for; else 0.
    logit_errors: [f64; 2],
    /// A bound on |m̂_f32 − m̂_f64| for every particle of the chunk, the two passes' computed
    /// minimum costs ([`super::screen::min_cost_error`]), when asked for; else 0.
    min_cost_error: f64,
}

/// I = H[Σ_i ω_i L_i(·)] − Σ_i ω_i H[L_i(·)], where L_i is the distribution of the outcome
/// (the configuration, or the region with [`OutcomeModel::Region`]) under particle i.
/// O(N·|Q|); particles are reduced in fixed chunks so the result does not depend on the
/// number of threads. A measured outcome's information is estimated
/// ([`measured_information`] with [`MEASURED_POINTS`] points). In float64.
pub fn query_value(belief: &Belief, set: &FeasibleSet, alpha: f64, outcomes: OutcomeModel) -> QueryValue {
    query_value_in(belief, set, alpha, outcomes, Precision::Float64)
}

/// [`query_value`] with the set passes of a configuration or region outcome in the given
/// precision (a measured outcome's estimate is always float64): float32 computes every
/// weight in f32 and adds the per-particle sums in f64 (docs/engine.md, "Float32").
pub fn query_value_in(
    belief: &Belief,
    set: &FeasibleSet,
    alpha: f64,
    outcomes: OutcomeModel,
    precision: Precision,
) -> QueryValue {
    let region = match outcomes {
        OutcomeModel::Configuration => false,
        OutcomeModel::Region => true,
        OutcomeModel::Measured { sigma } => return measured_value(belief, set, alpha, sigma),
    };
    let pass = match precision {
        Precision::Float64 => discrete_pass::<Float64>(belief, set, alpha, region),
        Precision::Float32 => discrete_pass::<Float32>(belief, set, alpha, region),
    };
    QueryValue { information_gain: pass.information_gain, expected_cost: pass.expected_cost }
}

/// [`query_value_in`] of every set of `menu`, in one pass over the particles for a
/// configuration or region outcome (the same numbers as set by set).
pub fn menu_query_values(
    belief: &Belief,
    menu: &[FeasibleSet],
    alpha: f64,
    outcomes: OutcomeModel,
    precision: Precision,
) -> Vec<QueryValue> {
    let region = match outcomes {
        OutcomeModel::Configuration => false,
        OutcomeModel::Region => true,
        OutcomeModel::Measured { sigma } => {
            return menu.iter().map(|set| measured_value(belief, set, alpha, sigma)).collect();
        }
    };
    let sets: Vec<&FeasibleSet> = menu.iter().collect();
    let passes = match precision {
        Precision::Float64 => discrete_passes::<Float64>(belief, &sets, alpha, region, false),
        Precision::Float32 => discrete_passes::<Float32>(belief, &sets, alpha, region, false),
    };
    passes.iter().map(|p| QueryValue { information_gain: p.information_gain, expected_cost: p.expected_cost }).collect()
}

/// A measured outcome's value: [`measured_information`] with [`MEASURED_POINTS`] points.
fn measured_value(belief: &Belief, set: &FeasibleSet, alpha: f64, sigma: &[f64]) -> QueryValue {
    let m = measured_information(belief, set, alpha, sigma, MEASURED_POINTS);
    QueryValue { information_gain: m.estimate, expected_cost: m.expected_cost }
}

/// A set pass in one precision, for the passes over the particles written once.
pub(super) trait PassPrecision {
    type Scratch;
    /// The accumulator of a configuration outcome's marginal.
    type Marginal: Copy + Default + Into<f64> + Send;
    fn scratch(len: usize) -> Self::Scratch;
    fn run(set: &ConfigSet, q_star: &[f64], w: &[f64], alpha: f64, scratch: &mut Self::Scratch) -> SetPass;
    fn min_cost(set: &ConfigSet, q_star: &[f64], w: &[f64], scratch: &mut Self::Scratch) -> f64;
    fn range_sums(scratch: &Self::Scratch, ranges: &[std::ops::Range<usize>], out: &mut [f64]);
    fn add_scaled_weights(scratch: &Self::Scratch, scale: f64, marginal: &mut [Self::Marginal]);
}

pub(super) struct Float64;

impl PassPrecision for Float64 {
    type Scratch = Scratch;
    type Marginal = f64;
    fn scratch(len: usize) -> Scratch {
        SetPass::scratch(len)
    }
    fn run(set: &ConfigSet, q_star: &[f64], w: &[f64], alpha: f64, scratch: &mut Scratch) -> SetPass {
        SetPass::run(set, q_star, w, alpha, scratch)
    }
    fn min_cost(set: &ConfigSet, q_star: &[f64], w: &[f64], scratch: &mut Scratch) -> f64 {
        SetPass::min_cost(set, q_star, w, scratch)
    }
    fn range_sums(scratch: &Scratch, ranges: &[std::ops::Range<usize>], out: &mut [f64]) {
        scratch.range_sums(ranges, out)
    }
    fn add_scaled_weights(scratch: &Scratch, scale: f64, marginal: &mut [f64]) {
        scratch.add_scaled_weights(scale, marginal)
    }
}

pub(super) struct Float32;

impl PassPrecision for Float32 {
    type Scratch = ScratchF32;
    type Marginal = f32;
    fn scratch(len: usize) -> ScratchF32 {
        ScratchF32::new(len)
    }
    fn run(set: &ConfigSet, q_star: &[f64], w: &[f64], alpha: f64, scratch: &mut ScratchF32) -> SetPass {
        crate::ergo::run_f32(set, q_star, w, alpha, scratch)
    }
    fn min_cost(set: &ConfigSet, q_star: &[f64], w: &[f64], scratch: &mut ScratchF32) -> f64 {
        crate::ergo::min_cost_f32(set, q_star, w, scratch)
    }
    fn range_sums(scratch: &ScratchF32, ranges: &[std::ops::Range<usize>], out: &mut [f64]) {
        scratch.range_sums(ranges, out)
    }
    fn add_scaled_weights(scratch: &ScratchF32, scale: f64, marginal: &mut [f32]) {
        scratch.add_scaled_weights(scale as f32, marginal)
    }
}

/// What one pass over a belief yields for a discrete outcome (the configuration or the
/// region): the marginal of the outcome, I(λ; outcome) and eq. 10's expected cost.
pub(super) struct DiscretePass {
    marginal: Vec<f64>,
    pub information_gain: f64,
    pub expected_cost: f64,
    /// The largest logit-error bounds over the particles, when asked for ([`Partial`]).
    pub logit_errors: [f64; 2],
    /// The largest bound on a particle's |m̂_f32 − m̂_f64|, when asked for ([`Partial`]).
    pub min_cost_error: f64,
}

fn discrete_pass<P: PassPrecision>(belief: &Belief, set: &FeasibleSet, alpha: f64, region: bool) -> DiscretePass {
    let partials = chunk_partials::<P>(belief, &[set], alpha, region, false);
    reduce(set, region, partials.iter().flatten())
}

/// [`discrete_pass`] over every set of `menu`: each chunk of particles goes over every set in
/// turn (one task and one scratch a chunk, the set's configurations hot for the chunk's
/// particles), and each set's partial sums are added over the chunks in order, so every
/// set's numbers are those of its own pass.
/// With `bound`, each pass also carries its logit-error bounds (a float32 pass's: its own
/// and float64's, [`super::screen::logit_errors`]) and its minimum-cost error bound
/// ([`super::screen::min_cost_error`]).
pub(super) fn discrete_passes<P: PassPrecision>(
    belief: &Belief,
    menu: &[&FeasibleSet],
    alpha: f64,
    region: bool,
    bound: bool,
) -> Vec<DiscretePass> {
    let partials = chunk_partials::<P>(belief, menu, alpha, region, bound);
    menu.iter().enumerate().map(|(q, set)| reduce(set, region, partials.iter().filter_map(|c| c.get(q)))).collect()
}

/// Each chunk's partial sums for every set of `menu`, chunk by chunk.
fn chunk_partials<P: PassPrecision>(
    belief: &Belief,
    menu: &[&FeasibleSet],
    alpha: f64,
    region: bool,
    bound: bool,
) -> Vec<Vec<Partial>> {
    let d = belief.dim();
    let longest = menu.iter().map(|s| s.len()).max().unwrap_or(0);
    chunks(belief)
        .map(|chunk| {
            let chunk: Vec<(&[f64], f64)> = chunk.collect();
            let mut scratch = P::scratch(longest);
            menu.iter()
                .map(|set| {
                    let k = if region { set.regions().len() } else { set.len() };
                    // A configuration outcome's marginal in the precision's type; a region's (a
                    // few numbers a particle) in f64 whatever the precision.
                    let mut config_marginal = vec![P::Marginal::default(); if region { 0 } else { k }];
                    let mut part = Partial {
                        marginal: vec![0.0; if region { k } else { 0 }],
                        conditional_entropy: 0.0,
                        expected_cost: 0.0,
                        logit_errors: [0.0; 2],
                        min_cost_error: 0.0,
                    };
                    let mut region_p = vec![0.0; set.regions().len()];
                    // With `bound`: the chunk's largest Σ_d w_d (reach_d + |q*_d|)² and minimum cost.
                    // (The reach only then: it builds the set's k-d groups on first use.)
                    let reach = if bound { set.configs().reach() } else { &[] };
                    let mut extent = [0.0f64; 2];
                    for &(p, w) in &chunk {
                        let pass = P::run(set.configs(), &p[..d], &p[d..], alpha, &mut scratch);
                        part.expected_cost += w * pass.min_cost;
                        if bound {
                            let terms = super::screen::reach_terms(reach, &p[..d], &p[d..]);
                            extent = [extent[0].max(terms), extent[1].max(pass.min_cost)];
                        }
                        let scale = w / pass.sum;
                        if region {
                            P::range_sums(&scratch, set.regions(), &mut region_p);
                            let mut h = 0.0;
                            for pr in region_p.iter_mut() {
                                *pr /= pass.sum;
                                h -= xlogx(*pr);
                            }
                            for (m, pr) in part.marginal.iter_mut().zip(&region_p) {
                                *m += w * pr;
                            }
                            part.conditional_entropy += w * h;
                        } else {
                            P::add_scaled_weights(&scratch, scale, &mut config_marginal);
                            part.conditional_entropy += w * pass.config_entropy();
                        }
                    }
                    if !region {
                        part.marginal = config_marginal.into_iter().map(Into::into).collect();
                    }
                    if bound {
                        part.logit_errors = super::screen::logit_errors(set.dim(), extent[0], extent[1], alpha);
                        part.min_cost_error = super::screen::min_cost_error(set.dim(), extent[0], extent[1]);
                    }
                    part
                })
                .collect()
        })
        .collect()
}

/// A set's pass from its chunks' partial sums, added in chunk order.
fn reduce<'a>(set: &FeasibleSet, region: bool, partials: impl Iterator<Item = &'a Partial>) -> DiscretePass {
    let k = if region { set.regions().len() } else { set.len() };
    let mut marginal = vec![0.0; k];
    let (mut conditional, mut cost, mut logit_errors, mut min_cost_error) = (0.0, 0.0, [0.0f64; 2], 0.0f64);
    for p in partials {
        for (m, v) in marginal.iter_mut().zip(&p.marginal) {
            *m += v;
        }
        conditional += p.conditional_entropy;
        cost += p.expected_cost;
        logit_errors = [logit_errors[0].max(p.logit_errors[0]), logit_errors[1].max(p.logit_errors[1])];
        min_cost_error = min_cost_error.max(p.min_cost_error);
    }
    let marginal_entropy = -marginal.iter().map(|&m| xlogx(m)).sum::<f64>();
    // Rounding can push the difference a hair outside [0, log K]; the true value is inside.
    let information_gain = (marginal_entropy - conditional).clamp(0.0, (k as f64).ln());
    DiscretePass { marginal, information_gain, expected_cost: cost, logit_errors, min_cost_error }
}

/// Points a measured outcome's information is averaged over in selection: 32 strata of the
/// configurations' marginal, two antithetic measurements each. Its error against a
/// brute-force integral is in docs/engine.md ("Measured outcomes").
pub const MEASURED_POINTS: usize = 64;

/// A measurement's density relative to the point's largest below e^-35 (≈ 6e-16) is left
/// out of the likelihoods: each likelihood is then low by less than 6e-16 of the largest
/// term, for any belief.
const KERNEL_CUT: f64 = -35.0;

/// The fixed noise draws of the measurement points (the same for every belief and query,
/// so that selection draws nothing from a session's random streams and queries are compared
/// on common random numbers).
const NOISE_SEED: u64 = 0x6d65_6173_7572_6564;

/// The information about λ in a measured arm, estimated, beside what bounds it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasuredInformation {
    /// I(λ; q_m) in nats: the mean of the points' values, within [0, `configuration`].
    pub estimate: f64,
    /// The estimate's Monte Carlo standard error (over the strata's antithetic pairs).
    pub standard_error: f64,
    /// I(λ; q), exact: the information of a noise-free measurement, an upper bound
    /// (q_m is q with independent noise: the data-processing inequality).
    pub configuration: f64,
    /// Σ_i ω_i min_q C(q; λ_i) (eq. 10, without α).
    pub expected_cost: f64,
}

/// I(λ; q_m) for a measurement q_m = q + ε of the configuration q the person chooses,
/// ε ~ N(0, diag σ²) (σ in rad per joint). With L_i(x) = Σ_k P(q_k | Q, λ_i) N(x; q_k, Σ)
/// and M(x) = Σ_i ω_i L_i(x),
///
///   I = E_{x∼M} [ Σ_i ω_i (L_i(x)/M(x)) ln(L_i(x)/M(x)) ],
///
/// the expected divergence of the posterior from the belief. The expectation is over
/// `points` measurements drawn from M by strata — configuration j of the marginal's
/// quantile (s + ½)/S, s < S = points/2, measured as q_j ± σ⊙e_s with fixed normal draws
/// e_s — and each point's value is exact over the particles. Deterministic, and the same
/// for any number of threads. O(N·(|Q| + points·k̄)), k̄ the configurations within
/// about 8σ of a point.
pub fn measured_information(
    belief: &Belief,
    set: &FeasibleSet,
    alpha: f64,
    sigma: &[f64],
    points: usize,
) -> MeasuredInformation {
    let configs = set.configs();
    let dim = configs.dim();
    assert_eq!(sigma.len(), dim, "one noise level per joint");
    assert!(points >= 2 && points.is_multiple_of(2), "points come in antithetic pairs");
    let exact = discrete_pass::<Float64>(belief, set, alpha, false);
    let strata = points / 2;
    // The measurement points: strata of the marginal, antithetic noise.
    let total: f64 = exact.marginal.iter().sum();
    let mut noise = <crate::SeededRng as rand::SeedableRng>::seed_from_u64(NOISE_SEED);
    let mut xs = vec![0.0; points * dim];
    let mut origin = vec![0; points];
    let (mut j, mut cum) = (0, exact.marginal[0]);
    for s in 0..strata {
        let u = (s as f64 + 0.5) / strata as f64 * total;
        while cum <= u && j + 1 < configs.len() {
            j += 1;
            cum += exact.marginal[j];
        }
        origin[2 * s] = j;
        origin[2 * s + 1] = j;
        for d in 0..dim {
            let e: f64 = rand_distr::Distribution::sample(&rand_distr::StandardNormal, &mut noise);
            let q = configs.joint(d)[j];
            xs[2 * s * dim + d] = q + sigma[d] * e;
            xs[(2 * s + 1) * dim + d] = q - sigma[d] * e;
        }
    }
    // Each point's measurement density under every configuration, relative to the point's
    // largest, kept by configuration: column k lists (point, density).
    let mut log_g = vec![0.0; configs.len()];
    let mut columns: Vec<Vec<(u32, f64)>> = vec![Vec::new(); configs.len()];
    let mut reach = vec![0.0; points];
    for (t, x) in xs.chunks_exact(dim).enumerate() {
        log_g.fill(0.0);
        for d in 0..dim {
            for (g, &q) in log_g.iter_mut().zip(configs.joint(d)) {
                let z = (x[d] - q) / sigma[d];
                *g -= 0.5 * z * z;
            }
        }
        let top = log_g.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        for (k, &g) in log_g.iter().enumerate() {
            if g - top > KERNEL_CUT {
                let density = (g - top).exp();
                columns[k].push((t as u32, density));
                reach[t] += exact.marginal[k] * density;
            }
        }
    }
    // Σ_i ω_i L_i(x_t) ln L_i(x_t) per point, over the particles in fixed chunks.
    let d = belief.dim();
    let partials: Vec<Vec<f64>> = chunks(belief)
        .map(|chunk| {
            let mut scratch = SetPass::scratch(configs.len());
            let mut acc = vec![0.0; 2 * points];
            let mut l = vec![0.0; points];
            for (p, w) in chunk {
                let pass = SetPass::run(configs, &p[..d], &p[d..], alpha, &mut scratch);
                // The control: the point's configuration j_t, ω p ln p (p = exps[j] / sum).
                for (a, &j) in acc[points..].iter_mut().zip(&origin) {
                    let e = scratch.exps()[j];
                    if e > 0.0 {
                        *a += w / pass.sum * e * (e.ln() - pass.sum.ln());
                    }
                }
                l.fill(0.0);
                for (column, &e) in columns.iter().zip(scratch.exps()) {
                    if e > 0.0 {
                        for &(t, g) in column {
                            l[t as usize] += e * g;
                        }
                    }
                }
                // L = l / sum: ω L ln L = (ω / sum) · l · (ln l − ln sum).
                let (scale, ln_sum) = (w / pass.sum, pass.sum.ln());
                for (a, &v) in acc[..points].iter_mut().zip(&l) {
                    if v > 0.0 {
                        *a += scale * v * (v.ln() - ln_sum);
                    }
                }
            }
            acc
        })
        .collect();
    let mut acc = vec![0.0; 2 * points];
    for part in &partials {
        for (a, v) in acc.iter_mut().zip(part) {
            *a += v;
        }
    }
    // A point's value: Σ_i ω_i r_i ln r_i with r_i = L_i / M, = acc / M − ln M; its
    // control, the same divergence for the noise-free configuration j_t the point measures,
    // Σ_i ω_i (p_ij/m_j) ln(p_ij/m_j), whose mean over j ∼ m is I(λ; q), known exactly.
    let (values, controls): (Vec<f64>, Vec<f64>) = (0..points)
        .map(|t| {
            let (a, m) = (acc[t], reach[t]);
            let value = if m > 0.0 { (a / m - m.ln()).max(0.0) } else { 0.0 };
            let mj = exact.marginal[origin[t]];
            let control = if mj > 0.0 { (acc[points + t] / mj - mj.ln()).max(0.0) } else { 0.0 };
            (value, control)
        })
        .unzip();
    let pair = |v: &[f64]| -> Vec<f64> { v.chunks_exact(2).map(|p| 0.5 * (p[0] + p[1])).collect() };
    let (v, c) = (pair(&values), pair(&controls));
    let (mv, mc) = (crate::stats::mean(&v), crate::stats::mean(&c));
    // The regression estimator: the controls' error against their known mean, scaled by
    // the slope of the values on the controls, is taken off.
    let (mut cov, mut var) = (0.0, 0.0);
    for (a, b) in v.iter().zip(&c) {
        cov += (a - mv) * (b - mc);
        var += (b - mc) * (b - mc);
    }
    let slope = if var > 0.0 { cov / var } else { 0.0 };
    let estimate = mv - slope * (mc - exact.information_gain);
    let residuals: Vec<f64> = v.iter().zip(&c).map(|(a, b)| a - slope * (b - mc)).collect();
    let standard_error = crate::stats::standard_error(&residuals);
    MeasuredInformation {
        estimate: estimate.clamp(0.0, exact.information_gain),
        standard_error,
        configuration: exact.information_gain,
        expected_cost: exact.expected_cost,
    }
}

/// Σ_i ω_i min_q C(q; λ_i) (eq. 10, without α): [`query_value_in`]'s `expected_cost` in
/// the same precision, the same bits (the same chunks, in the same order), without the
/// weights' exponentials: all that `passive` decides from.
pub fn expected_cost(belief: &Belief, set: &FeasibleSet, precision: Precision) -> f64 {
    let partials = match precision {
        Precision::Float64 => chunk_costs::<Float64>(belief, &[set]),
        Precision::Float32 => chunk_costs::<Float32>(belief, &[set]),
    };
    partials.iter().flatten().fold(0.0, |a, c| a + c)
}

/// [`expected_cost`] of every set of `menu`, in one pass over the particles (the same
/// numbers as set by set).
pub fn menu_expected_costs(belief: &Belief, menu: &[FeasibleSet], precision: Precision) -> Vec<f64> {
    let sets: Vec<&FeasibleSet> = menu.iter().collect();
    expected_costs(belief, &sets, precision)
}

/// [`expected_cost`] of every set of `sets`, in one pass over the particles.
pub(super) fn expected_costs(belief: &Belief, sets: &[&FeasibleSet], precision: Precision) -> Vec<f64> {
    let partials = match precision {
        Precision::Float64 => chunk_costs::<Float64>(belief, sets),
        Precision::Float32 => chunk_costs::<Float32>(belief, sets),
    };
    (0..sets.len()).map(|q| partials.iter().filter_map(|c| c.get(q)).fold(0.0, |a, c| a + c)).collect()
}

/// Each chunk's Σ_i ω_i min_q C(q; λ_i) for every set of `menu`, chunk by chunk (a chunk
/// goes over every set in turn); a set's expected cost is its partials added in chunk order.
fn chunk_costs<P: PassPrecision>(belief: &Belief, menu: &[&FeasibleSet]) -> Vec<Vec<f64>> {
    let d = belief.dim();
    let longest = menu.iter().map(|s| s.len()).max().unwrap_or(0);
    chunks(belief)
        .map(|chunk| {
            let chunk: Vec<(&[f64], f64)> = chunk.collect();
            let mut scratch = P::scratch(longest);
            menu.iter()
                .map(|set| {
                    let mut cost = 0.0;
                    for &(p, w) in &chunk {
                        cost += w * P::min_cost(set.configs(), &p[..d], &p[d..], &mut scratch);
                    }
                    cost
                })
                .collect()
        })
        .collect()
}

/// The belief's particles (λ as q* then w) with their weights, in fixed chunks of
/// [`PARTICLE_CHUNK`] so that a sum over chunks does not depend on the number of threads;
/// particles of weight 0 are left out.
pub(super) fn chunks(belief: &Belief) -> impl IndexedParallelIterator<Item = impl Iterator<Item = (&[f64], f64)>> {
    let s = 2 * belief.dim();
    belief
        .particles()
        .par_chunks(PARTICLE_CHUNK * s)
        .zip(belief.weights().par_chunks(PARTICLE_CHUNK))
        .map(move |(ps, ws)| ps.chunks_exact(s).zip(ws.iter().copied()).filter(|(_, w)| *w > 0.0))
}
