//! Cost and Boltzmann likelihood of a person's choice (eq. 1–3): the three observations
//! (configuration, region, measured) with their checks, read from the one pass over a
//! feasible set (`set_pass`).

use super::config_set::ConfigSet;
use super::set_pass::SetPass;
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
