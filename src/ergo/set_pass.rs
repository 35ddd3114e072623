//! The per-particle pass over a feasible set that the belief update, the selectors and the
//! simulated person share: every configuration's cost (eq. 2) and Boltzmann weight (eq. 1),
//! with the weights that cannot matter left out.
//!
//! # Pruning
//! A configuration whose logit ℓ_j = −α (C_j − min C) is below [`PRUNE_LOGIT`] = ln 1e-17
//! gets weight exactly 0 and its exponential is never computed: its probability is below
//! 1e-17 of the most likely configuration's. `docs/engine.md` bounds what this changes (at
//! most K·1e-17 relative in a normaliser, K·4e-16 nats in an entropy, K the number pruned);
//! likelihoods are read from the costs where pruning could matter, so they are exact.
//!
//! # Speed
//! Configurations go in blocks of [`BLOCK`], one [`Lanes`] value; a block whose every logit
//! is below the cut gets no exponential. The pass is written once over `Lanes` and compiled
//! for AVX-512, for AVX2 + FMA and for plain arrays; [`dispatch`] picks the best the CPU
//! runs. Every implementation gives the same bits (`lanes`), so no result depends on the
//! machine, nor (particles go in fixed chunks) on the number of threads.

use std::ops::Range;

use super::config_set::{ConfigSet, GROUP};
use super::lanes::{Lanes, Portable, WIDTH, exp_nonpositive as exp_lanes};
use super::likelihood::Observation;
use super::numeric::{exp_nonpositive, sum_lanes};

/// ln 1e-17: configurations this far below the best one in log-probability are given
/// weight 0.
pub(crate) const PRUNE_LOGIT: f64 = -39.143_946_580_898_5;

/// Configurations evaluated together: one AVX-512 register, two AVX2 registers.
pub(crate) const BLOCK: usize = WIDTH;

/// A region's sum of the pass's weights is used for its likelihood only when it is at least
/// this many times the region's size: then the pruned weights (each below 1e-17) change it
/// by less than 1e-12 relative. Below, the likelihood is recomputed from the costs.
const REGION_SUM_PER_CONFIG: f64 = 1e-5;

/// Buffers reused across particles: the costs and the shifted exponentials of one pass,
/// and which blocks have a non-zero exponential. Padded to whole blocks inside; read through
/// [`Scratch::costs`], [`Scratch::exps`] and [`Scratch::live_blocks`].
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    len: usize,
    costs: Vec<f64>,
    exps: Vec<f64>,
    /// Start index of every block with a weight above the cut, in increasing order: the
    /// first `live_count` entries.
    live: Vec<usize>,
    live_count: usize,
    /// (√w_d, −√w_d·q*_d) per joint, for the costs.
    terms: Vec<(f64, f64)>,
    /// A lower bound of the costs in each group of the set's boxes ([`SetPass::min_cost`]).
    bounds: Vec<f64>,
}

impl Scratch {
    /// C(q_j; λ) for every configuration j of the last pass.
    pub fn costs(&self) -> &[f64] {
        &self.costs[..self.len]
    }

    /// exp(−α (C_j − min C)) for every configuration j of the last pass, 0 where pruned.
    pub fn exps(&self) -> &[f64] {
        &self.exps[..self.len]
    }

    /// The start index of every block of [`BLOCK`] configurations that holds a non-zero
    /// weight, in increasing order; every other weight is 0.
    pub(crate) fn live_blocks(&self) -> &[usize] {
        &self.live[..self.live_count]
    }

    /// marginal[j] += scale · exps[j] for every configuration j (`marginal` as long as the
    /// set), visiting only the live blocks: what every particle adds to the information
    /// gain's marginal.
    pub fn add_scaled_weights(&self, scale: f64, marginal: &mut [f64]) {
        assert_eq!(marginal.len(), self.len, "one marginal entry per configuration");
        dispatch(AddScaled { scratch: self, scale, marginal })
    }

    /// Σ_{j∈range} exps[j] for every range (a region's weight; `out` as long as `ranges`),
    /// added lane by lane over the whole blocks inside a range, so a region's sum costs
    /// an eighth of an addition per configuration instead of one addition's latency.
    pub fn range_sums(&self, ranges: &[Range<usize>], out: &mut [f64]) {
        assert_eq!(out.len(), ranges.len(), "one sum per range");
        assert!(ranges.iter().all(|r| r.end <= self.len), "ranges within the set");
        dispatch(RangeSums { scratch: self, ranges, out })
    }

    fn prepare(&mut self, len: usize) {
        let blocks = len.div_ceil(BLOCK);
        self.len = len;
        self.costs.resize(blocks * BLOCK, 0.0);
        self.exps.resize(blocks * BLOCK, 0.0);
        self.live.resize(blocks, 0);
        self.live_count = 0;
    }
}

/// One particle evaluated on one feasible set.
///
/// After [`SetPass::run`], `scratch.costs()[j]` = C(q_j; λ) and `scratch.exps()[j]` =
/// exp(−α (C(q_j) − min C)) (0 where pruned), so P(q_j | Q, λ) = exps[j] / sum.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SetPass {
    /// min_q C(q; λ) over the set (eq. 10's inner minimum).
    pub min_cost: f64,
    /// Σ_j exps[j] (≥ 1).
    pub sum: f64,
    /// Σ_j exps[j] · (−α (C_j − min C)), for the entropy of the choice.
    pub sum_exp_logit: f64,
}

