//! Properties of the learning engine that must hold for any belief and feasible set.

use handover::belief::Belief;
use handover::ergo::{ConfigSet, FeasibleSet, Lambda, Observation};
use handover::select::{OutcomeModel, query_value};
use proptest::prelude::*;

const D: usize = 3;

fn lambda() -> impl Strategy<Value = Lambda> {
    (prop::collection::vec(-2.0..2.0f64, D), prop::collection::vec(0.01..3.0f64, D))
        .prop_map(|(q_star, w)| Lambda { q_star, w })
}

fn belief() -> impl Strategy<Value = Belief> {
    prop::collection::vec((lambda(), 0.01..1.0f64), 1..40).prop_map(|ps| {
        let (ls, ws): (Vec<_>, Vec<_>) = ps.into_iter().unzip();
        Belief::from_particles(&ls, &ws).unwrap()
    })
}

fn configs(max: usize) -> impl Strategy<Value = Vec<Vec<f64>>> {
    prop::collection::vec(prop::collection::vec(-3.0..3.0f64, D), 1..max)
}

fn set(rows: &[Vec<f64>]) -> FeasibleSet {
    FeasibleSet::new(ConfigSet::from_rows(rows).unwrap())
}

proptest! {
    #[test]
    fn posterior_sums_to_one(mut b in belief(), rows in configs(30), pick in any::<prop::sample::Index>(), alpha in 0.1..50.0f64) {
        let s = set(&rows);
        b.update(&s, alpha, &Observation::Config(pick.index(rows.len()))).unwrap();
        let total: f64 = b.weights().iter().sum();
        prop_assert!((total - 1.0).abs() < 1e-12, "sum {}", total);
        prop_assert!(b.weights().iter().all(|w| w.is_finite() && *w >= 0.0));
    }

    #[test]
    fn information_gain_lies_between_zero_and_log_set_size(b in belief(), rows in configs(30), alpha in 0.1..50.0f64) {
        let v = query_value(&b, &set(&rows), alpha, OutcomeModel::Configuration);
        prop_assert!(v.information_gain >= 0.0);
        prop_assert!(v.information_gain <= (rows.len() as f64).ln() + 1e-12);
    }

    #[test]
    fn a_single_configuration_gives_no_information(b in belief(), row in prop::collection::vec(-3.0..3.0f64, D), alpha in 0.1..50.0f64) {
        let v = query_value(&b, &set(&[row]), alpha, OutcomeModel::Configuration);
        prop_assert_eq!(v.information_gain, 0.0);
    }

    #[test]
    fn a_region_holding_the_whole_set_leaves_the_belief_unchanged(b in belief(), rows in configs(30), alpha in 0.1..50.0f64) {
        let mut after = b.clone();
        after.update(&set(&rows), alpha, &Observation::Region((0..rows.len()).collect())).unwrap();
        for (x, y) in b.weights().iter().zip(after.weights()) {
            prop_assert!((x - y).abs() < 1e-12, "{} vs {}", x, y);
        }
    }

    /// A joint that takes the same value in every configuration adds the same cost to every
    /// configuration (a different constant per particle): nothing may change.
    #[test]
    fn adding_a_constant_to_every_cost_changes_nothing(
        b in belief(), rows in configs(30), pick in any::<prop::sample::Index>(), alpha in 0.1..20.0f64,
        extra in -3.0..3.0f64, extra_q in -2.0..2.0f64, extra_w in 0.01..3.0f64,
    ) {
        let lambdas: Vec<Lambda> = (0..b.len()).map(|i| {
            let p = b.particle(i);
            let mut q_star = p[..D].to_vec();
            let mut w = p[D..].to_vec();
            q_star.push(extra_q + i as f64 * 0.01);
            w.push(extra_w + i as f64 * 0.1);
            Lambda { q_star, w }
        }).collect();
        let wide = Belief::from_particles(&lambdas, b.weights()).unwrap();
        let wide_rows: Vec<Vec<f64>> = rows.iter().map(|r| { let mut r = r.clone(); r.push(extra); r }).collect();
        let (s, ws) = (set(&rows), set(&wide_rows));
        let v = query_value(&b, &s, alpha, OutcomeModel::Configuration);
        let vw = query_value(&wide, &ws, alpha, OutcomeModel::Configuration);
        prop_assert!((v.information_gain - vw.information_gain).abs() < 1e-9);
        let obs = Observation::Config(pick.index(rows.len()));
        let (mut b1, mut b2) = (b.clone(), wide.clone());
        b1.update(&s, alpha, &obs).unwrap();
        b2.update(&ws, alpha, &obs).unwrap();
        for (x, y) in b1.weights().iter().zip(b2.weights()) {
            prop_assert!((x - y).abs() < 1e-9, "{} vs {}", x, y);
        }
    }
}

#[test]
fn huge_costs_give_no_nan() {
    let b = Belief::from_particles(
        &[Lambda { q_star: vec![0.0; D], w: vec![1e5; D] }, Lambda { q_star: vec![1.0; D], w: vec![1.0; D] }],
        &[1.0, 1.0],
    )
    .unwrap();
    let s = set(&[vec![0.0; D], vec![3.0; D], vec![-3.0; D]]);
    let v = query_value(&b, &s, 40.0, OutcomeModel::Configuration);
    assert!(v.information_gain.is_finite() && v.expected_cost.is_finite());
    let mut u = b.clone();
    u.update(&s, 40.0, &Observation::Config(2)).unwrap();
    assert!(u.weights().iter().all(|w| w.is_finite()));
    assert_eq!(u.weights()[1], 1.0, "the far particle explains the far choice");
}

/// The same computation on pools of one and two threads is bit-identical.
#[test]
fn results_are_identical_for_one_and_two_threads() {
    use handover::belief::{ComponentPrior, Prior};
    use rand::SeedableRng;
    let u = |min, max| ComponentPrior::Uniform { min, max };
    let prior = Prior::new(vec![u(-1.0, 1.0); D], vec![u(0.1, 2.0); D]).unwrap();
    let mut rng = handover::SeededRng::seed_from_u64(5);
    let b = Belief::from_prior(&prior, 1000, &mut rng).unwrap();
    let rows: Vec<Vec<f64>> =
        (0..300).map(|j| (0..D).map(|d| ((j * 7 + d * 13) % 17) as f64 / 5.0 - 1.5).collect()).collect();
    let s = set(&rows);
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let v = query_value(&b, &s, 10.0, OutcomeModel::Configuration);
            let mut u = b.clone();
            u.update(&s, 10.0, &Observation::Config(17)).unwrap();
            (v, u.weights().to_vec())
        })
    };
    let (v1, w1) = run(1);
    let (v2, w2) = run(2);
    assert_eq!(v1.information_gain.to_bits(), v2.information_gain.to_bits());
    assert_eq!(v1.expected_cost.to_bits(), v2.expected_cost.to_bits());
    assert_eq!(w1, w2);
}
