//! The set pass in float32 (`learning.precision: float32`): the same costs (eq. 2), pruning
//! and Boltzmann weights (eq. 1) as [`super::SetPass::run`], over sixteen f32 lanes instead
//! of eight f64 ones and with a float32 exponential, for the selectors' information gain and
//! expected cost. Belief updates, likelihoods and every logged estimate stay float64.
//!
//! Per configuration the costs, logits and weights are f32; sums of weights are made in f32
//! lanes (each lane over n/16 configurations) and the lanes added in float64, so a
//! normaliser's relative error is about n/16 · 6e-8 at worst. The tolerance this gives the
//! information gain and the choice of query is measured, not assumed
//! (`select::tests::float32_information_gain_is_within_its_tolerance` and the dry-run count in
//! `tests/integration/precision.rs`; docs/engine.md states both).

use std::ops::Range;

use super::config_set::ConfigSet;
use super::lanes_f32::{Lanes32, Portable32, WIDTH_F32, exp_nonpositive_f32, sum_lanes_f64};
use super::set_pass::{PRUNE_LOGIT, SetPass};

/// Configurations evaluated together: one AVX-512 register, two AVX2 registers.
const BLOCK: usize = WIDTH_F32;

/// The float32 pass's buffers, reused across particles (as [`super::Scratch`]).
#[derive(Clone, Debug, Default)]
pub struct ScratchF32 {
    len: usize,
    costs: Vec<f32>,
    exps: Vec<f32>,
    /// Start index of every block with a weight above the cut: the first `live_count`.
    live: Vec<usize>,
    live_count: usize,
    /// (√w_d, −√w_d·q*_d) per joint, rounded to f32.
    terms: Vec<(f32, f32)>,
}

impl ScratchF32 {
    pub fn new(len: usize) -> Self {
        let mut scratch = Self::default();
        scratch.prepare(len);
        scratch
    }

    /// exp(−α (C_j − min C)) in f32 for every configuration j of the last pass, 0 where pruned.
    pub fn exps(&self) -> &[f32] {
        &self.exps[..self.len]
    }

    /// marginal[j] += scale · exps[j] over the live blocks (`marginal` as long as the set).
    pub fn add_scaled_weights(&self, scale: f32, marginal: &mut [f32]) {
        assert_eq!(marginal.len(), self.len, "one marginal entry per configuration");
        dispatch(AddScaled { scratch: self, scale, marginal })
    }

    /// Σ_{j∈range} exps[j] for every range, the whole blocks inside a range added lane by
    /// lane in f32 and the lanes and the range's ends in float64.
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

/// [`SetPass::run`] in float32: `min_cost`, `sum` and `sum_exp_logit` of the f32 weights
/// (reported as f64), the weights in `scratch`.
pub fn run_f32(set: &ConfigSet, q_star: &[f64], w: &[f64], alpha: f64, scratch: &mut ScratchF32) -> SetPass {
    scratch.prepare(set.len());
    dispatch(Pass { set, q_star, w, alpha, scratch })
}

/// min_q C(q; λ) over the set in float32: [`run_f32`]'s `min_cost`, the same bits.
pub fn min_cost_f32(set: &ConfigSet, q_star: &[f64], w: &[f64], scratch: &mut ScratchF32) -> f64 {
    scratch.prepare(set.len());
    dispatch(MinCost { set, q_star, w, scratch })
}

/// Σ_d w_d·q_jd² of every configuration j for one w, computed in f64 and rounded to f32, in
/// blocks of [`WIDTH_F32`] (padding +∞): what [`cross_min_f32`] adds the cross terms to.
pub fn weighted_norms_f32(set: &ConfigSet, w: &[f64]) -> Vec<[f32; BLOCK]> {
    let mut norms = vec![[f32::INFINITY; BLOCK]; set.len().div_ceil(BLOCK)];
    for j in 0..set.len() {
        let norm: f64 = (0..set.dim()).map(|d| w[d] * set.joint(d)[j] * set.joint(d)[j]).sum();
        norms[j / BLOCK][j % BLOCK] = norm as f32;
    }
    norms
}

/// min_j (A_j − 2·Σ_d w_d·q*_d·q_jd) in float32, A = [`weighted_norms_f32`] of the same w:
/// the minimum cost (eq. 2) less Σ_d w_d·q*_d², one fused multiply-add a joint where the
/// cost's own form takes two. Its rounding does not shrink with the cost (the terms
/// cancel), so it serves a screen with a bound of the size of Σ_d w_d (|q_jd| + |q*_d|)²
/// (`select::screen`), not a cost.
pub fn cross_min_f32(set: &ConfigSet, norms: &[[f32; BLOCK]], q_star: &[f64], w: &[f64]) -> f32 {
    assert_eq!(norms.len(), set.len().div_ceil(BLOCK), "the set's norms");
    dispatch(CrossMin { set, norms, q_star, w })
}

struct CrossMin<'a> {
    set: &'a ConfigSet,
    norms: &'a [[f32; BLOCK]],
    q_star: &'a [f64],
    w: &'a [f64],
}

