//! Point estimates and credible intervals of a belief that depend on neither a grid nor a
//! tie-break: the posterior mean, a MAP estimate recomputed exactly from the prior and every
//! observation so far, and per-component weighted quantiles.

use super::{Belief, BeliefError, Prior};
use crate::ergo::{FeasibleSet, Lambda, Observation};

/// The lower and upper posterior quantiles of the credible intervals (a central 90 %
/// interval).
pub const CREDIBLE: (f64, f64) = (0.05, 0.95);

/// Particles whose unnormalised log posterior is within this of the best count as tied
/// maximisers (their weighted mean is the MAP estimate).
pub const MAP_TIE: f64 = 1e-9;

/// One observation of the belief's history: the feasible set it was made on, and what was
/// observed.
pub type Observed<'a> = (&'a FeasibleSet, &'a Observation);

impl Belief {
    /// The weighted `p`-quantile of every component: the smallest value x with
    /// P(λ_c ≤ x) ≥ p (a step of the weighted empirical distribution, so no interpolation
    /// decides it).
    pub fn quantile(&self, p: f64) -> Lambda {
        let [q] = self.quantiles([p]);
        q
    }

    /// [`Belief::quantile`] at every p of `ps`, from one sort of each component (a
    /// component every particle holds at one value, such as a known one, needs none).
    pub fn quantiles<const N: usize>(&self, ps: [f64; N]) -> [Lambda; N] {
        let s = 2 * self.dim;
        let mut out = [(); N].map(|_| vec![0.0; s]);
        let mut column: Vec<(f64, f64)> = Vec::with_capacity(self.len());
        for c in 0..s {
            column.clear();
            column.extend(self.particles.chunks_exact(s).zip(self.weights()).map(|(x, &w)| (x[c], w)));
            let first = column.first().map_or(0.0, |f| f.0);
            if column.iter().all(|&(x, _)| x.to_bits() == first.to_bits()) {
                // Every step of the distribution is at that one value.
                out.iter_mut().for_each(|o| o[c] = first);
                continue;
            }
            // Stable: tied values keep the particles' order, so the cumulative weights are
            // added in one fixed order.
            column.sort_by(|a, b| a.0.total_cmp(&b.0));
            for (o, p) in out.iter_mut().zip(ps) {
                let mut acc = 0.0;
                o[c] = column.last().map_or(0.0, |l| l.0);
                for &(x, w) in &column {
                    acc += w;
                    if acc >= p - 1e-12 {
                        o[c] = x;
                        break;
                    }
                }
            }
        }
        out.map(|o| Lambda::from_slice(&o))
    }

    /// The credible interval of every component ([`CREDIBLE`]).
    pub fn credible_interval(&self) -> (Lambda, Lambda) {
        let [low, high] = self.quantiles([CREDIBLE.0, CREDIBLE.1]);
        (low, high)
    }

    /// The unnormalised log posterior of every particle, recomputed exactly: log p(λ_i) plus
    /// Σ_t log P(obs_t | Q_t, λ_i) over every observation so far (eq. 4–5 without the
    /// normaliser, which is the same for every particle).
    pub(crate) fn log_posteriors(
        &self,
        prior: &Prior,
        history: &[Observed],
        alpha: f64,
    ) -> Result<Vec<f64>, BeliefError> {
        self.per_particle_log_likelihoods(history, alpha, |p| prior.log_density_unnormalised(p))
    }

    /// log Σ_i ω_i Π_t P(obs_t | Q_t, λ_i): the evidence of the observations under this
    /// belief at rationality `alpha` (eq. 4's normaliser, accumulated over every observation;
    /// for a prior belief, the marginal likelihood of the observations). Log-sum-exp, so it
    /// stays finite for any α at which some particle explains every observation. The direct,
    /// one-α reference that `analysis::alpha`'s one-pass grid is tested against.
    #[cfg(test)]
    pub(crate) fn log_evidence(&self, observed: &[Observed], alpha: f64) -> Result<f64, BeliefError> {
        let ll = self.per_particle_log_likelihoods(observed, alpha, |_| 0.0)?;
        let terms: Vec<f64> =
            self.weights.iter().zip(&ll).map(|(w, l)| if *w > 0.0 { w.ln() + l } else { f64::NEG_INFINITY }).collect();
        Ok(crate::ergo::log_sum_exp(&terms))
    }

    /// The MAP estimate among the particles: the particle of highest unnormalised log
    /// posterior ([`Belief::log_posteriors`]); where several distinct particles tie (a
    /// flat prior before any observation: all of them), the weighted mean of the tied ones,
    /// so that no tie-break decides it.
    pub fn map_estimate(&self, prior: &Prior, history: &[Observed], alpha: f64) -> Result<Lambda, BeliefError> {
        let lp = self.log_posteriors(prior, history, alpha)?;
        let best = lp.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let s = 2 * self.dim;
        let mut sum = vec![0.0; s];
        let mut total = 0.0;
        for ((p, &w), &l) in self.particles.chunks_exact(s).zip(self.weights()).zip(&lp) {
            if best.is_finite() && l >= best - MAP_TIE * best.abs().max(1.0) {
                // Equal weights for tied particles: duplicates after resampling count once each.
                let w = if w > 0.0 { w } else { 1.0 / self.len() as f64 };
                total += w;
                for (a, x) in sum.iter_mut().zip(p) {
                    *a += w * x;
                }
            }
        }
        if total <= 0.0 {
            return Ok(self.mean());
        }
        Ok(Lambda::from_slice(&sum.iter().map(|a| a / total).collect::<Vec<_>>()))
    }
}

