//! The population simulated participants are drawn from (the protocol's `population`
//! section): who dry runs and `plan` simulate, stated as an assumption the experimenter can
//! change, not the robot's prior.
//!
//! Each learned component of λ is a normal (mean, sd) truncated to the prior's support — a
//! person outside the support could not be learned at all; what is not learned takes the
//! protocol's `known` value, as the learner assumes. Without the section, the default: each
//! learned component's mean at the middle of its prior range and its sd a sixth of the range
//! (three sd either side span the prior: narrower than the uniform prior, whose sd is
//! range/√12), and the people's α the protocol's.

use rand::SeedableRng;
use serde::{Deserialize, Serialize};

use crate::belief::{ComponentPrior, Prior};
use crate::ergo::Lambda;
use crate::{SeededRng, derive_seed};

/// One component's spread over people: a normal, truncated to the prior's support.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Spread {
    pub mean: f64,
    /// 0: everyone has the mean.
    pub sd: f64,
}

/// The protocol's `population` section as written (q* in degrees).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PopulationSpec {
    /// One per joint, degrees; used for the learned part of λ.
    pub q_star_deg: Vec<Spread>,
    /// One per joint; used when w is learned.
    pub w: Vec<Spread>,
    /// The simulated people's rationality (default: the protocol's `learning.alpha`, the
    /// value the learner assumes). One value for everyone: a dry run's log records each
    /// person's λ but not a person's own α.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha: Option<f64>,
}

/// Draws by rejection before a truncated draw is clamped (a draw inside the support within
/// a few tries unless the support is far in a tail, which validation refuses).
const TRUNCATION_TRIES: usize = 64;

/// The resolved population: per component of λ (radians), the spread, or the known value.
#[derive(Clone, Debug, PartialEq)]
pub struct Population {
    components: Vec<Component>,
    pub alpha: f64,
}

#[derive(Clone, Debug, PartialEq)]
enum Component {
    Known(f64),
    Spread {
        mean: f64,
        sd: f64,
        min: f64,
        max: f64,
    },
    /// Drawn from the robot's own prior.
    Prior(ComponentPrior),
}

/// What a dry run's random draws are for (see [`derive_seed`]).
const PURPOSE_TRUTH: u64 = 303;

impl Population {
    /// The population of a protocol whose prior (radians, unlearned parts fixed) is `prior`,
    /// from its section (`spec`, q* in degrees), or the default without one; `alpha` is the
    /// protocol's. The spec's lengths and ranges are checked by protocol validation.
    pub fn new(spec: Option<&PopulationSpec>, prior: &Prior, alpha: f64) -> Self {
        let components = prior
            .components()
            .iter()
            .enumerate()
            .map(|(i, c)| match *c {
                ComponentPrior::Fixed { value } => Component::Known(value),
                _ => {
                    let (min, max) = c.support();
                    let (mean, sd) = match spec {
                        Some(s) if i < s.q_star_deg.len() => {
                            let d = s.q_star_deg[i];
                            (d.mean.to_radians(), d.sd.to_radians())
                        }
                        Some(s) => {
                            let d = s.w[i - s.q_star_deg.len()];
                            (d.mean, d.sd)
                        }
                        None => ((min + max) / 2.0, (max - min) / 6.0),
                    };
                    Component::Spread { mean, sd, min, max }
                }
            })
            .collect();
        Self { components, alpha: spec.and_then(|s| s.alpha).unwrap_or(alpha) }
    }

    /// People drawn from the robot's own prior (the paper's simulations' convention, and the
    /// dry runs' before the population section): `dry-run --population prior`.
    pub fn from_prior(prior: &Prior, alpha: f64) -> Self {
        Self { components: prior.components().iter().map(|c| Component::Prior(c.clone())).collect(), alpha }
    }

