//! The engine at the default study size: exact active selection and one console step.
//!
//! cargo bench --bench engine

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use handover::SeededRng;
use handover::belief::{Belief, ComponentPrior, Prior};
use handover::ergo::{ConfigSet, FeasibleSet, Observation, SetPass};
use handover::select::{Active, OutcomeModel, Precision, Problem, Selector};
use rand::{RngExt, SeedableRng};

const D: usize = 7;

fn belief(n: usize, rng: &mut SeededRng) -> Belief {
    let u = |min, max| ComponentPrior::Uniform { min, max };
    let prior = Prior::new(vec![u(-1.5, 1.5); D], vec![u(0.05, 1.0); D]).unwrap();
    Belief::from_prior(&prior, n, rng).unwrap()
}

fn menu(queries: usize, configs: usize, rng: &mut SeededRng) -> Vec<FeasibleSet> {
    (0..queries)
        .map(|_| {
            let rows: Vec<Vec<f64>> =
                (0..configs).map(|_| (0..D).map(|_| rng.random_range(-2.0..2.0)).collect()).collect();
            FeasibleSet::new(ConfigSet::from_rows(&rows).unwrap())
        })
        .collect()
}

/// One particle's pass over one feasible set (costs, weights, sums): the kernel every
/// likelihood and selector runs, per particle–configuration pair.
fn set_pass(c: &mut Criterion) {
    let mut g = c.benchmark_group("set_pass");
    let mut rng = SeededRng::seed_from_u64(4);
    let b = belief(256, &mut rng);
    for m in [300, 2000] {
        let set = &menu(1, m, &mut rng)[0];
        let mut scratch = SetPass::scratch(m);
        g.throughput(Throughput::Elements((256 * m) as u64));
        g.bench_function(format!("256_particles_x_{m}_configs"), |bench| {
            bench.iter(|| {
                let mut total = 0.0;
                for p in b.particles().chunks_exact(2 * D) {
                    total += SetPass::run(set.configs(), &p[..D], &p[D..], 10.0, &mut scratch).sum;
                }
                total
            })
        });
    }
    g.finish();
}

fn select_active(c: &mut Criterion) {
    let mut g = c.benchmark_group("select_active");
    g.sample_size(10);
    for (n, m) in [(2000, 1000), (5000, 2000)] {
        let mut rng = SeededRng::seed_from_u64(1);
        let b = belief(n, &mut rng);
        let menu = menu(8, m, &mut rng);
        g.throughput(Throughput::Elements((n * 8 * m) as u64));
        // Float64 and float32 side by side, in one run.
        for precision in [Precision::Float64, Precision::Float32] {
            let problem =
                Problem { belief: &b, menu: &menu, alpha: 10.0, outcomes: OutcomeModel::Configuration, precision };
            for threads in [1, 2] {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let id = BenchmarkId::new(format!("{n}x8x{m}/{}", precision.name()), format!("{threads}-threads"));
                g.bench_function(id, |bench| bench.iter(|| pool.install(|| Active.select(&problem, &mut rng).index)));
            }
        }
    }
    g.finish();
}

fn console_step(c: &mut Criterion) {
    let mut g = c.benchmark_group("console_step_study_size");
    g.sample_size(10);
    let mut rng = SeededRng::seed_from_u64(2);
    let b = belief(2000, &mut rng);
    let menu = menu(8, 1000, &mut rng);
    let jitter = vec![0.03; 2 * D];
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        g.bench_function(format!("update_resample_select/{threads}-threads"), |bench| {
            bench.iter(|| {
                pool.install(|| {
                    let mut b = b.clone();
                    let mut rng = SeededRng::seed_from_u64(3);
                    b.update(&menu[0], 10.0, &Observation::Config(17)).unwrap();
                    b.resample(&jitter, &mut rng);
                    let problem = Problem {
                        belief: &b,
                        menu: &menu,
                        alpha: 10.0,
                        outcomes: OutcomeModel::Configuration,
                        precision: Default::default(),
                    };
                    Active.select(&problem, &mut rng).index
                })
            })
        });
    }
    g.finish();
}