impl WithLanes32 for CrossMin<'_> {
    type Output = f32;

    #[inline(always)]
    fn run<V: Lanes32>(self) -> f32 {
        match self.set.dim() {
            7 => self.run_dim::<V, 7>(),
            2 => self.run_dim::<V, 2>(),
            _ => self.run_dim::<V, 0>(),
        }
    }
}

impl CrossMin<'_> {
    #[inline(always)]
    fn run_dim<V: Lanes32, const D: usize>(self) -> f32 {
        let CrossMin { set, norms, q_star, w } = self;
        let slope = |d: usize| (-2.0 * w[d] * q_star[d]) as f32;
        if D > 0 {
            // The joints' blocks looked up once, not once per block; no allocation a call.
            let joints: [&[[f32; BLOCK]]; D] = std::array::from_fn(|d| set.joint_blocks_f32(d));
            let slopes: [f32; D] = std::array::from_fn(slope);
            cross_min_with::<V, _>(&joints, &slopes, norms)
        } else {
            let slopes: Vec<f32> = (0..set.dim()).map(slope).collect();
            cross_min_with::<V, _>(&set, &slopes, norms)
        }
    }
}

/// min over the blocks of A + Σ_d slope_d·q_d (padding lanes +∞ through A).
#[inline(always)]
fn cross_min_with<V: Lanes32, J: JointBlocks32>(joints: &J, slopes: &[f32], norms: &[[f32; BLOCK]]) -> f32 {
    let mut mins = V::splat(f32::INFINITY);
    for (b, norm) in norms.iter().enumerate() {
        let mut acc = V::load(norm);
        for (d, &slope) in slopes.iter().enumerate() {
            acc = V::splat(slope).mul_add(V::load(joints.block(d, b)), acc);
        }
        mins = mins.min(acc);
    }
    let mut m = [0.0; BLOCK];
    mins.store(&mut m);
    m.into_iter().fold(f32::INFINITY, f32::min)
}

/// Work written once over [`Lanes32`], run by [`dispatch`].
trait WithLanes32 {
    type Output;
    fn run<V: Lanes32>(self) -> Self::Output;
}

/// Runs `task` compiled for the best [`Lanes32`] implementation this CPU supports.
#[inline(always)]
fn dispatch<T: WithLanes32>(task: T) -> T::Output {
    #[cfg(target_arch = "x86_64")]
    {
        use super::lanes_f32::{Avx2x32, Avx512x32};
        #[target_feature(enable = "avx512f")]
        fn avx512<T: WithLanes32>(task: T) -> T::Output {
            task.run::<Avx512x32>()
        }
        #[target_feature(enable = "avx2,fma")]
        fn avx2<T: WithLanes32>(task: T) -> T::Output {
            task.run::<Avx2x32>()
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
    task.run::<Portable32>()
}

struct MinCost<'a> {
    set: &'a ConfigSet,
    q_star: &'a [f64],
    w: &'a [f64],
    scratch: &'a mut ScratchF32,
}

impl WithLanes32 for MinCost<'_> {
    type Output = f64;

    #[inline(always)]
    fn run<V: Lanes32>(self) -> f64 {
        let MinCost { set, q_star, w, scratch } = self;
        f64::from(costs_and_min::<V>(set, q_star, w, &mut scratch.costs, &mut scratch.terms))
    }
}

