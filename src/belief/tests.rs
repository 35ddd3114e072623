use rand::SeedableRng;

use super::*;
use crate::SeededRng;
use crate::ergo::ConfigSet;

fn lam(q: &[f64], w: &[f64]) -> Lambda {
    Lambda { q_star: q.to_vec(), w: w.to_vec() }
}

fn set(rows: &[&[f64]]) -> FeasibleSet {
    FeasibleSet::new(ConfigSet::from_rows(rows).unwrap())
}

/// One joint: q* uniform on [−2, 2], w known (1).
fn interval_prior() -> Prior {
    Prior::new(vec![ComponentPrior::Uniform { min: -2.0, max: 2.0 }], vec![ComponentPrior::Fixed { value: 1.0 }])
        .unwrap()
}

#[test]
fn update_matches_bayes_rule_by_hand() {
    let mut b = Belief::from_particles(&[lam(&[0.0], &[1.0]), lam(&[2.0], &[1.0])], &[1.0, 1.0]).unwrap();
    b.update(&set(&[&[0.0], &[2.0]]), 1.0, &Observation::Config(0)).unwrap();
    let a = 1.0 / (1.0 + (-4.0f64).exp());
    assert!((b.weights()[0] - a).abs() < 1e-15);
    assert!((b.weights()[1] - (1.0 - a)).abs() < 1e-15);
}

#[test]
fn each_particle_has_its_own_normaliser() {
    // eq. 5: same q*, different w; the set {0, 1}. With one global normaliser the
    // posterior would be proportional to e^0 for both and stay uniform.
    let mut b = Belief::from_particles(&[lam(&[0.0], &[1.0]), lam(&[0.0], &[2.0])], &[1.0, 1.0]).unwrap();
    b.update(&set(&[&[0.0], &[1.0]]), 1.0, &Observation::Config(0)).unwrap();
    let (la, lb) = (1.0 / (1.0 + (-1.0f64).exp()), 1.0 / (1.0 + (-2.0f64).exp()));
    assert!((b.weights()[0] - la / (la + lb)).abs() < 1e-15);
    assert!((b.weights()[1] - lb / (la + lb)).abs() < 1e-15);
}

#[test]
fn update_survives_costs_of_a_million() {
    let mut b = Belief::from_particles(&[lam(&[0.0], &[1.0]), lam(&[1000.0], &[1.0])], &[1.0, 1.0]).unwrap();
    b.update(&set(&[&[0.0], &[1000.0]]), 1.0, &Observation::Config(1)).unwrap();
    assert!(b.weights().iter().all(|w| w.is_finite()));
    assert_eq!(b.weights()[1], 1.0);
}

#[test]
fn ess_of_uniform_weights_is_n_and_of_a_point_mass_is_one() {
    let b = Belief::from_particles(&[lam(&[0.0], &[1.0]), lam(&[1.0], &[1.0])], &[1.0, 1.0]).unwrap();
    assert!((b.ess() - 2.0).abs() < 1e-12);
    let b = Belief::from_particles(&[lam(&[0.0], &[1.0]), lam(&[1.0], &[1.0])], &[0.0, 3.0]).unwrap();
    assert!((b.ess() - 1.0).abs() < 1e-12);
}

#[test]
fn gridded_entropy_and_mode_by_hand() {
    let ps = [lam(&[0.1], &[1.0]), lam(&[0.2], &[1.0]), lam(&[1.5], &[1.0])];
    let b = Belief::from_particles(&ps, &[0.3, 0.3, 0.4]).unwrap();
    let grid = Grid::new(vec![1.0, 1.0]).unwrap();
    let h = b.entropy(&grid);
    assert!((h - -(0.6f64 * 0.6f64.ln() + 0.4 * 0.4f64.ln())).abs() < 1e-15);
    let mode = b.mode(&grid);
    assert!((mode.q_star[0] - 0.15).abs() < 1e-15);
    let mean = b.mean();
    assert!((mean.q_star[0] - (0.03 + 0.06 + 0.6)).abs() < 1e-15);
}

#[test]
fn entropy_of_one_cell_is_zero() {
    let b = Belief::from_particles(&[lam(&[0.1], &[1.0]), lam(&[0.2], &[1.0])], &[0.0, 1.0]).unwrap();
    assert_eq!(b.entropy(&Grid::new(vec![1.0, 1.0]).unwrap()), 0.0);
}

#[test]
fn systematic_resampling_copies_the_heavy_particle() {
    let ps = [lam(&[0.0], &[1.0]), lam(&[1.0], &[1.0]), lam(&[2.0], &[1.0])];
    let mut b = Belief::from_particles(&ps, &[0.0, 1.0, 0.0]).unwrap();
    b.resample(&[0.0, 0.0], &mut SeededRng::seed_from_u64(3));
    for i in 0..3 {
        assert_eq!(b.particle(i), &[1.0, 1.0]);
    }
    assert!(b.weights().iter().all(|&w| (w - 1.0 / 3.0).abs() < 1e-15));
}