/// One training trial of the default protocol's session (2000 particles, 8 queries of
/// 300–450 configurations, region outcomes): the grasp's update, resampling and the next
/// suggestion — what the console waits for after the operator presses a grip's key. Run with
/// the default region observations and, side by side, the paper's configuration
/// observations; and at 20 000 particles learning q* and w together (14-D). Beside them, what
/// the console's worker does while the participant reaches (learning ahead for every grip
/// offered) and what the key then costs (adopting the learner for the grip taken).
fn session_step_default_protocol(c: &mut Criterion) {
    use handover::protocol::{DEFAULT_PROTOCOL, Study};
    use handover::session::{Event, Prompt, Session, SessionStart, condition_order};
    let mut g = c.benchmark_group("session_step_default_protocol");
    g.sample_size(10);
    for (observation, particles, learn, precision) in [
        ("region", 2000, "q-star", "float64"),
        ("region", 2000, "q-star", "float32"),
        ("configuration", 2000, "q-star", "float64"),
        ("region", 20_000, "both", "float64"),
        ("region", 20_000, "both", "float32"),
    ] {
        let mut v: serde_json::Value = serde_json::from_str(DEFAULT_PROTOCOL).unwrap();
        v["learning"]["observation"] = observation.into();
        v["learning"]["particles"] = particles.into();
        v["learning"]["learn"] = learn.into();
        v["learning"]["precision"] = precision.into();
        let observation = format!("{observation}_{precision}");
        let study = std::sync::Arc::new(Study::from_json(&v.to_string(), "bench").unwrap());
        let start = SessionStart {
            session_id: "bench".into(),
            participant: "bench".into(),
            protocol_name: study.protocol.name.clone(),
            protocol_sha256: study.sha256.clone(),
            seed: 1,
            condition_order: condition_order(&study, 0),
            program_labels: study.protocol.session.program_labels.clone(),
            software_version: "bench".into(),
            pilot: true,
            slot: 0,
            started_at: String::new(),
            simulated_truth: None,
            resumed_from: None,
            selection: None,
        };
        let mut session = Session::new(study, start).unwrap();
        // The session at its k-th grasp (1-based): present the suggested query, and the grip to take.
        let present = |session: &mut Session| -> String {
            let Prompt::Present(view) = session.prompt() else { unreachable!() };
            let id = session.query(view.query).query.id.clone();
            session.apply(&Event::QueryPresented { query: id }).unwrap();
            let q = session.query(view.query);
            session.study().object(q).regions[q.regions[0]].id.clone()
        };
        // The first grasp, and the fifth (the MAP estimate recomputes every observation so far).
        for k in 1..=5 {
            let region = present(&mut session);
            if k == 1 || k == 5 {
                for threads in [1, 2] {
                    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                    let name = format!(
                        "{observation}_{particles}_{learn}/grasp_{k}_update_and_next_suggestion/{threads}-threads"
                    );
                    g.bench_function(name, |b| {
                        b.iter(|| {
                            pool.install(|| {
                                let mut s = session.clone();
                                s.apply(&Event::GraspRecorded { region: region.clone(), measured: None }).unwrap();
                                s.learners()[0].suggestion
                            })
                        })
                    });
                }
                // The same key when the console's worker learned ahead while the participant
                // reached (two threads): the response adopts the learner computed for the grip.
                let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
                let mut ahead = session.clone();
                g.bench_function(
                    format!("{observation}_{particles}_{learn}/grasp_{k}_learning_ahead/2-threads"),
                    |b| b.iter(|| pool.install(|| ahead.clone().speculate(&mut || false))),
                );
                assert!(pool.install(|| ahead.speculate(&mut || false)));
                g.bench_function(
                    format!(
                        "{observation}_{particles}_{learn}/grasp_{k}_learned_ahead_key_to_next_suggestion/2-threads"
                    ),
                    |b| {
                        b.iter(|| {
                            let mut s = ahead.clone();
                            s.apply(&Event::GraspRecorded { region: region.clone(), measured: None }).unwrap();
                            assert_eq!(s.adopted_ahead(), 1);
                            s.learners()[0].suggestion
                        })
                    },
                );
            }
            session.apply(&Event::GraspRecorded { region, measured: None }).unwrap();
        }
    }
    g.finish();
}

/// One simulated study of `plan` (10 sessions of the default protocol, driven and analysed
/// as `plan` does), in float64 and float32 side by side; the protocol fitted to each body
/// comes from the plan's cache, as it does for nearly every session of a default plan.
fn plan_study(c: &mut Criterion) {
    use handover::plan::{FittedBodies, simulate_study};
    use handover::protocol::{DEFAULT_PROTOCOL, Study};
    let mut g = c.benchmark_group("plan_study_default_protocol");
    g.sample_size(10);
    for precision in ["float64", "float32"] {
        let mut v: serde_json::Value = serde_json::from_str(DEFAULT_PROTOCOL).unwrap();
        v["learning"]["precision"] = precision.into();
        let text = v.to_string();
        let study = Study::from_json(&text, "bench").unwrap();
        let bodies = FittedBodies::default();
        simulate_study(&text, &study, 1, 0, 10, false, &bodies).unwrap();
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        g.bench_function(format!("10_sessions/{precision}/2-threads"), |b| {
            b.iter(|| pool.install(|| simulate_study(&text, &study, 1, 0, 10, false, &bodies).unwrap().len()))
        });
    }
    g.finish();
}

criterion_group!(benches, set_pass, select_active, console_step, session_step_default_protocol, plan_study);
criterion_main!(benches);
