//! `handover simulate` as a user runs it.

use crate::support::handover;

use std::path::Path;

fn tmp(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("handover-sim-{}-{name}", std::process::id()))
}

/// One seed, where a test reads one seed's rows (the default is 5).
const ONE_SEED: [&str; 2] = ["--seeds", "1"];

const SMALL: [&str; 10] =
    ["--trials", "4", "--iterations", "3", "--test-size", "30", "--particles", "200", "--seed", "11"];

fn run_small(dir: &Path, threads: &str) {
    let mut args = vec!["research", "simulate", "planar2", "--threads", threads, "--out", dir.to_str().unwrap()];
    args.extend(SMALL);
    args.extend(ONE_SEED);
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
fn active_learns_faster_and_passive_is_more_comfortable_over_seeds() {
    let dir = std::env::temp_dir().join(format!("handover-sim-seeds-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (code, out, err) = handover(&[
        "research",
        "simulate",
        "planar2",
        "--trials",
        "12",
        "--test-size",
        "100",
        "--particles",
        "400",
        "--algorithms",
        "active,passive",
        "--seeds",
        "3",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("seeds 0–2") && out.contains("confidence interval over seeds"), "{out}");
    // summary.csv: the mean over 3 seeds × 12 trials, with a 95 % interval over the seeds.
    let mut r = csv::Reader::from_path(dir.join("summary.csv")).unwrap();
    let h = r.headers().unwrap().clone();
    let col = |name: &str| h.iter().position(|c| c == name).unwrap();
    let (alg, it, m, mean, n, seeds, lo, hi) = (
        col("algorithm"),
        col("iteration"),
        col("measure"),
        col("mean"),
        col("n"),
        col("seeds"),
        col("ci_low"),
        col("ci_high"),
    );
    let rows: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
    let get = |a: &str, i: &str, measure: &str| -> (f64, f64, f64) {
        let row = rows.iter().find(|x| &x[alg] == a && &x[it] == i && &x[m] == measure).unwrap();
        assert_eq!((&row[n], &row[seeds]), ("36", "3"));
        (row[mean].parse().unwrap(), row[lo].parse().unwrap(), row[hi].parse().unwrap())
    };
    let (ad, alo, ahi) = get("active", "5", "distance_to_truth");
    assert!(alo < ad && ad < ahi);
    assert!(ad < get("passive", "5", "distance_to_truth").0, "active ends closer to the truth:\n{out}");
    assert!(
        get("active", "5", "test_log_likelihood").0 > get("passive", "5", "test_log_likelihood").0,
        "active predicts the test set better:\n{out}"
    );
    assert!(get("passive", "3", "true_cost").0 < get("active", "3", "true_cost").0, "passive costs less:\n{out}");
    // tests.csv: passive against active, paired over the same trials of every seed.
    let mut t = csv::Reader::from_path(dir.join("tests.csv")).unwrap();
    let th = t.headers().unwrap().clone();
    for c in [
        "measure",
        "first",
        "second",
        "n",
        "mean_difference",
        "ci_low",
        "ci_high",
        "median_difference",
        "share_first_higher",
        "p_value",
        "seeds",
    ] {
        assert!(th.iter().any(|x| x == c), "{c}");
    }
    let tests: Vec<csv::StringRecord> = t.records().map(|x| x.unwrap()).collect();
    assert_eq!(tests.len(), 3, "one per compared measure");
    assert!(tests.iter().all(|x| &x[th.iter().position(|c| c == "n").unwrap()] == "36"));
    let mut metrics = csv::Reader::from_path(dir.join("metrics.csv")).unwrap();
    assert!(metrics.headers().unwrap().iter().any(|c| c == "seed"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The last iteration's distance to the truth of every algorithm × trial, in metrics.csv order.
fn last_distances(dir: &Path) -> Vec<f64> {
    let mut r = csv::Reader::from_path(dir.join("metrics.csv")).unwrap();
    let h = r.headers().unwrap().clone();
    let col = |name: &str| h.iter().position(|c| c == name).unwrap();
    let (it, dist) = (col("iteration"), col("distance_to_truth"));
    r.records().map(|x| x.unwrap()).filter(|x| &x[it] == "3").map(|x| x[dist].parse().unwrap()).collect()
}

#[test]
fn a_precise_measurement_learns_as_the_configuration_does_and_a_noisy_one_less() {
    let run = |name: &str, observation: &[&str]| {
        let dir = tmp(name);
        let mut args =
            vec!["research", "simulate", "planar2", "--algorithms", "active,passive", "--out", dir.to_str().unwrap()];
        args.extend(SMALL);
        args.extend(ONE_SEED);
        args.extend(observation);
        let (code, out, err) = handover(&args);
        assert_eq!(code, 0, "{err}");
        (out, last_distances(&dir))
    };
    let (_, config) = run("obs-config", &[]);
    let (out, precise) = run("obs-precise", &["--observation", "measured", "--sigma-deg", "0.01"]);
    assert!(out.contains("observing the configuration measured with σ = 0.010° per joint"), "{out}");
    let (_, noisy) = run("obs-noisy", &["--observation", "measured", "--sigma-deg", "50"]);
    assert_eq!(config.len(), 8);
    for (a, b) in config.iter().zip(&precise) {
        assert!((a - b).abs() < 1e-6, "{config:?} vs {precise:?}");
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    assert!(mean(&noisy) > mean(&config), "σ = 50°: {noisy:?} vs the configuration: {config:?}");
}

#[test]
fn arm7_learns_from_the_grip_taken() {
    let dir = tmp("obs-region");
    let (code, out, err) = handover(
        &[
            &["research", "simulate", "arm7", "--observation", "region", "--algorithms", "active,passive"][..],
            &["--out", dir.to_str().unwrap(), "--menu", "4"][..],
            &SMALL[..],
            &ONE_SEED[..],
        ]
        .concat(),
    );
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("observing the region (grip) taken"), "{out}");
    assert_eq!(last_distances(&dir).len(), 8, "2 algorithms × 4 trials");
}

#[test]
fn planar2_learns_from_the_piece_taken() {
    let run = |observation: &str| {
        let dir = tmp(&format!("obs-planar2-{observation}"));
        let mut args =
            vec!["research", "simulate", "planar2", "--algorithms", "active,passive", "--out", dir.to_str().unwrap()];
        args.extend(&SMALL[2..]);
        args.extend(["--trials", "16", "--observation", observation]);
        args.extend(ONE_SEED);
        let (code, out, err) = handover(&args);
        assert_eq!(code, 0, "{err}");
        (out, last_distances(&dir))
    };
    let (out, region) = run("region");
    assert!(out.contains("observing the region (connected piece) taken"), "{out}");
    let (_, config) = run("configuration");
    assert_eq!(region.len(), 32, "2 algorithms × 16 trials");
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    // The piece says less than the configuration: on average the learner ends farther away.
    assert!(mean(&region) > mean(&config), "piece {region:?} vs configuration {config:?}");
}

#[test]
fn two_sets_alternates() {
    let (code, out, _) = handover(&["research", "simulate", "two-sets", "--particles", "1000"]);
    assert_eq!(code, 0);
    let chosen: Vec<&str> = out.lines().skip(2).map(|l| l.split_whitespace().nth(3).unwrap()).collect();
    assert_eq!(chosen.len(), 8);
    assert!(chosen.windows(2).filter(|w| w[0] != w[1]).count() >= 3, "{chosen:?}");
}

#[test]
fn bad_arguments_exit_2() {
    for args in [
        vec!["research", "simulate", "planar2", "--trials", "0"],
        vec!["research", "simulate", "planar2", "--algorithms", "greedy"],
        vec!["research", "simulate", "planar2", "--alpha", "-1"],
        vec!["research", "simulate", "planar2", "--learn", "elbows"],
        vec!["research", "simulate", "planar2", "--threads", "0"],
        vec!["research", "simulate", "planar2", "--seeds", "0"],
        vec!["research", "simulate", "planar2", "--estimate", "median"],
        vec!["research", "simulate", "hexapod"],
        vec!["research", "simulate", "planar2", "--observation", "measured"],
        vec!["research", "simulate", "planar2", "--sigma-deg", "5"],
        vec!["research", "simulate", "planar2", "--observation", "measured", "--sigma-deg", "0"],
        vec!["research", "simulate", "planar2", "--observation", "measured", "--sigma-deg", "90"],
        vec!["research", "simulate", "two-sets", "--observation", "measured", "--sigma-deg", "5"],
        vec!["research", "simulate", "arm7", "--observation", "region", "--sigma-deg", "5"],
    ] {
        let (code, _, err) = handover(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
    }
}

#[test]
fn the_front_anchors_passive_and_active_and_writes_csv_and_svg() {
    let dir = tmp("front");
    let (code, out, err) = handover(&[
        "research",
        "front",
        "--scenarios",
        "planar2",
        "--learn",
        "q-star",
        "--seeds",
        "2",
        "--trials",
        "12",
        "--particles",
        "300",
        "--test-size",
        "5",
        "--betas",
        "0.1,1000",
        "--epsilons",
        "0,1000",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("planar2, learning q-star"), "{out}");
    assert!(dir.join("front.svg").exists());
    let mut r = csv::Reader::from_path(dir.join("front.csv")).unwrap();
    let h = r.headers().unwrap().clone();
    let col = |name: &str| h.iter().position(|x| x == name).unwrap();
    let rows: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
    assert_eq!(rows.len(), 6, "active, passive, 2 β and 2 ε");
    let get = |sel: &str, param: &str, c: &str| -> String {
        rows.iter().find(|r| &r[col("selector")] == sel && &r[col("parameter")] == param).unwrap()[col(c)].to_string()
    };
    let num = |sel: &str, param: &str, c: &str| get(sel, param, c).parse::<f64>().unwrap();
    assert_eq!(num("passive", "", "cost_ratio"), 1.0);
    assert_eq!(num("passive", "", "gain"), 0.0);
    assert_eq!(num("active", "", "gain"), 1.0);
    // ε = 0 allows nothing above passive's cost: passive's choices; ε huge is active's.
    assert_eq!(get("budgeted", "0.0", "distance"), get("passive", "", "distance"));
    assert_eq!(get("budgeted", "1000.0", "distance"), get("active", "", "distance"));
    // β huge weighs only cost: passive's choices.
    assert_eq!(get("hybrid", "1000.0", "distance"), get("passive", "", "distance"));
    // Fieller's intervals: present ones hold their ratio; a ratio of passive's cost to
    // itself is exactly 1 when bounded (two seeds rarely bound it); an unbounded interval is left empty, both ends together.
    for r in &rows {
        for (point, low, high) in
            [("gain", "gain_ci_low", "gain_ci_high"), ("cost_ratio", "cost_ratio_ci_low", "cost_ratio_ci_high")]
        {
            assert_eq!(r[col(low)].is_empty(), r[col(high)].is_empty(), "{r:?}");
            if !r[col(low)].is_empty() {
                let v = |c: &str| r[col(c)].parse::<f64>().unwrap();
                assert!(v(low) <= v(point) + 1e-12 && v(point) <= v(high) + 1e-12, "{point}: {r:?}");
            }
        }
    }
    for end in ["cost_ratio_ci_low", "cost_ratio_ci_high"] {
        let v = get("passive", "", end);
        assert!(v.is_empty() || (v.parse::<f64>().unwrap() - 1.0).abs() < 1e-12, "{end}: {v}");
    }
    let (code, _, err) = handover(&["research", "front", "--seeds", "1"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("'--seeds <N>'") && err.contains("2..=1000"), "{err}");
}

#[test]
fn shards_merged_are_byte_for_byte_the_whole_run() {
    let dir = tmp("shards");
    let _ = std::fs::remove_dir_all(&dir);
    let run = |extra: &[&str]| {
        let mut args = vec!["research", "simulate", "planar2", "--seeds", "2", "--algorithms", "active,passive,random"];
        args.extend(SMALL);
        args.extend(extra);
        handover(&args)
    };
    let s = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let (code, _, err) = run(&["--out", &s("whole")]);
    assert_eq!(code, 0, "{err}");
    for k in 0..3 {
        let (code, _, err) = run(&["--shard", &format!("{k}/3"), "--out", &s(&format!("shard{k}"))]);
        assert_eq!(code, 0, "{err}");
        assert!(dir.join(format!("shard{k}/shard.json")).exists());
    }
    // In any order of the directories.
    let (code, _, err) = run(&["--merge", &s("shard2"), &s("shard0"), &s("shard1"), "--out", &s("merged")]);
    assert_eq!(code, 0, "{err}");
    for file in ["metrics.csv", "summary.csv", "tests.csv"] {
        let (a, b) = (
            std::fs::read(dir.join("whole").join(file)).unwrap(),
            std::fs::read(dir.join("merged").join(file)).unwrap(),
        );
        assert!(a == b, "{file} differs");
    }
    // The merged table says what the run cost, not what the merge did.
    let (code, out, err) = run(&["--merge", &s("shard0"), &s("shard1"), &s("shard2")]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("s of computing in 3 shards, merged in"), "{out}");
    // A shard edited, of another version, or that never finished is refused, naming it.
    let edited = dir.join("edited");
    let version = dir.join("version");
    let unfinished = dir.join("unfinished");
    for d in [&edited, &version, &unfinished] {
        std::fs::create_dir_all(d).unwrap();
        std::fs::copy(dir.join("shard0/metrics.csv"), d.join("metrics.csv")).unwrap();
    }
    let manifest = std::fs::read_to_string(dir.join("shard0/shard.json")).unwrap();
    std::fs::write(edited.join("shard.json"), &manifest).unwrap();
    let metrics = std::fs::read_to_string(edited.join("metrics.csv")).unwrap();
    let last = metrics.trim_end().rfind(',').unwrap();
    std::fs::write(edited.join("metrics.csv"), format!("{}9{}", &metrics[..=last], &metrics[last + 1..])).unwrap();
    let this = env!("CARGO_PKG_VERSION");
    std::fs::write(version.join("shard.json"), manifest.replace(&format!("\"{this}\""), "\"0.0.1\"")).unwrap();
    for (shard, says) in [
        (&edited, "metrics.csv is not the file the shard wrote"),
        (&version, &*format!("computed by handover 0.0.1, this is {this}")),
        (&unfinished, "no shard.json: the shard did not finish"),
    ] {
        let (code, _, err) = run(&["--merge", shard.to_str().unwrap(), &s("shard1"), &s("shard2")]);
        assert_eq!(code, 2, "{err}");
        assert!(err.contains(says) && err.contains(shard.to_str().unwrap()), "{says}: {err}");
    }
    // A shard missing, given twice, or of another run is refused (exit 2).
    for (args, says) in [
        (vec!["--merge", &s("shard0"), &s("shard1")], "shards 2 of 3 are missing"),
        (vec!["--merge", &s("shard0"), &s("shard1"), &s("shard1"), &s("shard2")], "is given twice"),
        (vec!["--beta", "0.5", "--merge", &s("shard0"), &s("shard1"), &s("shard2")], "a shard of another run"),
        (vec!["--shard", "3/3", "--out", &s("x")], "expected K/N"),
        (vec!["--shard", "0/2"], "--shard needs --out"),
    ] {
        let (code, _, err) = run(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
    // A hostile shard: a manifest that would size a huge table, numbers that are not finite
    // or would overflow a sum. Each is refused naming the file and field, nothing allocated.
    let hostile = |name: &str, file: &str, edit: &dyn Fn(String) -> String| {
        let copy = dir.join(name);
        let _ = std::fs::remove_dir_all(&copy);
        std::fs::create_dir_all(&copy).unwrap();
        for f in ["metrics.csv", "shard.json"] {
            std::fs::copy(dir.join("shard0").join(f), copy.join(f)).unwrap();
        }
        let text = std::fs::read_to_string(copy.join(file)).unwrap();
        std::fs::write(copy.join(file), edit(text)).unwrap();
        // A hostile shard says its edited file's hash, so that the rows are read.
        crate::shards::rehash(&copy, file);
        s(name)
    };
    let of = |n: &'static str| move |t: String| t.replace("\"of\": 3", &format!("\"of\": {n}"));
    let column = |v: &'static str| {
        move |t: String| {
            let mut lines: Vec<String> = t.lines().map(String::from).collect();
            let mut cells: Vec<String> = lines[1].split(',').map(String::from).collect();
            let at = lines[0].split(',').position(|h| h == "distance_to_truth").unwrap();
            cells[at] = v.to_string();
            lines[1] = cells.join(",");
            lines.join("\n") + "\n"
        }
    };
    let cases: Vec<(String, &str)> = vec![
        (hostile("of-1e18", "shard.json", &of("1000000000000000000")), "\"of\" is 1000000000000000000"),
        (hostile("of-1e9", "shard.json", &of("1000000000")), "expected 1 to 100000 shards"),
        (hostile("nan", "metrics.csv", &column("NaN")), "distance_to_truth is NaN"),
        (hostile("inf", "metrics.csv", &column("inf")), "distance_to_truth is inf"),
        (hostile("huge", "metrics.csv", &column("1e308")), "distance_to_truth is 1e308"),
    ];
    for (shard, says) in &cases {
        let (code, _, err) = run(&["--merge", shard, &s("shard1"), &s("shard2"), "--out", &s("hostile-out")]);
        assert_eq!(code, 2, "{shard}: {err}");
        assert!(err.contains(says) && !err.contains("panicked"), "{shard}: {err}");
        assert!(!dir.join("hostile-out").join("summary.csv").exists(), "{shard}: nothing merged");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_array_job_example_runs_its_shards_and_merges_them_without_a_cluster() {
    let dir = tmp("array-job");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/examples/array-job.sbatch");
    // A settings file as docs/examples/array-job.env has it, with a comma inside an option.
    let settings = dir.join("run.env");
    let args = format!("planar2 --seeds 2 --algorithms active,passive {}", SMALL.join(" "));
    std::fs::write(
        &settings,
        format!(
            "HANDOVER={}\nCOMMAND=simulate\nARGS=({args})\nOUT={}\nSHARDS=3\n",
            env!("CARGO_BIN_EXE_handover"),
            dir.join("run").display()
        ),
    )
    .unwrap();
    let task = |index: Option<usize>, extra: &[&str]| {
        let mut cmd = std::process::Command::new("bash");
        cmd.arg(&script).arg(&settings).args(extra).env_remove("SLURM_ARRAY_TASK_ID");
        if let Some(k) = index {
            cmd.env("SLURM_ARRAY_TASK_ID", k.to_string());
        }
        let out = cmd.output().unwrap();
        (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    // Shard 1 is not run: the merge says which is missing, from the shards' own manifests.
    for k in [0, 2] {
        let (code, err) = task(Some(k), &[]);
        assert_eq!(code, Some(0), "{err}");
    }
    let (code, err) = task(None, &["merge"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("shards 1 of 3 are missing"), "{err}");
    // Run again by its index, then merged.
    let (code, err) = task(Some(1), &[]);
    assert_eq!(code, Some(0), "{err}");
    let (code, err) = task(None, &["merge"]);
    assert_eq!(code, Some(0), "{err}");
    let (code, err) = task(Some(3), &[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("array index 3 is not below SHARDS=3"), "{err}");
    let (code, _, err) = handover(
        &[
            &["research", "simulate", "planar2", "--seeds", "2", "--algorithms", "active,passive"][..],
            &SMALL[..],
            &["--out", dir.join("whole").to_str().unwrap()],
        ]
        .concat(),
    );
    assert_eq!(code, 0, "{err}");
    for file in ["metrics.csv", "summary.csv", "tests.csv"] {
        let whole = std::fs::read(dir.join("whole").join(file)).unwrap();
        assert!(std::fs::read(dir.join("run").join(file)).unwrap() == whole, "{file}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_run_without_a_terminal_prints_progress_lines() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_handover"))
        .args([
            "research",
            "simulate",
            "planar2",
            "--seeds",
            "2",
            "--trials",
            "6",
            "--iterations",
            "5",
            "--particles",
            "2000",
        ])
        .env("HANDOVER_PROGRESS_S", "0.2")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("simulate planar2 q-star: ")).collect();
    assert!(!lines.is_empty(), "{err}");
    assert!(lines[0].contains("/12 (") && lines[0].contains("elapsed"), "{err}");
}

/// A selector named twice runs once, wherever the repetition is.
#[test]
fn an_algorithm_named_twice_runs_once() {
    let (code, out, err) = handover(&[
        "research",
        "simulate",
        "planar2",
        "--seeds",
        "1",
        "--trials",
        "2",
        "--iterations",
        "2",
        "--algorithms",
        "active,passive,active",
    ]);
    assert_eq!(code, 0, "{err}");
    let rows = out.lines().filter(|l| l.starts_with("active ")).count();
    assert_eq!(rows, 1, "{out}");
    assert_eq!(out.lines().filter(|l| l.starts_with("passive ")).count(), 1, "{out}");
}

/// Five algorithms on one axis are five overlapping bands: each is drawn beside active in a
/// panel of its own, and a band that would reach below a distance's least value (0) is cut
/// there, which the legend says.
#[test]
fn plots_show_each_algorithm_beside_active_within_the_measures_range() {
    let dir = tmp("plots");
    let _ = std::fs::remove_dir_all(&dir);
    let mut args = vec!["research", "simulate", "planar2", "--seeds", "2", "--out", dir.to_str().unwrap()];
    args.extend(SMALL);
    let (code, _, err) = handover(&args);
    assert_eq!(code, 0, "{err}");
    let svg = std::fs::read_to_string(dir.join("distance_to_truth.svg")).unwrap();
    for panel in ["active-paper and active", "passive and active", "random and active", "hybrid and active"] {
        assert!(svg.contains(panel), "{panel}");
    }
    let cut = svg.contains("cut at 0, the least value");
    // Whether a band was cut depends on the data; the test log-likelihood has no least value.
    let loglik = std::fs::read_to_string(dir.join("test_log_likelihood.svg")).unwrap();
    assert!(!loglik.contains("cut at"), "log-likelihoods are not cut");
    let csv = std::fs::read_to_string(dir.join("summary.csv")).unwrap();
    let below_zero = csv
        .lines()
        .filter(|l| l.contains(",distance_to_truth,"))
        .any(|l| l.split(',').any(|c| c.parse::<f64>().is_ok_and(|v| v < 0.0)));
    assert_eq!(cut, below_zero, "the legend says a band was cut exactly when an interval reaches below 0");
    let _ = std::fs::remove_dir_all(&dir);
}