#[test]
fn jitter_stays_inside_the_prior_support() {
    let prior =
        Prior::new(vec![ComponentPrior::Uniform { min: 0.0, max: 0.1 }], vec![ComponentPrior::Fixed { value: 1.0 }])
            .unwrap();
    let mut rng = SeededRng::seed_from_u64(9);
    let mut b = Belief::from_prior(&prior, 500, &mut rng).unwrap();
    b.resample(&[1.0, 1.0], &mut rng);
    for i in 0..b.len() {
        let p = b.particle(i);
        assert!((0.0..=0.1).contains(&p[0]), "{p:?}");
        assert_eq!(p[1], 1.0, "a fixed component is never jittered");
    }
}

#[test]
fn ess_policy_resamples_only_below_threshold() {
    let ps = [lam(&[0.0], &[1.0]), lam(&[1.0], &[1.0])];
    let mut b = Belief::from_particles(&ps, &[1.0, 1.0]).unwrap();
    let mut rng = SeededRng::seed_from_u64(1);
    assert!(!b.maybe_resample(ResamplePolicy::EssBelow { fraction: 0.5 }, &[0.0, 0.0], &mut rng));
    let mut b = Belief::from_particles(&ps, &[1.0, 0.0]).unwrap();
    assert!(b.maybe_resample(ResamplePolicy::EssBelow { fraction: 0.9 }, &[0.0, 0.0], &mut rng));
    assert_eq!(b.particle(1), &[0.0, 1.0]);
}

#[test]
fn density_of_a_single_particle_at_itself() {
    let b = Belief::from_particles(&[lam(&[0.5], &[1.0])], &[1.0]).unwrap();
    // Both components are free for explicit particles: two unit-height Gaussians.
    let h = [0.1, 0.2];
    let want = 1.0 / (0.1 * 0.2 * 2.0 * std::f64::consts::PI);
    assert!((b.density_at(&lam(&[0.5], &[1.0]), &h) - want).abs() < 1e-9);
    assert!((b.distance(&lam(&[0.5], &[1.0]), &lam(&[0.5], &[3.0])) - 2.0).abs() < 1e-15);
}

#[test]
fn test_metrics_by_hand() {
    let s = set(&[&[0.0], &[1.0]]);
    let truth = lam(&[0.0], &[1.0]);
    // P = [1, e^-1] / (1 + e^-1); E[C] = e^-1 / (1 + e^-1).
    let e = (-1.0f64).exp();
    assert!((true_cost(&s, &truth, 1.0) - e / (1.0 + e)).abs() < 1e-15);
    let tests = vec![TestExample { set: s.clone(), observation: Observation::Config(0) }];
    let ll = test_log_likelihood(&truth, &tests, 1.0).unwrap();
    assert!((ll - (1.0 / (1.0 + e)).ln()).abs() < 1e-15);
    let b = Belief::from_particles(&[truth.clone(), lam(&[1.0], &[1.0])], &[1.0, 1.0]).unwrap();
    let pp = posterior_predictive_log_likelihood(&b, &tests, 1.0).unwrap();
    assert!((pp - (0.5f64).ln()).abs() < 1e-15, "mixture of a and 1 - a is 1/2: {pp}");
}

#[test]
fn bad_particles_are_refused() {
    assert_eq!(Belief::from_particles(&[], &[]), Err(BeliefError::NoParticles));
    assert_eq!(
        Belief::from_particles(&[lam(&[0.0], &[1.0])], &[-1.0]),
        Err(BeliefError::BadWeight { index: 0, weight: -1.0 })
    );
    assert_eq!(Belief::from_particles(&[lam(&[0.0], &[1.0])], &[0.0]), Err(BeliefError::AllZeroWeights));
    assert!(matches!(
        Belief::from_particles(&[lam(&[0.0], &[1.0]), lam(&[0.0, 1.0], &[1.0, 1.0])], &[1.0, 1.0]),
        Err(BeliefError::BadParticle { index: 1, .. })
    ));
}

/// A belief over q* of a 2-joint arm, and a feasible set of four configurations.
fn measured_setup() -> (Belief, FeasibleSet) {
    let mut rng = SeededRng::seed_from_u64(4);
    let particles: Vec<Lambda> = (0..200)
        .map(|_| {
            use rand::RngExt;
            lam(&[rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)], &[1.0, 0.5])
        })
        .collect();
    let b = Belief::from_particles(&particles, &vec![1.0; particles.len()]).unwrap();
    let s = set(&[&[0.0, 0.0], &[0.5, -0.2], &[-0.4, 0.6], &[0.9, 0.9]]);
    (b, s)
}

