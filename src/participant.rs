//! Simulated participants: a person with ground-truth cost parameters λ* who chooses among
//! feasible configurations with Boltzmann probability (eq. 1, 3).

use rand::RngExt;

use crate::SeededRng;
use crate::ergo::{FeasibleSet, Lambda, SetPass};

/// A Boltzmann chooser with ground truth λ* and rationality α.
#[derive(Clone, Debug, PartialEq)]
pub struct SimulatedPerson {
    pub truth: Lambda,
    pub alpha: f64,
}

impl SimulatedPerson {
    /// Draws a configuration index from P(q | Q, λ*) ∝ exp(−α C(q; λ*)).
    pub fn choose(&self, set: &FeasibleSet, rng: &mut SeededRng) -> usize {
        let mut scratch = SetPass::scratch(set.len());
        let pass = SetPass::run(set.configs(), &self.truth.q_star, &self.truth.w, self.alpha, &mut scratch);
        let target = rng.random::<f64>() * pass.sum;
        let mut acc = 0.0;
        for (j, e) in scratch.exps.iter().enumerate() {
            acc += e;
            if acc > target {
                return j;
            }
        }
        pass.argmin
    }

    /// The region (handle) of a drawn configuration: what a person reports.
    pub fn choose_region(&self, set: &FeasibleSet, rng: &mut SeededRng) -> usize {
        set.region_of(self.choose(set, rng))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ergo::ConfigSet;
    use rand::SeedableRng;

    #[test]
    fn choices_follow_the_boltzmann_distribution() {
        let set = FeasibleSet::new(ConfigSet::from_rows(&[[0.0], [1.0], [2.0]]).unwrap());
        let p = SimulatedPerson { truth: Lambda { q_star: vec![0.0], w: vec![1.0] }, alpha: 1.0 };
        let mut rng = SeededRng::seed_from_u64(1);
        let n = 200_000;
        let mut counts = [0usize; 3];
        for _ in 0..n {
            counts[p.choose(&set, &mut rng)] += 1;
        }
        let z = 1.0 + (-1.0f64).exp() + (-4.0f64).exp();
        for (j, c) in [0.0f64, 1.0, 4.0].iter().enumerate() {
            let want = (-c).exp() / z;
            let got = counts[j] as f64 / n as f64;
            assert!((got - want).abs() < 0.005, "config {j}: {got} vs {want}");
        }
    }
}