impl SetPass {
    pub fn scratch(len: usize) -> Scratch {
        let mut scratch = Scratch::default();
        scratch.prepare(len);
        scratch
    }

    /// Evaluates every configuration's cost and Boltzmann weight under (q*, w, α).
    pub fn run(set: &ConfigSet, q_star: &[f64], w: &[f64], alpha: f64, scratch: &mut Scratch) -> SetPass {
        scratch.prepare(set.len());
        dispatch(Pass { set, q_star, w, alpha, scratch })
    }

    /// min_q C(q; λ) over the set: [`SetPass::run`]'s `min_cost`, the same bits, without the
    /// weights and without the costs that cannot be the minimum: each group of the set's
    /// boxes ([`GROUP`] configurations) whose lower bound of the cost exceeds the lowest
    /// cost found so far (with a margin for rounding far above the costs' own) is skipped.
    /// The group of the lowest bound goes first. `scratch`'s costs are not filled.
    pub fn min_cost(set: &ConfigSet, q_star: &[f64], w: &[f64], scratch: &mut Scratch) -> f64 {
        scratch.prepare(set.len());
        dispatch(MinCost { set, q_star, w, scratch })
    }

    /// The maximum-likelihood configuration: the lowest index of minimal cost.
    pub fn argmin(&self, scratch: &Scratch) -> usize {
        scratch.costs().iter().position(|&c| c == self.min_cost).unwrap_or(0)
    }

    /// log Σ_j exp(−α C_j): the particle's own normaliser (eq. 5).
    pub fn log_norm(&self, alpha: f64) -> f64 {
        -alpha * self.min_cost + self.sum.ln()
    }

    /// Entropy (nats) of the person's choice among the configurations.
    pub fn config_entropy(&self) -> f64 {
        (self.sum.ln() - self.sum_exp_logit / self.sum).max(0.0)
    }

    /// log P(observation | Q, λ) from this pass.
    pub fn log_likelihood(&self, obs: &Observation, alpha: f64, scratch: &Scratch) -> f64 {
        let costs = scratch.costs();
        let logit = |j: usize| -alpha * (costs[j] - self.min_cost);
        match obs {
            Observation::Config(j) => logit(*j) - self.sum.ln(),
            Observation::Region(idx) => {
                let [s] = region_weights([scratch.exps()], idx);
                self.region_log_likelihood(idx, s, alpha, scratch)
            }
            Observation::Measured(g) => {
                // log Σ_j exp(ℓ_j + g_j) − log S, by log-sum-exp over the costs.
                let (max, s) = dispatch(MeasuredSum { costs, g, alpha, min_cost: self.min_cost });
                max + s.ln() - self.sum.ln()
            }
        }
    }
}

impl SetPass {
    /// log P(region | Q, λ) = log Σ_{j∈R} exp(ℓ_j) − log S, given `s` = the region's weights
    /// added in index order ([`region_weights`]): from the pass's weights while pruning
    /// cannot have changed their sum (nor underflow), else by log-sum-exp over the costs.
    pub fn region_log_likelihood(&self, idx: &[usize], s: f64, alpha: f64, scratch: &Scratch) -> f64 {
        if s >= REGION_SUM_PER_CONFIG * idx.len() as f64 {
            return s.ln() - self.sum.ln();
        }
        let costs = scratch.costs();
        let logit = |j: usize| -alpha * (costs[j] - self.min_cost);
        let max = idx.iter().map(|&j| logit(j)).fold(f64::NEG_INFINITY, f64::max);
        let s: f64 = idx.iter().map(|&j| exp_nonpositive(logit(j) - max)).sum();
        max + s.ln() - self.sum.ln()
    }
}

/// Σ_{j∈idx} exps[j] added in index order, for K passes' weights at once: each sum's bits are
/// those of adding one by one, but the K chains of additions overlap, where one chain would
/// wait out each addition's latency.
pub fn region_weights<const K: usize>(exps: [&[f64]; K], idx: &[usize]) -> [f64; K] {
    let mut sums = [-0.0; K];
    for &j in idx {
        for (s, e) in sums.iter_mut().zip(&exps) {
            *s += e[j];
        }
    }
    sums
}

/// A measured arm's (max_j t_j, Σ_j exp(t_j − max)) with t_j = ℓ_j + g_j: the terms and
/// their exponentials a chunk at a time in plain loops the compiler vectorises for the
/// dispatched CPU (each lane's operations are the scalar ones, unfused, so the bits are
/// too), the sum in index order as one addition after another.
struct MeasuredSum<'a> {
    costs: &'a [f64],
    g: &'a [f64],
    alpha: f64,
    min_cost: f64,
}

/// Configurations per chunk of [`MeasuredSum`].
const MEASURED_CHUNK: usize = 64;

