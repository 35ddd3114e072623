//! The paper's simulation studies (sections V and VI): ground truth drawn from the prior,
//! a random menu, a simulated person, every algorithm from the same prior, measured after
//! every iteration on the four measures of section IV.

mod arm7;
mod front;
mod observations;
mod planar2;
mod shards;
mod summary;
mod two_sets;

use rand::SeedableRng;
use rayon::prelude::*;

use crate::belief::{Belief, CellIndex, Estimate, Grid, Observed, Prior, ResamplePolicy, TestExample, true_cost};
use crate::ergo::{FeasibleSet, Lambda, LearnMask, Observation};
use crate::participant::SimulatedPerson;
use crate::select::{OutcomeModel, Problem, SelectorKind, Tradeoff};
use crate::{SeededRng, derive_seed};

pub use arm7::Arm7;
pub use front::{FrontPoint, FrontSetting, front, front_settings};
pub use observations::{
    OBSERVATION_MEASURES, ObservationRow, iterations_to_match_region, observation_label, observation_settings,
    observation_sweep,
};
pub use planar2::Planar2;
pub use shards::{SHARD_MANIFEST, ShardManifest, merge_order, read_metrics, shard_units};
pub use summary::{MEASURES, SummaryRow, paired_tests, summarise};

pub use two_sets::{TwoSetsStep, two_sets};

/// A simulated setting: an arm, a prior and a source of random queries.
pub trait Scenario: Sync {
    fn name(&self) -> &'static str;
    /// The prior over λ for a learn-mask (the unlearned part fixed).
    fn prior(&self, learn: LearnMask) -> Prior;
    /// The default rationality α.
    fn default_alpha(&self, learn: LearnMask) -> f64;
    /// The default number of iterations.
    fn default_iterations(&self) -> usize;
    /// One random query's feasible set. With `regions`, its configurations are grouped into
    /// the regions a region observation reports (arm7's always are: its grips; planar2's then
    /// are ordered by connected piece, which changes the order the simulated person draws in,
    /// so runs observing the configuration keep the outline's order).
    fn random_query(&self, rng: &mut SeededRng, regions: bool) -> FeasibleSet;
}

/// Settings of one simulation run.
#[derive(Clone, Debug)]
pub struct Settings {
    pub learn: LearnMask,
    pub trials: usize,
    pub menu: usize,
    pub iterations: usize,
    pub test_size: usize,
    pub particles: usize,
    pub alpha: f64,
    pub algorithms: Vec<SelectorKind>,
    pub seed: u64,
    /// β of `hybrid` and ε of `budgeted`.
    pub tradeoff: Tradeoff,
    /// The grid, jitter and kernel of the belief (the same in every simulation).
    pub numerics: BeliefNumerics,
    /// The point estimate that distance and test log-likelihood are measured on.
    pub estimate: Estimate,
    /// What the learner observes of each choice.
    pub observation: SimObservation,
    /// The arithmetic of the selectors' information gain and expected cost.
    pub precision: crate::select::Precision,
}

/// How a simulated belief is gridded, jittered and smoothed; one value for every
/// simulation command (`Default`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeliefNumerics {
    /// Cells per prior range for the gridded entropy and the mode.
    pub grid_boxes: usize,
    /// Jitter after resampling, as a fraction of each learned component's prior range.
    pub jitter_fraction: f64,
    /// Kernel bandwidth of the density at λ*, as a fraction of each prior range.
    pub bandwidth_fraction: f64,
}

impl Default for BeliefNumerics {
    fn default() -> Self {
        Self { grid_boxes: 10, jitter_fraction: 0.01, bandwidth_fraction: 0.05 }
    }
}

/// What a simulated learner observes of the person's choice.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SimObservation {
    /// The configuration chosen (the paper's simulations).
    Configuration,
    /// Only the region the chosen configuration lies in, and queries scored by their
    /// information about the region: arm7's grip taken, as in the user study; planar2's
    /// connected piece of the object taken (one elbow branch along a reachable stretch of the
    /// outline).
    Region,
    /// The chosen configuration measured with independent Gaussian noise of this standard
    /// deviation (rad) on every joint. Queries are still selected by their information about
    /// the configuration: the noiseless limit, an upper bound on a noisy measurement's.
    Measured { sigma_rad: f64 },
}

