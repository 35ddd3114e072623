use rand::SeedableRng;

use super::*;
use crate::ergo::{ConfigSet, Lambda};

fn lam(q: &[f64], w: &[f64]) -> Lambda {
    Lambda { q_star: q.to_vec(), w: w.to_vec() }
}

fn set(rows: &[&[f64]]) -> FeasibleSet {
    FeasibleSet::new(ConfigSet::from_rows(rows).unwrap())
}

fn binary_entropy(a: f64) -> f64 {
    -(a * a.ln() + (1.0 - a) * (1.0 - a).ln())
}

fn two_particles() -> Belief {
    Belief::from_particles(&[lam(&[0.0], &[1.0]), lam(&[1.0], &[1.0])], &[1.0, 1.0]).unwrap()
}

#[test]
fn exact_information_gain_by_hand() {
    // L_1 = [a, 1 − a], L_2 = [1 − a, a] with a = 1 / (1 + e^-1): I = ln 2 − H_b(a).
    let a = 1.0 / (1.0 + (-1.0f64).exp());
    let v = query_value(&two_particles(), &set(&[&[0.0], &[1.0]]), 1.0, OutcomeModel::Configuration);
    assert!((v.information_gain - (2.0f64.ln() - binary_entropy(a))).abs() < 1e-14);
    // eq. 10: each particle has a zero-cost configuration.
    assert_eq!(v.expected_cost, 0.0);
}

#[test]
fn paper_information_gain_by_hand() {
    // Each particle's ML choice is its own q*; each posterior is [a, 1 − a] or [1 − a, a].
    let a = 1.0 / (1.0 + (-1.0f64).exp());
    let grid = Grid::new(vec![0.5, 1.0]).unwrap();
    let ig = information_gain_paper(&two_particles(), &set(&[&[0.0], &[1.0]]), 1.0, OutcomeModel::Configuration, &grid);
    assert!((ig - (2.0f64.ln() - binary_entropy(a))).abs() < 1e-14);
}

#[test]
fn region_outcomes_by_hand() {
    // Regions {0} and {1, 2} with configs 0, 1, 1: the region split is the config split.
    let s = FeasibleSet::with_regions(ConfigSet::from_rows(&[[0.0], [1.0], [1.0]]).unwrap(), &[0, 1, 1]).unwrap();
    let v = query_value(&two_particles(), &s, 1.0, OutcomeModel::Region);
    let p1 = 1.0 / (1.0 + 2.0 * (-1.0f64).exp());
    let p2 = (-1.0f64).exp() / (2.0 + (-1.0f64).exp());
    let m = 0.5 * (p1 + p2);
    let want = binary_entropy(m) - 0.5 * (binary_entropy(p1) + binary_entropy(p2));
    assert!((v.information_gain - want).abs() < 1e-14);
}

#[test]
fn single_configuration_teaches_nothing() {
    let v = query_value(&two_particles(), &set(&[&[0.3]]), 5.0, OutcomeModel::Configuration);
    assert_eq!(v.information_gain, 0.0);
}

#[test]
fn passive_picks_the_lowest_expected_cost() {
    let menu = [set(&[&[3.0], &[2.0]]), set(&[&[0.5], &[-4.0]])];
    let b = two_particles();
    let p = Problem { belief: &b, menu: &menu, alpha: 1.0, outcomes: OutcomeModel::Configuration };
    let s = Passive.select(&p, &mut SeededRng::seed_from_u64(0));
    // Set 0: min costs 4 and 1 → 2.5; set 1: 0.25 and 0.25 → 0.25 (maximised negated).
    assert_eq!(s.criterion, vec![-2.5, -0.25]);
    assert_eq!(s.index, 1);
}

#[test]
fn ties_go_to_the_earliest_item() {
    let menu = [set(&[&[0.0], &[1.0]]), set(&[&[0.0], &[1.0]])];
    let b = two_particles();
    let p = Problem { belief: &b, menu: &menu, alpha: 1.0, outcomes: OutcomeModel::Configuration };
    let grid = Grid::new(vec![0.5, 1.0]).unwrap();
    for kind in [
        SelectorKind::Active,
        SelectorKind::ActivePaper,
        SelectorKind::Passive,
        SelectorKind::Hybrid,
        SelectorKind::Budgeted,
    ] {
        assert_eq!(
            kind.build(&grid, Tradeoff::default()).select(&p, &mut SeededRng::seed_from_u64(0)).index,
            0,
            "{kind:?}"
        );
    }
}

