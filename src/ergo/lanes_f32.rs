//! Sixteen f32 lanes as one value, for the float32 set pass (`set_pass_f32`): one AVX-512
//! register, two AVX2 registers, or a plain array — twice the lanes of the float64 pass's
//! [`super::lanes`] in the same registers.
//!
//! As there, every operation is one IEEE operation per lane, fused multiply-adds included,
//! so every implementation gives the same bits (tested) and a float32 result does not depend
//! on the machine.
//!
//! Safety: the x86 implementations call intrinsics of their instruction sets. They are used
//! only inside functions compiled for those instruction sets, which are called only after
//! the CPU was found to support them.

/// The number of lanes.
pub const WIDTH_F32: usize = 16;

const LN2_HI: f32 = 0.693_359_4;
const LN2_LO: f32 = -2.121_944_4e-4;
/// 1.5 · 2^23: adding it rounds to the nearest integer and leaves that integer in the low
/// bits of the mantissa.
const ROUND_MAGIC: f32 = 12_582_912.0;
/// Below this e^x is under 2^-125 and is returned as exactly 0 (the pass never asks for
/// less than e^-39.2: pruned weights are 0 without an exponential).
const EXP_FLOOR: f32 = -87.0;
/// The Taylor coefficients of e^r from 1/7! down to 1, in the order Horner's rule takes
/// them: for |r| ≤ ln 2 / 2 the truncation error is below 6e-9 relative, under half an ulp.
const EXP_TAYLOR: [f32; 8] = [1.0 / 5040.0, 1.0 / 720.0, 1.0 / 120.0, 1.0 / 24.0, 1.0 / 6.0, 0.5, 1.0, 1.0];

/// Sixteen f32 lanes and the operations the float32 set pass needs.
pub(super) trait Lanes32: Copy {
    /// A lane-wise truth value.
    type Mask: Copy;
    fn splat(x: f32) -> Self;
    fn load(a: &[f32; WIDTH_F32]) -> Self;
    fn store(self, a: &mut [f32; WIDTH_F32]);
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

/// e^x for x ≤ 0 lane by lane in float32: Cody–Waite reduction, a degree-7 Taylor polynomial
/// by fused Horner steps, 2^n from the exponent bits (< 4e-7 relative error against
/// `f64::exp` over [−87, 0], tested; exactly 0 below −87; NaN stays NaN).
#[inline(always)]
pub(super) fn exp_nonpositive_f32<V: Lanes32>(x: V) -> V {
    let floor = V::splat(EXP_FLOOR);
    let below = x.lt(floor);
    let xc = V::select(below, floor, x);
    let shifted = xc.mul_add(V::splat(std::f32::consts::LOG2_E), V::splat(ROUND_MAGIC));
    let n = shifted.sub(V::splat(ROUND_MAGIC));
    let r = n.mul_add(V::splat(-LN2_LO), n.mul_add(V::splat(-LN2_HI), xc));
    let mut p = V::splat(EXP_TAYLOR[0]);
    for &c in &EXP_TAYLOR[1..] {
        p = p.mul_add(r, V::splat(c));
    }
    V::select(below, V::splat(0.0), p.mul(shifted.pow2_of_rounded()))
}

/// The lanes' sum in float64, in a fixed order (pairs of halves, as `numeric::sum_lanes`).
#[inline(always)]
pub(super) fn sum_lanes_f64<V: Lanes32>(v: V) -> f64 {
    let mut a = [0.0f32; WIDTH_F32];
    v.store(&mut a);
    let mut h: [f64; WIDTH_F32] = a.map(f64::from);
    let mut width = WIDTH_F32;
    while width > 1 {
        width /= 2;
        for k in 0..width {
            h[k] += h[k + width];
        }
    }
    h[0]
}

/// Plain arrays: the reference, and every machine without AVX2 and FMA.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Portable32([f32; WIDTH_F32]);

impl Portable32 {
    #[inline(always)]
    fn map(self, b: Self, f: impl Fn(f32, f32) -> f32) -> Self {
        Self(std::array::from_fn(|k| f(self.0[k], b.0[k])))
    }
}

impl Lanes32 for Portable32 {
    type Mask = [bool; WIDTH_F32];
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Self([x; WIDTH_F32])
    }
    #[inline(always)]
    fn load(a: &[f32; WIDTH_F32]) -> Self {
        Self(*a)
    }
    #[inline(always)]
    fn store(self, a: &mut [f32; WIDTH_F32]) {
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
        Self(self.0.map(|s| f32::from_bits(s.to_bits().wrapping_add(127) << 23)))
    }
}

