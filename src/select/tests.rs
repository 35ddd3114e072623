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

/// The configuration outcome's problem in float64.
fn configuration_problem<'a>(b: &'a Belief, menu: &'a [FeasibleSet], alpha: f64) -> Problem<'a> {
    Problem { belief: b, menu, alpha, outcomes: OutcomeModel::Configuration, precision: Precision::Float64 }
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
    let p = configuration_problem(&b, &menu, 1.0);
    let s = Passive.select(&p, &mut SeededRng::seed_from_u64(0));
    // Set 0: min costs 4 and 1 → 2.5; set 1: 0.25 and 0.25 → 0.25 (maximised negated).
    assert_eq!(s.criterion, vec![-2.5, -0.25]);
    assert_eq!(s.index, 1);
}

#[test]
fn ties_go_to_the_earliest_item() {
    let menu = [set(&[&[0.0], &[1.0]]), set(&[&[0.0], &[1.0]])];
    let b = two_particles();
    let p = configuration_problem(&b, &menu, 1.0);
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
    let p = configuration_problem(&b, &menu, 4.0);
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
    let p = configuration_problem(&b, &menu, 1.0);
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
    let sigma = [0.1];
    let names: Vec<&str> =
        [OutcomeModel::Configuration, OutcomeModel::Region, OutcomeModel::Measured { sigma: &sigma }]
            .map(|m| m.name())
            .to_vec();
    assert_eq!(names, ["configuration", "region", "measured"]);
}

/// A random belief of `n` particles over `dim` joints and a random set of `k`
/// configurations (a fixed seed).
fn random_problem(seed: u64, dim: usize, n: usize, k: usize, spread: f64) -> (Belief, FeasibleSet) {
    use rand::RngExt;
    let mut rng = SeededRng::seed_from_u64(seed);
    let lambdas: Vec<Lambda> = (0..n)
        .map(|_| Lambda {
            q_star: (0..dim).map(|_| rng.random_range(-1.0..1.0)).collect(),
            w: (0..dim).map(|_| rng.random_range(0.2..2.0)).collect(),
        })
        .collect();
    let weights: Vec<f64> = (0..n).map(|_| rng.random_range(0.1..1.0)).collect();
    let rows: Vec<Vec<f64>> = (0..k).map(|_| (0..dim).map(|_| rng.random_range(-spread..spread)).collect()).collect();
    let refs: Vec<&[f64]> = rows.iter().map(|r| r.as_slice()).collect();
    (Belief::from_particles(&lambdas, &weights).unwrap(), set(&refs))
}

/// I(λ; q_m) by brute force: ∫ Σ_i ω_i f_i(x) ln(f_i(x) / f(x)) dx on a fine grid over
/// every point within 12σ of a configuration (1 or 2 joints), f_i the measurement's density
/// under particle i.
fn brute_force_measured(belief: &Belief, s: &FeasibleSet, alpha: f64, sigma: &[f64]) -> f64 {
    let dim = s.configs().dim();
    let n = belief.weights().len();
    let p: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            let lam = belief.particle(i);
            let (q_star, w) = lam.split_at(dim);
            let c: Vec<f64> =
                (0..s.len()).map(|j| -alpha * crate::ergo::cost(&s.configs().config(j), q_star, w)).collect();
            let top = c.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let e: Vec<f64> = c.iter().map(|v| (v - top).exp()).collect();
            let z: f64 = e.iter().sum();
            e.iter().map(|v| v / z).collect()
        })
        .collect();
    let w: Vec<f64> = belief.weights().to_vec();
    let lo: Vec<f64> = (0..dim)
        .map(|d| s.configs().joint(d).iter().copied().fold(f64::INFINITY, f64::min) - 12.0 * sigma[d])
        .collect();
    let hi: Vec<f64> = (0..dim)
        .map(|d| s.configs().joint(d).iter().copied().fold(f64::NEG_INFINITY, f64::max) + 12.0 * sigma[d])
        .collect();
    let steps: usize = if dim == 1 { 200_000 } else { 700 };
    let h: Vec<f64> = (0..dim).map(|d| (hi[d] - lo[d]) / steps as f64).collect();
    let cells = steps.pow(dim as u32);
    let norm: f64 = sigma.iter().map(|s| s * (2.0 * std::f64::consts::PI).sqrt()).product();
    let mut total = 0.0;
    let mut x = vec![0.0; dim];
    let mut f_i = vec![0.0; n];
    for cell in 0..cells {
        let mut c = cell;
        for d in 0..dim {
            x[d] = lo[d] + (c % steps) as f64 * h[d] + 0.5 * h[d];
            c /= steps;
        }
        let g: Vec<f64> = (0..s.len())
            .map(|j| {
                let q = s.configs().config(j);
                (-(0..dim).map(|d| ((x[d] - q[d]) / sigma[d]).powi(2)).sum::<f64>() / 2.0).exp() / norm
            })
            .collect();
        let mut f = 0.0;
        for i in 0..n {
            f_i[i] = p[i].iter().zip(&g).map(|(a, b)| a * b).sum();
            f += w[i] * f_i[i];
        }
        if f > 0.0 {
            for i in 0..n {
                if f_i[i] > 0.0 {
                    total += w[i] * f_i[i] * (f_i[i] / f).ln();
                }
            }
        }
    }
    total * h.iter().product::<f64>()
}

