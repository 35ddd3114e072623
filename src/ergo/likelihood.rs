//! Cost and Boltzmann likelihood of a person's choice (eq. 1–3), and the per-particle pass
//! over a feasible set that the belief update and the selectors share.
//!
//! Its length: the three observations (configuration, region, measured) with their checks,
//! and the one vectorised pass every likelihood is read from, with its tests.

use super::config_set::ConfigSet;
use super::numeric::{LANES, exp_nonpositive, sum_lanes};
use super::{FeasibleSet, Lambda};

/// C(q; λ) = Σ_d w_d (q_d − q*_d)² (eq. 2 with W = diag(w)).
pub fn cost(q: &[f64], q_star: &[f64], w: &[f64]) -> f64 {
    let mut c = 0.0;
    for d in 0..q.len() {
        let t = q[d] - q_star[d];
        c += w[d] * t * t;
    }
    c
}

/// What was observed of the person's choice.
#[derive(Clone, Debug, PartialEq)]
pub enum Observation {
    /// The configuration itself (an index into the feasible set).
    Config(usize),
    /// Only that the choice lies in this subset (the handle grabbed), as indices.
    Region(Vec<usize>),
    /// A measured joint vector q_m with Gaussian noise: for each configuration q_j of the set,
    /// log N(q_m; q_j, diag σ²) ([`Observation::measured`]). Its likelihood is
    /// log Σ_j P(q_j | Q, λ) N(q_m; q_j, Σ): the person chose some q_j, and the measuring
    /// system saw it with noise.
    Measured(Vec<f64>),
}

/// The measurement noise σ a study or a simulation may state, degrees: from 0.01° (a
/// measurement that pins the configuration) to one radian (beyond it a measurement says
/// nothing of a joint, and |q_m| stays within the 10 rad a measurement may have).
pub const SIGMA_DEG: (f64, f64) = (0.01, 1.0f64.to_degrees());

/// Why an observation does not fit its feasible set.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ObservationError {
    #[error("configuration index {index} is out of range (the set has {len})")]
    IndexOutOfRange { index: usize, len: usize },
    #[error("a region observation needs at least one configuration")]
    EmptyRegion,
    #[error("a measured observation needs one finite log-density per configuration ({got} for {len})")]
    MeasuredLength { got: usize, len: usize },
    #[error("a measurement {0}")]
    BadMeasurement(String),
}

impl Observation {
    /// Checks the indices against a set of `len` configurations.
    pub fn check(&self, len: usize) -> Result<(), ObservationError> {
        match self {
            Observation::Config(i) if *i >= len => Err(ObservationError::IndexOutOfRange { index: *i, len }),
            Observation::Config(_) => Ok(()),
            Observation::Region(r) if r.is_empty() => Err(ObservationError::EmptyRegion),
            Observation::Region(r) => match r.iter().find(|&&i| i >= len) {
                Some(&index) => Err(ObservationError::IndexOutOfRange { index, len }),
                None => Ok(()),
            },
            Observation::Measured(g) if g.len() != len || !g.iter().all(|v| v.is_finite()) => {
                Err(ObservationError::MeasuredLength { got: g.len(), len })
            }
            Observation::Measured(_) => Ok(()),
        }
    }

