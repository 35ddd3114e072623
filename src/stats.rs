//! Descriptive statistics, confidence intervals and the Wilcoxon signed-rank test, shared by
//! the analysis of logs and the simulation studies.

/// Mean; NaN for no values.
pub fn mean(v: &[f64]) -> f64 {
    if v.is_empty() { f64::NAN } else { v.iter().sum::<f64>() / v.len() as f64 }
}

/// Standard error of the mean (sample sd / √n); 0 for one value, NaN for none.
pub fn standard_error(v: &[f64]) -> f64 {
    match v.len() {
        0 => f64::NAN,
        1 => 0.0,
        n => {
            let m = mean(v);
            (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt() / (n as f64).sqrt()
        }
    }
}

/// The p-th quantile by linear interpolation between order statistics (R's type 7).
pub fn quantile(v: &[f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let h = (s.len() - 1) as f64 * p;
    let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
    s[lo] + (h - lo as f64) * (s[hi] - s[lo])
}

pub fn median(v: &[f64]) -> f64 {
    quantile(v, 0.5)
}

/// The 0.975 quantile of Student's t with `df` degrees of freedom (two-sided 95 %), from
/// the standard table for df ≤ 30 and the normal value beyond; NaN for df = 0.
pub fn t_975(df: usize) -> f64 {
    const TABLE: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145, 2.131,
        2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042,
    ];
    match df {
        0 => f64::NAN,
        1..=30 => TABLE[df - 1],
        31..=60 => 2.000 + (2.042 - 2.000) * (60 - df) as f64 / 30.0,
        61..=120 => 1.980 + (2.000 - 1.980) * (120 - df) as f64 / 60.0,
        _ => 1.960,
    }
}

/// The mean of `v` with its 95 % confidence interval (Student's t); the interval is NaN for
/// fewer than two values.
pub fn mean_ci95(v: &[f64]) -> (f64, f64, f64) {
    let m = mean(v);
    let h = t_975(v.len().saturating_sub(1)) * standard_error(v);
    (m, m - h, m + h)
}

/// Paired differences in groups (one group per seed), summarised.
#[derive(Clone, Debug, PartialEq)]
pub struct GroupedDifferences {
    /// Pairs in all groups.
    pub n: usize,
    pub mean: f64,
    /// 95 % confidence interval of the mean difference: over the groups' means when there
    /// are several groups, else over the pairs.
    pub ci_low: f64,
    pub ci_high: f64,
    /// Two-sided Wilcoxon signed-rank p over every pair (none when every difference is 0).
    pub p_value: Option<f64>,
    /// Non-empty groups.
    pub groups: usize,
    /// Groups whose pairs alone give p < .05, with a positive and a negative mean difference.
    pub significant_positive: usize,
    pub significant_negative: usize,
}

/// Summarises paired differences given per group; `None` when there are none.
pub fn grouped_differences(groups: &[Vec<f64>]) -> Option<GroupedDifferences> {
    let groups: Vec<&Vec<f64>> = groups.iter().filter(|g| !g.is_empty()).collect();
    let all: Vec<f64> = groups.iter().flat_map(|g| g.iter().copied()).collect();
    if all.is_empty() {
        return None;
    }
    let means: Vec<f64> = groups.iter().map(|g| mean(g)).collect();
    let (mut positive, mut negative) = (0, 0);
    for (g, m) in groups.iter().zip(&means) {
        if wilcoxon_signed_rank(g).is_some_and(|w| w.p_value < 0.05) {
            if *m > 0.0 {
                positive += 1;
            } else if *m < 0.0 {
                negative += 1;
            }
        }
    }
    let (_, ci_low, ci_high) = if means.len() > 1 { mean_ci95(&means) } else { mean_ci95(&all) };
    Some(GroupedDifferences {
        n: all.len(),
        mean: mean(&all),
        ci_low,
        ci_high,
        p_value: wilcoxon_signed_rank(&all).map(|w| w.p_value),
        groups: means.len(),
        significant_positive: positive,
        significant_negative: negative,
    })
}

/// The result of a Wilcoxon signed-rank test on paired differences.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Wilcoxon {
    /// Pairs with a non-zero difference (zeros are dropped, Wilcoxon's original treatment).
    pub n: usize,
    /// Sum of the ranks of the positive differences (mid-ranks for ties in |d|).
    pub w_plus: f64,
    /// Two-sided p-value.
    pub p_value: f64,
    /// Whether p is exact (all 2^n sign patterns enumerated, n ≤ 20) or from the normal
    /// approximation with tie correction.
    pub exact: bool,
}

/// Mid-ranks of |d| (1-based).
fn ranks(abs: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..abs.len()).collect();
    idx.sort_by(|&a, &b| abs[a].total_cmp(&abs[b]));
    let mut r = vec![0.0; abs.len()];
    let mut i = 0;
    while i < idx.len() {
        let mut j = i;
        while j + 1 < idx.len() && abs[idx[j + 1]] == abs[idx[i]] {
            j += 1;
        }
        let mid = (i + j) as f64 / 2.0 + 1.0;
        for &k in &idx[i..=j] {
            r[k] = mid;
        }
        i = j + 1;
    }
    r
}