#[cfg(target_arch = "x86_64")]
pub(super) use x86::{Avx2x32, Avx512x32};

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::*;

    use super::{Lanes32, WIDTH_F32};

    /// One AVX-512 register (AVX-512F) of sixteen f32.
    #[derive(Clone, Copy)]
    pub struct Avx512x32(__m512);

    // SAFETY (every block below): AVX-512F is available (the module's header).
    impl Lanes32 for Avx512x32 {
        type Mask = __mmask16;
        #[inline(always)]
        fn splat(x: f32) -> Self {
            Self(unsafe { _mm512_set1_ps(x) })
        }
        #[inline(always)]
        fn load(a: &[f32; WIDTH_F32]) -> Self {
            // SAFETY: `a` holds the sixteen f32 read.
            Self(unsafe { _mm512_loadu_ps(a.as_ptr()) })
        }
        #[inline(always)]
        fn store(self, a: &mut [f32; WIDTH_F32]) {
            // SAFETY: `a` holds the sixteen f32 written.
            unsafe { _mm512_storeu_ps(a.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn add(self, b: Self) -> Self {
            Self(unsafe { _mm512_add_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn sub(self, b: Self) -> Self {
            Self(unsafe { _mm512_sub_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn mul(self, b: Self) -> Self {
            Self(unsafe { _mm512_mul_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn mul_add(self, b: Self, c: Self) -> Self {
            Self(unsafe { _mm512_fmadd_ps(self.0, b.0, c.0) })
        }
        #[inline(always)]
        fn min(self, b: Self) -> Self {
            Self(unsafe { _mm512_min_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn ge(self, b: Self) -> Self::Mask {
            unsafe { _mm512_cmp_ps_mask::<_CMP_GE_OQ>(self.0, b.0) }
        }
        #[inline(always)]
        fn lt(self, b: Self) -> Self::Mask {
            unsafe { _mm512_cmp_ps_mask::<_CMP_LT_OQ>(self.0, b.0) }
        }
        #[inline(always)]
        fn any(m: Self::Mask) -> bool {
            m != 0
        }
        #[inline(always)]
        fn select(m: Self::Mask, yes: Self, no: Self) -> Self {
            Self(unsafe { _mm512_mask_blend_ps(m, no.0, yes.0) })
        }
        #[inline(always)]
        fn pow2_of_rounded(self) -> Self {
            Self(unsafe {
                let bits = _mm512_add_epi32(_mm512_castps_si512(self.0), _mm512_set1_epi32(127));
                _mm512_castsi512_ps(_mm512_slli_epi32::<23>(bits))
            })
        }
    }

    /// Two AVX2 registers (AVX2 and FMA) of eight f32 each.
    #[derive(Clone, Copy)]
    pub struct Avx2x32([__m256; 2]);

    impl Avx2x32 {
        #[inline(always)]
        fn each(self, b: Self, f: impl Fn(__m256, __m256) -> __m256) -> Self {
            Self([f(self.0[0], b.0[0]), f(self.0[1], b.0[1])])
        }
    }

    // SAFETY (every block below): AVX2 and FMA are available (the module's header).
    impl Lanes32 for Avx2x32 {
        type Mask = [__m256; 2];
        #[inline(always)]
        fn splat(x: f32) -> Self {
            let v = unsafe { _mm256_set1_ps(x) };
            Self([v, v])
        }
        #[inline(always)]
        fn load(a: &[f32; WIDTH_F32]) -> Self {
            // SAFETY: `a` holds the sixteen f32 read.
            unsafe { Self([_mm256_loadu_ps(a.as_ptr()), _mm256_loadu_ps(a.as_ptr().add(8))]) }
        }
        #[inline(always)]
        fn store(self, a: &mut [f32; WIDTH_F32]) {
            // SAFETY: `a` holds the sixteen f32 written.
            unsafe {
                _mm256_storeu_ps(a.as_mut_ptr(), self.0[0]);
                _mm256_storeu_ps(a.as_mut_ptr().add(8), self.0[1]);
            }
        }
        #[inline(always)]
        fn add(self, b: Self) -> Self {
            self.each(b, |x, y| unsafe { _mm256_add_ps(x, y) })
        }
        #[inline(always)]
        fn sub(self, b: Self) -> Self {
            self.each(b, |x, y| unsafe { _mm256_sub_ps(x, y) })
        }
        #[inline(always)]
        fn mul(self, b: Self) -> Self {
            self.each(b, |x, y| unsafe { _mm256_mul_ps(x, y) })
        }
        #[inline(always)]
        fn mul_add(self, b: Self, c: Self) -> Self {
            unsafe { Self([_mm256_fmadd_ps(self.0[0], b.0[0], c.0[0]), _mm256_fmadd_ps(self.0[1], b.0[1], c.0[1])]) }
        }
        #[inline(always)]
        fn min(self, b: Self) -> Self {
            self.each(b, |x, y| unsafe { _mm256_min_ps(x, y) })
        }
        #[inline(always)]
        fn ge(self, b: Self) -> Self::Mask {
            self.each(b, |x, y| unsafe { _mm256_cmp_ps::<_CMP_GE_OQ>(x, y) }).0
        }
        #[inline(always)]
        fn lt(self, b: Self) -> Self::Mask {
            self.each(b, |x, y| unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(x, y) }).0
        }
        #[inline(always)]
        fn any(m: Self::Mask) -> bool {
            unsafe { _mm256_movemask_ps(_mm256_or_ps(m[0], m[1])) != 0 }
        }
        #[inline(always)]
        fn select(m: Self::Mask, yes: Self, no: Self) -> Self {
            unsafe { Self([_mm256_blendv_ps(no.0[0], yes.0[0], m[0]), _mm256_blendv_ps(no.0[1], yes.0[1], m[1])]) }
        }
        #[inline(always)]
        fn pow2_of_rounded(self) -> Self {
            let one = |v: __m256| unsafe {
                let bits = _mm256_add_epi32(_mm256_castps_si256(v), _mm256_set1_epi32(127));
                _mm256_castsi256_ps(_mm256_slli_epi32::<23>(bits))
            };
            Self([one(self.0[0]), one(self.0[1])])
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Arguments over the whole range, the edges and the special values.
    fn arguments() -> Vec<f32> {
        let mut xs: Vec<f32> = (0..40_000).map(|i| -(i as f32) * 0.002_3).collect();
        xs.extend([0.0, -0.0, -1e-30, -39.143_948, -86.999, -87.0, -87.001, -103.0, -1e9]);
        xs.extend([f32::NEG_INFINITY, f32::NAN, f32::MIN]);
        while !xs.len().is_multiple_of(WIDTH_F32) {
            xs.push(-1.0);
        }
        xs
    }

    fn exps<V: Lanes32>(xs: &[f32]) -> Vec<f32> {
        let mut out = vec![0.0; xs.len()];
        for (x, o) in xs.as_chunks::<WIDTH_F32>().0.iter().zip(out.as_chunks_mut::<WIDTH_F32>().0) {
            exp_nonpositive_f32(V::load(x)).store(o);
        }
        out
    }

    #[test]
    fn the_float32_exponential_is_within_a_few_ulps() {
        let xs = arguments();
        let got = exps::<Portable32>(&xs);
        let mut worst: f64 = 0.0;
        for (&x, &e) in xs.iter().zip(&got) {
            if x.is_nan() {
                assert!(e.is_nan());
            } else if x < -87.0 {
                assert_eq!(e, 0.0, "e^{x}");
            } else {
                let want = f64::from(x).exp();
                worst = worst.max(((f64::from(e) - want) / want).abs());
            }
        }
        assert!(worst < 4e-7, "worst relative error {worst}");
        assert_eq!(got[0], 1.0);
    }

    #[test]
    fn lanes_are_summed_in_float64() {
        let v = Portable32(std::array::from_fn(|k| 1.0 + k as f32 * 1e-7));
        let want: f64 = (0..16).map(|k| f64::from(1.0 + k as f32 * 1e-7)).sum();
        assert!((sum_lanes_f64(v) - want).abs() < 1e-15 * want);
    }

    /// Every implementation this CPU runs gives the portable one's bits.
    #[test]
    fn every_float32_implementation_gives_the_same_bits() {
        let xs = arguments();
        let want: Vec<u32> = exps::<Portable32>(&xs).iter().map(|e| e.to_bits()).collect();
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx2,fma")]
            fn avx2(xs: &[f32]) -> Vec<f32> {
                exps::<Avx2x32>(xs)
            }
            #[target_feature(enable = "avx512f")]
            fn avx512(xs: &[f32]) -> Vec<f32> {
                exps::<Avx512x32>(xs)
            }
            let bits = |v: Vec<f32>| v.iter().map(|e| e.to_bits()).collect::<Vec<u32>>();
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