struct Pass<'a> {
    set: &'a ConfigSet,
    q_star: &'a [f64],
    w: &'a [f64],
    alpha: f64,
    scratch: &'a mut ScratchF32,
}

impl WithLanes32 for Pass<'_> {
    type Output = SetPass;

    /// The float64 pass's two sweeps: costs and their minimum; then block by block the
    /// logits, and for a block with a logit above the cut (listed as live) the weights and
    /// their sums, zeros for any other.
    #[inline(always)]
    fn run<V: Lanes32>(self) -> SetPass {
        let Pass { set, q_star, w, alpha, scratch } = self;
        let min_cost = costs_and_min::<V>(set, q_star, w, &mut scratch.costs, &mut scratch.terms);
        let (neg_alpha, min, cut) = (V::splat(-alpha as f32), V::splat(min_cost), V::splat(PRUNE_LOGIT as f32));
        let zero = V::splat(0.0);
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
                // A pruned lane adds nothing, not 0 · ℓ (its logit may be −∞: 0 · −∞ is NaN).
                let x = V::select(keep, exp_nonpositive_f32(logit), zero);
                let logit = V::select(keep, logit, zero);
                x.store(e);
                sums = sums.add(x);
                sums_logit = x.mul_add(logit, sums_logit);
            } else {
                zero.store(e);
            }
        }
        scratch.live_count = live;
        SetPass { min_cost: f64::from(min_cost), sum: sum_lanes_f64(sums), sum_exp_logit: sum_lanes_f64(sums_logit) }
    }
}

struct AddScaled<'a> {
    scratch: &'a ScratchF32,
    scale: f32,
    marginal: &'a mut [f32],
}

impl WithLanes32 for AddScaled<'_> {
    type Output = ();

    #[inline(always)]
    fn run<V: Lanes32>(self) {
        let AddScaled { scratch, scale, marginal } = self;
        let scale_lanes = V::splat(scale);
        let whole = marginal.len() - marginal.len() % BLOCK;
        let (blocks, tail) = marginal.as_chunks_mut::<BLOCK>();
        let exps = scratch.exps.as_chunks::<BLOCK>().0;
        for &start in &scratch.live[..scratch.live_count] {
            let b = start / BLOCK;
            if let Some(m) = blocks.get_mut(b) {
                scale_lanes.mul_add(V::load(&exps[b]), V::load(m)).store(m);
            } else {
                for (k, m) in tail.iter_mut().enumerate() {
                    *m = scale.mul_add(scratch.exps[whole + k], *m);
                }
            }
        }
    }
}

struct RangeSums<'a> {
    scratch: &'a ScratchF32,
    ranges: &'a [Range<usize>],
    out: &'a mut [f64],
}

impl WithLanes32 for RangeSums<'_> {
    type Output = ();

    #[inline(always)]
    fn run<V: Lanes32>(self) {
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
            let mut sum = sum_lanes_f64(lanes);
            for j in head.chain(tail) {
                sum += f64::from(self.scratch.exps[j]);
            }
            *out = sum;
        }
    }
}

/// C_j in f32 for every configuration into `costs` (padding lanes +∞); returns the
/// minimum. Each term is u² with u = √w_d·q_jd − √w_d·q*_d, as in the float64 pass.
#[inline(always)]
fn costs_and_min<V: Lanes32>(
    set: &ConfigSet,
    q_star: &[f64],
    w: &[f64],
    costs: &mut [f32],
    terms: &mut Vec<(f32, f32)>,
) -> f32 {
    let n = set.len();
    let blocks = n.div_ceil(BLOCK);
    let dims = set.dim();
    terms.clear();
    terms.extend(w[..dims].iter().zip(q_star).map(|(w, q)| (w.sqrt() as f32, -(w.sqrt() * q) as f32)));
    let out = &mut costs.as_chunks_mut::<BLOCK>().0[..blocks];
    match dims {
        7 => costs_of_blocks::<V, 7>(set, terms, n, out),
        2 => costs_of_blocks::<V, 2>(set, terms, n, out),
        _ => costs_of_blocks::<V, 0>(set, terms, n, out),
    }
}