/// The two-sided Wilcoxon signed-rank test of paired differences `d` against 0. Zero
/// differences are dropped; ties in |d| get mid-ranks. With at most 20 non-zero pairs the
/// p-value is exact: the share of the 2^n equally likely sign patterns (under H0) whose
/// W+ is at least as far from n(n+1)/4 as the observed one. `None` without non-zero pairs.
pub fn wilcoxon_signed_rank(d: &[f64]) -> Option<Wilcoxon> {
    let nz: Vec<f64> = d.iter().copied().filter(|x| *x != 0.0).collect();
    let n = nz.len();
    if n == 0 {
        return None;
    }
    let r = ranks(&nz.iter().map(|x| x.abs()).collect::<Vec<_>>());
    // `+ 0.0`: an empty float sum is −0, which would print as "-0".
    let w_plus: f64 = nz.iter().zip(&r).filter(|(x, _)| **x > 0.0).map(|(_, r)| r).sum::<f64>() + 0.0;
    let centre: f64 = r.iter().sum::<f64>() / 2.0;
    let observed = (w_plus - centre).abs();
    if n <= 20 {
        let mut extreme = 0u64;
        for mask in 0u64..(1 << n) {
            let w: f64 = (0..n).filter(|&i| mask >> i & 1 == 1).map(|i| r[i]).sum();
            if (w - centre).abs() >= observed - 1e-9 {
                extreme += 1;
            }
        }
        let p = extreme as f64 / (1u64 << n) as f64;
        return Some(Wilcoxon { n, w_plus, p_value: p.min(1.0), exact: true });
    }
    // Normal approximation with the tie correction of the variance.
    let mut tie_term = 0.0;
    let mut sorted = r.clone();
    sorted.sort_by(|a, b| a.total_cmp(b));
    let mut i = 0;
    while i < sorted.len() {
        let mut j = i;
        while j + 1 < sorted.len() && sorted[j + 1] == sorted[i] {
            j += 1;
        }
        let t = (j - i + 1) as f64;
        tie_term += t * t * t - t;
        i = j + 1;
    }
    let nf = n as f64;
    let var = nf * (nf + 1.0) * (2.0 * nf + 1.0) / 24.0 - tie_term / 48.0;
    let z = observed / var.sqrt();
    let p = 2.0 * (1.0 - standard_normal_cdf(z));
    Some(Wilcoxon { n, w_plus, p_value: p.min(1.0), exact: false })
}

/// Φ(z) by the complementary error function (Abramowitz–Stegun 7.1.26, |error| < 1.5e-7).
fn standard_normal_cdf(z: f64) -> f64 {
    let x = z.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let poly =
        t * (0.254_829_592 + t * (-0.284_496_736 + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erfc = poly * (-x * x).exp();
    if z >= 0.0 { 1.0 - erfc / 2.0 } else { erfc / 2.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t_quantiles_and_intervals() {
        assert_eq!(t_975(4), 2.776);
        assert_eq!(t_975(1000), 1.96);
        assert!(t_975(0).is_nan());
        let (m, lo, hi) = mean_ci95(&[1.0, 2.0, 3.0]);
        // se = 1/√3, t(2) = 4.303.
        assert!(
            (m - 2.0).abs() < 1e-12 && (hi - m - 4.303 / 3f64.sqrt()).abs() < 1e-9 && (m - lo - (hi - m)).abs() < 1e-12
        );
        assert!(mean_ci95(&[1.0]).1.is_nan());
    }

    #[test]
    fn quartiles_match_r_type_7() {
        let v = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0];
        assert_eq!(median(&v), 4.5);
        assert_eq!(quantile(&v, 0.25), 2.75);
        assert_eq!(quantile(&v, 0.75), 6.25);
        assert!((standard_error(&[1.0, 3.0]) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn exact_wilcoxon_by_hand() {
        // All five differences positive with distinct ranks: W+ = 15, only the all-positive
        // and all-negative patterns are as extreme: p = 2/32.
        let w = wilcoxon_signed_rank(&[1.0, 2.0, 3.0, 4.0, 5.0]).unwrap();
        assert_eq!((w.n, w.w_plus, w.exact), (5, 15.0, true));
        assert!((w.p_value - 0.0625).abs() < 1e-15);
        // Zeros are dropped; ties get mid-ranks: d = [0, 1, -1, 2] → |d| ranks 1.5, 1.5, 3.
        let w = wilcoxon_signed_rank(&[0.0, 1.0, -1.0, 2.0]).unwrap();
        assert_eq!((w.n, w.w_plus), (3, 4.5));
        // Patterns with |W+ − 3| ≥ 1.5: W+ ∈ {0, 1.5(×2)…}: enumerate by hand: sums of subsets of
        // {1.5, 1.5, 3}: 0, 1.5, 1.5, 3, 3, 4.5, 4.5, 6 → |·−3| ≥ 1.5 for 0, 1.5, 1.5, 4.5, 4.5, 6.
        assert!((w.p_value - 6.0 / 8.0).abs() < 1e-15);
        assert!(wilcoxon_signed_rank(&[0.0, 0.0]).is_none());
        // No positive difference: W+ is zero, and prints as "0".
        let w = wilcoxon_signed_rank(&[-1.0, -2.0]).unwrap();
        assert_eq!(format!("{}", w.w_plus), "0");
    }

    #[test]
    fn normal_approximation_for_large_samples() {
        let d: Vec<f64> = (1..=30).map(|i| i as f64).collect();
        let w = wilcoxon_signed_rank(&d).unwrap();
        assert!(!w.exact && w.p_value < 1e-5);
        assert!((standard_normal_cdf(1.959_964) - 0.975).abs() < 1e-6);
    }
}
