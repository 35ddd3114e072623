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

/// The 0.975 quantile of Student's t with `df` degrees of freedom (two-sided 95 %; R's
/// `qt(0.975, df)`), from statrs's inverse of the regularised incomplete beta function; NaN
/// for df = 0.
pub(crate) fn t_975(df: usize) -> f64 {
    use statrs::distribution::{ContinuousCDF, StudentsT};
    if df == 0 {
        return f64::NAN;
    }
    StudentsT::new(0.0, 1.0, df as f64).map_or(f64::NAN, |t| t.inverse_cdf(0.975))
}

/// The mean of `v` with its 95 % confidence interval (Student's t); the interval is NaN for
/// fewer than two values.
pub fn mean_ci95(v: &[f64]) -> (f64, f64, f64) {
    let m = mean(v);
    let h = t_975(v.len().saturating_sub(1)) * standard_error(v);
    (m, m - h, m + h)
}

/// Fieller's 95 % interval for a ratio of paired means, mean(num) / mean(den), from the pairs
/// (num_k, den_k): every R for which the two-sided t-test (n − 1 df) of the mean of
/// num_k − R·den_k does not reject 0. It is bounded only when mean(den) is itself
/// significantly away from 0; otherwise the set is unbounded (the whole line, or all but an
/// interval) and the data do not bound the ratio: `None`. Also `None` below two pairs.
pub fn fieller_ratio_ci95(num: &[f64], den: &[f64]) -> Option<(f64, f64)> {
    let n = num.len();
    if n < 2 || den.len() != n {
        return None;
    }
    let (mn, md) = (mean(num), mean(den));
    let (mut snn, mut sdd, mut snd) = (0.0, 0.0, 0.0);
    for (a, b) in num.iter().zip(den) {
        let (x, y) = (a - mn, b - md);
        snn += x * x;
        sdd += y * y;
        snd += x * y;
    }
    // The variances and covariance of the two means.
    let scale = ((n - 1) * n) as f64;
    let (vnn, vdd, vnd) = (snn / scale, sdd / scale, snd / scale);
    let t2 = t_975(n - 1).powi(2);
    // (mn − R·md)² ≤ t²·(vnn − 2R·vnd + R²·vdd), i.e. a·R² − 2b·R + c ≤ 0.
    let a = md * md - t2 * vdd;
    let b = mn * md - t2 * vnd;
    let c = mn * mn - t2 * vnn;
    if a <= 0.0 || !a.is_finite() {
        return None;
    }
    // At R = mn / md the left side is ≤ 0, so the discriminant is ≥ 0 up to rounding.
    let root = (b * b - a * c).max(0.0).sqrt();
    Some(((b - root) / a, (b + root) / a))
}

/// A paired comparison of two conditions (or algorithms, or protocols) on one measure at one
/// iteration: the differences (first − second) of the same participants or trials, in groups
/// (one per seed; a study's sessions are one group). The one shape of every paired result:
/// `analyze`'s Fig. 10 tests, `dry-run --seeds`/`--versus`, the simulations' `tests.csv`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, Default)]
pub struct Paired {
    pub measure: &'static str,
    pub iteration: usize,
    /// Whose values the differences start from, and whose are subtracted.
    pub first: String,
    pub second: String,
    /// Pairs in all groups.
    pub n: usize,
    /// Mean of (first − second).
    pub mean_difference: f64,
    /// 95 % t-interval of the mean difference: over the groups' means when there are several
    /// groups, else over the pairs (NaN below two).
    pub ci_low: f64,
    pub ci_high: f64,
    /// The median difference over every pair, and the share of pairs with the first higher:
    /// beside the mean, whether an effect is everyone's or a few's.
    pub median_difference: f64,
    pub share_first_higher: f64,
    /// Two-sided Wilcoxon signed-rank p over every pair (none when every difference is zero:
    /// the test is not defined).
    pub p_value: Option<f64>,
    /// Non-empty groups (seeds).
    pub seeds: usize,
    /// Groups whose pairs alone give p < .05, with first > second and with first < second.
    pub seeds_first_higher: usize,
    pub seeds_first_lower: usize,
}

