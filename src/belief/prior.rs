//! Priors over λ = [q*, w], one distribution per component.

use rand::{Rng, RngExt};
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::ergo::{Lambda, LearnMask};

/// The prior of one component of λ.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum ComponentPrior {
    /// Known, not learned.
    Fixed { value: f64 },
    /// Uniform on [min, max].
    Uniform { min: f64, max: f64 },
    /// Normal(mean, sd²) truncated to [min, max].
    Gaussian { mean: f64, sd: f64, min: f64, max: f64 },
}

/// Why a prior was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PriorError {
    #[error("{component}: min {min} must be below max {max}")]
    EmptyRange { component: String, min: f64, max: f64 },
    #[error("{component}: {field} is {value}, expected a finite number")]
    NonFinite { component: String, field: &'static str, value: f64 },
    #[error("{component}: sd is {sd}, expected a positive number")]
    BadSd { component: String, sd: f64 },
    #[error(
        "{component}: mean {mean} lies outside [{min}, {max}], expected a mean inside the range it is truncated to"
    )]
    MeanOutside { component: String, mean: f64, min: f64, max: f64 },
    #[error("{component}: a weight's support must be non-negative, found min {min}")]
    NegativeWeight { component: String, min: f64 },
    #[error("q* has {q_star} components and w has {w}; they must agree")]
    LengthMismatch { q_star: usize, w: usize },
    #[error("the prior has {prior} joints and the known λ {known}; they must agree")]
    KnownMismatch { prior: usize, known: usize },
}

impl ComponentPrior {
    /// The support [min, max] (a point for a fixed component).
    pub fn support(&self) -> (f64, f64) {
        match *self {
            ComponentPrior::Fixed { value } => (value, value),
            ComponentPrior::Uniform { min, max } | ComponentPrior::Gaussian { min, max, .. } => (min, max),
        }
    }

    pub fn is_fixed(&self) -> bool {
        matches!(self, ComponentPrior::Fixed { .. })
    }

    fn check(&self, component: String) -> Result<(), PriorError> {
        let finite = |field: &'static str, value: f64| {
            if value.is_finite() {
                Ok(())
            } else {
                Err(PriorError::NonFinite { component: component.clone(), field, value })
            }
        };
        match *self {
            ComponentPrior::Fixed { value } => finite("value", value),
            ComponentPrior::Uniform { min, max } => {
                finite("min", min)?;
                finite("max", max)?;
                if min < max { Ok(()) } else { Err(PriorError::EmptyRange { component, min, max }) }
            }
            ComponentPrior::Gaussian { mean, sd, min, max } => {
                finite("mean", mean)?;
                finite("min", min)?;
                finite("max", max)?;
                if !(sd.is_finite() && sd > 0.0) {
                    return Err(PriorError::BadSd { component, sd });
                }
                if min >= max {
                    return Err(PriorError::EmptyRange { component, min, max });
                }
                // A mean outside the range puts nearly all its mass outside: the draws would
                // fall back to uniform and the prior would not be the one written.
                if (min..=max).contains(&mean) {
                    Ok(())
                } else {
                    Err(PriorError::MeanOutside { component, mean, min, max })
                }
            }
        }
    }

    /// One draw.
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> f64 {
        match *self {
            ComponentPrior::Fixed { value } => value,
            ComponentPrior::Uniform { min, max } => min + (max - min) * rng.random::<f64>(),
            ComponentPrior::Gaussian { mean, sd, min, max } => {
                // Rejection from the untruncated normal (the mean lies in the window, so a
                // draw lands in it at least about half the time); after many misses (a window
                // far narrower than sd) uniform on the window, which the normal nearly is there.
                for _ in 0..1000 {
                    let z: f64 = StandardNormal.sample(rng);
                    let x = mean + sd * z;
                    if (min..=max).contains(&x) {
                        return x;
                    }
                }
                min + (max - min) * rng.random::<f64>()
            }
        }
    }
}

/// A prior over λ = [q*, w] of D joints: 2D independent components.
#[derive(Clone, Debug, PartialEq)]
pub struct Prior {
    components: Vec<ComponentPrior>,
}

impl Prior {
    /// A prior from per-joint priors of q* and of w (fixed components are known).
    pub fn new(q_star: Vec<ComponentPrior>, w: Vec<ComponentPrior>) -> Result<Self, PriorError> {
        if q_star.len() != w.len() {
            return Err(PriorError::LengthMismatch { q_star: q_star.len(), w: w.len() });
        }
        for (d, c) in q_star.iter().enumerate() {
            c.check(format!("q_star[{d}]"))?;
        }
        for (d, c) in w.iter().enumerate() {
            c.check(format!("w[{d}]"))?;
            let (min, _) = c.support();
            if min < 0.0 {
                return Err(PriorError::NegativeWeight { component: format!("w[{d}]"), min });
            }
        }
        let mut components = q_star;
        components.extend(w);
        Ok(Self { components })
    }