impl WithLanes for MeasuredSum<'_> {
    type Output = (f64, f64);

    #[inline(always)]
    fn run<V: Lanes>(self) -> (f64, f64) {
        let MeasuredSum { costs, g, alpha, min_cost } = self;
        let term = |c: f64, g: f64| -alpha * (c - min_cost) + g;
        // The maximum in lanes of 8: max ignores order (and NaN, as a fold from −∞ does).
        let mut lanes = [f64::NEG_INFINITY; 8];
        let (costs8, g8) = (costs.chunks_exact(8), g.chunks_exact(8));
        let (costs_rest, g_rest) = (costs8.remainder(), g8.remainder());
        for (c, g) in costs8.zip(g8) {
            for k in 0..8 {
                lanes[k] = lanes[k].max(term(c[k], g[k]));
            }
        }
        let mut max = lanes.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        for (&c, &g) in costs_rest.iter().zip(g_rest) {
            max = max.max(term(c, g));
        }
        let mut e = [0.0; MEASURED_CHUNK];
        let mut s = 0.0;
        for (c, g) in costs.chunks(MEASURED_CHUNK).zip(g.chunks(MEASURED_CHUNK)) {
            let e = &mut e[..c.len()];
            for ((e, &c), &g) in e.iter_mut().zip(c).zip(g) {
                *e = exp_nonpositive(term(c, g) - max);
            }
            for &e in e.iter() {
                s += e;
            }
        }
        (max, s)
    }
}

/// The costs' minimum alone: what `passive` needs of a particle.
struct MinCost<'a> {
    set: &'a ConfigSet,
    q_star: &'a [f64],
    w: &'a [f64],
    scratch: &'a mut Scratch,
}

impl WithLanes for MinCost<'_> {
    type Output = f64;

    #[inline(always)]
    fn run<V: Lanes>(self) -> f64 {
        match self.set.dim() {
            7 => self.run_dim::<V, 7>(),
            2 => self.run_dim::<V, 2>(),
            _ => self.run_dim::<V, 0>(),
        }
    }
}

/// Blocks in a group of the set's boxes.
const GROUP_BLOCKS: usize = GROUP / BLOCK;

impl MinCost<'_> {
    /// The groups' lower bounds, then the groups that may hold the minimum.
    ///
    /// A group's bound is Σ_d w_d·gap_d², gap_d the distance from q*_d to the group's range
    /// of joint d: no configuration of the group costs less (eq. 2). A group is skipped when
    /// bound·(1 − 1e-9) − slack > the lowest cost so far, slack = 1e-9·Σ_d w_d (1 + |q*_d| +
    /// max_j |q_jd|)²: the rounding of a computed cost (and of the bound) is below 1e-15 of
    /// that sum, so every cost of a skipped group is above the minimum, and the minimum found
    /// is the minimum of every computed cost, the same bits ([`costs_and_min`]'s costs, lane
    /// by lane).
    #[inline(always)]
    fn run_dim<V: Lanes, const D: usize>(self) -> f64 {
        let MinCost { set, q_star, w, scratch } = self;
        let dims = joints::<D>(set);
        let terms = &mut scratch.terms;
        terms.clear();
        terms.extend(w[..dims].iter().zip(q_star).map(|(w, q)| (w.sqrt(), -(w.sqrt() * q))));
        let boxes = set.group_boxes();
        let groups = boxes.groups;
        let bounds = &mut scratch.bounds;
        bounds.clear();
        bounds.resize(groups, 0.0);
        let mut slack = 0.0;
        for d in 0..dims {
            let (q, wd) = (q_star[d], w[d]);
            let range = d * groups..(d + 1) * groups;
            for ((b, &lo), &hi) in bounds.iter_mut().zip(&boxes.lo[range.clone()]).zip(&boxes.hi[range]) {
                let gap = (lo - q).max(q - hi).max(0.0);
                *b += wd * gap * gap;
            }
            slack += wd * (1.0 + q.abs() + boxes.reach[d]).powi(2);
        }
        let slack = 1e-9 * slack;
        let (n, sorted) = (set.len(), &boxes.sorted);
        if D > 0 {
            let joints: [&[[f64; BLOCK]]; D] = std::array::from_fn(|d| sorted.joint_blocks(d));
            bounded_min::<V, _>(&joints, &terms[..dims], n, bounds, slack)
        } else {
            bounded_min::<V, _>(&sorted, terms, n, bounds, slack)
        }
    }
}

/// The minimum cost over the groups whose bound does not rule them out.
#[inline(always)]
fn bounded_min<V: Lanes, J: JointBlocks>(
    joints: &J,
    terms: &[(f64, f64)],
    n: usize,
    bounds: &[f64],
    slack: f64,
) -> f64 {
    let first = bounds.iter().enumerate().fold(0, |best, (g, &b)| if b < bounds[best] { g } else { best });
    let mut min = group_min::<V, J>(joints, terms, n, first);
    for (g, &bound) in bounds.iter().enumerate() {
        if g != first && bound * (1.0 - 1e-9) - slack <= min {
            min = min.min(group_min::<V, J>(joints, terms, n, g));
        }
    }
    min
}