#[test]
fn active_prefers_the_separating_query_and_passive_the_comfortable_one() {
    // Query 0 offers the two particles' own optima (informative); query 1 offers one
    // configuration both find cheap (uninformative, comfortable on average).
    let menu = [set(&[&[0.0], &[1.0]]), set(&[&[0.5]])];
    let b = two_particles();
    let p = Problem { belief: &b, menu: &menu, alpha: 4.0, outcomes: OutcomeModel::Configuration };
    let mut rng = SeededRng::seed_from_u64(0);
    assert_eq!(Active.select(&p, &mut rng).index, 0);
    assert_eq!(Passive.select(&p, &mut rng).index, 0, "min cost 0 beats 0.25");
    let menu = [set(&[&[-1.0], &[2.0]]), set(&[&[0.5]])];
    let p = Problem { menu: &menu, ..p };
    assert_eq!(Active.select(&p, &mut rng).index, 0);
    assert_eq!(Passive.select(&p, &mut rng).index, 1);
    // A large β makes hybrid behave like passive; β = 0 like active.
    assert_eq!(Hybrid { beta: 100.0 }.select(&p, &mut rng).index, 1);
    assert_eq!(Hybrid { beta: 0.0 }.select(&p, &mut rng).index, 0);
}

#[test]
fn random_is_reproducible_for_a_seed() {
    let menu: Vec<_> = (0..8).map(|i| set(&[&[i as f64]])).collect();
    let b = two_particles();
    let p = Problem { belief: &b, menu: &menu, alpha: 1.0, outcomes: OutcomeModel::Configuration };
    let draw = |seed| {
        let mut rng = SeededRng::seed_from_u64(seed);
        (0..20).map(|_| Random.select(&p, &mut rng).index).collect::<Vec<_>>()
    };
    assert_eq!(draw(4), draw(4));
    assert!(draw(4).iter().any(|&i| i != draw(4)[0]));
}

#[test]
fn selector_names_round_trip() {
    for k in SelectorKind::ALL {
        assert_eq!(k.name().parse::<SelectorKind>(), Ok(k));
    }
    assert!("greedy".parse::<SelectorKind>().is_err());
}

#[test]
fn outcome_model_names_are_the_protocol_spelling() {
    for m in [OutcomeModel::Configuration, OutcomeModel::Region] {
        assert_eq!(serde_json::to_value(m).unwrap(), serde_json::Value::String(m.name().into()));
    }
}

#[test]
fn budgeted_takes_the_most_informative_query_within_its_cost_budget() {
    let b = two_particles();
    // 0: informative and costly; 1: cheapest, uninformative; 2: a little dearer, a little
    // informative.
    let menu = [set(&[&[-1.0], &[2.0]]), set(&[&[0.5]]), set(&[&[-0.6], &[1.7]])];
    let p = Problem { belief: &b, menu: &menu, alpha: 1.0, outcomes: OutcomeModel::Configuration };
    let v = menu_values(&p);
    let passive = v[1].expected_cost;
    assert!(v[2].expected_cost > passive && v[0].expected_cost > v[2].expected_cost, "{v:?}");
    assert!(v[0].information_gain > v[2].information_gain && v[2].information_gain > v[1].information_gain);
    let mut rng = SeededRng::seed_from_u64(0);
    let pick = |epsilon: f64, rng: &mut SeededRng| Budgeted { epsilon }.select(&p, rng).index;
    assert_eq!(pick(0.0, &mut rng), 1, "no budget above passive: passive's query");
    let just = v[2].expected_cost / passive - 1.0;
    assert_eq!(pick(just * 0.999, &mut rng), 1, "query 2 is just over the budget");
    assert_eq!(pick(just * 1.001, &mut rng), 2, "query 2 is just within it");
    assert_eq!(pick(1e6, &mut rng), Active.select(&p, &mut rng).index, "an unlimited budget is active");
    // The criterion marks what is over the budget.
    let c = Budgeted { epsilon: just * 1.001 }.select(&p, &mut rng).criterion;
    assert_eq!(c[0], f64::NEG_INFINITY);
    assert_eq!(c[2], v[2].information_gain);
}
