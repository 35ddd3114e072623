//! `handover simulate` as a user runs it.

use std::path::Path;
use std::process::Command;

fn handover(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_handover")).args(args).output().unwrap();
    (out.status.code().unwrap(), String::from_utf8(out.stdout).unwrap(), String::from_utf8(out.stderr).unwrap())
}

fn tmp(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("handover-sim-{}-{name}", std::process::id()))
}

const SMALL: [&str; 10] =
    ["--trials", "4", "--iterations", "3", "--test-size", "30", "--particles", "200", "--seed", "11"];

fn run_small(dir: &Path, threads: &str) {
    let mut args = vec!["simulate", "planar2", "--threads", threads, "--out", dir.to_str().unwrap()];
    args.extend(SMALL);
    let (code, out, err) = handover(&args);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("active") && out.contains("passive"), "{out}");
}

#[test]
fn same_seed_gives_byte_identical_csv_for_any_thread_count() {
    let (a, b) = (tmp("t1"), tmp("t2"));
    run_small(&a, "1");
    run_small(&b, "2");
    for f in ["metrics.csv", "summary.csv"] {
        assert_eq!(std::fs::read(a.join(f)).unwrap(), std::fs::read(b.join(f)).unwrap(), "{f}");
    }
    // Every algorithm × trial × iteration (0..=3), and a plot per measure.
    let mut r = csv::Reader::from_path(a.join("metrics.csv")).unwrap();
    let h = r.headers().unwrap().clone();
    for col in
        ["algorithm", "trial", "iteration", "density_at_truth", "distance_to_truth", "test_log_likelihood", "true_cost"]
    {
        assert!(h.iter().any(|c| c == col), "{col} missing from {h:?}");
    }
    assert_eq!(r.records().count(), 5 * 4 * 4);
    for m in ["density_at_truth", "distance_to_truth", "test_log_likelihood", "true_cost"] {
        assert!(std::fs::read_to_string(a.join(format!("{m}.svg"))).unwrap().contains("<svg"));
    }
    std::fs::remove_dir_all(a).unwrap();
    std::fs::remove_dir_all(b).unwrap();
}

#[test]
fn active_learns_faster_and_passive_is_more_comfortable() {
    let (code, out, err) = handover(&[
        "simulate",
        "planar2",
        "--trials",
        "16",
        "--test-size",
        "100",
        "--particles",
        "500",
        "--algorithms",
        "active,passive",
    ]);
    assert_eq!(code, 0, "{err}");
    // Columns: algorithm, distance it0 (mean ± se), distance last, test LL last, mean true cost, …
    let row = |alg: &str| -> Vec<String> {
        out.lines().find(|l| l.starts_with(alg)).unwrap().split_whitespace().map(String::from).collect()
    };
    let (a, p) = (row("active "), row("passive"));
    let num = |r: &Vec<String>, i: usize| r[i].parse::<f64>().unwrap();
    assert!(num(&a, 4) < num(&p, 4), "active ends closer to the truth:\n{out}");
    assert!(num(&a, 7) > num(&p, 7), "active predicts the test set better:\n{out}");
    assert!(num(&p, 10) < num(&a, 10), "passive costs the person less:\n{out}");
}

#[test]
fn two_sets_alternates() {
    let (code, out, _) = handover(&["simulate", "two-sets", "--particles", "1000"]);
    assert_eq!(code, 0);
    let chosen: Vec<&str> = out.lines().skip(2).map(|l| l.split_whitespace().nth(3).unwrap()).collect();
    assert_eq!(chosen.len(), 8);
    assert!(chosen.windows(2).filter(|w| w[0] != w[1]).count() >= 3, "{chosen:?}");
}

#[test]
fn bad_arguments_exit_2() {
    for args in [
        vec!["simulate", "planar2", "--trials", "0"],
        vec!["simulate", "planar2", "--algorithms", "greedy"],
        vec!["simulate", "planar2", "--alpha", "-1"],
        vec!["simulate", "planar2", "--learn", "elbows"],
        vec!["simulate", "planar2", "--threads", "0"],
        vec!["simulate", "hexapod"],
    ] {
        let (code, _, err) = handover(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
    }
}