/// The lowest cost in group g (padding lanes +∞).
#[inline(always)]
fn group_min<V: Lanes, J: JointBlocks>(joints: &J, terms: &[(f64, f64)], n: usize, g: usize) -> f64 {
    let whole = n / BLOCK;
    let mut mins = V::splat(f64::INFINITY);
    for b in g * GROUP_BLOCKS..((g + 1) * GROUP_BLOCKS).min(n.div_ceil(BLOCK)) {
        let c =
            if b < whole { block_cost::<V, J>(terms, joints, b) } else { partial_block_cost::<V, J>(terms, joints, n) };
        mins = mins.min(c);
    }
    // Halving rather than a chain of eight dependent minima: the same value (a minimum does
    // not round, and a cost is never −0 or NaN).
    let mut m = to_array(mins);
    let mut width = BLOCK;
    while width > 1 {
        width /= 2;
        for k in 0..width {
            m[k] = m[k].min(m[k + width]);
        }
    }
    m[0]
}

/// Work written once over [`Lanes`], run by [`dispatch`].
trait WithLanes {
    type Output;
    fn run<V: Lanes>(self) -> Self::Output;
}

/// Runs `task` compiled for the best [`Lanes`] implementation this CPU supports: AVX-512,
/// else AVX2 with FMA, else plain arrays.
#[inline(always)]
fn dispatch<T: WithLanes>(task: T) -> T::Output {
    #[cfg(target_arch = "x86_64")]
    {
        use super::lanes::{Avx2, Avx512};
        #[target_feature(enable = "avx512f")]
        fn avx512<T: WithLanes>(task: T) -> T::Output {
            task.run::<Avx512>()
        }
        #[target_feature(enable = "avx2,fma")]
        fn avx2<T: WithLanes>(task: T) -> T::Output {
            task.run::<Avx2>()
        }
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F, checked just above.
            return unsafe { avx512(task) };
        }
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the CPU supports AVX2 and FMA, checked just above.
            return unsafe { avx2(task) };
        }
    }
    task.run::<Portable>()
}

/// The pass of one particle over one set.
struct Pass<'a> {
    set: &'a ConfigSet,
    q_star: &'a [f64],
    w: &'a [f64],
    alpha: f64,
    scratch: &'a mut Scratch,
}

impl WithLanes for Pass<'_> {
    type Output = SetPass;

    /// Specialised for the arms this program models (7 joints; the planar arm's 2), so that
    /// their joint loops unroll, and for any other number of joints.
    #[inline(always)]
    fn run<V: Lanes>(self) -> SetPass {
        match self.set.dim() {
            7 => self.run_dim::<V, 7>(),
            2 => self.run_dim::<V, 2>(),
            _ => self.run_dim::<V, 0>(),
        }
    }
}

impl Pass<'_> {
    /// Two sweeps over the blocks: the costs and their minimum; then block by block the
    /// logits, and for a block with a logit above the cut (listed as live) the weights and
    /// their sums, zeros for any other. The sums go over the live blocks in order.
    #[inline(always)]
    fn run_dim<V: Lanes, const D: usize>(self) -> SetPass {
        let Pass { set, q_star, w, alpha, scratch } = self;
        let min_cost = costs_and_min::<V, D>(set, q_star, w, &mut scratch.costs, &mut scratch.terms);

        let (neg_alpha, min, cut, zero) = (V::splat(-alpha), V::splat(min_cost), V::splat(PRUNE_LOGIT), V::splat(0.0));
        let mut live = 0;
        let (mut sums, mut sums_logit) = (zero, zero);
        let costs = scratch.costs.as_chunks::<BLOCK>().0;
        let exps = scratch.exps.as_chunks_mut::<BLOCK>().0;
        for (b, (c, e)) in costs.iter().zip(exps.iter_mut()).enumerate() {
            let logit = neg_alpha.mul(V::load(c).sub(min));
            let keep = logit.ge(cut);
            if V::any(keep) {
                scratch.live[live] = b * BLOCK;
                live += 1;
                // A pruned lane adds nothing, not 0 · ℓ: its logit may be −∞ (a padding
                // lane, or a cost so large that α·C overflows), and 0 · −∞ is NaN.
                let x = V::select(keep, exp_lanes(logit), zero);
                let logit = V::select(keep, logit, zero);
                x.store(e);
                sums = sums.add(x);
                sums_logit = x.mul_add(logit, sums_logit);
            } else {
                zero.store(e);
            }
        }
        scratch.live_count = live;
        SetPass { min_cost, sum: sum_lanes(to_array(sums)), sum_exp_logit: sum_lanes(to_array(sums_logit)) }
    }
}

/// marginal += scale · weights over the live blocks.
struct AddScaled<'a> {
    scratch: &'a Scratch,
    scale: f64,
    marginal: &'a mut [f64],
}

