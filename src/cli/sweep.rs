//! The options and checks shared by the commands that sweep a setting over seeds on the
//! simulated scenarios (`front`, `observations`).

use anyhow::Result;
use clap::{Args, ValueEnum};
use handover::belief::Estimate;
use handover::ergo::LearnMask;
use handover::experiment::{Arm7, Planar2, Scenario, Settings, SimObservation};
use handover::select::{SelectorKind, Tradeoff};

use super::input::count;

/// A scenario a sweep runs on.
#[derive(Debug, Clone, Copy, ValueEnum, PartialEq)]
pub enum SweepScenario {
    Planar2,
    Arm7,
}

impl SweepScenario {
    pub fn build(self) -> Box<dyn Scenario> {
        match self {
            SweepScenario::Planar2 => Box::new(Planar2::default()),
            SweepScenario::Arm7 => Box::new(Arm7::default()),
        }
    }
}

/// Seeds, trials and the learner's size.
#[derive(Debug, Args)]
pub struct SweepArgs {
    /// Seeds (SEED, SEED+1, …), 2 to 1000: every measure is the mean over seeds with a 95 %
    /// interval.
    #[arg(long, value_name = "N", default_value_t = 5, value_parser = clap::value_parser!(u64).range(2..=1000))]
    pub seeds: u64,
    /// Seed of every random draw; the same seed gives byte-identical CSV for any --threads.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Trials per seed (each with its own truth, menu and test set).
    #[arg(long, default_value_t = 20, value_parser = count(1))]
    pub trials: usize,
    /// Queries on each trial's menu.
    #[arg(long, default_value_t = 8, value_parser = count(1))]
    pub menu: usize,
    /// Queries per selector and trial [default: planar2 5, arm7 10].
    #[arg(long, value_parser = count(1))]
    pub iterations: Option<usize>,
    /// Test-set size per trial.
    #[arg(long, default_value_t = 300, value_parser = count(1))]
    pub test_size: usize,
    /// Particles in the belief.
    #[arg(long, default_value_t = 1000, value_parser = count(1))]
    pub particles: usize,
    /// Worker threads [default: all cores]; the numbers do not depend on it.
    #[arg(long, value_parser = count(1))]
    pub threads: Option<usize>,
}

impl SweepArgs {
    /// The worker threads, and their number.
    pub fn pool(&self) -> Result<(rayon::ThreadPool, usize)> {
        super::progress::worker_pool(self.threads)
    }

    /// The progress bar of `runs` runs of every seed's trials, named `name`.
    pub fn progress(&self, name: &str, runs: u64) -> indicatif::ProgressBar {
        super::progress::bar(name, runs * self.seeds * self.trials as u64, "trials")
    }

    /// A scenario's settings for this sweep, with its default α and iterations.
    pub fn settings(&self, scenario: &dyn Scenario, learn: LearnMask, algorithms: Vec<SelectorKind>) -> Settings {
        Settings {
            learn,
            trials: self.trials,
            menu: self.menu,
            iterations: self.iterations.unwrap_or_else(|| scenario.default_iterations()),
            test_size: self.test_size,
            particles: self.particles,
            alpha: scenario.default_alpha(learn),
            algorithms,
            seed: self.seed,
            tradeoff: Tradeoff::default(),
            numerics: Default::default(),
            estimate: Estimate::Mean,
            observation: SimObservation::Configuration,
            precision: Default::default(),
        }
    }
}
