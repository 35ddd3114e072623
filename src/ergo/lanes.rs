//! Eight f64 lanes as one value, for the set pass: one AVX-512 register, two AVX2 registers,
//! or a plain array (every other machine; the compiler vectorises it where it can).
//!
//! The set pass is written once over [`Lanes`] and compiled for each implementation; the
//! one chosen at run time depends on the CPU (`set_pass::SetPass::run`). Every operation is
//! one IEEE operation per lane, fused multiply-adds included, so every implementation gives
//! the same bits (tested), and a result does not depend on the machine it was computed on.
//!
//! Safety: the x86 implementations call intrinsics of their instruction sets. They are
//! private to this module's parent and used only inside functions compiled for those
//! instruction sets, which are called only after the CPU was found to support them.

use super::numeric::{EXP_FLOOR, EXP_TAYLOR, LANES, LN2_HI, LN2_LO, LOG2_E, ROUND_MAGIC};

/// The number of lanes.
pub const WIDTH: usize = LANES;

/// Eight f64 lanes and the operations the set pass needs.
pub(super) trait Lanes: Copy {
    /// A lane-wise truth value.
    type Mask: Copy;
    fn splat(x: f64) -> Self;
    fn load(a: &[f64; WIDTH]) -> Self;
    fn store(self, a: &mut [f64; WIDTH]);
    fn add(self, b: Self) -> Self;
    fn sub(self, b: Self) -> Self;
    fn mul(self, b: Self) -> Self;
    /// self · b + c with one rounding.
    fn mul_add(self, b: Self, c: Self) -> Self;
    /// The lesser of each pair (the second when they are equal or either is NaN).
    fn min(self, b: Self) -> Self;
    /// self ≥ b (false where either is NaN).
    fn ge(self, b: Self) -> Self::Mask;
    /// self < b (false where either is NaN).
    fn lt(self, b: Self) -> Self::Mask;
    fn any(m: Self::Mask) -> bool;
    /// `yes` where the mask holds, else `no`.
    fn select(m: Self::Mask, yes: Self, no: Self) -> Self;
    /// 2^n for lanes holding n + [`ROUND_MAGIC`] (n a small integer): the exponent built
    /// from the low mantissa bits.
    fn pow2_of_rounded(self) -> Self;
}

/// e^x for x ≤ 0 lane by lane: `numeric::exp_nonpositive` with every multiply-add fused
/// (< 1e-15 relative error against `f64::exp`, exactly 0 below −708, NaN stays NaN).
#[inline(always)]
pub(super) fn exp_nonpositive<V: Lanes>(x: V) -> V {
    let floor = V::splat(EXP_FLOOR);
    let below = x.lt(floor);
    let xc = V::select(below, floor, x);
    let shifted = xc.mul_add(V::splat(LOG2_E), V::splat(ROUND_MAGIC));
    let n = shifted.sub(V::splat(ROUND_MAGIC));
    let r = n.mul_add(V::splat(-LN2_LO), n.mul_add(V::splat(-LN2_HI), xc));
    let mut p = V::splat(EXP_TAYLOR[0]);
    for &c in &EXP_TAYLOR[1..] {
        p = p.mul_add(r, V::splat(c));
    }
    V::select(below, V::splat(0.0), p.mul(shifted.pow2_of_rounded()))
}

/// Plain arrays: the reference, and every machine without AVX2 and FMA.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Portable([f64; WIDTH]);

impl Portable {
    #[inline(always)]
    fn map(self, b: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        Self(std::array::from_fn(|k| f(self.0[k], b.0[k])))
    }
}

impl Lanes for Portable {
    type Mask = [bool; WIDTH];
    #[inline(always)]
    fn splat(x: f64) -> Self {
        Self([x; WIDTH])
    }
    #[inline(always)]
    fn load(a: &[f64; WIDTH]) -> Self {
        Self(*a)
    }
    #[inline(always)]
    fn store(self, a: &mut [f64; WIDTH]) {
        *a = self.0;
    }
    #[inline(always)]
    fn add(self, b: Self) -> Self {
        self.map(b, |x, y| x + y)
    }
    #[inline(always)]
    fn sub(self, b: Self) -> Self {
        self.map(b, |x, y| x - y)
    }
    #[inline(always)]
    fn mul(self, b: Self) -> Self {
        self.map(b, |x, y| x * y)
    }
    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        Self(std::array::from_fn(|k| self.0[k].mul_add(b.0[k], c.0[k])))
    }
    #[inline(always)]
    fn min(self, b: Self) -> Self {
        self.map(b, |x, y| if x < y { x } else { y })
    }
    #[inline(always)]
    fn ge(self, b: Self) -> Self::Mask {
        std::array::from_fn(|k| self.0[k] >= b.0[k])
    }
    #[inline(always)]
    fn lt(self, b: Self) -> Self::Mask {
        std::array::from_fn(|k| self.0[k] < b.0[k])
    }
    #[inline(always)]
    fn any(m: Self::Mask) -> bool {
        m.iter().fold(false, |a, &b| a | b)
    }
    #[inline(always)]
    fn select(m: Self::Mask, yes: Self, no: Self) -> Self {
        Self(std::array::from_fn(|k| if m[k] { yes.0[k] } else { no.0[k] }))
    }
    #[inline(always)]
    fn pow2_of_rounded(self) -> Self {
        Self(self.0.map(|s| f64::from_bits(s.to_bits().wrapping_add(1023) << 52)))
    }
}