impl WithLanes for AddScaled<'_> {
    type Output = ();

    #[inline(always)]
    fn run<V: Lanes>(self) {
        let AddScaled { scratch, scale, marginal } = self;
        let scale_lanes = V::splat(scale);
        let n = marginal.len();
        let whole = n - n % BLOCK;
        let (blocks, tail) = marginal.as_chunks_mut::<BLOCK>();
        let exps = scratch.exps.as_chunks::<BLOCK>().0;
        for &start in scratch.live_blocks() {
            let b = start / BLOCK;
            if let Some(m) = blocks.get_mut(b) {
                V::load(m).add(scale_lanes.mul(V::load(&exps[b]))).store(m);
            } else {
                // The last, partial block: the same operations one by one.
                for (k, m) in tail.iter_mut().enumerate() {
                    *m += scale * scratch.exps[whole + k];
                }
            }
        }
    }
}

/// Σ exps over each range.
struct RangeSums<'a> {
    scratch: &'a Scratch,
    ranges: &'a [Range<usize>],
    out: &'a mut [f64],
}

impl WithLanes for RangeSums<'_> {
    type Output = ();

    /// In a fixed order: the lanes of the range's whole blocks (summed as `sum_lanes` does),
    /// then the configurations before the first whole block, then those after the last.
    #[inline(always)]
    fn run<V: Lanes>(self) {
        let blocks = self.scratch.exps.as_chunks::<BLOCK>().0;
        for (range, out) in self.ranges.iter().zip(self.out.iter_mut()) {
            let first = range.start.div_ceil(BLOCK);
            let last = (range.end / BLOCK).max(first);
            let mut lanes = V::splat(0.0);
            for block in &blocks[first..last] {
                lanes = lanes.add(V::load(block));
            }
            let head = range.start..(first * BLOCK).min(range.end);
            let tail = (last * BLOCK).max(head.end)..range.end;
            let mut sum = sum_lanes(to_array(lanes));
            for j in head.chain(tail) {
                sum += self.scratch.exps[j];
            }
            *out = sum;
        }
    }
}

/// The lanes' values in order.
#[inline(always)]
fn to_array<V: Lanes>(v: V) -> [f64; BLOCK] {
    let mut a = [0.0; BLOCK];
    v.store(&mut a);
    a
}

/// The number of joints: `D`, or the set's when `D` = 0.
#[inline(always)]
fn joints<const D: usize>(set: &ConfigSet) -> usize {
    if D == 0 { set.dim() } else { D }
}

/// C_j = Σ_d w_d (q_jd − q*_d)² for every configuration (eq. 2) into `costs` (padded to
/// whole blocks: padding lanes get +∞); returns the minimum.
///
/// Each term is computed as u² with u = √w_d·q_jd − √w_d·q*_d (one fused multiply-add), two
/// operations a joint instead of three; u carries the rounding of √w_d·q*_d, about as large
/// as that of q_jd − q*_d in the direct form, so the cost is as accurate (costs agree with
/// [`super::cost`] to 1e-14 relative, tested). The terms are added over d in order.
#[inline(always)]
fn costs_and_min<V: Lanes, const D: usize>(
    set: &ConfigSet,
    q_star: &[f64],
    w: &[f64],
    costs: &mut [f64],
    terms: &mut Vec<(f64, f64)>,
) -> f64 {
    let n = set.len();
    let blocks = n.div_ceil(BLOCK);
    let dims = joints::<D>(set);
    terms.clear();
    terms.extend(w[..dims].iter().zip(q_star).map(|(w, q)| (w.sqrt(), -(w.sqrt() * q))));
    let out = &mut costs.as_chunks_mut::<BLOCK>().0[..blocks];
    if D > 0 {
        // The joints' blocks looked up once, not once per block.
        let joints: [&[[f64; BLOCK]]; D] = std::array::from_fn(|d| &set.joint_blocks(d)[..blocks]);
        costs_of_blocks::<V, _>(&joints, &terms[..dims], n, out)
    } else {
        costs_of_blocks::<V, _>(&set, terms, n, out)
    }
}

/// Where a block's values of joint d come from.
trait JointBlocks {
    fn block(&self, d: usize, b: usize) -> &[f64; BLOCK];
}

/// The joints' blocks looked up beforehand (a known number of joints).
impl<const D: usize> JointBlocks for [&[[f64; BLOCK]]; D] {
    #[inline(always)]
    fn block(&self, d: usize, b: usize) -> &[f64; BLOCK] {
        &self[d][b]
    }
}

/// Looked up in the set each time (any number of joints, no allocation).
impl JointBlocks for &ConfigSet {
    #[inline(always)]
    fn block(&self, d: usize, b: usize) -> &[f64; BLOCK] {
        &self.joint_blocks(d)[b]
    }
}

/// The costs of every block of `out` (n configurations; the padding lanes of the last block
/// +∞) and their minimum.
#[inline(always)]
fn costs_of_blocks<V: Lanes, J: JointBlocks>(
    joints: &J,
    terms: &[(f64, f64)],
    n: usize,
    out: &mut [[f64; BLOCK]],
) -> f64 {
    let whole = n / BLOCK;
    let mut mins = V::splat(f64::INFINITY);
    for (b, o) in out[..whole].iter_mut().enumerate() {
        let c = block_cost::<V, J>(terms, joints, b);
        mins = mins.min(c);
        c.store(o);
    }
    if whole < out.len() {
        let c = partial_block_cost::<V, J>(terms, joints, n);
        mins = mins.min(c);
        c.store(&mut out[whole]);
    }
    to_array(mins).into_iter().fold(f64::INFINITY, f64::min)
}