    /// Simulated participant `index`'s λ, determined by the run's seed.
    pub fn draw(&self, seed: u64, index: usize) -> Lambda {
        let mut rng = SeededRng::seed_from_u64(derive_seed(seed, index as u64, PURPOSE_TRUTH));
        let values: Vec<f64> = self
            .components
            .iter()
            .map(|c| match c {
                Component::Known(v) => *v,
                Component::Spread { mean, sd, min, max } => truncated_normal(*mean, *sd, (*min, *max), &mut rng),
                Component::Prior(c) => c.sample(&mut rng),
            })
            .collect();
        Lambda::from_slice(&values)
    }
}

/// A draw of N(mean, sd) truncated to [min, max] by rejection: within a few tries unless
/// the range is far in a tail; the work is bounded and the last draw clamped. `sd` must be
/// finite and non-negative (0: the mean, clamped).
pub fn truncated_normal(mean: f64, sd: f64, (min, max): (f64, f64), rng: &mut SeededRng) -> f64 {
    let Ok(normal) = rand_distr::Normal::new(mean, sd) else { return mean.clamp(min, max) };
    if sd == 0.0 {
        return mean.clamp(min, max);
    }
    let mut v = mean;
    for _ in 0..TRUNCATION_TRIES {
        v = rand_distr::Distribution::sample(&normal, rng);
        if (min..=max).contains(&v) {
            return v;
        }
    }
    v.clamp(min, max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::Study;

    #[test]
    fn the_default_population_is_centred_on_the_prior_and_narrower_than_it() {
        let study = Study::default_study();
        let prior = study.prior.clone();
        let pop = Population::new(None, &prior, 5.0);
        let draws: Vec<Lambda> = (0..4000).map(|i| pop.draw(7, i)).collect();
        for (j, c) in prior.components().iter().enumerate().take(7) {
            let (lo, hi) = c.support();
            let v: Vec<f64> = draws.iter().map(|l| l.q_star[j]).collect();
            let m = crate::stats::mean(&v);
            let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
            assert!(v.iter().all(|x| (lo..=hi).contains(x)));
            assert!((m - (lo + hi) / 2.0).abs() < 0.01 * (hi - lo), "joint {j}: mean {m}");
            // A sixth of the range, a little less after truncation; the uniform's is range/√12.
            assert!(sd < (hi - lo) / 6.0 && sd > (hi - lo) / 6.6, "joint {j}: sd {sd}");
        }
        // w is not learned: everyone has the known weights.
        assert!(draws.iter().all(|l| l.w == draws[0].w));
        assert_eq!(pop.alpha, 5.0);
    }

    #[test]
    fn a_population_without_spread_is_one_person_and_draws_are_seeded() {
        let study = Study::default_study();
        let prior = study.prior.clone();
        let spec = PopulationSpec {
            q_star_deg: [10.0, 10.0, 0.0, 85.0, 0.0, 0.0, 0.0].map(|mean| Spread { mean, sd: 0.0 }).to_vec(),
            w: vec![Spread { mean: 1.0, sd: 0.0 }; 7],
            alpha: Some(40.0),
        };
        let pop = Population::new(Some(&spec), &prior, 5.0);
        let a = pop.draw(1, 0);
        assert_eq!(a, pop.draw(2, 9));
        assert!((a.q_star[3] - 85f64.to_radians()).abs() < 1e-12);
        assert_eq!(pop.alpha, 40.0);
        // From the prior: what the prior itself draws from the same seed.
        let from_prior = Population::from_prior(&prior, 5.0);
        let mut rng = SeededRng::seed_from_u64(derive_seed(4, 2, PURPOSE_TRUTH));
        assert_eq!(from_prior.draw(4, 2), Lambda::from_slice(&prior.sample(&mut rng)));
        let wide = Population::new(None, &prior, 5.0);
        assert_eq!(wide.draw(3, 4), wide.draw(3, 4));
        assert_ne!(wide.draw(3, 4), wide.draw(3, 5));
    }
}