/// The measures of one algorithm in one trial after one iteration (0 = the prior).
#[derive(Clone, Debug, PartialEq, serde::Serialize, Default)]
pub struct MetricRow {
    pub algorithm: &'static str,
    /// The run's seed (`simulate --seeds N` runs N seeds).
    pub seed: u64,
    pub trial: usize,
    pub iteration: usize,
    pub density_at_truth: f64,
    pub log_density_at_truth: f64,
    pub distance_to_truth: f64,
    pub test_log_likelihood: f64,
    /// Expected cost under λ* of the configuration the person picks in the query chosen at
    /// this iteration (none at iteration 0).
    pub true_cost: Option<f64>,
    /// Menu index of the query chosen at this iteration.
    pub query: Option<usize>,
    /// Gridded entropy of the belief (eq. 6).
    pub entropy: f64,
}

mod purpose {
    pub(crate) const TRUTH: u64 = 1;
    pub const MENU: u64 = 2;
    pub(crate) const TEST: u64 = 3;
    pub const PARTICLES: u64 = 4;
    pub(crate) const PERSON: u64 = 5;
    pub(crate) const RESAMPLE: u64 = 6;
    pub(crate) const SELECT: u64 = 7;
    pub const MEASURE: u64 = 8;
}

fn rng(seed: u64, trial: usize, purpose: u64) -> SeededRng {
    SeededRng::seed_from_u64(derive_seed(seed, trial as u64, purpose))
}

/// What every algorithm of a trial shares.
struct Trial {
    truth: Lambda,
    menu: Vec<FeasibleSet>,
    tests: Vec<TestExample>,
    start: Belief,
}

fn supports(prior: &Prior) -> Vec<(f64, f64)> {
    prior.components().iter().map(|c| c.support()).collect()
}

fn setup(scenario: &dyn Scenario, s: &Settings, prior: &Prior, trial: usize) -> Trial {
    let truth = Lambda::from_slice(&prior.sample(&mut rng(s.seed, trial, purpose::TRUTH)));
    let mut menu_rng = rng(s.seed, trial, purpose::MENU);
    let regions = s.observation == SimObservation::Region;
    let menu = (0..s.menu).map(|_| scenario.random_query(&mut menu_rng, regions)).collect();
    let person = SimulatedPerson { truth: truth.clone(), alpha: s.alpha };
    let mut test_rng = rng(s.seed, trial, purpose::TEST);
    let tests = (0..s.test_size)
        .map(|_| {
            // Test choices are scored as configurations: the same test set for every model.
            let set = scenario.random_query(&mut test_rng, false);
            let choice = person.choose(&set, &mut test_rng);
            TestExample { set, observation: Observation::Config(choice) }
        })
        .collect();
    let start =
        Belief::from_prior(prior, s.particles, &mut rng(s.seed, trial, purpose::PARTICLES)).expect("particles > 0");
    Trial { truth, menu, tests, start }
}