/// The measured outcome's information against a brute-force integral, in one and two
/// joints, from a measurement that pins the configuration to one that barely tells them
/// apart: within four of its standard errors, and within 0.02 nats or 10 % with the
/// selectors' 64 points; 2048 points come within a quarter of that.
#[test]
fn measured_information_matches_a_brute_force_integral() {
    for (seed, dim, sigma) in [(1, 1, 0.02), (2, 1, 0.3), (3, 1, 1.0), (4, 2, 0.1), (5, 2, 0.4), (6, 2, 1.5)] {
        let (b, s) = random_problem(seed, dim, 6, 5, 1.0);
        let sig = vec![sigma; dim];
        let reference = brute_force_measured(&b, &s, 2.0, &sig);
        let exact_config = query_value(&b, &s, 2.0, OutcomeModel::Configuration).information_gain;
        assert!(reference <= exact_config + 1e-6, "data processing: {reference} ≤ {exact_config}");
        for (points, tolerance) in [(MEASURED_POINTS, 1.0), (2048, 0.25)] {
            let m = measured_information(&b, &s, 2.0, &sig, points);
            let err = (m.estimate - reference).abs();
            eprintln!(
                "dim {dim} σ {sigma}: reference {reference:.5}, {points} points {:.5} ± {:.5}, I(λ;q) {exact_config:.5}",
                m.estimate, m.standard_error
            );
            assert!(
                err <= 4.0 * m.standard_error + 1e-9,
                "{points} points: {} vs {reference} (se {})",
                m.estimate,
                m.standard_error
            );
            assert!(
                err <= tolerance * (0.02f64).max(0.1 * reference),
                "{points} points: {} vs {reference}",
                m.estimate
            );
            assert_eq!(m.configuration, exact_config);
        }
    }
}

/// A measurement far finer than the configurations' spacing tells as much as the
/// configuration; one far coarser than the set tells nearly nothing.
#[test]
fn measured_information_spans_the_configuration_s_and_nothing() {
    let (b, s) = random_problem(9, 7, 300, 40, 1.0);
    let exact = query_value(&b, &s, 3.0, OutcomeModel::Configuration).information_gain;
    let fine = measured_information(&b, &s, 3.0, &[1e-5; 7], MEASURED_POINTS);
    assert!((fine.estimate - exact).abs() < 1e-9 * exact.max(1.0), "{} vs {exact}", fine.estimate);
    let coarse = measured_information(&b, &s, 3.0, &[100.0; 7], MEASURED_POINTS);
    assert!(coarse.estimate < 1e-3 * exact, "{} vs {exact}", coarse.estimate);
    let region = query_value(&b, &s, 3.0, OutcomeModel::Measured { sigma: &[0.1; 7] });
    let m = measured_information(&b, &s, 3.0, &[0.1; 7], MEASURED_POINTS);
    assert_eq!(region.information_gain, m.estimate);
    assert_eq!(region.expected_cost, expected_cost(&b, &s, Precision::Float64));
}