impl Paired {
    /// Summarises the differences given per group; `None` when there are none.
    pub fn over_groups(
        measure: &'static str,
        iteration: usize,
        first: impl Into<String>,
        second: impl Into<String>,
        groups: &[Vec<f64>],
    ) -> Option<Paired> {
        let groups: Vec<&Vec<f64>> = groups.iter().filter(|g| !g.is_empty()).collect();
        let all: Vec<f64> = groups.iter().flat_map(|g| g.iter().copied()).collect();
        if all.is_empty() {
            return None;
        }
        let means: Vec<f64> = groups.iter().map(|g| mean(g)).collect();
        let (mut higher, mut lower) = (0, 0);
        for (g, m) in groups.iter().zip(&means) {
            if wilcoxon_signed_rank(g).is_some_and(|w| w.p_value < 0.05) {
                if *m > 0.0 {
                    higher += 1;
                } else if *m < 0.0 {
                    lower += 1;
                }
            }
        }
        let (_, ci_low, ci_high) = if means.len() > 1 { mean_ci95(&means) } else { mean_ci95(&all) };
        Some(Paired {
            measure,
            iteration,
            first: first.into(),
            second: second.into(),
            n: all.len(),
            mean_difference: mean(&all),
            ci_low,
            ci_high,
            median_difference: median(&all),
            share_first_higher: all.iter().filter(|x| **x > 0.0).count() as f64 / all.len() as f64,
            p_value: wilcoxon_signed_rank(&all).map(|w| w.p_value),
            seeds: means.len(),
            seeds_first_higher: higher,
            seeds_first_lower: lower,
        })
    }
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
    /// Whether p is exact (the null distribution over all 2^n sign patterns, n ≤
    /// [`WILCOXON_EXACT_MAX`]) or from the normal approximation with tie correction.
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

/// Up to this many non-zero pairs the Wilcoxon p-value is exact (the null distribution
/// computed by recursion over the ranks, O(n³) work); beyond it, the normal approximation.
pub(crate) const WILCOXON_EXACT_MAX: usize = 300;

/// The two-sided Wilcoxon signed-rank test of paired differences `d` against 0. Zero
/// differences are dropped; ties in |d| get mid-ranks. With at most [`WILCOXON_EXACT_MAX`]
/// non-zero pairs the p-value is exact: the probability, over the 2^n equally likely sign
/// patterns under H0 (each rank with its mid-rank), that W+ is at least as far from its
/// centre as the observed one; beyond, the normal approximation with the tie correction of
/// the variance (no continuity correction). `None` without non-zero pairs.
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
    if n <= WILCOXON_EXACT_MAX {
        return Some(Wilcoxon { n, w_plus, p_value: exact_p(&r, w_plus).min(1.0), exact: true });
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
    // 2(1 − Φ(z)) as erfc(z/√2): no cancellation in a tiny tail.
    let p = statrs::function::erf::erfc(z / std::f64::consts::SQRT_2);
    Some(Wilcoxon { n, w_plus, p_value: p.min(1.0), exact: false })
}

/// The exact two-sided p of W+ = `w_plus` over the sign patterns of `ranks` (mid-ranks are
/// multiples of ½, so twice a rank is an integer): the distribution of 2W+ is built one rank
/// at a time, P_k(s) = ½ P_{k−1}(s) + ½ P_{k−1}(s − 2r_k), and the p-value sums the
/// probabilities of the sums at least as far from the centre as the observed one.
fn exact_p(ranks: &[f64], w_plus: f64) -> f64 {
    let doubled: Vec<usize> = ranks.iter().map(|r| (2.0 * r).round() as usize).collect();
    let total: usize = doubled.iter().sum();
    let mut p = vec![0.0f64; total + 1];
    p[0] = 1.0;
    let mut reach = 0;
    for &r in &doubled {
        reach += r;
        for s in (0..=reach).rev() {
            let with = if s >= r { p[s - r] } else { 0.0 };
            p[s] = 0.5 * p[s] + 0.5 * with;
        }
    }
    // Distances from the centre in units of ½ rank (the centre is total/2 in doubled units).
    let observed = ((2.0 * w_plus).round() as i64 * 2 - total as i64).abs();
    p.iter().enumerate().filter(|(s, _)| (*s as i64 * 2 - total as i64).abs() >= observed).map(|(_, q)| q).sum()
}

#[cfg(test)]
mod tests {
    /// At each end of Fieller's interval the paired t-test of num − R·den sits exactly on
    /// its 95 % boundary (the interval's definition), inside it does not reject, and the
    /// ratio of the means lies within.
    #[test]
    fn fieller_interval_is_where_the_paired_t_test_does_not_reject() {
        let num = [0.31, 0.12, 0.45, 0.22, 0.05, 0.38, 0.27, 0.19];
        let den = [0.40, 0.21, 0.52, 0.30, 0.18, 0.36, 0.33, 0.29];
        let (low, high) = fieller_ratio_ci95(&num, &den).unwrap();
        let ratio = mean(&num) / mean(&den);
        assert!(low < ratio && ratio < high, "{low} {ratio} {high}");
        // SciPy 1.17.1: brentq on ttest_1samp(num − R·den).pvalue = 0.05 either side of the ratio.
        assert!((low - 0.5729235415494751).abs() < 1e-9 && (high - 0.8962228409012657).abs() < 1e-9, "{low} {high}");
        let t_of = |r: f64| {
            let d: Vec<f64> = num.iter().zip(&den).map(|(a, b)| a - r * b).collect();
            mean(&d) / standard_error(&d)
        };
        for end in [low, high] {
            assert!((t_of(end).abs() - t_975(7)).abs() < 1e-9, "t at {end}: {}", t_of(end));
        }
        for r in [low + 1e-3, ratio, high - 1e-3] {
            assert!(t_of(r).abs() < t_975(7), "{r}");
        }
        for r in [low - 1e-3, high + 1e-3] {
            assert!(t_of(r).abs() > t_975(7), "{r}");
        }
    }

