//! The paper's Fig. 3/4 experiment: two synthetic feasible sets; the active selector
//! alternates between them.

use rand::SeedableRng;

use crate::SeededRng;
use crate::belief::{Belief, ComponentPrior, Grid, Prior, ResamplePolicy};
use crate::ergo::{ConfigSet, FeasibleSet, Lambda, Observation};
use crate::participant::SimulatedPerson;
use crate::select::{OutcomeModel, query_value};

/// One iteration of the two-sets experiment.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct TwoSetsStep {
    pub iteration: usize,
    /// Exact information gain of set A and of set B before the choice.
    pub information_gain_a: f64,
    pub information_gain_b: f64,
    /// The set the active selector offered ("A" or "B").
    pub chosen: &'static str,
    /// The configuration the simulated person took (joints 1 and 2).
    pub response_1: f64,
    pub response_2: f64,
    /// The belief's mean q* and gridded entropy after the update.
    pub mean_q_star_1: f64,
    pub mean_q_star_2: f64,
    pub entropy: f64,
}

/// Set A spreads along joint 1 (it tells about q*₁ only); set B along joint 2.
pub(crate) fn the_two_sets() -> [FeasibleSet; 2] {
    let line = |horizontal: bool| {
        let rows: Vec<[f64; 2]> = (0..41)
            .map(|k| {
                let t = -2.0 + 0.1 * k as f64;
                if horizontal { [t, -1.5] } else { [1.5, t] }
            })
            .collect();
        FeasibleSet::new(ConfigSet::from_rows(&rows).expect("finite"))
    };
    [line(true), line(false)]
}

/// Runs the active selector on the two sets for `iterations` queries.
pub fn two_sets(seed: u64, iterations: usize, particles: usize, alpha: f64) -> Vec<TwoSetsStep> {
    let u = ComponentPrior::Uniform { min: -2.0, max: 2.0 };
    let one = ComponentPrior::Fixed { value: 1.0 };
    let prior = Prior::new(vec![u.clone(), u], vec![one.clone(), one]).expect("valid");
    let mut rng = SeededRng::seed_from_u64(seed);
    let truth = Lambda { q_star: vec![0.4, -0.7], w: vec![1.0, 1.0] };
    let person = SimulatedPerson { truth, alpha };
    let mut belief = Belief::from_prior(&prior, particles, &mut rng).expect("particles > 0");
    let sets = the_two_sets();
    let grid = Grid::over_supports(&[(-2.0, 2.0), (-2.0, 2.0), (1.0, 1.0), (1.0, 1.0)], 20);
    let jitter = [0.02, 0.02, 0.0, 0.0];
    let mut steps = Vec::new();
    for iteration in 1..=iterations {
        let ig: Vec<f64> =
            sets.iter().map(|s| query_value(&belief, s, alpha, OutcomeModel::Configuration).information_gain).collect();
        let k = if ig[1] > ig[0] { 1 } else { 0 };
        let choice = person.choose(&sets[k], &mut rng);
        belief.update(&sets[k], alpha, &Observation::Config(choice)).expect("positive likelihood");
        belief.maybe_resample(ResamplePolicy::EveryUpdate, &jitter, &mut rng);
        let q = sets[k].configs().config(choice);
        let mean = belief.mean();
        steps.push(TwoSetsStep {
            iteration,
            information_gain_a: ig[0],
            information_gain_b: ig[1],
            chosen: ["A", "B"][k],
            response_1: q[0],
            response_2: q[1],
            mean_q_star_1: mean.q_star[0],
            mean_q_star_2: mean.q_star[1],
            entropy: belief.entropy(&grid),
        });
    }
    steps
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn active_alternates_between_the_two_sets() {
        let steps = two_sets(7, 8, 2000, 2.0);
        let chosen: Vec<_> = steps.iter().map(|s| s.chosen).collect();
        let switches = chosen.windows(2).filter(|w| w[0] != w[1]).count();
        assert!(chosen.contains(&"A") && chosen.contains(&"B"), "{chosen:?}");
        assert!(switches >= 3, "alternates: {chosen:?}");
        // It learns both coordinates.
        let last = steps.last().unwrap();
        assert!((last.mean_q_star_1 - 0.4).abs() < 0.3 && (last.mean_q_star_2 + 0.7).abs() < 0.3, "{last:?}");
    }
}