#[test]
fn budgeted_takes_the_most_informative_query_within_its_cost_budget() {
    let b = two_particles();
    // 0: informative and costly; 1: cheapest, uninformative; 2: a little dearer, a little
    // informative.
    let menu = [set(&[&[-1.0], &[2.0]]), set(&[&[0.5]]), set(&[&[-0.6], &[1.7]])];
    let p = configuration_problem(&b, &menu, 1.0);
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

#[test]
fn passive_expected_cost_alone_is_the_same_bits_as_the_whole_pass() {
    // Random particles (some with weight 0) over several chunks, 7 and 2 joints, sets of
    // sizes around the lane width.
    let mut rng = SeededRng::seed_from_u64(11);
    use rand::RngExt;
    for (dim, particles, configs) in [(7, 300, 37), (7, 65, 8), (2, 200, 5), (3, 130, 17)] {
        let lambdas: Vec<Lambda> = (0..particles)
            .map(|_| Lambda {
                q_star: (0..dim).map(|_| rng.random_range(-1.5..1.5)).collect(),
                w: (0..dim).map(|_| rng.random_range(0.0..2.0)).collect(),
            })
            .collect();
        let weights: Vec<f64> =
            (0..particles).map(|i| if i % 7 == 3 { 0.0 } else { rng.random_range(0.1..1.0) }).collect();
        let belief = Belief::from_particles(&lambdas, &weights).unwrap();
        let rows: Vec<Vec<f64>> =
            (0..configs).map(|_| (0..dim).map(|_| rng.random_range(-2.0..2.0)).collect()).collect();
        let refs: Vec<&[f64]> = rows.iter().map(|r| r.as_slice()).collect();
        let s = set(&refs);
        for precision in [Precision::Float64, Precision::Float32] {
            let whole = query_value_in(&belief, &s, 3.0, OutcomeModel::Configuration, precision).expected_cost;
            let alone = expected_cost(&belief, &s, precision);
            assert_eq!(alone.to_bits(), whole.to_bits(), "{precision:?}, {dim} joints, {configs} configurations");
        }
    }
}

/// The selectors' 64 points against 8192 on the default protocol's menu (2000 particles
/// from the prior, σ = 5°), with the region's and the configuration's information beside:
/// docs/engine.md quotes its output. Seconds in a release build, so run by hand:
/// `cargo test --release --lib measured_information_on_the_default_menu -- --ignored --nocapture`.
#[test]
#[ignore = "a measurement for docs/engine.md"]
fn measured_information_on_the_default_menu() {
    let study = crate::protocol::Study::default_study();
    let alpha = study.protocol.learning.alpha;
    let menu: Vec<FeasibleSet> = study.training.iter().map(|q| crate::session::choice_set(&q.feasible)).collect();
    let belief = Belief::from_prior(&study.prior, 2000, &mut SeededRng::seed_from_u64(3)).unwrap();
    let sigma = [5f64.to_radians(); 7];
    println!("query |Q|  64 points (se)  8192 points (se)  I(λ;q)  I(λ;region)  time of 64");
    for (k, s) in menu.iter().enumerate() {
        let t0 = std::time::Instant::now();
        let a = measured_information(&belief, s, alpha, &sigma, MEASURED_POINTS);
        let dt = t0.elapsed();
        let b = measured_information(&belief, s, alpha, &sigma, 8192);
        let r = query_value(&belief, s, alpha, OutcomeModel::Region).information_gain;
        println!(
            "{k:5} {:3}  {:.4} ({:.4})  {:.4} ({:.4})  {:.4}  {r:.4}  {dt:.1?}",
            s.len(),
            a.estimate,
            a.standard_error,
            b.estimate,
            b.standard_error,
            a.configuration
        );
        assert!((a.estimate - b.estimate).abs() <= 0.02 && (a.estimate - b.estimate).abs() <= 4.0 * a.standard_error);
    }
}

/// The float32 pass's information gain and expected cost against float64's on the default
/// protocol's menu, for beliefs from the prior and after 1 to 5 handovers of simulated people
/// (region and configuration outcomes, 2000 particles): docs/engine.md states the tolerance
/// this checks (relative error of I below 1e-5 where I > 0.01 nats, 1e-8 nats absolute
/// below; expected cost 1e-6 relative; measured 2.0e-7, 3.8e-10 and 3.7e-8). Printed with
/// `--nocapture`.
#[test]
fn float32_information_gain_is_within_its_tolerance() {
    use crate::ergo::Observation;
    let study = crate::protocol::Study::default_study();
    let alpha = study.protocol.learning.alpha;
    let menu: Vec<FeasibleSet> = study.training.iter().map(|q| crate::session::choice_set(&q.feasible)).collect();
    let (mut worst_rel, mut worst_abs, mut worst_cost) = (0.0f64, 0.0f64, 0.0f64);
    let mut rng = SeededRng::seed_from_u64(320);
    for person in 0..3 {
        let mut belief = Belief::from_prior(&study.prior, 2000, &mut rng).unwrap();
        let person_model = crate::participant::SimulatedPerson {
            truth: crate::ergo::Lambda::from_slice(&study.prior.sample(&mut rng)),
            alpha,
        };
        for step in 0..=5 {
            for outcomes in [OutcomeModel::Region, OutcomeModel::Configuration] {
                for s in &menu {
                    let a = query_value_in(&belief, s, alpha, outcomes, Precision::Float64);
                    let b = query_value_in(&belief, s, alpha, outcomes, Precision::Float32);
                    let err = (a.information_gain - b.information_gain).abs();
                    if a.information_gain > 0.01 {
                        worst_rel = worst_rel.max(err / a.information_gain);
                    } else {
                        worst_abs = worst_abs.max(err);
                    }
                    worst_cost = worst_cost.max((a.expected_cost - b.expected_cost).abs() / a.expected_cost);
                }
            }
            if step < 5 {
                // The simulated person takes a grip of the query active would offer.
                let q = (person + 3 * step) % menu.len();
                let j = person_model.choose(&menu[q], &mut rng);
                let region = menu[q].regions()[menu[q].region_of(j)].clone().collect();
                belief.update(&menu[q], alpha, &Observation::Region(region)).unwrap();
                belief.maybe_resample(crate::belief::ResamplePolicy::EveryUpdate, &[0.02; 7], &mut rng);
            }
        }
    }
    println!(
        "float32 vs float64: I relative {worst_rel:.2e}, absolute (I ≤ 0.01) {worst_abs:.2e}, E[cost] relative {worst_cost:.2e}"
    );
    assert!(worst_rel < 1e-5 && worst_abs < 1e-8 && worst_cost < 1e-6, "{worst_rel:e} {worst_abs:e} {worst_cost:e}");
}

/// The menu's values in one pass over the particles are each set's own, bit for bit:
/// configuration and region outcomes, both precisions, and the expected costs alone.
#[test]
fn a_menu_in_one_pass_is_each_set_on_its_own() {
    let study = crate::protocol::Study::default_study();
    let belief = Belief::from_prior(&study.prior, 150, &mut SeededRng::seed_from_u64(5)).unwrap();
    let menu: Vec<FeasibleSet> = study.training.iter().map(|q| crate::session::choice_set(&q.feasible)).collect();
    let menu = &menu;
    for outcomes in [OutcomeModel::Configuration, OutcomeModel::Region] {
        for precision in [Precision::Float64, Precision::Float32] {
            let together = menu_query_values(&belief, menu, 5.0, outcomes, precision);
            let alone: Vec<QueryValue> =
                menu.iter().map(|s| query_value_in(&belief, s, 5.0, outcomes, precision)).collect();
            assert_eq!(together, alone, "{outcomes:?}, {precision:?}");
            let costs = menu_expected_costs(&belief, menu, precision);
            let alone: Vec<f64> = menu.iter().map(|s| expected_cost(&belief, s, precision)).collect();
            assert_eq!(costs, alone, "{precision:?}");
        }
    }
}
