//! `handover score` as a user runs it: JSON in, JSON out, exit 2 on bad input.

use std::io::Write;
use std::process::{Command, Stdio};

fn score(input: &str) -> (i32, String, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_handover"))
        .args(["research", "score", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(input.as_bytes()).unwrap();
    let out = child.wait_with_output().unwrap();
    (out.status.code().unwrap(), String::from_utf8(out.stdout).unwrap(), String::from_utf8(out.stderr).unwrap())
}

const GOOD: &str = r#"{"alpha": 1.0,
  "particles": [{"q_star": [0.0], "w": [1.0]}, {"q_star": [1.0], "w": [1.0], "weight": 1}],
  "menu": [{"id": "far", "configs": [[-1.0], [2.0]]}, {"id": "split", "configs": [[0.0], [1.0]]}, {"id": "one", "configs": [[0.5]]}],
  "grid_cell": [0.5, 1.0],
  "observation": {"query": "split", "config": 0}}"#;

#[test]
fn scores_a_menu_and_reports_the_posterior() {
    let (code, out, err) = score(GOOD);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let a = 1.0 / (1.0 + (-1.0f64).exp());
    let hb = -(a * a.ln() + (1.0 - a) * (1.0 - a).ln());
    let ig = v["queries"][1]["information_gain"].as_f64().unwrap();
    assert!((ig - (2.0f64.ln() - hb)).abs() < 1e-12, "{ig}");
    assert_eq!(v["queries"][2]["information_gain"].as_f64().unwrap(), 0.0);
    assert_eq!(v["active"], "far", "its optima separate the particles more sharply");
    assert_eq!(v["passive"], "split");
    assert!(v["active_paper"].is_string());
    assert!((v["queries"][2]["expected_cost"].as_f64().unwrap() - 0.25).abs() < 1e-15);
    let post: Vec<f64> = serde_json::from_value(v["posterior"].clone()).unwrap();
    assert!((post[0] - a).abs() < 1e-12 && (post[1] - (1.0 - a)).abs() < 1e-12);
}

#[test]
fn a_measured_arm_updates_as_its_nearest_configuration_when_precise_and_not_at_all_when_noisy() {
    let post = |observation: serde_json::Value| -> Vec<f64> {
        let (code, out, err) = score(&with(|v| v["observation"] = observation.clone()));
        assert_eq!(code, 0, "{err}");
        serde_json::from_value(serde_json::from_str::<serde_json::Value>(&out).unwrap()["posterior"].clone()).unwrap()
    };
    let by_config = post(serde_json::json!({"query": "split", "config": 0}));
    let precise = post(serde_json::json!({"query": "split", "measured": [0.0001], "sigma": [0.0001]}));
    let noisy = post(serde_json::json!({"query": "split", "measured": [0.0001], "sigma": [100000.0]}));
    for k in 0..2 {
        assert!((precise[k] - by_config[k]).abs() < 1e-9, "{precise:?} vs {by_config:?}");
        assert!((noisy[k] - 0.5).abs() < 1e-9, "the prior is uniform: {noisy:?}");
    }
}

#[test]
fn optional_parts_are_left_out_when_not_asked_for() {
    let input = r#"{"alpha": 1, "particles": [{"q_star": [0], "w": [1]}], "menu": [{"id": "a", "configs": [[0]]}]}"#;
    let (code, out, _) = score(input);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!(v.get("posterior").is_none() && v.get("active_paper").is_none());
    assert!(v["queries"][0].get("information_gain_paper").is_none());
}

fn with(field_edit: impl Fn(&mut serde_json::Value)) -> String {
    let mut v: serde_json::Value = serde_json::from_str(GOOD).unwrap();
    field_edit(&mut v);
    v.to_string()
}

#[test]
fn bad_input_exits_2_naming_the_field() {
    use serde_json::json;
    let cases: Vec<(String, &str)> = vec![
        ("not json".to_string(), "expected"),
        (with(|v| v["alpha"] = json!(0)), "alpha"),
        (with(|v| v["alpha"] = json!(-2.5)), "alpha"),
        (with(|v| v["alpha"] = json!("big")), "invalid type"),
        (with(|v| v["particles"] = json!([])), "particles"),
        (with(|v| v["menu"] = json!([])), "menu"),
        (with(|v| v["menu"][0]["configs"] = json!([])), "menu[0].configs"),
        (with(|v| v["menu"][1]["configs"][0] = json!([0.0, 1.0])), "menu[1].configs[0]"),
        (with(|v| v["particles"][1]["w"] = json!([1.0, 2.0])), "particles[1].w"),
        (with(|v| v["particles"][0]["weight"] = json!(-1)), "particles[0].weight"),
        (
            with(|v| {
                v["particles"][0]["weight"] = json!(0);
                v["particles"][1]["weight"] = json!(0);
            }),
            "every weight is zero",
        ),
        (with(|v| v["observation"]["query"] = json!("nowhere")), "observation.query"),
        (with(|v| v["observation"]["config"] = json!(7)), "out of range"),
        (
            with(|v| {
                v["observation"] = json!({"query": "split", "region": [0, 9]});
            }),
            "out of range",
        ),
        (
            with(|v| {
                v["observation"] = json!({"query": "split"});
            }),
            "exactly one",
        ),
        (
            with(|v| v["observation"] = json!({"query": "split", "measured": [0.1], "sigma": [0.0]})),
            "observation.measured",
        ),
        (
            with(|v| v["observation"] = json!({"query": "split", "measured": [0.1, 0.2], "sigma": [0.1]})),
            "observation.measured",
        ),
        (with(|v| v["observation"] = json!({"query": "split", "measured": [0.1]})), "exactly one"),
        (with(|v| v["grid_cell"] = json!([1.0])), "grid_cell"),
        (with(|v| v["grid_cell"] = json!([1.0, 0.0])), "grid_cell[1]"),
        (with(|v| v["menu"][1]["id"] = json!("far")), "duplicate"),
        (with(|v| v["extra"] = json!(1)), "unknown field"),
        (GOOD.replace("[0.5]]}]", "[1e999]]}]"), "out of range"),
    ];
    for (input, needle) in cases {
        let (code, out, err) = score(&input);
        assert_eq!(code, 2, "input {input}: stdout {out} stderr {err}");
        assert!(err.contains(needle), "expected '{needle}' in: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}