#[cfg(target_arch = "x86_64")]
pub(super) use x86::{Avx2, Avx512};

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::*;

    use super::{Lanes, WIDTH};

    /// One AVX-512 register (AVX-512F).
    #[derive(Clone, Copy)]
    pub struct Avx512(__m512d);

    // SAFETY (every block below): AVX-512F is available (the module's header).
    impl Lanes for Avx512 {
        type Mask = __mmask8;
        #[inline(always)]
        fn splat(x: f64) -> Self {
            Self(unsafe { _mm512_set1_pd(x) })
        }
        #[inline(always)]
        fn load(a: &[f64; WIDTH]) -> Self {
            // SAFETY: `a` holds the eight f64 read.
            Self(unsafe { _mm512_loadu_pd(a.as_ptr()) })
        }
        #[inline(always)]
        fn store(self, a: &mut [f64; WIDTH]) {
            // SAFETY: `a` holds the eight f64 written.
            unsafe { _mm512_storeu_pd(a.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn add(self, b: Self) -> Self {
            Self(unsafe { _mm512_add_pd(self.0, b.0) })
        }
        #[inline(always)]
        fn sub(self, b: Self) -> Self {
            Self(unsafe { _mm512_sub_pd(self.0, b.0) })
        }
        #[inline(always)]
        fn mul(self, b: Self) -> Self {
            Self(unsafe { _mm512_mul_pd(self.0, b.0) })
        }
        #[inline(always)]
        fn mul_add(self, b: Self, c: Self) -> Self {
            Self(unsafe { _mm512_fmadd_pd(self.0, b.0, c.0) })
        }
        #[inline(always)]
        fn min(self, b: Self) -> Self {
            Self(unsafe { _mm512_min_pd(self.0, b.0) })
        }
        #[inline(always)]
        fn ge(self, b: Self) -> Self::Mask {
            unsafe { _mm512_cmp_pd_mask::<_CMP_GE_OQ>(self.0, b.0) }
        }
        #[inline(always)]
        fn lt(self, b: Self) -> Self::Mask {
            unsafe { _mm512_cmp_pd_mask::<_CMP_LT_OQ>(self.0, b.0) }
        }
        #[inline(always)]
        fn any(m: Self::Mask) -> bool {
            m != 0
        }
        #[inline(always)]
        fn select(m: Self::Mask, yes: Self, no: Self) -> Self {
            Self(unsafe { _mm512_mask_blend_pd(m, no.0, yes.0) })
        }
        #[inline(always)]
        fn pow2_of_rounded(self) -> Self {
            Self(unsafe {
                let bits = _mm512_add_epi64(_mm512_castpd_si512(self.0), _mm512_set1_epi64(1023));
                _mm512_castsi512_pd(_mm512_slli_epi64::<52>(bits))
            })
        }
    }

    /// Two AVX2 registers (AVX2 and FMA).
    #[derive(Clone, Copy)]
    pub struct Avx2([__m256d; 2]);

    impl Avx2 {
        #[inline(always)]
        fn each(self, b: Self, f: impl Fn(__m256d, __m256d) -> __m256d) -> Self {
            Self([f(self.0[0], b.0[0]), f(self.0[1], b.0[1])])
        }
    }

    // SAFETY (every block below): AVX2 and FMA are available (the module's header).
    impl Lanes for Avx2 {
        type Mask = [__m256d; 2];
        #[inline(always)]
        fn splat(x: f64) -> Self {
            let v = unsafe { _mm256_set1_pd(x) };
            Self([v, v])
        }
        #[inline(always)]
        fn load(a: &[f64; WIDTH]) -> Self {
            // SAFETY: `a` holds the eight f64 read.
            unsafe { Self([_mm256_loadu_pd(a.as_ptr()), _mm256_loadu_pd(a.as_ptr().add(4))]) }
        }
        #[inline(always)]
        fn store(self, a: &mut [f64; WIDTH]) {
            // SAFETY: `a` holds the eight f64 written.
            unsafe {
                _mm256_storeu_pd(a.as_mut_ptr(), self.0[0]);
                _mm256_storeu_pd(a.as_mut_ptr().add(4), self.0[1]);
            }
        }
        #[inline(always)]
        fn add(self, b: Self) -> Self {
            self.each(b, |x, y| unsafe { _mm256_add_pd(x, y) })
        }
        #[inline(always)]
        fn sub(self, b: Self) -> Self {
            self.each(b, |x, y| unsafe { _mm256_sub_pd(x, y) })
        }
        #[inline(always)]
        fn mul(self, b: Self) -> Self {
            self.each(b, |x, y| unsafe { _mm256_mul_pd(x, y) })
        }
        #[inline(always)]
        fn mul_add(self, b: Self, c: Self) -> Self {
            unsafe { Self([_mm256_fmadd_pd(self.0[0], b.0[0], c.0[0]), _mm256_fmadd_pd(self.0[1], b.0[1], c.0[1])]) }
        }
        #[inline(always)]
        fn min(self, b: Self) -> Self {
            self.each(b, |x, y| unsafe { _mm256_min_pd(x, y) })
        }
        #[inline(always)]
        fn ge(self, b: Self) -> Self::Mask {
            self.each(b, |x, y| unsafe { _mm256_cmp_pd::<_CMP_GE_OQ>(x, y) }).0
        }
        #[inline(always)]
        fn lt(self, b: Self) -> Self::Mask {
            self.each(b, |x, y| unsafe { _mm256_cmp_pd::<_CMP_LT_OQ>(x, y) }).0
        }
        #[inline(always)]
        fn any(m: Self::Mask) -> bool {
            unsafe { _mm256_movemask_pd(_mm256_or_pd(m[0], m[1])) != 0 }
        }
        #[inline(always)]
        fn select(m: Self::Mask, yes: Self, no: Self) -> Self {
            unsafe { Self([_mm256_blendv_pd(no.0[0], yes.0[0], m[0]), _mm256_blendv_pd(no.0[1], yes.0[1], m[1])]) }
        }
        #[inline(always)]
        fn pow2_of_rounded(self) -> Self {
            let one = |v: __m256d| unsafe {
                let bits = _mm256_add_epi64(_mm256_castpd_si256(v), _mm256_set1_epi64x(1023));
                _mm256_castsi256_pd(_mm256_slli_epi64::<52>(bits))
            };
            Self([one(self.0[0]), one(self.0[1])])
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Arguments over the whole range, the edges and the special values.
    fn arguments() -> Vec<f64> {
        let mut xs: Vec<f64> = (0..60_000).map(|i| -(i as f64) * 0.011_9).collect();
        xs.extend([0.0, -0.0, -1e-300, -39.143_946_580_898_5, -707.999, -708.0, -708.001, -745.2, -1e9]);
        xs.extend([f64::NEG_INFINITY, f64::NAN, f64::MIN]);
        while !xs.len().is_multiple_of(WIDTH) {
            xs.push(-1.0);
        }
        xs
    }

    fn exps<V: Lanes>(xs: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; xs.len()];
        for (x, o) in xs.as_chunks::<WIDTH>().0.iter().zip(out.as_chunks_mut::<WIDTH>().0) {
            exp_nonpositive(V::load(x)).store(o);
        }
        out
    }

    #[test]
    fn the_lane_exponential_matches_std_to_a_few_ulps() {
        let xs = arguments();
        let got = exps::<Portable>(&xs);
        let mut worst: f64 = 0.0;
        for (&x, &e) in xs.iter().zip(&got) {
            if x.is_nan() {
                assert!(e.is_nan());
            } else if x < -708.0 {
                assert_eq!(e, 0.0, "e^{x}");
            } else {
                worst = worst.max(((e - x.exp()) / x.exp()).abs());
            }
        }
        assert!(worst < 1e-15, "worst relative error {worst}");
        assert_eq!(got[0], 1.0);
    }

    /// Every implementation this CPU runs gives the portable one's bits.
    #[test]
    fn every_implementation_gives_the_same_bits() {
        let xs = arguments();
        let want: Vec<u64> = exps::<Portable>(&xs).iter().map(|e| e.to_bits()).collect();
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx2,fma")]
            fn avx2(xs: &[f64]) -> Vec<f64> {
                exps::<Avx2>(xs)
            }
            #[target_feature(enable = "avx512f")]
            fn avx512(xs: &[f64]) -> Vec<f64> {
                exps::<Avx512>(xs)
            }
            let bits = |v: Vec<f64>| v.iter().map(|e| e.to_bits()).collect::<Vec<u64>>();
            if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
                // SAFETY: the CPU supports AVX2 and FMA, checked just above.
                assert_eq!(bits(unsafe { avx2(&xs) }), want);
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU supports AVX-512F, checked just above.
                assert_eq!(bits(unsafe { avx512(&xs) }), want);
            }
        }
        assert_eq!(want.len(), xs.len());
    }
}
