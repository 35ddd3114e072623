//! Query selection (section III-D/E): which robot action to offer next.
//!
//! Five selectors behind one trait. All are deterministic given their RNG, and ties go to
//! the earliest menu item.

mod information;
mod paper;
mod screen;

use rand::RngExt;
use serde::{Deserialize, Serialize};

use crate::SeededRng;
use crate::belief::{Belief, Grid};
use crate::ergo::FeasibleSet;

pub use information::{
    MEASURED_POINTS, MeasuredInformation, QueryValue, expected_cost, measured_information, menu_expected_costs,
    menu_query_values, query_value, query_value_in,
};
pub use paper::information_gain_paper;
pub use screen::{Screen, ScreenedChoice, screened_active_choice, screened_passive_choice};

/// What the robot observes of the person's choice, and so what an outcome is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum OutcomeModel<'a> {
    /// The configuration (measured, or mapped from the handle by a label model).
    Configuration,
    /// Only the region (handle) grabbed.
    Region,
    /// The arm's joint angles measured with Gaussian noise of σ per joint (rad, in the
    /// arm model's order): q_m = q + ε, ε ~ N(0, diag σ²).
    Measured { sigma: &'a [f64] },
}

impl OutcomeModel<'_> {
    /// The protocol's name for it (`"observation"` in the protocol).
    pub fn name(self) -> &'static str {
        match self {
            OutcomeModel::Configuration => "configuration",
            OutcomeModel::Region => "region",
            OutcomeModel::Measured { .. } => "measured",
        }
    }
}

/// The arithmetic of the selectors' set passes (protocol `learning.precision`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// IEEE double throughout (the default): information gains exact to rounding.
    #[default]
    Float64,
    /// Costs, weights and their sums per particle in IEEE single (sixteen lanes where
    /// float64 has eight), each particle's sums and everything after them in double: the
    /// tolerance in docs/engine.md ("Float32"). Belief updates stay float64.
    Float32,
}

impl Precision {
    /// Its name in protocols and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Precision::Float64 => "float64",
            Precision::Float32 => "float32",
        }
    }

    /// Whether it is the default (float64), for leaving it out of serialised protocols.
    pub fn is_default(&self) -> bool {
        *self == Precision::Float64
    }
}

/// The belief, the menu and the choice model a selector decides from.
#[derive(Clone, Copy)]
pub struct Problem<'a> {
    pub belief: &'a Belief,
    pub menu: &'a [FeasibleSet],
    pub alpha: f64,
    pub outcomes: OutcomeModel<'a>,
    /// The arithmetic of the set passes of the information gain and expected cost.
    pub precision: Precision,
}

/// A selector's choice and the criterion it maximised, for every menu item (`passive`
/// maximises the negated expected cost).
#[derive(Clone, Debug, PartialEq)]
pub struct Selection {
    pub index: usize,
    pub criterion: Vec<f64>,
}

/// A query-selection rule.
pub trait Selector: Send + Sync {
    /// Its name on the command line and in logs.
    fn name(&self) -> &'static str;
    /// Chooses a menu item.
    fn select(&self, problem: &Problem, rng: &mut SeededRng) -> Selection;
}

/// Information gain and expected cost of every menu item.
pub fn menu_values(problem: &Problem) -> Vec<QueryValue> {
    menu_query_values(problem.belief, problem.menu, problem.alpha, problem.outcomes, problem.precision)
}

/// The parameters of the selectors that trade information against comfort.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tradeoff {
    /// `hybrid`'s β: nats of information per unit of expected cost.
    pub beta: f64,
    /// `budgeted`'s ε: the expected cost allowed above the passive query's, as a fraction.
    pub epsilon: f64,
}

impl Default for Tradeoff {
    fn default() -> Self {
        Tradeoff { beta: DEFAULT_HYBRID_BETA, epsilon: DEFAULT_BUDGET_EPSILON }
    }
}

/// The criterion maximised by a selector that decides from information gain and expected
/// cost alone: I (`active`), −E[cost] (`passive`, eq. 11), I − β·E[cost] (`hybrid`), I over
/// the queries whose E[cost] ≤ (1 + ε)·min E[cost] and −∞ elsewhere (`budgeted`); `None`
/// for those that need more (`random`, `active-paper`).
fn objective(kind: SelectorKind, values: &[QueryValue], t: Tradeoff) -> Option<Vec<f64>> {
    Some(match kind {
        SelectorKind::Active => values.iter().map(|v| v.information_gain).collect(),
        SelectorKind::Passive => values.iter().map(|v| -v.expected_cost).collect(),
        SelectorKind::Hybrid => values.iter().map(|v| v.information_gain - t.beta * v.expected_cost).collect(),
        SelectorKind::Budgeted => {
            let passive = values.iter().map(|v| v.expected_cost).fold(f64::INFINITY, f64::min);
            let budget = passive + t.epsilon * passive.abs();
            values
                .iter()
                .map(|v| if v.expected_cost <= budget { v.information_gain } else { f64::NEG_INFINITY })
                .collect()
        }
        SelectorKind::Random | SelectorKind::ActivePaper => return None,
    })
}

/// The choice of `active`, `passive`, `hybrid` or `budgeted` from already computed values;
/// `None` for the selectors that need more (`random`, `active-paper`).
pub fn choose_from_values(kind: SelectorKind, values: &[QueryValue], t: Tradeoff) -> Option<usize> {
    objective(kind, values, t).map(|v| argmax(&v))
}