    /// A measured joint vector `q_m` (rad) of a person choosing from `set`, with independent
    /// Gaussian noise of standard deviation `sigma[d]` (rad) per joint: the log-density
    /// log N(q_m; q_j, diag σ²) of every configuration q_j.
    pub fn measured(set: &ConfigSet, q_m: &[f64], sigma: &[f64]) -> Result<Self, ObservationError> {
        let dim = set.dim();
        if q_m.len() != dim || sigma.len() != dim {
            return Err(ObservationError::BadMeasurement(format!(
                "has {} angles and {} noise levels, expected {dim} of each",
                q_m.len(),
                sigma.len()
            )));
        }
        if !q_m.iter().all(|v| v.is_finite() && v.abs() <= 10.0) {
            return Err(ObservationError::BadMeasurement(format!(
                "{q_m:?} is not a vector of finite angles (|q| ≤ 10 rad)"
            )));
        }
        if !sigma.iter().all(|s| s.is_finite() && *s >= 1e-9) {
            return Err(ObservationError::BadMeasurement(format!(
                "noise {sigma:?} is not a finite standard deviation ≥ 1e-9 rad per joint"
            )));
        }
        let norm: f64 = sigma.iter().map(|s| (s * (2.0 * std::f64::consts::PI).sqrt()).ln()).sum();
        let mut g = vec![-norm; set.len()];
        for d in 0..dim {
            let (m, s) = (q_m[d], sigma[d]);
            for (gj, &q) in g.iter_mut().zip(set.joint(d)) {
                let z = (m - q) / s;
                *gj -= 0.5 * z * z;
            }
        }
        Ok(Observation::Measured(g))
    }

    /// The configuration a measurement is nearest to (the highest density; the lowest index on
    /// ties), which implies the region taken. None for other observations.
    pub fn nearest(&self) -> Option<usize> {
        let Observation::Measured(g) = self else { return None };
        let mut best: Option<(usize, f64)> = None;
        for (j, &v) in g.iter().enumerate() {
            if best.is_none_or(|(_, b)| v > b) {
                best = Some((j, v));
            }
        }
        best.map(|(j, _)| j)
    }
}

/// Log-likelihood of an observation given λ: for a configuration,
/// log P(q | Q, λ) = −αC(q) − logsumexp_{q̂∈Q}(−αC(q̂)) (eq. 1 and 3); for a region R ⊂ Q,
/// log Σ_{q∈R} P(q | Q, λ). Finite whenever the true value is, for costs up to 1e6 and beyond.
pub fn log_likelihood(
    set: &FeasibleSet,
    lambda: &Lambda,
    alpha: f64,
    obs: &Observation,
) -> Result<f64, ObservationError> {
    obs.check(set.len())?;
    let mut scratch = SetPass::scratch(set.len());
    let pass = SetPass::run(set.configs(), &lambda.q_star, &lambda.w, alpha, &mut scratch);
    Ok(pass.log_likelihood(obs, alpha, &scratch))
}

/// Below this, a region's sum of the pass's exponentials may have lost precision to
/// underflow (each term is exact to a few ulps down to 1e-307), and the region likelihood is
/// recomputed from the costs.
const REGION_SUM_FLOOR: f64 = 1e-200;

/// Buffers reused across particles: the costs and the shifted exponentials of one pass.
#[derive(Clone, Debug)]
pub struct Scratch {
    pub costs: Vec<f64>,
    pub exps: Vec<f64>,
}

/// One particle evaluated on one feasible set.
///
/// After [`SetPass::run`], `scratch.costs[j]` = C(q_j; λ) and
/// `scratch.exps[j]` = exp(−α (C(q_j) − min C)), so P(q_j | Q, λ) = exps[j] / sum.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SetPass {
    /// min_q C(q; λ) over the set (eq. 10's inner minimum).
    pub min_cost: f64,
    /// The lowest index attaining it: the maximum-likelihood configuration.
    pub argmin: usize,
    /// Σ_j exps[j] (≥ 1).
    pub sum: f64,
    /// Σ_j exps[j] · (−α (C_j − min C)), for the entropy of the choice.
    pub sum_exp_logit: f64,
}

impl SetPass {
    pub fn scratch(len: usize) -> Scratch {
        Scratch { costs: vec![0.0; len], exps: vec![0.0; len] }
    }