    /// A denominator whose mean is not told from 0 leaves the ratio unbounded; a ratio of a
    /// quantity to itself is exactly 1; a numerator of zeros exactly 0.
    #[test]
    fn fieller_interval_is_none_when_the_denominator_is_not_told_from_zero() {
        let num = [0.3, 0.1, 0.4, 0.2];
        assert_eq!(fieller_ratio_ci95(&num, &[0.2, -0.3, 0.25, -0.1]), None);
        assert_eq!(fieller_ratio_ci95(&num[..1], &[0.2]), None);
        let (l, h) = fieller_ratio_ci95(&num, &num).unwrap();
        assert!((l - 1.0).abs() < 1e-12 && (h - 1.0).abs() < 1e-12, "{l} {h}");
        assert_eq!(fieller_ratio_ci95(&[0.0; 4], &num), Some((0.0, 0.0)));
    }

    use super::*;

    /// `qt(0.975, df)` as R and scipy 1.17.1 (`scipy.stats.t.ppf(0.975, df)`) give it, to
    /// 10 decimals: the table's range, the old table's interpolated ranges (31–120), and beyond.
    const T_975: [(usize, f64); 22] = [
        (1, 12.7062047362),
        (2, 4.3026527297),
        (3, 3.1824463053),
        (4, 2.7764451052),
        (5, 2.5705818356),
        (10, 2.228138852),
        (15, 2.1314495456),
        (20, 2.0859634473),
        (29, 2.0452296421),
        (30, 2.0422724563),
        (31, 2.0395134464),
        (40, 2.0210753903),
        (45, 2.0141033889),
        (59, 2.0009953781),
        (60, 2.000297822),
        (61, 1.999623585),
        (90, 1.9866745407),
        (119, 1.9800998765),
        (120, 1.9799304051),
        (121, 1.9797637625),
        (200, 1.9718962236),
        (1000, 1.9623390808),
    ];