fn select_by_values(kind: SelectorKind, problem: &Problem, t: Tradeoff) -> Selection {
    let criterion = objective(kind, &menu_values(problem), t).expect("a selector of values");
    Selection { index: argmax(&criterion), criterion }
}

/// Index of the largest value; the earliest on ties.
pub fn argmax(values: &[f64]) -> usize {
    let mut best = 0;
    for (i, &v) in values.iter().enumerate() {
        if v > values[best] {
            best = i;
        }
    }
    best
}

/// `active`: maximises the exact mutual information between λ and the choice.
pub struct Active;

impl Selector for Active {
    fn name(&self) -> &'static str {
        "active"
    }
    fn select(&self, problem: &Problem, _: &mut SeededRng) -> Selection {
        select_by_values(SelectorKind::Active, problem, Tradeoff::default())
    }
}

/// `active-paper`: maximises eq. 8 (eq. 9).
pub struct ActivePaper {
    pub grid: Grid,
}

impl Selector for ActivePaper {
    fn name(&self) -> &'static str {
        "active-paper"
    }
    fn select(&self, problem: &Problem, _: &mut SeededRng) -> Selection {
        let criterion: Vec<f64> = problem
            .menu
            .iter()
            .map(|set| information_gain_paper(problem.belief, set, problem.alpha, problem.outcomes, &self.grid))
            .collect();
        Selection { index: argmax(&criterion), criterion }
    }
}

/// `passive`: minimises the expected cost Σ_i ω_i min_q C(q; λ_i) (eq. 10–11).
pub struct Passive;

impl Selector for Passive {
    fn name(&self) -> &'static str {
        "passive"
    }
    fn select(&self, problem: &Problem, _: &mut SeededRng) -> Selection {
        select_by_values(SelectorKind::Passive, problem, Tradeoff::default())
    }
}

/// `random`: a uniformly random menu item.
pub struct Random;

impl Selector for Random {
    fn name(&self) -> &'static str {
        "random"
    }
    fn select(&self, problem: &Problem, rng: &mut SeededRng) -> Selection {
        let n = problem.menu.len();
        Selection { index: rng.random_range(0..n), criterion: vec![1.0 / n as f64; n] }
    }
}

/// The default β of `hybrid` (nats of information per unit of expected cost).
pub const DEFAULT_HYBRID_BETA: f64 = 0.1;

/// `hybrid`: maximises I − β·E[cost], trading learning against comfort (the paper's
/// footnote 1); β = 0 is `active`.
pub struct Hybrid {
    pub beta: f64,
}

impl Selector for Hybrid {
    fn name(&self) -> &'static str {
        "hybrid"
    }
    fn select(&self, problem: &Problem, _: &mut SeededRng) -> Selection {
        select_by_values(SelectorKind::Hybrid, problem, Tradeoff { beta: self.beta, ..Tradeoff::default() })
    }
}

/// The default ε of `budgeted`.
pub const DEFAULT_BUDGET_EPSILON: f64 = 0.25;

/// `budgeted`: the most informative query whose expected cost is at most (1 + ε) times the
/// passive query's (the lowest expected cost on the menu; the paper's footnote 1 as a
/// constraint); ε = 0 is the most informative of the cheapest queries, ε = ∞ is `active`.
pub struct Budgeted {
    pub epsilon: f64,
}

impl Selector for Budgeted {
    fn name(&self) -> &'static str {
        "budgeted"
    }
    fn select(&self, problem: &Problem, _: &mut SeededRng) -> Selection {
        select_by_values(SelectorKind::Budgeted, problem, Tradeoff { epsilon: self.epsilon, ..Tradeoff::default() })
    }
}

/// The selectors by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum SelectorKind {
    Active,
    ActivePaper,
    Passive,
    Random,
    Hybrid,
    Budgeted,
}

impl SelectorKind {
    pub const ALL: [SelectorKind; 6] = [
        SelectorKind::Active,
        SelectorKind::ActivePaper,
        SelectorKind::Passive,
        SelectorKind::Random,
        SelectorKind::Hybrid,
        SelectorKind::Budgeted,
    ];

    pub fn name(self) -> &'static str {
        match self {
            SelectorKind::Active => "active",
            SelectorKind::ActivePaper => "active-paper",
            SelectorKind::Passive => "passive",
            SelectorKind::Random => "random",
            SelectorKind::Hybrid => "hybrid",
            SelectorKind::Budgeted => "budgeted",
        }
    }

    /// The selector, with the grid `active-paper` needs and the β of `hybrid` / ε of `budgeted`.
    pub fn build(self, grid: &Grid, t: Tradeoff) -> Box<dyn Selector> {
        match self {
            SelectorKind::Active => Box::new(Active),
            SelectorKind::ActivePaper => Box::new(ActivePaper { grid: grid.clone() }),
            SelectorKind::Passive => Box::new(Passive),
            SelectorKind::Random => Box::new(Random),
            SelectorKind::Hybrid => Box::new(Hybrid { beta: t.beta }),
            SelectorKind::Budgeted => Box::new(Budgeted { epsilon: t.epsilon }),
        }
    }
}

impl std::str::FromStr for SelectorKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|k| k.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(|k| k.name()).collect();
            format!("unknown selector '{s}': expected one of {}", names.join(", "))
        })
    }
}

#[cfg(test)]
mod tests;