/// The costs of every block of `out` and their minimum; `D` joints unrolled (0: the set's,
/// looked up in the set each time).
#[inline(always)]
fn costs_of_blocks<V: Lanes32, const D: usize>(
    set: &ConfigSet,
    terms: &[(f32, f32)],
    n: usize,
    out: &mut [[f32; BLOCK]],
) -> f32 {
    if D > 0 {
        // The joints' blocks looked up once, not once per block.
        let joints: [&[[f32; BLOCK]]; D] = std::array::from_fn(|d| &set.joint_blocks_f32(d)[..out.len()]);
        costs_with::<V, _>(&joints, &terms[..D], n, out)
    } else {
        costs_with::<V, _>(&set, terms, n, out)
    }
}

/// Where a block's values of joint d come from.
trait JointBlocks32 {
    fn block(&self, d: usize, b: usize) -> &[f32; BLOCK];
}

impl<const D: usize> JointBlocks32 for [&[[f32; BLOCK]]; D] {
    #[inline(always)]
    fn block(&self, d: usize, b: usize) -> &[f32; BLOCK] {
        &self[d][b]
    }
}

impl JointBlocks32 for &ConfigSet {
    #[inline(always)]
    fn block(&self, d: usize, b: usize) -> &[f32; BLOCK] {
        &self.joint_blocks_f32(d)[b]
    }
}

/// The costs of every block, padding lanes +∞, and their minimum.
#[inline(always)]
fn costs_with<V: Lanes32, J: JointBlocks32>(
    joints: &J,
    terms: &[(f32, f32)],
    n: usize,
    out: &mut [[f32; BLOCK]],
) -> f32 {
    let whole = n / BLOCK;
    let mut mins = V::splat(f32::INFINITY);
    for (b, o) in out[..whole].iter_mut().enumerate() {
        let c = block_cost::<V, J>(terms, joints, b);
        mins = mins.min(c);
        c.store(o);
    }
    if whole < out.len() {
        // The last, partial block: its padding lanes +∞.
        let mut c = [0.0; BLOCK];
        block_cost::<V, J>(terms, joints, whole).store(&mut c);
        c[n - whole * BLOCK..].fill(f32::INFINITY);
        let c = V::load(&c);
        mins = mins.min(c);
        c.store(&mut out[whole]);
    }
    let mut m = [0.0; BLOCK];
    mins.store(&mut m);
    m.into_iter().fold(f32::INFINITY, f32::min)
}