    /// Evaluates every configuration's cost and Boltzmann weight under (q*, w, α).
    pub fn run(set: &ConfigSet, q_star: &[f64], w: &[f64], alpha: f64, scratch: &mut Scratch) -> SetPass {
        scratch.costs.resize(set.len(), 0.0);
        scratch.exps.resize(set.len(), 0.0);
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2, checked just above.
                return unsafe { run_avx2(set, q_star, w, alpha, scratch) };
            }
        }
        run_body(set, q_star, w, alpha, scratch)
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
        match obs {
            Observation::Config(j) => -alpha * (scratch.costs[*j] - self.min_cost) - self.sum.ln(),
            Observation::Region(idx) => {
                // log Σ_{j∈R} exp(ℓ_j) − log S, with ℓ_j = −α (C_j − min C): from the pass's
                // exponentials while their sum is far from underflow, else from the costs so
                // that it stays finite when every exps[j] of R underflows.
                let s: f64 = idx.iter().map(|&j| scratch.exps[j]).sum();
                if s > REGION_SUM_FLOOR {
                    return s.ln() - self.sum.ln();
                }
                let max =
                    idx.iter().map(|&j| -alpha * (scratch.costs[j] - self.min_cost)).fold(f64::NEG_INFINITY, f64::max);
                let s: f64 =
                    idx.iter().map(|&j| exp_nonpositive(-alpha * (scratch.costs[j] - self.min_cost) - max)).sum();
                max + s.ln() - self.sum.ln()
            }
            Observation::Measured(g) => {
                // log Σ_j exp(ℓ_j + g_j) − log S, by log-sum-exp over the costs.
                let term = |j: usize| -alpha * (scratch.costs[j] - self.min_cost) + g[j];
                let max = (0..g.len()).map(term).fold(f64::NEG_INFINITY, f64::max);
                let s: f64 = (0..g.len()).map(|j| exp_nonpositive(term(j) - max)).sum();
                max + s.ln() - self.sum.ln()
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn run_avx2(set: &ConfigSet, q_star: &[f64], w: &[f64], alpha: f64, scratch: &mut Scratch) -> SetPass {
    run_body(set, q_star, w, alpha, scratch)
}

#[inline(always)]
fn run_body(set: &ConfigSet, q_star: &[f64], w: &[f64], alpha: f64, scratch: &mut Scratch) -> SetPass {
    let costs = &mut scratch.costs[..];
    let exps = &mut scratch.exps[..];
    costs.fill(0.0);
    for d in 0..set.dim() {
        let (qs, wd) = (q_star[d], w[d]);
        for (c, &q) in costs.iter_mut().zip(set.joint(d)) {
            let t = q - qs;
            *c += wd * t * t;
        }
    }
    let mut mins = [f64::INFINITY; LANES];
    let mut chunks = costs.chunks_exact(LANES);
    for chunk in &mut chunks {
        for k in 0..LANES {
            mins[k] = mins[k].min(chunk[k]);
        }
    }
    let mut min_cost = chunks.remainder().iter().copied().fold(f64::INFINITY, f64::min);
    for m in mins {
        min_cost = min_cost.min(m);
    }
    let argmin = costs.iter().position(|&c| c == min_cost).unwrap_or(0);

    for (e, &c) in exps.iter_mut().zip(costs.iter()) {
        *e = exp_nonpositive(-alpha * (c - min_cost));
    }
    let mut sums = [0.0; LANES];
    let mut sums_el = [0.0; LANES];
    let mut cc = costs.chunks_exact(LANES);
    let mut ee = exps.chunks_exact(LANES);
    for (c, e) in (&mut cc).zip(&mut ee) {
        for k in 0..LANES {
            sums[k] += e[k];
            sums_el[k] += e[k] * (-alpha * (c[k] - min_cost));
        }
    }
    for (k, (c, e)) in cc.remainder().iter().zip(ee.remainder()).enumerate() {
        sums[k] += e;
        sums_el[k] += e * (-alpha * (c - min_cost));
    }
    SetPass { min_cost, argmin, sum: sum_lanes(sums), sum_exp_logit: sum_lanes(sums_el) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set(rows: &[&[f64]]) -> FeasibleSet {
        FeasibleSet::new(ConfigSet::from_rows(rows).unwrap())
    }

    #[test]
    fn cost_is_weighted_squared_distance() {
        // (1-0)^2 * 2 + (3-1)^2 * 0.5 = 2 + 2 = 4
        assert_eq!(cost(&[1.0, 3.0], &[0.0, 1.0], &[2.0, 0.5]), 4.0);
    }

    #[test]
    fn likelihood_matches_hand_computed_boltzmann() {
        // q* = 0, w = 1, α = 2; costs 0, 1, 4 → P ∝ e^0, e^-2, e^-8.
        let s = set(&[&[0.0], &[1.0], &[2.0]]);
        let l = Lambda { q_star: vec![0.0], w: vec![1.0] };
        let z = 1.0 + (-2.0f64).exp() + (-8.0f64).exp();
        let got = log_likelihood(&s, &l, 2.0, &Observation::Config(1)).unwrap();
        assert!((got - ((-2.0f64).exp() / z).ln()).abs() < 1e-14);
        let region = log_likelihood(&s, &l, 2.0, &Observation::Region(vec![1, 2])).unwrap();
        assert!((region - (((-2.0f64).exp() + (-8.0f64).exp()) / z).ln()).abs() < 1e-14);
    }

    #[test]
    fn likelihood_stays_finite_for_huge_costs() {
        // Costs 0 and 1e6 with α = 1: log P of the far one is exactly −1e6 (to rounding).
        let s = set(&[&[0.0], &[1000.0]]);
        let l = Lambda { q_star: vec![0.0], w: vec![1.0] };
        let far = log_likelihood(&s, &l, 1.0, &Observation::Config(1)).unwrap();
        assert!((far + 1e6).abs() < 1e-6, "{far}");
        let region = log_likelihood(&s, &l, 1.0, &Observation::Region(vec![1])).unwrap();
        assert!((region + 1e6).abs() < 1e-6, "{region}");
        let near = log_likelihood(&s, &l, 1.0, &Observation::Config(0)).unwrap();
        assert_eq!(near, 0.0);
    }

    #[test]
    fn region_likelihood_is_accurate_on_both_sides_of_the_fast_paths_floor() {
        // A far region of one configuration with cost c (α = 1): log P = −c − ln(1 + e^−c).
        // e^−437 ≈ 1e-190 is summed from the pass; e^−483 ≈ 1e-210 is recomputed from costs.
        for c in [437.0f64, 483.0, 700.0] {
            let s = set(&[&[0.0], &[c.sqrt()]]);
            let l = Lambda { q_star: vec![0.0], w: vec![1.0] };
            let region = log_likelihood(&s, &l, 1.0, &Observation::Region(vec![1])).unwrap();
            let config = log_likelihood(&s, &l, 1.0, &Observation::Config(1)).unwrap();
            assert!((region + c).abs() < 1e-9 * c, "cost {c}: {region}");
            assert!((region - config).abs() < 1e-9 * c, "cost {c}: {region} vs {config}");
        }
    }

    #[test]
    fn pass_entropy_of_uniform_choice_is_log_n() {
        let s = set(&[&[1.0], &[-1.0], &[1.0], &[-1.0]]);
        let mut sc = SetPass::scratch(4);
        let p = SetPass::run(s.configs(), &[0.0], &[1.0], 3.0, &mut sc);
        assert!((p.config_entropy() - 4.0f64.ln()).abs() < 1e-14);
        assert_eq!(p.argmin, 0);
        assert_eq!(p.min_cost, 1.0);
    }

    #[test]
    fn a_measurement_is_a_mixture_of_the_configurations_weighted_by_their_density() {
        // q* = 0, w = 1, α = 1; configurations 0, 1, 2; q_m = 0.4, σ = 0.5.
        let s = set(&[&[0.0], &[1.0], &[2.0]]);
        let l = Lambda { q_star: vec![0.0], w: vec![1.0] };
        let obs = Observation::measured(s.configs(), &[0.4], &[0.5]).unwrap();
        let z: f64 = [0.0f64, -1.0, -4.0].iter().map(|c| c.exp()).sum();
        let n = |q: f64| (-0.5 * ((0.4 - q) / 0.5f64).powi(2)).exp() / (0.5 * (2.0 * std::f64::consts::PI).sqrt());
        let want = ((1.0 / z) * n(0.0) + ((-1.0f64).exp() / z) * n(1.0) + ((-4.0f64).exp() / z) * n(2.0)).ln();
        let got = log_likelihood(&s, &l, 1.0, &obs).unwrap();
        assert!((got - want).abs() < 1e-13, "{got} vs {want}");
        assert_eq!(obs.nearest(), Some(0));
        // Finite however far the measurement and however large the costs.
        let far = Observation::measured(s.configs(), &[9.0], &[1e-6]).unwrap();
        assert!(log_likelihood(&s, &Lambda { q_star: vec![9.0], w: vec![1e3] }, 50.0, &far).unwrap().is_finite());
    }

    #[test]
    fn bad_measurements_are_refused() {
        let s = set(&[&[0.0, 0.0]]);
        for (q, sigma) in [
            (vec![0.0], vec![0.1, 0.1]),
            (vec![f64::NAN, 0.0], vec![0.1, 0.1]),
            (vec![0.0, 0.0], vec![0.0, 0.1]),
            (vec![0.0, 0.0], vec![0.1, f64::INFINITY]),
        ] {
            assert!(matches!(Observation::measured(s.configs(), &q, &sigma), Err(ObservationError::BadMeasurement(_))));
        }
        assert_eq!(
            Observation::Measured(vec![0.0; 3]).check(1),
            Err(ObservationError::MeasuredLength { got: 3, len: 1 })
        );
        assert!(Observation::Measured(vec![f64::NEG_INFINITY]).check(1).is_err());
    }

    #[test]
    fn bad_observations_are_refused() {
        let s = set(&[&[0.0]]);
        let l = Lambda { q_star: vec![0.0], w: vec![1.0] };
        assert_eq!(
            log_likelihood(&s, &l, 1.0, &Observation::Config(3)),
            Err(ObservationError::IndexOutOfRange { index: 3, len: 1 })
        );
        assert_eq!(log_likelihood(&s, &l, 1.0, &Observation::Region(vec![])), Err(ObservationError::EmptyRegion));
    }
}

/// The label model of the user study (footnote 2): given the region the person grabbed,
/// the most likely configuration in it under a stated λ, i.e. argmin of C(q; λ) over the
/// region (the lowest index on ties). `None` for an empty region.
pub fn most_likely_in_region(set: &FeasibleSet, region: usize, lambda: &Lambda) -> Option<usize> {
    let range = set.regions().get(region)?.clone();
    let configs = set.configs();
    let mut best: Option<(usize, f64)> = None;
    let mut q = vec![0.0; configs.dim()];
    for j in range {
        for (d, v) in q.iter_mut().enumerate() {
            *v = configs.joint(d)[j];
        }
        let c = cost(&q, &lambda.q_star, &lambda.w);
        if best.is_none_or(|(_, b)| c < b) {
            best = Some((j, c));
        }
    }
    best.map(|(j, _)| j)
}

#[cfg(test)]
mod label_model_tests {
    use super::*;

    #[test]
    fn label_model_picks_the_cheapest_configuration_of_the_grabbed_region() {
        let configs = ConfigSet::from_rows(&[[0.0], [0.9], [0.2], [3.0], [1.1]]).unwrap();
        let set = FeasibleSet::with_regions(configs, &[0, 0, 0, 1, 1]).unwrap();
        let l = Lambda { q_star: vec![1.0], w: vec![1.0] };
        assert_eq!(most_likely_in_region(&set, 0, &l), Some(1));
        assert_eq!(most_likely_in_region(&set, 1, &l), Some(4));
        assert_eq!(most_likely_in_region(&set, 2, &l), None);
    }
}
