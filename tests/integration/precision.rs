//! The float32 pass (`learning.precision: float32`) against float64 where it is used:
//! the queries chosen over simulated sessions (counted), a float32 dry run's logs verified by
//! replay, and `simulate` whose every choice agreed writing the same metrics.

use std::sync::Arc;

use handover::dryrun::plan_from;
use handover::ergo::FeasibleSet;
use handover::select::{Precision, SelectorKind, Tradeoff, choose_from_values, menu_values};
use handover::session::{Session, choice_set};

use crate::support::{handover, tmpdir};

/// The selectors that decide from the menu's values.
const DECIDING: [SelectorKind; 4] =
    [SelectorKind::Active, SelectorKind::Passive, SelectorKind::Hybrid, SelectorKind::Budgeted];

/// Simulated people (the protocol's population) run through the default protocol's session
/// in float64; before every training handover each learner's belief scores the menu in
/// float64 and in float32, and every selector that decides from those scores chooses from
/// each. Counts the choices that agree (the issue asks for ≥ 99.9 % of them).
#[test]
fn float32_chooses_the_query_float64_chooses_over_simulated_sessions() {
    let study = Arc::new(handover::protocol::Study::default_study());
    let menu: Vec<FeasibleSet> = study.training.iter().map(|q| choice_set(&q.feasible)).collect();
    let (mut agree, mut total, mut worst) = (0usize, 0usize, 0.0f64);
    for seed in 0..30 {
        let p = plan_from(&study, &study.population(), 7700 + seed, 0, None, "2026-12-06T00:00:00Z".into());
        let mut session = Session::new(Arc::clone(&study), p.start.clone()).unwrap();
        let mut scored = std::collections::HashSet::new();
        while let Some(event) = p.participant.respond(&session) {
            for learner in session.learners() {
                // Each belief once (a learner keeps its belief until its next grasp).
                if !scored.insert((learner.condition, learner.iteration)) || learner.iteration >= 5 {
                    continue;
                }
                let ctx = session.context();
                let mut problem = ctx.problem(&learner.belief, &menu);
                let exact = menu_values(&problem);
                problem.precision = Precision::Float32;
                let fast = menu_values(&problem);
                for (a, b) in exact.iter().zip(&fast) {
                    worst = worst.max((a.information_gain - b.information_gain).abs() / a.information_gain.max(1e-3));
                }
                for kind in DECIDING {
                    let t = Tradeoff::default();
                    total += 1;
                    agree += usize::from(choose_from_values(kind, &exact, t) == choose_from_values(kind, &fast, t));
                }
            }
            session.apply(&event).unwrap();
        }
    }
    println!("float32 chose float64's query in {agree} of {total} choices; worst relative error of I {worst:.1e}");
    // 30 people × 2 conditions × 5 beliefs × 4 selectors.
    assert_eq!(total, 1200);
    assert_eq!(agree, total, "{agree} of {total} choices agree");
    assert!(worst < 1e-5, "{worst:e}");
}

/// A float32 protocol's dry run logs its precision and verifies bit for bit (replay recomputes
/// every score in float32), and its analysis equals the float64 run's where every choice
/// agreed: the same queries, the same beliefs (float64 either way).
#[test]
fn a_float32_dry_run_verifies_and_learns_what_float64_learns() {
    let dir = tmpdir("precision");
    let mut v: serde_json::Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 600.into();
    let p64 = dir.join("float64.json");
    std::fs::write(&p64, v.to_string()).unwrap();
    v["learning"]["precision"] = "float32".into();
    let p32 = dir.join("float32.json");
    std::fs::write(&p32, v.to_string()).unwrap();
    let (mut summaries, mut scores) = (vec![], vec![]);
    for (name, protocol) in [("float64", &p64), ("float32", &p32)] {
        let logs = dir.join(name);
        let (code, _, err) = handover(&[
            "dry-run",
            "--protocol",
            protocol.to_str().unwrap(),
            "--logs",
            logs.to_str().unwrap(),
            "--participants",
            "3",
            "--seed",
            "7710",
        ]);
        assert_eq!(code, 0, "{err}");
        let (code, _, err) = handover(&["analyze", "--alpha-particles", "300", logs.to_str().unwrap(), "--verify"]);
        assert_eq!(code, 0, "{name}: {err}");
        let files = handover::record::mcap_files(&logs);
        let first = std::fs::read(&files[0]).unwrap();
        let logged = String::from_utf8_lossy(&first).contains("\"precision\":\"float32\"");
        assert_eq!(logged, name == "float32", "{name}: the protocol in the log names its precision");
        scores.push(logged_scores(&files[0]));
        let (code, out, err) = handover(&["analyze", "--alpha-particles", "300", logs.to_str().unwrap()]);
        assert_eq!(code, 0, "{err}");
        summaries.push(out);
    }
    assert_eq!(summaries[0], summaries[1], "the same choices give the same analysis");
    // The float32 run scored in float32: its logged scores differ from float64's, within the
    // tolerance.
    assert_eq!(scores[0].len(), scores[1].len());
    assert!(scores[0] != scores[1], "the float32 protocol scored in float64");
    for (a, b) in scores[0].iter().zip(&scores[1]) {
        assert!((a - b).abs() <= 1e-5 * a.abs().max(1e-3), "{a} vs {b}");
    }
}

/// Every number in the `/trial/query` messages' scores of a log.
fn logged_scores(path: &std::path::Path) -> Vec<f64> {
    fn numbers(v: &serde_json::Value, out: &mut Vec<f64>) {
        match v {
            serde_json::Value::Number(n) => out.extend(n.as_f64()),
            serde_json::Value::Array(a) => a.iter().for_each(|x| numbers(x, out)),
            serde_json::Value::Object(o) => o.values().for_each(|x| numbers(x, out)),
            _ => {}
        }
    }
    let mut out = vec![];
    for m in handover::record::read_log(path).unwrap().messages.iter().filter(|m| m.topic == "/trial/query") {
        numbers(&m.value["scores"], &mut out);
    }
    assert!(!out.is_empty(), "{}: no scores logged", path.display());
    out
}

/// `simulate --precision float32` writes the metrics float64 writes when every choice agrees
/// (they depend on the queries chosen, never on their scores).
#[test]
fn simulate_in_float32_writes_float64s_metrics() {
    let dir = tmpdir("precision-sim");
    let mut outputs = vec![];
    for precision in ["float64", "float32"] {
        let out = dir.join(precision);
        let (code, _, err) = handover(&[
            "research",
            "simulate",
            "arm7",
            "--trials",
            "3",
            "--seeds",
            "2",
            "--iterations",
            "4",
            "--particles",
            "300",
            "--test-size",
            "40",
            "--algorithms",
            "active,passive,hybrid",
            "--seed",
            "7720",
            "--precision",
            precision,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{err}");
        outputs.push(std::fs::read(out.join("metrics.csv")).unwrap());
    }
    assert!(outputs[0] == outputs[1], "float32 changed a simulated choice");
}