/// Runs one trial of every algorithm; rows in algorithm order, then iteration.
fn run_trial(scenario: &dyn Scenario, s: &Settings, prior: &Prior, trial: usize) -> Vec<MetricRow> {
    let t = setup(scenario, s, prior, trial);
    let sup = supports(prior);
    let grid = Grid::over_supports(&sup, s.numerics.grid_boxes);
    let jitter: Vec<f64> =
        sup.iter().map(|(lo, hi)| if hi > lo { (hi - lo) * s.numerics.jitter_fraction } else { 0.0 }).collect();
    let bandwidth: Vec<f64> =
        sup.iter().map(|(lo, hi)| if hi > lo { (hi - lo) * s.numerics.bandwidth_fraction } else { 1.0 }).collect();
    let person = SimulatedPerson { truth: t.truth.clone(), alpha: s.alpha };
    let mut rows = Vec::with_capacity(s.algorithms.len() * (s.iterations + 1));
    for &kind in &s.algorithms {
        let selector = kind.build(&grid, s.tradeoff);
        let mut belief = t.start.clone();
        let mut person_rng = rng(s.seed, trial, purpose::PERSON);
        let mut resample_rng = rng(s.seed, trial, purpose::RESAMPLE);
        let mut select_rng = rng(s.seed, trial, purpose::SELECT);
        let mut measure_rng = rng(s.seed, trial, purpose::MEASURE);
        let mut history: Vec<(usize, Observation)> = Vec::new();
        let measure = |belief: &Belief,
                       history: &[(usize, Observation)],
                       iteration: usize,
                       query: Option<usize>,
                       cost: Option<f64>| {
            let cells = CellIndex::new(belief, &grid);
            let estimate = match s.estimate {
                Estimate::Mean => belief.mean(),
                Estimate::GridMode => cells.mode(belief),
                Estimate::Map => {
                    let observed: Vec<Observed> = history.iter().map(|(q, o)| (&t.menu[*q], o)).collect();
                    belief.map_estimate(prior, &observed, s.alpha).expect("observations index their own sets")
                }
            };
            let log_density = belief.log_density_at(&t.truth, &bandwidth);
            MetricRow {
                algorithm: kind.name(),
                seed: s.seed,
                trial,
                iteration,
                density_at_truth: log_density.exp(),
                log_density_at_truth: log_density,
                distance_to_truth: belief.distance(&estimate, &t.truth),
                test_log_likelihood: crate::belief::test_log_likelihood(&estimate, &t.tests, s.alpha)
                    .expect("test observations index their own sets"),
                true_cost: cost,
                query,
                entropy: cells.entropy(belief.weights()),
            }
        };
        rows.push(measure(&belief, &history, 0, None, None));
        for iteration in 1..=s.iterations {
            let outcomes = match s.observation {
                SimObservation::Region => OutcomeModel::Region,
                SimObservation::Configuration | SimObservation::Measured { .. } => OutcomeModel::Configuration,
            };
            let problem = Problem { belief: &belief, menu: &t.menu, alpha: s.alpha, outcomes, precision: s.precision };
            let chosen = selector.select(&problem, &mut select_rng).index;
            let set = &t.menu[chosen];
            let cost = true_cost(set, &t.truth, s.alpha);
            let choice = person.choose(set, &mut person_rng);
            let observation = match s.observation {
                SimObservation::Configuration => Observation::Config(choice),
                SimObservation::Region => Observation::Region(set.regions()[set.region_of(choice)].clone().collect()),
                SimObservation::Measured { sigma_rad } => measure_choice(set, choice, sigma_rad, &mut measure_rng),
            };
            belief.update(set, s.alpha, &observation).expect("a drawn choice has positive likelihood");
            belief.maybe_resample(ResamplePolicy::EveryUpdate, &jitter, &mut resample_rng);
            history.push((chosen, observation));
            rows.push(measure(&belief, &history, iteration, Some(chosen), Some(cost)));
        }
    }
    rows
}

/// The configuration `choice` of `set` as a measuring system with Gaussian noise σ (rad) on
/// every joint reports it, and the observation it makes.
fn measure_choice(set: &FeasibleSet, choice: usize, sigma: f64, rng: &mut SeededRng) -> Observation {
    let noise = rand_distr::Normal::new(0.0, sigma).expect("a positive, finite σ (checked by the caller)");
    let q_m: Vec<f64> =
        set.configs().config(choice).iter().map(|q| q + rand_distr::Distribution::sample(&noise, rng)).collect();
    let sigmas = vec![sigma; q_m.len()];
    Observation::measured(set.configs(), &q_m, &sigmas).expect("a finite measurement of a finite configuration")
}

/// Runs every trial (in parallel; the result does not depend on the number of threads),
/// calling `progress` after each trial.
pub fn simulate(scenario: &dyn Scenario, s: &Settings, progress: &(dyn Fn() + Sync)) -> Vec<MetricRow> {
    let all: Vec<usize> = (0..s.trials).collect();
    simulate_trials(scenario, s, &all, progress)
}

/// Runs the given trials of a run only (a shard of it): each trial's rows are those the
/// whole run has for it, since a trial's draws depend only on the seed and the trial.
pub fn simulate_trials(
    scenario: &dyn Scenario,
    s: &Settings,
    trials: &[usize],
    progress: &(dyn Fn() + Sync),
) -> Vec<MetricRow> {
    let prior = scenario.prior(s.learn);
    let per_trial: Vec<Vec<MetricRow>> = trials
        .par_iter()
        .map(|&trial| {
            let rows = run_trial(scenario, s, &prior, trial);
            progress();
            rows
        })
        .collect();
    per_trial.into_iter().flatten().collect()
}