/// The costs of the last, partial block of a set of n configurations, its padding lanes +∞.
#[inline(always)]
fn partial_block_cost<V: Lanes, J: JointBlocks>(terms: &[(f64, f64)], joints: &J, n: usize) -> V {
    let whole = n / BLOCK;
    let mut c = to_array(block_cost::<V, J>(terms, joints, whole));
    c[n - whole * BLOCK..].fill(f64::INFINITY);
    V::load(&c)
}

/// The costs of block b: Σ_d u_d², u_d = √w_d·q_d + shift_d, `terms` = (√w_d, shift_d).
#[inline(always)]
fn block_cost<V: Lanes, J: JointBlocks>(terms: &[(f64, f64)], joints: &J, b: usize) -> V {
    let mut acc = V::splat(0.0);
    for (d, &(scale, shift)) in terms.iter().enumerate() {
        let u = V::splat(scale).mul_add(V::load(joints.block(d, b)), V::splat(shift));
        acc = u.mul_add(u, acc);
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ergo::FeasibleSet;

    fn set(rows: &[&[f64]]) -> FeasibleSet {
        FeasibleSet::new(ConfigSet::from_rows(rows).unwrap())
    }

    /// A measured arm's log-sum-exp, vectorised, is the scalar fold's bit for bit: the same
    /// maximum and the same sum in index order, at every length around the chunks and lanes,
    /// on the dispatched CPU and on plain arrays.
    #[test]
    fn the_measured_sum_is_the_scalar_fold_bit_for_bit() {
        use rand::{RngExt, SeedableRng};
        let mut rng = crate::SeededRng::seed_from_u64(7);
        for len in [1, 2, 7, 8, 9, 63, 64, 65, 130, 517] {
            for spread in [0.1, 30.0, 800.0] {
                let costs: Vec<f64> = (0..len).map(|_| rng.random::<f64>() * spread).collect();
                let g: Vec<f64> = (0..len).map(|_| -rng.random::<f64>() * spread).collect();
                let (alpha, min_cost) = (5.0, costs.iter().copied().fold(f64::INFINITY, f64::min));
                let term = |j: usize| -alpha * (costs[j] - min_cost) + g[j];
                let max = (0..len).map(term).fold(f64::NEG_INFINITY, f64::max);
                let s: f64 = (0..len).map(|j| exp_nonpositive(term(j) - max)).sum();
                let task = || MeasuredSum { costs: &costs, g: &g, alpha, min_cost };
                for (what, (m, t)) in [("dispatched", dispatch(task())), ("plain", task().run::<Portable>())] {
                    assert_eq!(m.to_bits(), max.to_bits(), "{what}: length {len}, spread {spread}");
                    assert_eq!(t.to_bits(), s.to_bits(), "{what}: length {len}, spread {spread}");
                }
            }
        }
    }

    #[test]
    fn pass_entropy_of_uniform_choice_is_log_n() {
        let s = set(&[&[1.0], &[-1.0], &[1.0], &[-1.0]]);
        let mut sc = SetPass::scratch(4);
        let p = SetPass::run(s.configs(), &[0.0], &[1.0], 3.0, &mut sc);
        assert!((p.config_entropy() - 4.0f64.ln()).abs() < 1e-14);
        assert_eq!(p.argmin(&sc), 0);
        assert_eq!(p.min_cost, 1.0);
    }

    /// Every size of set around the block's, and costs on both sides of the cut: the pass
    /// agrees with the weights computed one by one (pruned ones exactly 0, the rest to 1e-15).
    #[test]
    fn the_pass_prunes_exactly_the_weights_below_the_cut_and_keeps_the_rest() {
        for n in 1..=3 * BLOCK + 1 {
            // Costs j·0.7 with α = 5: logits 0, −3.5, −7, … cross the cut at j = 12.
            let rows: Vec<Vec<f64>> = (0..n).map(|j| vec![(j as f64 * 0.7).sqrt(), 0.0]).collect();
            let s = FeasibleSet::new(ConfigSet::from_rows(&rows).unwrap());
            let mut sc = SetPass::scratch(n);
            let p = SetPass::run(s.configs(), &[0.0, 0.0], &[1.0, 1.0], 5.0, &mut sc);
            let mut sum = 0.0;
            for j in 0..n {
                let l = -5.0 * (sc.costs()[j] - p.min_cost);
                if l < PRUNE_LOGIT {
                    assert_eq!(sc.exps()[j], 0.0, "n = {n}, j = {j}");
                } else {
                    assert!((sc.exps()[j] - l.exp()).abs() <= 1e-15 * l.exp(), "n = {n}, j = {j}");
                    sum += l.exp();
                }
            }
            assert!((p.sum - sum).abs() <= 1e-15 * sum);
            // The live blocks are those holding a weight above the cut.
            let want: Vec<usize> =
                (0..n).step_by(BLOCK).filter(|&b| sc.exps()[b..(b + BLOCK).min(n)].iter().any(|&e| e > 0.0)).collect();
            assert_eq!(sc.live_blocks(), want, "n = {n}");
        }
    }

    /// The pass's costs (√w·q − √w·q*)² agree with the direct form w·(q − q*)² of eq. 2, on
    /// sets of every size around the block's, with 7 joints, 2 and 3 (the unrolled and the
    /// general code).
    #[test]
    fn the_pass_costs_are_those_of_eq_2() {
        use rand::{RngExt, SeedableRng};
        let mut rng = crate::SeededRng::seed_from_u64(7);
        for dim in [7, 2, 3] {
            for n in [1, 5, BLOCK, BLOCK + 1, 3 * BLOCK - 1, 300] {
                let rows: Vec<Vec<f64>> =
                    (0..n).map(|_| (0..dim).map(|_| rng.random_range(-2.0..2.0)).collect()).collect();
                let s = FeasibleSet::new(ConfigSet::from_rows(&rows).unwrap());
                let q_star: Vec<f64> = (0..dim).map(|_| rng.random_range(-1.5..1.5)).collect();
                let w: Vec<f64> = (0..dim).map(|_| rng.random_range(0.0..1.0)).collect();
                let mut sc = SetPass::scratch(n);
                let p = SetPass::run(s.configs(), &q_star, &w, 10.0, &mut sc);
                let direct: Vec<f64> = rows.iter().map(|q| crate::ergo::cost(q, &q_star, &w)).collect();
                for (j, (&got, &want)) in sc.costs().iter().zip(&direct).enumerate() {
                    assert!((got - want).abs() <= 1e-14 * want.max(1e-300), "dim {dim}, n {n}, j {j}: {got} vs {want}");
                }
                assert_eq!(p.min_cost, sc.costs().iter().copied().fold(f64::INFINITY, f64::min));
                assert_eq!(sc.costs().len(), n);
            }
        }
    }

    /// The pass gives the same bits under every lane implementation this CPU runs: costs,
    /// weights, live blocks and sums (so no result depends on the machine).
    #[test]
    fn every_implementation_of_the_pass_gives_the_same_bits() {
        use rand::{RngExt, SeedableRng};
        fn run_with<V: Lanes>(set: &ConfigSet, q_star: &[f64], w: &[f64]) -> (SetPass, Scratch) {
            let mut scratch = SetPass::scratch(set.len());
            let pass = Pass { set, q_star, w, alpha: 40.0, scratch: &mut scratch }.run::<V>();
            (pass, scratch)
        }
        let mut rng = crate::SeededRng::seed_from_u64(8);
        for dim in [7, 3] {
            let n = 16 * BLOCK + 3;
            // Wide enough that some blocks are pruned whole with 3 joints as with 7.
            let span = 2.0 * (7.0 / dim as f64).sqrt() * 1.5;
            let rows: Vec<Vec<f64>> =
                (0..n).map(|_| (0..dim).map(|_| rng.random_range(-span..span)).collect()).collect();
            let set = ConfigSet::from_rows(&rows).unwrap();
            let q_star: Vec<f64> = (0..dim).map(|_| rng.random_range(-1.5..1.5)).collect();
            let w: Vec<f64> = (0..dim).map(|_| rng.random_range(0.05..1.0)).collect();
            let bits = |(p, sc): (SetPass, Scratch)| {
                let words = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
                (
                    words(&[p.min_cost, p.sum, p.sum_exp_logit]),
                    words(sc.costs()),
                    words(sc.exps()),
                    sc.live_blocks().to_vec(),
                )
            };
            let want = bits(run_with::<Portable>(&set, &q_star, &w));
            // Some blocks are pruned whole and some are not.
            assert!(!want.3.is_empty() && want.3.len() < n.div_ceil(BLOCK), "dim {dim}: live {:?}", want.3);
            #[cfg(target_arch = "x86_64")]
            {
                use crate::ergo::lanes::{Avx2, Avx512};
                #[target_feature(enable = "avx2,fma")]
                fn avx2(set: &ConfigSet, q_star: &[f64], w: &[f64]) -> (SetPass, Scratch) {
                    run_with::<Avx2>(set, q_star, w)
                }
                #[target_feature(enable = "avx512f")]
                fn avx512(set: &ConfigSet, q_star: &[f64], w: &[f64]) -> (SetPass, Scratch) {
                    run_with::<Avx512>(set, q_star, w)
                }
                if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
                    // SAFETY: the CPU supports AVX2 and FMA, checked just above.
                    assert_eq!(bits(unsafe { avx2(&set, &q_star, &w) }), want, "AVX2, dim {dim}");
                }
                if std::arch::is_x86_feature_detected!("avx512f") {
                    // SAFETY: the CPU supports AVX-512F, checked just above.
                    assert_eq!(bits(unsafe { avx512(&set, &q_star, &w) }), want, "AVX-512, dim {dim}");
                }
            }
        }
    }

    /// The bounded minimum ([`SetPass::min_cost`]) is the whole pass's, bit for bit: sets of
    /// many groups along a curve (as a feasible set's self-motion) and scattered, q* on and far
    /// from them, weights of 0 included, 7 joints, 2 and 3.
    #[test]
    fn the_bounded_minimum_is_the_whole_pass_minimum() {
        use rand::{RngExt, SeedableRng};
        let mut rng = crate::SeededRng::seed_from_u64(12);
        for dim in [7, 2, 3] {
            for n in [1, BLOCK + 3, GROUP + 1, 40 * GROUP + 5] {
                let curve = rng.random_bool(0.5);
                let rows: Vec<Vec<f64>> = (0..n)
                    .map(|j| {
                        let t = j as f64 / n as f64 * 6.0;
                        (0..dim)
                            .map(|d| {
                                if curve {
                                    (t * (d + 1) as f64 * 0.7).sin() + rng.random_range(-0.01..0.01)
                                } else {
                                    rng.random_range(-2.0..2.0)
                                }
                            })
                            .collect()
                    })
                    .collect();
                let set = ConfigSet::from_rows(&rows).unwrap();
                for spread in [0.1, 1.0, 10.0] {
                    for _ in 0..20 {
                        let q_star: Vec<f64> = (0..dim).map(|_| rng.random_range(-spread..spread)).collect();
                        let w: Vec<f64> = (0..dim)
                            .map(|_| if rng.random_bool(0.1) { 0.0 } else { rng.random_range(0.05..2.0) })
                            .collect();
                        let mut whole = SetPass::scratch(n);
                        let want = SetPass::run(&set, &q_star, &w, 5.0, &mut whole).min_cost;
                        let mut alone = SetPass::scratch(n);
                        let got = SetPass::min_cost(&set, &q_star, &w, &mut alone);
                        assert_eq!(got.to_bits(), want.to_bits(), "dim {dim}, n {n}, curve {curve}, spread {spread}");
                    }
                }
            }
        }
    }

    /// Region sums added K at a time are each the sum added one by one.
    #[test]
    fn region_weights_added_together_are_each_added_in_order() {
        let exps: Vec<Vec<f64>> = (0..3).map(|k| (0..50).map(|j| 1.0 / (1 + j + 7 * k) as f64).collect()).collect();
        let idx: Vec<usize> = (3..41).step_by(2).collect();
        let got = region_weights([&exps[0][..], &exps[1][..], &exps[2][..]], &idx);
        for (k, e) in exps.iter().enumerate() {
            let mut want = 0.0;
            for &j in &idx {
                want += e[j];
            }
            assert_eq!(got[k].to_bits(), want.to_bits(), "{k}");
        }
    }

    /// A range's sum is the sum of its weights, for ranges on and across block boundaries.
    #[test]
    fn range_sums_are_the_sums_of_the_weights() {
        let n = 5 * BLOCK + 3;
        let rows: Vec<Vec<f64>> = (0..n).map(|j| vec![(j % 11) as f64 * 0.3]).collect();
        let s = FeasibleSet::new(ConfigSet::from_rows(&rows).unwrap());
        let mut sc = SetPass::scratch(n);
        SetPass::run(s.configs(), &[0.0], &[1.0], 2.0, &mut sc);
        let mut ranges = vec![];
        for a in [0, 1, BLOCK - 1, BLOCK, BLOCK + 5, 3 * BLOCK] {
            for b in [a, a + 1, a + 3, 2 * BLOCK, 3 * BLOCK + 1, n] {
                if a <= b && b <= n {
                    ranges.push(a..b);
                }
            }
        }
        let mut got = vec![0.0; ranges.len()];
        sc.range_sums(&ranges, &mut got);
        for (r, g) in ranges.iter().zip(&got) {
            let want: f64 = sc.exps()[r.clone()].iter().sum();
            assert!((g - want).abs() <= 1e-14 * want.max(1.0), "{r:?}: {g} vs {want}");
        }
    }

    /// A cost so large that α·C overflows to +∞ is pruned like any other: no NaN in the sums.
    #[test]
    fn an_overflowing_cost_leaves_the_pass_finite() {
        for n in [2, BLOCK + 2] {
            let mut rows = vec![vec![0.0]; n];
            rows[1] = vec![1e200];
            let s = FeasibleSet::new(ConfigSet::from_rows(&rows).unwrap());
            let mut sc = SetPass::scratch(n);
            let p = SetPass::run(s.configs(), &[0.0], &[1.0], 1e10, &mut sc);
            assert_eq!(sc.exps()[1], 0.0);
            assert_eq!(p.sum, (n - 1) as f64);
            assert!((p.config_entropy() - ((n - 1) as f64).ln()).abs() < 1e-14, "{p:?}");
        }
    }

    /// A region whose every configuration is pruned still has its exact likelihood.
    #[test]
    fn a_pruned_region_keeps_its_exact_likelihood() {
        // Costs 0 and 50 (α = 1): the second is pruned; log P = −50 − ln(1 + e^−50).
        let s = set(&[&[0.0], &[50f64.sqrt()]]);
        let mut sc = SetPass::scratch(2);
        let p = SetPass::run(s.configs(), &[0.0], &[1.0], 1.0, &mut sc);
        assert_eq!(sc.exps()[1], 0.0);
        let region = p.log_likelihood(&Observation::Region(vec![1]), 1.0, &sc);
        assert!((region + 50.0 + (-50f64).exp().ln_1p()).abs() < 1e-12, "{region}");
    }
}