/// Which point estimate of λ a measure uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Estimate {
    /// The posterior mean (the default: well defined for any belief).
    #[default]
    Mean,
    /// The particle of highest exact unnormalised posterior.
    Map,
    /// The paper's gridded mode (to reproduce its figures; noise in 7-D).
    GridMode,
}

impl Estimate {
    pub const ALL: [Estimate; 3] = [Estimate::Mean, Estimate::Map, Estimate::GridMode];

    pub fn name(self) -> &'static str {
        match self {
            Estimate::Mean => "mean",
            Estimate::Map => "map",
            Estimate::GridMode => "grid-mode",
        }
    }
}

impl std::str::FromStr for Estimate {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|e| e.name() == s)
            .ok_or_else(|| format!("unknown estimate '{s}', expected mean, map or grid-mode"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::belief::ComponentPrior;
    use crate::ergo::ConfigSet;
    use rand::SeedableRng;

    fn flat_prior() -> Prior {
        let u = ComponentPrior::Uniform { min: -1.0, max: 1.0 };
        Prior::new(vec![u.clone(), u], vec![ComponentPrior::Fixed { value: 1.0 }, ComponentPrior::Fixed { value: 1.0 }])
            .unwrap()
    }

    #[test]
    fn before_any_observation_the_estimates_are_the_priors_centre_not_a_corner() {
        let prior = flat_prior();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let b = Belief::from_prior(&prior, 4000, &mut rng).unwrap();
        let map = b.map_estimate(&prior, &[], 2.0).unwrap();
        let mean = b.mean();
        for (m, a) in map.q_star.iter().zip(&mean.q_star) {
            assert!(m.abs() < 0.05 && (m - a).abs() < 1e-12, "MAP {map:?}, mean {mean:?}");
        }
        let (lo, hi) = b.credible_interval();
        for c in 0..2 {
            assert!((lo.q_star[c] + 0.9).abs() < 0.05 && (hi.q_star[c] - 0.9).abs() < 0.05, "{lo:?} {hi:?}");
        }
    }

    #[test]
    fn the_map_is_the_particle_the_observations_favour() {
        let prior = flat_prior();
        let lambdas: Vec<Lambda> = [[-0.5, 0.0], [0.2, 0.1], [0.6, -0.4]]
            .iter()
            .map(|q| Lambda { q_star: q.to_vec(), w: vec![1.0, 1.0] })
            .collect();
        let b = Belief::from_particles(&lambdas, &[1.0, 1.0, 1.0]).unwrap();
        let set = FeasibleSet::new(ConfigSet::from_rows(&[[0.2, 0.1], [0.6, -0.4], [-0.5, 0.0]]).unwrap());
        let obs = Observation::Config(0);
        let map = b.map_estimate(&prior, &[(&set, &obs)], 5.0).unwrap();
        assert_eq!(map.q_star, vec![0.2, 0.1]);
    }

    #[test]
    fn weighted_quantiles_are_steps_of_the_distribution() {
        let lambdas: Vec<Lambda> =
            [0.0, 1.0, 2.0, 3.0].iter().map(|&q| Lambda { q_star: vec![q], w: vec![1.0] }).collect();
        let b = Belief::from_particles(&lambdas, &[0.1, 0.1, 0.1, 0.7]).unwrap();
        assert_eq!(b.quantile(0.05).q_star, vec![0.0]);
        assert_eq!(b.quantile(0.25).q_star, vec![2.0]);
        assert_eq!(b.quantile(0.95).q_star, vec![3.0]);
        // A known component (one value everywhere) is that value at every p.
        assert_eq!(b.quantile(0.05).w, vec![1.0]);
        assert_eq!(b.quantile(0.95).w, vec![1.0]);
    }

    /// Several quantiles from one sort are each quantile computed alone, with ties and
    /// unsorted particles.
    #[test]
    fn quantiles_at_once_are_the_quantiles_one_by_one() {
        let qs = [2.0, -1.0, 2.0, 0.5, -1.0, 3.0, 0.5];
        let lambdas: Vec<Lambda> = qs.iter().map(|&q| Lambda { q_star: vec![q, -q], w: vec![0.3, 1.0] }).collect();
        let b = Belief::from_particles(&lambdas, &[0.2, 0.05, 0.1, 0.3, 0.15, 0.1, 0.1]).unwrap();
        let ps = [0.05, 0.2, 0.5, 0.95, 1.0];
        let together = b.quantiles(ps);
        for (p, q) in ps.iter().zip(&together) {
            let alone = b.quantile(*p);
            assert_eq!(q, &alone, "p = {p}");
            // The step itself, by a naive count.
            let mut sorted: Vec<(f64, f64)> = qs.iter().copied().zip(b.weights().iter().copied()).collect();
            sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
            let mut acc = 0.0;
            let want = sorted.iter().find(|(_, w)| {
                acc += w;
                acc >= p - 1e-12
            });
            assert_eq!(q.q_star[0], want.map_or(3.0, |x| x.0), "p = {p}");
        }
        let (lo, hi) = b.credible_interval();
        assert_eq!((lo, hi), (b.quantile(0.05), b.quantile(0.95)));
    }
}