    #[test]
    fn t_quantiles_match_r_and_scipy() {
        for (df, q) in T_975 {
            assert!((t_975(df) - q).abs() < 1e-8, "df {df}: {} vs {q}", t_975(df));
        }
        assert!(t_975(0).is_nan());
        let (m, lo, hi) = mean_ci95(&[1.0, 2.0, 3.0]);
        // se = 1/√3, t(2) = 4.3026527297.
        let h = 4.3026527297 / 3f64.sqrt();
        assert!((m - 2.0).abs() < 1e-12 && (hi - m - h).abs() < 1e-8 && (m - lo - (hi - m)).abs() < 1e-12);
        assert!(mean_ci95(&[1.0]).1.is_nan());
    }

    /// Two-sided exact Wilcoxon p-values from scipy 1.17.1: `wilcoxon(d, method='exact')`
    /// for data without ties or zeros, and for data with them the exact sign-flip
    /// distribution of W+ on mid-ranks (`permutation_test((nz,), W+, permutation_type=
    /// 'samples', n_resamples=inf)`, zeros dropped first); R's `wilcox.test(d, exact=TRUE)`
    /// gives the same for the untied cases.
    #[test]
    fn exact_wilcoxon_matches_scipy() {
        let signs = |n: i32, k: i32| -> Vec<f64> { (1..=n).map(|i| if i % k == 0 { -i } else { i } as f64).collect() };
        let cases: [(Vec<f64>, f64); 6] = [
            (vec![1.0, -2.0, 3.0, 4.0, 5.0, -6.0, 7.0, 8.0, 9.0, 10.0], 0.048828125),
            (signs(25, 4), 0.034173786640167236),
            (signs(40, 3), 0.06616061626664305),
            (vec![0.0, 1.0, -1.0, 2.0, 2.0, -3.0, 4.0, 4.0, 4.0, 5.0], 0.05859375),
            (
                vec![1.5, 1.5, -1.5, 2.0, 2.0, 2.0, -3.0, 3.0, 3.5, -0.5, 0.5, 4.0, 4.0, 4.0, 4.0, 6.0],
                0.004180908203125,
            ),
            (vec![1.0, 2.0, 3.0, 4.0, 5.0], 0.0625),
        ];
        for (d, p) in cases {
            let w = wilcoxon_signed_rank(&d).unwrap();
            assert!(w.exact, "{d:?}");
            assert!((w.p_value - p).abs() < 1e-12 * p.max(1e-3), "{d:?}: {} vs {p}", w.p_value);
        }
    }

    /// Beyond the exact range: the normal approximation with the tie correction, as scipy's
    /// `wilcoxon(d, method='approx', correction=False)` (700 pairs with ties).
    #[test]
    fn normal_approximation_matches_scipy_beyond_the_exact_range() {
        let d: Vec<f64> = (2..702).map(|i: i64| if i % 3 != 0 { i / 2 } else { -(i / 2) } as f64).collect();
        let w = wilcoxon_signed_rank(&d).unwrap();
        assert!(!w.exact && w.n == 700);
        assert!((w.p_value - 1.5413934063348332e-14).abs() < 1e-6 * 1.5413934063348332e-14, "{}", w.p_value);
        // 2(1 − Φ(1.959964)) = 2 × scipy's norm.sf(1.959964).
        let p = statrs::function::erf::erfc(1.959964 / std::f64::consts::SQRT_2);
        assert!((p - 0.0499999981928846).abs() < 1e-11, "{p}");
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
    fn the_exact_distribution_is_fast_at_the_limit() {
        let d: Vec<f64> = (1..=WILCOXON_EXACT_MAX as i64).map(|i| if i % 2 == 0 { i } else { -i / 2 } as f64).collect();
        let t0 = std::time::Instant::now();
        let w = wilcoxon_signed_rank(&d).unwrap();
        assert!(w.exact && w.p_value > 0.0 && w.p_value < 1.0);
        assert!(t0.elapsed().as_secs_f64() < 2.0, "{:?}", t0.elapsed());
    }
}