#[test]
fn a_precise_measurement_updates_as_the_nearest_configuration_does() {
    let (b, s) = measured_setup();
    let mut by_config = b.clone();
    by_config.update(&s, 3.0, &Observation::Config(1)).unwrap();
    for sigma in [1e-3, 1e-5] {
        let mut by_measure = b.clone();
        let obs = Observation::measured(s.configs(), &[0.5 + sigma, -0.2 - sigma], &[sigma, sigma]).unwrap();
        assert_eq!(obs.nearest(), Some(1));
        by_measure.update(&s, 3.0, &obs).unwrap();
        let gap = by_config.weights().iter().zip(by_measure.weights()).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(gap < 1e-9, "σ = {sigma}: largest weight difference {gap}");
    }
}

#[test]
fn a_hopelessly_noisy_measurement_leaves_the_belief_as_it_was() {
    let (b, s) = measured_setup();
    let mut after = b.clone();
    let obs = Observation::measured(s.configs(), &[0.3, 0.1], &[1e4, 1e4]).unwrap();
    after.update(&s, 3.0, &obs).unwrap();
    let gap = b.weights().iter().zip(after.weights()).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(gap < 1e-9, "largest weight difference {gap}");
    // A noise level in between moves it, so the two limits are not the same update.
    let mut between = b.clone();
    between.update(&s, 3.0, &Observation::measured(s.configs(), &[0.3, 0.1], &[0.2, 0.2]).unwrap()).unwrap();
    let moved = b.weights().iter().zip(between.weights()).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(moved > 1e-4, "{moved}");
}

/// The posterior of a 1-D q* (w = 1 known, uniform prior on [−2, 2]) after configurations
/// `seen` of a set on a 0.1 grid, by quadrature: (mean, sd).
fn posterior_by_quadrature(set: &FeasibleSet, seen: &[usize], alpha: f64) -> (f64, f64) {
    let configs: Vec<f64> = set.configs().joint(0).to_vec();
    let n = 40_000;
    let (mut m0, mut m1, mut m2) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let q = -2.0 + 4.0 * (i as f64 + 0.5) / n as f64;
        let log_z = log_sum_exp(&configs.iter().map(|c| -alpha * (c - q).powi(2)).collect::<Vec<_>>());
        let lp: f64 = seen.iter().map(|&k| -alpha * (configs[k] - q).powi(2) - log_z).sum();
        let p = lp.exp();
        m0 += p;
        m1 += p * q;
        m2 += p * q * q;
    }
    let mean = m1 / m0;
    (mean, (m2 / m0 - mean * mean).sqrt())
}

#[test]
fn moves_take_any_equally_weighted_cloud_to_the_posterior_by_quadrature() {
    let rows: Vec<Vec<f64>> = (0..=40).map(|k| vec![-2.0 + 0.1 * k as f64]).collect();
    let rows: Vec<&[f64]> = rows.iter().map(|r| r.as_slice()).collect();
    let set = set(&rows);
    let prior = interval_prior();
    let seen = [24, 27, 25];
    let obs: Vec<Observation> = seen.iter().map(|&k| Observation::Config(k)).collect();
    let history: Vec<Observed> = obs.iter().map(|o| (&set, o)).collect();
    let alpha = 2.0;
    let (mean, sd) = posterior_by_quadrature(&set, &seen, alpha);
    // Start from the prior, far from the posterior (sd 1.15 against about 0.4).
    let n = 4000;
    let start = Belief::from_prior(&prior, n, &mut SeededRng::seed_from_u64(1)).unwrap();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut b = start.clone();
            let report = b.move_particles(&prior, &history, alpha, 40, &[0.01, 0.0], &mut SeededRng::seed_from_u64(2));
            (b, report.unwrap())
        })
    };
    let (b, report) = run(2);
    assert_eq!(run(1).0, b, "the same particles for any number of threads");
    assert!((0.2..0.9).contains(&report.acceptance), "acceptance {}", report.acceptance);
    let q: Vec<f64> = b.particles().chunks_exact(2).map(|p| p[0]).collect();
    assert!(q.iter().all(|x| (-2.0..=2.0).contains(x)), "every move stays in the prior's support");
    assert!(b.particles().chunks_exact(2).all(|p| p[1] == 1.0), "known components do not move");
    let m = q.iter().sum::<f64>() / n as f64;
    let s = (q.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n as f64).sqrt();
    // Monte Carlo error of the mean ≈ sd/√n ≈ 0.006 (more with the chains' correlation).
    assert!((m - mean).abs() < 0.03, "mean {m} against {mean}");
    assert!((s - sd).abs() < 0.05 * sd, "sd {s} against {sd}");
    // Jitter alone does not: the prior cloud keeps the prior's spread.
    let mut jittered = start.clone();
    jittered.resample(&[0.01, 0.0], &mut SeededRng::seed_from_u64(3));
    let spread = |b: &Belief| {
        let q: Vec<f64> = b.particles().chunks_exact(2).map(|p| p[0]).collect();
        let m = q.iter().sum::<f64>() / q.len() as f64;
        (q.iter().map(|x| (x - m).powi(2)).sum::<f64>() / q.len() as f64).sqrt()
    };
    assert!(spread(&jittered) > 2.0 * sd);
}

