//! Numerically stable building blocks: log-sum-exp, an exponential for non-positive
//! arguments that the compiler can vectorise, and x·log x with 0·log 0 = 0.

pub(super) const LN2_HI: f64 = 6.931_471_803_691_238e-1;
pub(super) const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
pub(super) const LOG2_E: f64 = std::f64::consts::LOG2_E;
/// 1.5 · 2^52: adding it rounds to the nearest integer and leaves that integer in the low
/// bits of the mantissa.
pub(super) const ROUND_MAGIC: f64 = 6_755_399_441_055_744.0;
/// Below this, exp(x) is under 1e-307 and is returned as exactly 0.
pub(super) const EXP_FLOOR: f64 = -708.0;
/// The Taylor coefficients of e^r from 1/12! down to 1, in the order Horner's rule takes them.
pub(super) const EXP_TAYLOR: [f64; 13] = [
    1.0 / 479_001_600.0,
    1.0 / 39_916_800.0,
    1.0 / 3_628_800.0,
    1.0 / 362_880.0,
    1.0 / 40_320.0,
    1.0 / 5_040.0,
    1.0 / 720.0,
    1.0 / 120.0,
    1.0 / 24.0,
    1.0 / 6.0,
    0.5,
    1.0,
    1.0,
];

/// e^x for x ≤ 0 (or −∞), to within a few units in the last place.
///
/// Branch-free so that loops over it vectorise: Cody–Waite reduction x = n·ln 2 + r with
/// |r| ≤ ln 2 / 2, a degree-12 Taylor polynomial for e^r (truncation error < 2e-16) by
/// Horner's rule, and 2^n built from the exponent bits. Arguments below −708 give exactly
/// 0; NaN gives NaN. (The set pass has a vector twin with fused multiply-adds,
/// `lanes::exp_nonpositive`.)
#[inline(always)]
pub fn exp_nonpositive(x: f64) -> f64 {
    let xc = if x < EXP_FLOOR { EXP_FLOOR } else { x };
    let shifted = xc * LOG2_E + ROUND_MAGIC;
    let n = shifted - ROUND_MAGIC;
    let r = (xc - n * LN2_HI) - n * LN2_LO;
    let mut p = EXP_TAYLOR[0];
    for c in &EXP_TAYLOR[1..] {
        p = p * r + c;
    }
    // The low 12 bits of `shifted` hold n (two's complement); n + 1023 is the biased exponent.
    let scale = f64::from_bits(shifted.to_bits().wrapping_add(1023) << 52);
    let e = p * scale;
    if x < EXP_FLOOR { 0.0 } else { e }
}

/// log Σ exp(x_i), stable for any magnitudes: −∞ for an empty slice or all −∞.
pub fn log_sum_exp(xs: &[f64]) -> f64 {
    let max = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if max == f64::NEG_INFINITY {
        return f64::NEG_INFINITY;
    }
    if max == f64::INFINITY {
        return f64::INFINITY;
    }
    let sum: f64 = xs.iter().map(|&x| exp_nonpositive(x - max)).sum();
    max + sum.ln()
}

/// x · ln x with the limit 0 · ln 0 = 0.
#[inline]
pub fn xlogx(x: f64) -> f64 {
    if x > 0.0 { x * x.ln() } else { 0.0 }
}

/// Number of independent accumulators in reductions: a fixed order of summation that the
/// compiler can keep in vector registers, so results do not depend on the SIMD width.
pub(crate) const LANES: usize = 8;

/// Lane-wise sum in a fixed order.
#[inline(always)]
pub(crate) fn sum_lanes(lanes: [f64; LANES]) -> f64 {
    ((lanes[0] + lanes[4]) + (lanes[1] + lanes[5])) + ((lanes[2] + lanes[6]) + (lanes[3] + lanes[7]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_matches_std_to_a_few_ulps() {
        let mut worst: f64 = 0.0;
        let mut x: f64 = 0.0;
        while x > -708.0 {
            let want = x.exp();
            let got = exp_nonpositive(x);
            worst = worst.max(((got - want) / want).abs());
            x -= 0.013_7;
        }
        assert!(worst < 1e-15, "worst relative error {worst}");
        assert_eq!(exp_nonpositive(0.0), 1.0);
    }

    #[test]
    fn exp_underflows_to_exact_zero() {
        assert_eq!(exp_nonpositive(-709.0), 0.0);
        assert_eq!(exp_nonpositive(-1e9), 0.0);
        assert_eq!(exp_nonpositive(f64::NEG_INFINITY), 0.0);
        assert!(exp_nonpositive(f64::NAN).is_nan());
    }

    #[test]
    fn log_sum_exp_is_stable_for_huge_magnitudes() {
        let v = log_sum_exp(&[-1e6, -1e6 - 2.0f64.ln()]);
        assert!((v - (-1e6 + 1.5f64.ln())).abs() < 1e-9, "{v}");
        assert_eq!(log_sum_exp(&[]), f64::NEG_INFINITY);
        assert_eq!(log_sum_exp(&[f64::NEG_INFINITY, f64::NEG_INFINITY]), f64::NEG_INFINITY);
        assert!((log_sum_exp(&[0.0, 0.0]) - 2.0f64.ln()).abs() < 1e-15);
    }

    #[test]
    fn zero_log_zero_is_zero() {
        assert_eq!(xlogx(0.0), 0.0);
        assert!((xlogx(0.5) - 0.5 * 0.5f64.ln()).abs() < 1e-16);
    }
}