/// The costs of block b: Σ_d u_d², u_d = √w_d·q_d + shift_d.
#[inline(always)]
fn block_cost<V: Lanes32, J: JointBlocks32>(terms: &[(f32, f32)], joints: &J, b: usize) -> V {
    let mut acc = V::splat(0.0);
    for (d, &(scale, shift)) in terms.iter().enumerate() {
        let u = V::splat(scale).mul_add(V::load(joints.block(d, b)), V::splat(shift));
        acc = u.mul_add(u, acc);
    }
    acc
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};

    use super::*;
    use crate::ergo::SetPass;

    fn random_set(dim: usize, n: usize, rng: &mut crate::SeededRng) -> ConfigSet {
        let rows: Vec<Vec<f64>> = (0..n).map(|_| (0..dim).map(|_| rng.random_range(-2.0..2.0)).collect()).collect();
        ConfigSet::from_rows(&rows).unwrap()
    }

    /// Costs, weights, sums and pruning agree with the float64 pass to float32's precision,
    /// on sets of every size around the block's, with 7, 2 and 3 joints.
    #[test]
    fn the_float32_pass_agrees_with_the_float64_pass() {
        let mut rng = crate::SeededRng::seed_from_u64(32);
        for dim in [7, 2, 3] {
            for n in [1, 5, BLOCK - 1, BLOCK, BLOCK + 1, 3 * BLOCK + 7, 500] {
                let set = random_set(dim, n, &mut rng);
                let q_star: Vec<f64> = (0..dim).map(|_| rng.random_range(-1.5..1.5)).collect();
                let w: Vec<f64> = (0..dim).map(|_| rng.random_range(0.05..1.0)).collect();
                let (mut s64, mut s32) = (SetPass::scratch(n), ScratchF32::new(n));
                let p64 = SetPass::run(&set, &q_star, &w, 5.0, &mut s64);
                let p32 = run_f32(&set, &q_star, &w, 5.0, &mut s32);
                assert!((p32.min_cost - p64.min_cost).abs() <= 1e-6 * (1.0 + p64.min_cost), "{p32:?} {p64:?}");
                assert!((p32.sum - p64.sum).abs() <= 2e-5 * p64.sum, "dim {dim} n {n}: {p32:?} vs {p64:?}");
                assert!((p32.config_entropy() - p64.config_entropy()).abs() <= 1e-4, "{p32:?} vs {p64:?}");
                for (j, (&a, &b)) in s32.exps().iter().zip(s64.exps()).enumerate() {
                    // Weights near the cut may fall either side of it.
                    if b > 1e-15 {
                        assert!((f64::from(a) - b).abs() <= 1e-4 * b, "dim {dim} n {n} j {j}: {a} vs {b}");
                    }
                }
                assert_eq!(min_cost_f32(&set, &q_star, &w, &mut s32).to_bits(), p32.min_cost.to_bits());
            }
        }
    }

    /// Every lane implementation this CPU runs gives the portable one's bits.
    #[test]
    fn every_implementation_of_the_float32_pass_gives_the_same_bits() {
        fn run_with<V: Lanes32>(set: &ConfigSet, q_star: &[f64], w: &[f64]) -> (Vec<u64>, Vec<u32>) {
            let mut scratch = ScratchF32::new(set.len());
            let p = Pass { set, q_star, w, alpha: 40.0, scratch: &mut scratch }.run::<V>();
            let mut sums = vec![0.0; 2];
            RangeSums { scratch: &scratch, ranges: &[0..set.len(), 3..set.len() - 5], out: &mut sums }.run::<V>();
            let mut words = vec![p.min_cost.to_bits(), p.sum.to_bits(), p.sum_exp_logit.to_bits()];
            words.extend(sums.iter().map(|s| s.to_bits()));
            (words, scratch.exps().iter().map(|e| e.to_bits()).collect())
        }
        let mut rng = crate::SeededRng::seed_from_u64(33);
        for dim in [7, 3] {
            let set = random_set(dim, 16 * BLOCK + 3, &mut rng);
            let q_star: Vec<f64> = (0..dim).map(|_| rng.random_range(-1.5..1.5)).collect();
            let w: Vec<f64> = (0..dim).map(|_| rng.random_range(0.05..1.0)).collect();
            let want = run_with::<Portable32>(&set, &q_star, &w);
            assert!(want.1.contains(&0) && want.1.iter().any(|&e| e != 0), "some weights pruned, some kept");
            #[cfg(target_arch = "x86_64")]
            {
                use crate::ergo::lanes_f32::{Avx2x32, Avx512x32};
                #[target_feature(enable = "avx2,fma")]
                fn avx2(set: &ConfigSet, q_star: &[f64], w: &[f64]) -> (Vec<u64>, Vec<u32>) {
                    run_with::<Avx2x32>(set, q_star, w)
                }
                #[target_feature(enable = "avx512f")]
                fn avx512(set: &ConfigSet, q_star: &[f64], w: &[f64]) -> (Vec<u64>, Vec<u32>) {
                    run_with::<Avx512x32>(set, q_star, w)
                }
                if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
                    // SAFETY: the CPU supports AVX2 and FMA, checked just above.
                    assert_eq!(unsafe { avx2(&set, &q_star, &w) }, want, "AVX2, dim {dim}");
                }
                if std::arch::is_x86_feature_detected!("avx512f") {
                    // SAFETY: the CPU supports AVX-512F, checked just above.
                    assert_eq!(unsafe { avx512(&set, &q_star, &w) }, want, "AVX-512, dim {dim}");
                }
            }
        }
    }

    /// A cost so large that α·C overflows is pruned: no NaN in the sums.
    #[test]
    fn an_overflowing_cost_leaves_the_float32_pass_finite() {
        let mut rows = vec![vec![0.0]; BLOCK + 2];
        rows[1] = vec![1e30];
        let set = ConfigSet::from_rows(&rows).unwrap();
        let mut sc = ScratchF32::new(set.len());
        let p = run_f32(&set, &[0.0], &[1.0], 1e10, &mut sc);
        assert_eq!(sc.exps()[1], 0.0);
        assert_eq!(p.sum, (BLOCK + 1) as f64);
        assert!(p.sum_exp_logit.is_finite());
    }
}