    /// A prior that learns what `mask` says and takes the rest from `known`.
    pub fn with_mask(
        mask: LearnMask,
        q_star: Vec<ComponentPrior>,
        w: Vec<ComponentPrior>,
        known: &Lambda,
    ) -> Result<Self, PriorError> {
        let dim = q_star.len();
        if w.len() != dim {
            return Err(PriorError::LengthMismatch { q_star: dim, w: w.len() });
        }
        if known.q_star.len() != dim || known.w.len() != dim {
            let known = if known.q_star.len() != dim { known.q_star.len() } else { known.w.len() };
            return Err(PriorError::KnownMismatch { prior: dim, known });
        }
        let fix = |c: usize, p: ComponentPrior, v: f64| {
            if mask.learns(c, dim) { p } else { ComponentPrior::Fixed { value: v } }
        };
        let q: Vec<_> = q_star.into_iter().enumerate().map(|(d, p)| fix(d, p, known.q_star[d])).collect();
        let w: Vec<_> = w.into_iter().enumerate().map(|(d, p)| fix(dim + d, p, known.w[d])).collect();
        Self::new(q, w)
    }

    /// Number of joints D.
    pub fn dim(&self) -> usize {
        self.components.len() / 2
    }

    pub fn components(&self) -> &[ComponentPrior] {
        &self.components
    }

    /// Indices into [q*, w] of the learned (not fixed) components.
    pub fn free(&self) -> Vec<usize> {
        (0..self.components.len()).filter(|&c| !self.components[c].is_fixed()).collect()
    }

    /// One draw of λ as [q*, w].
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> Vec<f64> {
        self.components.iter().map(|c| c.sample(rng)).collect()
    }

    /// log p(λ) up to a constant (the same for every λ): 0 inside a uniform component's
    /// range, −½((x − μ)/σ)² inside a truncated Gaussian's, −∞ outside a support; fixed
    /// components contribute nothing.
    pub fn log_density_unnormalised(&self, lambda: &[f64]) -> f64 {
        self.components
            .iter()
            .zip(lambda)
            .map(|(c, &x)| match *c {
                ComponentPrior::Fixed { .. } => 0.0,
                ComponentPrior::Uniform { min, max } => {
                    if (min..=max).contains(&x) {
                        0.0
                    } else {
                        f64::NEG_INFINITY
                    }
                }
                ComponentPrior::Gaussian { mean, sd, min, max } => {
                    if (min..=max).contains(&x) {
                        -0.5 * ((x - mean) / sd).powi(2)
                    } else {
                        f64::NEG_INFINITY
                    }
                }
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn draws_stay_in_support() {
        let p = Prior::new(
            vec![ComponentPrior::Uniform { min: -1.0, max: 1.0 }],
            vec![ComponentPrior::Gaussian { mean: 0.1, sd: 5.0, min: 0.1, max: 2.0 }],
        )
        .unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        for _ in 0..1000 {
            let l = p.sample(&mut rng);
            assert!((-1.0..=1.0).contains(&l[0]) && (0.1..=2.0).contains(&l[1]), "{l:?}");
        }
    }

    #[test]
    fn mask_fixes_the_known_part() {
        let u = ComponentPrior::Uniform { min: 0.0, max: 1.0 };
        let known = Lambda { q_star: vec![0.3], w: vec![0.7] };
        let p = Prior::with_mask(LearnMask::QStar, vec![u.clone()], vec![u], &known).unwrap();
        assert_eq!(p.free(), vec![0]);
        assert_eq!(p.components()[1], ComponentPrior::Fixed { value: 0.7 });
    }

    #[test]
    fn bad_priors_name_the_component() {
        let e = Prior::new(
            vec![ComponentPrior::Uniform { min: 1.0, max: 0.0 }],
            vec![ComponentPrior::Fixed { value: 1.0 }],
        )
        .unwrap_err();
        assert_eq!(e.to_string(), "q_star[0]: min 1 must be below max 0");
        let outside = ComponentPrior::Gaussian { mean: 300.0, sd: 10.0, min: -10.0, max: 60.0 };
        let e = Prior::new(vec![outside], vec![ComponentPrior::Fixed { value: 1.0 }]).unwrap_err();
        assert!(e.to_string().starts_with("q_star[0]: mean 300 lies outside [-10, 60]"), "{e}");
        // A known λ of another length than the prior's is refused, not indexed past its end.
        let u = ComponentPrior::Uniform { min: 0.0, max: 1.0 };
        let known = Lambda { q_star: vec![0.3], w: vec![0.7] };
        let e = Prior::with_mask(LearnMask::QStar, vec![u.clone(), u.clone()], vec![u.clone(), u], &known).unwrap_err();
        assert_eq!(e, PriorError::KnownMismatch { prior: 2, known: 1 });
        let e = Prior::new(
            vec![ComponentPrior::Fixed { value: 0.0 }],
            vec![ComponentPrior::Uniform { min: -1.0, max: 1.0 }],
        )
        .unwrap_err();
        assert!(e.to_string().starts_with("w[0]"), "{e}");
    }
}