#[test]
fn zero_moves_change_nothing() {
    let prior = interval_prior();
    let start = Belief::from_prior(&prior, 100, &mut SeededRng::seed_from_u64(1)).unwrap();
    let mut b = start.clone();
    b.move_particles(&prior, &[], 1.0, 0, &[0.1, 0.0], &mut SeededRng::seed_from_u64(2)).unwrap();
    assert_eq!(b, start);
}

/// A region observation's likelihoods, four particles at a time, are each particle's own
/// pass and likelihood, bit for bit (particle counts around the group of four, weights of 0).
#[test]
fn region_likelihoods_four_at_a_time_are_each_particles_own() {
    use rand::RngExt;
    let mut rng = SeededRng::seed_from_u64(21);
    let rows: Vec<Vec<f64>> = (0..45).map(|_| (0..3).map(|_| rng.random_range(-2.0..2.0)).collect()).collect();
    let labels: Vec<usize> = (0..45).map(|j| usize::from(j >= 20)).collect();
    let set = FeasibleSet::with_regions(ConfigSet::from_rows(&rows).unwrap(), &labels).unwrap();
    for n in [1, 3, 4, 5, 70] {
        let lambdas: Vec<Lambda> = (0..n)
            .map(|_| {
                let q: Vec<f64> = (0..3).map(|_| rng.random_range(-1.5..1.5)).collect();
                lam(&q, &[rng.random_range(0.1..2.0), 1.0, rng.random_range(0.1..2.0)])
            })
            .collect();
        let b = Belief::from_particles(&lambdas, &vec![1.0; n]).unwrap();
        for (alpha, region) in [(3.0, 0), (40.0, 1)] {
            let obs = Observation::Region(set.regions()[region].clone().collect());
            let got = b.log_likelihoods(&set, alpha, &obs).unwrap();
            for (i, l) in lambdas.iter().enumerate() {
                let mut scratch = SetPass::scratch(set.len());
                let pass = SetPass::run(set.configs(), &l.q_star, &l.w, alpha, &mut scratch);
                let want = pass.log_likelihood(&obs, alpha, &scratch);
                assert_eq!(got[i].to_bits(), want.to_bits(), "{n} particles, particle {i}, α {alpha}");
            }
        }
    }
}

/// A copy shares the particles and weights (a session is copied on every event) and each
/// change — an update, a resampling, moves — leaves the other copy as it was.
#[test]
fn copies_share_particles_until_one_changes() {
    let prior = interval_prior();
    let start = Belief::from_prior(&prior, 64, &mut SeededRng::seed_from_u64(1)).unwrap();
    let kept = Belief {
        particles: Arc::new(start.particles().to_vec()),
        weights: Arc::new(start.weights().to_vec()),
        ..start.clone()
    };
    let copy = start.clone();
    assert!(std::ptr::eq(copy.particles().as_ptr(), start.particles().as_ptr()));
    assert!(std::ptr::eq(copy.weights().as_ptr(), start.weights().as_ptr()));
    let set = set(&[&[-1.0], &[0.5]]);
    let obs = Observation::Config(1);
    let mut updated = start.clone();
    updated.update(&set, 2.0, &obs).unwrap();
    assert!(std::ptr::eq(updated.particles().as_ptr(), start.particles().as_ptr()), "an update keeps the particles");
    assert_ne!(updated.weights(), start.weights());
    let mut resampled = updated.clone();
    resampled.resample(&[0.1, 0.0], &mut SeededRng::seed_from_u64(2));
    assert_ne!(resampled.particles(), updated.particles());
    let mut moved = start.clone();
    let history = [(&set, &obs)];
    moved.move_particles(&prior, &history, 2.0, 3, &[0.1, 0.0], &mut SeededRng::seed_from_u64(3)).unwrap();
    assert_ne!(moved.particles(), start.particles());
    assert_eq!(start, kept, "the first copy is as it was");
    assert_eq!(copy, kept);
}
