//! `handover research score`: the engine as a JSON tool (scores a menu, optionally updates a belief).

use std::collections::HashSet;
use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use handover::belief::{Belief, Grid};
use handover::ergo::{ConfigSet, FeasibleSet, Lambda, Observation};
use handover::select::{
    OutcomeModel, Precision, Problem, SelectorKind, Tradeoff, argmax, choose_from_values, information_gain_paper,
    menu_values,
};
use serde::{Deserialize, Serialize};

use super::input::{bad, parse_json, read_text};

/// Score a menu of queries against a particle belief, and optionally update it with an
/// observation. Reads JSON, writes JSON to stdout.
///
/// Input: {"alpha", "particles": [{"q_star", "w", "weight"?}], "menu": [{"id", "configs"}],
/// "grid_cell"?, "observation"?: {"query", "config" | "region" | "measured" with "sigma"}}. Output: per query the exact
/// information gain (nats), the paper's eq. 8 gain (with grid_cell) and the expected cost
/// of eq. 10; the active, active_paper and passive choices; the normalised posterior
/// weights (with observation).
#[derive(Debug, Args)]
pub struct ScoreArgs {
    /// The input JSON file, or `-` for standard input.
    file: PathBuf,
    /// The arithmetic of the information gain and expected cost: float64, or float32 (its
    /// tolerance in docs/engine.md); posteriors are float64 either way.
    #[arg(long, value_enum, default_value_t = Precision::Float64)]
    precision: Precision,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Input {
    alpha: f64,
    particles: Vec<ParticleIn>,
    menu: Vec<QueryIn>,
    #[serde(default)]
    grid_cell: Option<Vec<f64>>,
    #[serde(default)]
    observation: Option<ObservationIn>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ParticleIn {
    q_star: Vec<f64>,
    w: Vec<f64>,
    #[serde(default = "one")]
    weight: f64,
}

fn one() -> f64 {
    1.0
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct QueryIn {
    id: String,
    configs: Vec<Vec<f64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ObservationIn {
    query: String,
    #[serde(default)]
    config: Option<usize>,
    #[serde(default)]
    region: Option<Vec<usize>>,
    /// A measured joint vector (rad), with `sigma`: per-joint noise (rad).
    #[serde(default)]
    measured: Option<Vec<f64>>,
    #[serde(default)]
    sigma: Option<Vec<f64>>,
}

#[derive(Debug, Serialize)]
struct QueryOut {
    id: String,
    information_gain: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    information_gain_paper: Option<f64>,
    expected_cost: f64,
}

#[derive(Debug, Serialize)]
struct Output {
    queries: Vec<QueryOut>,
    active: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    active_paper: Option<String>,
    passive: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    posterior: Option<Vec<f64>>,
}

/// The input, checked and in the engine's types.
struct Config {
    alpha: f64,
    belief: Belief,
    ids: Vec<String>,
    menu: Vec<FeasibleSet>,
    grid: Option<Grid>,
    observation: Option<(usize, Observation)>,
}

/// Budgets of one `score` input: joints, queries, and particle–configuration pairs (each
/// costs a few nanoseconds per selection).
const MAX_DIM: usize = 64;
const MAX_QUERIES: usize = 10_000;
const MAX_PAIRS: f64 = 1e9;

fn check_finite(v: &[f64], field: &str, name: &str) -> Result<()> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(bad(format!("{name}: {field}[{i}] is {}, expected a finite number", v[i]))),
        None => Ok(()),
    }
}

impl Config {
    fn from_input(input: Input, name: &str) -> Result<Self> {
        if !(input.alpha.is_finite() && input.alpha > 0.0) {
            return Err(bad(format!("{name}: alpha is {}, expected a positive finite number", input.alpha)));
        }
        if input.particles.is_empty() {
            return Err(bad(format!("{name}: particles is empty, expected at least one particle")));
        }
        let dim = input.particles[0].q_star.len();
        if dim == 0 || dim > MAX_DIM {
            return Err(bad(format!(
                "{name}: particles[0].q_star has {dim} components, expected 1 to {MAX_DIM} (one angle per joint)"
            )));
        }
        if input.menu.len() > MAX_QUERIES {
            return Err(bad(format!(
                "{name}: menu has {} queries, over the budget of {MAX_QUERIES}",
                input.menu.len()
            )));
        }
        let pairs = input.particles.len() as f64 * input.menu.iter().map(|q| q.configs.len() as f64).sum::<f64>();
        if pairs > MAX_PAIRS {
            return Err(bad(format!(
                "{name}: particles × menu configurations = {pairs} pairs, over the budget of {MAX_PAIRS}"
            )));
        }
        let mut lambdas = Vec::with_capacity(input.particles.len());
        let mut weights = Vec::with_capacity(input.particles.len());
        for (i, p) in input.particles.into_iter().enumerate() {
            for (field, v) in [("q_star", &p.q_star), ("w", &p.w)] {
                if v.len() != dim {
                    return Err(bad(format!(
                        "{name}: particles[{i}].{field} has {} components, expected {dim}",
                        v.len()
                    )));
                }
                check_finite(v, &format!("particles[{i}].{field}"), name)?;
            }
            if let Some(d) = p.w.iter().position(|w| *w < 0.0) {
                return Err(bad(format!(
                    "{name}: particles[{i}].w[{d}] is {}, expected a non-negative weight (a cost is never negative)",
                    p.w[d]
                )));
            }
            if !(p.weight.is_finite() && p.weight >= 0.0) {
                return Err(bad(format!(
                    "{name}: particles[{i}].weight is {}, expected a finite non-negative number",
                    p.weight
                )));
            }
            lambdas.push(Lambda { q_star: p.q_star, w: p.w });
            weights.push(p.weight);
        }
        if weights.iter().all(|&w| w == 0.0) {
            return Err(bad(format!("{name}: particles: every weight is zero, expected at least one positive weight")));
        }
        let belief = Belief::from_particles(&lambdas, &weights).map_err(|e| bad(format!("{name}: particles: {e}")))?;

        if input.menu.is_empty() {
            return Err(bad(format!("{name}: menu is empty, expected at least one query")));
        }
        let mut seen = HashSet::new();
        let mut reach = vec![0.0f64; dim];
        let mut ids = Vec::new();
        let mut menu = Vec::new();
        for (k, q) in input.menu.into_iter().enumerate() {
            if !seen.insert(q.id.clone()) {
                return Err(bad(format!("{name}: menu[{k}].id '{}' is a duplicate, expected unique ids", q.id)));
            }
            if q.configs.is_empty() {
                return Err(bad(format!("{name}: menu[{k}].configs is empty, expected at least one configuration")));
            }
            for (j, c) in q.configs.iter().enumerate() {
                if c.len() != dim {
                    return Err(bad(format!("{name}: menu[{k}].configs[{j}] has {} joints, expected {dim}", c.len())));
                }
                check_finite(c, &format!("menu[{k}].configs[{j}]"), name)?;
                for (r, v) in reach.iter_mut().zip(c) {
                    *r = r.max(v.abs());
                }
            }
            let set = ConfigSet::from_rows(&q.configs).map_err(|e| bad(format!("{name}: menu[{k}].configs: {e}")))?;
            ids.push(q.id);
            menu.push(FeasibleSet::new(set));
        }

        // Every α·C(q; λ) must be a finite number: bound it by Σ w (|q*| + max |q|)².
        for (i, l) in lambdas.iter().enumerate() {
            let bound: f64 =
                l.q_star.iter().zip(&l.w).zip(&reach).map(|((qs, w), r)| w * (qs.abs() + r).powi(2)).sum::<f64>();
            if !(input.alpha * bound).is_finite() {
                return Err(bad(format!(
                    "{name}: particles[{i}]: alpha × cost is not a finite number for some configuration \
                     (q_star or w too large for the menu), expected finite costs"
                )));
            }
        }
        let grid = match input.grid_cell {
            None => None,
            Some(widths) => {
                if widths.len() != 2 * dim {
                    return Err(bad(format!(
                        "{name}: grid_cell has {} widths, expected {} (one per component of λ = [q*, w])",
                        widths.len(),
                        2 * dim
                    )));
                }
                if let Some(i) = widths.iter().position(|w| !(w.is_finite() && *w > 0.0)) {
                    return Err(bad(format!(
                        "{name}: grid_cell[{i}] is {}, expected a positive finite width",
                        widths[i]
                    )));
                }
                Grid::new(widths)
            }
        };

        let observation = match input.observation {
            None => None,
            Some(o) => {
                let k = ids
                    .iter()
                    .position(|id| *id == o.query)
                    .ok_or_else(|| bad(format!("{name}: observation.query '{}' is not a menu id", o.query)))?;
                let obs = match (o.config, o.region, o.measured, o.sigma) {
                    (Some(c), None, None, None) => Observation::Config(c),
                    (None, Some(r), None, None) => Observation::Region(r),
                    (None, None, Some(q), Some(sigma)) => Observation::measured(menu[k].configs(), &q, &sigma)
                        .map_err(|e| bad(format!("{name}: observation.measured: {e}")))?,
                    _ => {
                        return Err(bad(format!(
                            "{name}: observation needs exactly one of \"config\" (an index), \"region\" (a list of \
                             indices) or \"measured\" (joint angles, rad) with \"sigma\" (per-joint noise, rad)"
                        )));
                    }
                };
                obs.check(menu[k].len()).map_err(|e| bad(format!("{name}: observation: {e}")))?;
                Some((k, obs))
            }
        };
        Ok(Self { alpha: input.alpha, belief, ids, menu, grid, observation })
    }
}

fn score(cfg: Config, precision: Precision) -> Result<Output> {
    let outcomes = OutcomeModel::Configuration;
    let problem = Problem { belief: &cfg.belief, menu: &cfg.menu, alpha: cfg.alpha, outcomes, precision };
    let values = menu_values(&problem);
    let paper: Option<Vec<f64>> = cfg
        .grid
        .as_ref()
        .map(|g| cfg.menu.iter().map(|s| information_gain_paper(&cfg.belief, s, cfg.alpha, outcomes, g)).collect());
    let active =
        choose_from_values(SelectorKind::Active, &values, Tradeoff::default()).expect("active decides from values");
    let passive =
        choose_from_values(SelectorKind::Passive, &values, Tradeoff::default()).expect("passive decides from values");
    let active_paper = paper.as_ref().map(|p| cfg.ids[argmax(p)].clone());
    let posterior = match &cfg.observation {
        None => None,
        Some((k, obs)) => {
            let mut b = cfg.belief.clone();
            b.update(&cfg.menu[*k], cfg.alpha, obs).map_err(|e| anyhow::anyhow!("observation: {e}"))?;
            Some(b.weights().to_vec())
        }
    };
    let queries = values
        .iter()
        .enumerate()
        .map(|(k, v)| QueryOut {
            id: cfg.ids[k].clone(),
            information_gain: v.information_gain,
            information_gain_paper: paper.as_ref().map(|p| p[k]),
            expected_cost: v.expected_cost,
        })
        .collect();
    Ok(Output { queries, active: cfg.ids[active].clone(), active_paper, passive: cfg.ids[passive].clone(), posterior })
}

pub fn run(args: ScoreArgs) -> Result<()> {
    let name = if args.file.as_os_str() == "-" { "<stdin>".to_string() } else { args.file.display().to_string() };
    let text = read_text(&args.file)?;
    let input: Input = parse_json(&text, &name)?;
    let out = score(Config::from_input(input, &name)?, args.precision)?;
    outln!("{}", serde_json::to_string_pretty(&out)?);
    Ok(())
}
