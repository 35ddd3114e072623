//! `handover plan` as a user runs it: power where there is no effect and where every
//! participant shares one, a planned study reproduced by `analyze`, shards merged, bad input.

use crate::support::handover;

use std::path::{Path, PathBuf};

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("handover-plan-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The default protocol with 300 particles (the tests' speed), changed by `edit`.
fn protocol(dir: &Path, name: &str, edit: impl FnOnce(&mut serde_json::Value)) -> String {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/protocols/bike-handover.json")).unwrap();
    let mut p: serde_json::Value = serde_json::from_str(&text).unwrap();
    p["learning"]["particles"] = 300.into();
    edit(&mut p);
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_string_pretty(&p).unwrap()).unwrap();
    path.to_str().unwrap().to_string()
}

/// Everyone is the label model's person (no individual differences).
fn label_model_population(p: &mut serde_json::Value) {
    let q: Vec<serde_json::Value> = p["learning"]["label_model"]["q_star_deg"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| serde_json::json!({ "mean": m, "sd": 0.0 }))
        .collect();
    p["population"] =
        serde_json::json!({ "q_star_deg": q, "w": vec![serde_json::json!({ "mean": 1.0, "sd": 0.0 }); 7] });
}

#[derive(Debug, serde::Deserialize)]
struct Power {
    participants: usize,
    measure: String,
    iteration: usize,
    studies: usize,
    power: f64,
    power_low: f64,
    power_high: f64,
}

fn powers(dir: &Path) -> Vec<Power> {
    csv::Reader::from_path(dir.join("power.csv")).unwrap().deserialize().map(|r| r.unwrap()).collect()
}

fn at<'a>(rows: &'a [Power], n: usize, measure: &str, iteration: usize) -> &'a Power {
    rows.iter().find(|r| r.participants == n && r.measure == measure && r.iteration == iteration).unwrap()
}

/// With no individual differences and α = 5 the two conditions end up predicting the test
/// handles alike: the power of the test log-likelihood's comparison at the last iteration is
/// at the significance level (its interval holds 5 %), and 2 participants can never reach it.
#[test]
fn without_an_effect_the_power_is_the_significance_level() {
    let dir = tmp("null");
    let p = protocol(&dir, "null.json", label_model_population);
    let out = dir.join("out");
    let (code, stdout, err) = handover(&[
        "plan",
        "--protocol",
        &p,
        "--sizes",
        "2,8",
        "--studies",
        "40",
        "--seed",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(stdout.contains("the protocol's population"), "{stdout}");
    let rows = powers(&out);
    let last = at(&rows, 8, "test_log_likelihood", 5);
    assert_eq!(last.studies, 40);
    assert!(last.power <= 0.15 && last.power_low <= 0.05 && last.power_high >= 0.05, "{last:?}");
    assert_eq!(at(&rows, 2, "test_log_likelihood", 5).power, 0.0);
    for f in ["studies.csv", "study_objects.csv", "objects.csv", "power.svg"] {
        assert!(out.join(f).exists(), "{f}");
    }
}

/// Where every participant shares the effect — the same person, at α = 40, whom active
/// selection leaves further from the truth than passive — the power rises with the study's
/// size: none at 3 participants (a signed-rank test cannot reach p < .05 with 3 pairs), most
/// studies at 10.
#[test]
fn an_effect_every_participant_shares_gains_power_with_participants() {
    let dir = tmp("planted");
    let p = protocol(&dir, "planted.json", |p| {
        label_model_population(p);
        p["learning"]["alpha"] = 40.0.into();
    });
    let out = dir.join("out");
    let (code, _, err) = handover(&[
        "plan",
        "--protocol",
        &p,
        "--sizes",
        "3,10",
        "--studies",
        "12",
        "--seed",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let rows = powers(&out);
    let (small, large) = (at(&rows, 3, "distance_to_truth_deg", 5), at(&rows, 10, "distance_to_truth_deg", 5));
    assert_eq!(small.power, 0.0);
    assert!(large.power >= 0.5 && large.power_low > small.power_high - 0.3, "{large:?}");
}

#[derive(Debug, serde::Deserialize)]
struct StudyRow {
    study: usize,
    participants: usize,
    measure: String,
    iteration: usize,
    mean_difference: f64,
    p_value: Option<f64>,
}

#[derive(Debug, serde::Deserialize)]
struct Fig10 {
    iteration: usize,
    pairs: usize,
    mean_difference: f64,
    p_value: Option<f64>,
}

/// The first simulated study, kept as logs, is what `analyze` finds in them: the same paired
/// differences and p-values per iteration.
#[test]
fn a_planned_study_kept_as_logs_is_what_analyze_finds() {
    let dir = tmp("keep");
    let p = protocol(&dir, "p.json", |_| {});
    let (out, logs, analysed) = (dir.join("out"), dir.join("logs"), dir.join("analysed"));
    let (code, _, err) = handover(&[
        "plan",
        "--protocol",
        &p,
        "--sizes",
        "4",
        "--studies",
        "2",
        "--seed",
        "5",
        "--out",
        out.to_str().unwrap(),
        "--keep-logs",
        logs.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let (code, _, err) = handover(&["analyze", logs.to_str().unwrap(), "--out", analysed.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let planned: Vec<StudyRow> = csv::Reader::from_path(out.join("studies.csv"))
        .unwrap()
        .deserialize()
        .map(|r| r.unwrap())
        .filter(|r: &StudyRow| r.study == 0 && r.participants == 4 && r.measure == "test_log_likelihood")
        .collect();
    let found: Vec<Fig10> = csv::Reader::from_path(analysed.join("pilot/fig10_tests.csv"))
        .unwrap()
        .deserialize()
        .map(|r| r.unwrap())
        .collect();
    assert_eq!(planned.len(), 6);
    for r in &planned {
        let f = found.iter().find(|f| f.iteration == r.iteration).unwrap();
        assert_eq!(f.pairs, 4);
        assert!((f.mean_difference - r.mean_difference).abs() < 1e-9, "{r:?} vs {f:?}");
        match (f.p_value, r.p_value) {
            (Some(a), Some(b)) => assert!((a - b).abs() < 1e-12, "{r:?} vs {f:?}"),
            (a, b) => assert_eq!(a, b, "{r:?} vs {f:?}"),
        }
    }
}

/// Shards run apart and merged write byte for byte what the whole plan writes; a shard of
/// another plan or a missing one is refused.
#[test]
fn shards_merged_are_byte_for_byte_the_whole_plan() {
    let dir = tmp("shards");
    let p = protocol(&dir, "p.json", |_| {});
    let s = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let run = |extra: &[&str]| {
        let mut args = vec!["plan", "--protocol", &p, "--sizes", "2,3", "--studies", "3", "--seed", "2"];
        args.extend(extra);
        handover(&args)
    };
    let (code, _, err) = run(&["--out", &s("whole"), "--threads", "1"]);
    assert_eq!(code, 0, "{err}");
    for k in 0..2 {
        let (code, _, err) = run(&["--shard", &format!("{k}/2"), "--out", &s(&format!("shard{k}"))]);
        assert_eq!(code, 0, "{err}");
    }
    let (code, _, err) = run(&["--merge", &s("shard1"), &s("shard0"), "--out", &s("merged")]);
    assert_eq!(code, 0, "{err}");
    for f in ["studies.csv", "study_objects.csv", "power.csv", "objects.csv"] {
        assert_eq!(
            std::fs::read(dir.join("whole").join(f)).unwrap(),
            std::fs::read(dir.join("merged").join(f)).unwrap(),
            "{f}"
        );
    }
    let (code, _, err) = run(&["--merge", &s("shard0"), "--out", &s("x")]);
    assert_eq!(code, 2);
    assert!(err.contains("shards 1 of 2 are missing"), "{err}");
    // A second run into the same folder: another seed is refused and leaves it whole; the
    // same run again (a requeued job) replaces its own files.
    let before = std::fs::read(dir.join("whole/studies.csv")).unwrap();
    let (code, _, err) =
        handover(&["plan", "--protocol", &p, "--sizes", "2,3", "--studies", "3", "--seed", "3", "--out", &s("whole")]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("a run of other options, seeds or shard wrote them"), "{err}");
    assert_eq!(std::fs::read(dir.join("whole/studies.csv")).unwrap(), before);
    let (code, _, err) = run(&["--shard", "1/2", "--out", &s("shard0")]);
    assert_eq!(code, 2, "another shard into a shard's folder: {err}");
    let (code, _, err) = run(&["--out", &s("whole")]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(std::fs::read(dir.join("whole/studies.csv")).unwrap(), before);
    // A shard whose numbers are not finite, or whose manifest would size a huge table.
    for (name, file, from, to, says) in [
        ("nan", "studies.csv", None, "NaN", "is NaN, expected a finite number"),
        ("inf", "studies.csv", None, "-inf", "is -inf, expected a finite number"),
        ("of", "shard.json", Some("\"of\": 2"), "\"of\": 1000000000000000000", "expected 1 to 100000 shards"),
    ] {
        let copy = dir.join(format!("hostile-{name}"));
        std::fs::create_dir_all(&copy).unwrap();
        for f in ["studies.csv", "study_objects.csv", "shard.json"] {
            std::fs::copy(dir.join("shard0").join(f), copy.join(f)).unwrap();
        }
        let text = std::fs::read_to_string(copy.join(file)).unwrap();
        let text = match from {
            Some(from) => text.replace(from, to),
            // The last cell of the first row: a number in every plan row.
            None => {
                let mut lines: Vec<String> = text.lines().map(String::from).collect();
                let cut = lines[1].rfind(',').unwrap();
                lines[1] = format!("{},{to}", &lines[1][..cut]);
                lines.join("\n") + "\n"
            }
        };
        std::fs::write(copy.join(file), text).unwrap();
        // A hostile shard says its edited file's hash, so that the rows are read.
        crate::shards::rehash(&copy, file);
        let (code, _, err) = run(&["--merge", copy.to_str().unwrap(), &s("shard1"), "--out", &s("hostile-out")]);
        assert_eq!(code, 2, "{name}: {err}");
        assert!(err.contains(says) && err.contains(file), "{name}: {err}");
    }
    // A manifest that leaves out a file the merge reads: that file is never trusted unhashed.
    let copy = dir.join("hostile-unlisted");
    std::fs::create_dir_all(&copy).unwrap();
    for f in ["studies.csv", "study_objects.csv", "shard.json"] {
        std::fs::copy(dir.join("shard0").join(f), copy.join(f)).unwrap();
    }
    let mut m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(copy.join("shard.json")).unwrap()).unwrap();
    m["files"].as_object_mut().unwrap().remove("studies.csv");
    std::fs::write(copy.join("shard.json"), m.to_string()).unwrap();
    let edited = std::fs::read_to_string(copy.join("studies.csv")).unwrap().replacen(",0.", ",9.", 1);
    std::fs::write(copy.join("studies.csv"), edited).unwrap();
    let (code, _, err) = run(&["--merge", copy.to_str().unwrap(), &s("shard1"), "--out", &s("hostile-out")]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("\"files\" names study_objects.csv, expected studies.csv, study_objects.csv"), "{err}");
    let (code, _, err) = handover(&[
        "plan",
        "--protocol",
        &p,
        "--sizes",
        "2,3",
        "--studies",
        "4",
        "--seed",
        "2",
        "--merge",
        &s("shard0"),
        &s("shard1"),
        "--out",
        &s("y"),
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("a shard of another run"), "{err}");
}

#[test]
fn bad_input_exits_2_naming_what() {
    let dir = tmp("bad");
    let p = protocol(&dir, "bad.json", |p| {
        label_model_population(p);
        p["population"]["q_star_deg"][3]["mean"] = 170.0.into();
        p["population"]["w"][0]["sd"] = (-1.0).into();
    });
    let (code, _, err) = handover(&["plan", "--protocol", &p, "--sizes", "4", "--studies", "1"]);
    assert_eq!(code, 2);
    assert!(err.contains("population.q_star_deg[3].mean") && err.contains("population.w[0].sd"), "{err}");
    for (args, what) in [
        (vec!["plan", "--sizes", "1"], "--sizes has 1"),
        (vec!["plan", "--sizes", "4,4"], "names a size twice"),
        (vec!["plan", "--studies", "0"], "'--studies <STUDIES>'"),
        (vec!["plan", "--studies", "10000", "--sizes", "40"], "over the budget of 200000"),
        (vec!["plan", "--shard", "0/2"], "--shard needs --out"),
    ] {
        let (code, _, err) = handover(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(what), "{args:?}: {err}");
    }
}

/// `--population prior` plans with people as varied as the robot's prior: their q* spread
/// over each joint's prior range as a uniform draw does (variance width²/12), where the
/// protocol's default population's sd is a sixth of the range (a third of that variance).
#[test]
fn a_plan_from_the_prior_draws_people_across_the_prior() {
    let dir = tmp("prior");
    let p = protocol(&dir, "p.json", |_| {});
    let ranges: Vec<(f64, f64)> = {
        let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
        v["learning"]["prior"]["q_star_deg"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| (c["min"].as_f64().unwrap().to_radians(), c["max"].as_f64().unwrap().to_radians()))
            .collect()
    };
    let spread = |population: &str| {
        let logs = dir.join(format!("logs-{population}"));
        let (code, out, err) = handover(&[
            "plan",
            "--protocol",
            &p,
            "--sizes",
            "12",
            "--studies",
            "1",
            "--seed",
            "3",
            "--population",
            population,
            "--keep-logs",
            logs.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{err}");
        if population == "prior" {
            assert!(out.contains("the robot's prior as the population"), "{out}");
        }
        let truths: Vec<Vec<f64>> = handover::record::mcap_files(&logs)
            .iter()
            .map(|f| handover::record::read_log(f).unwrap().start.simulated_truth.unwrap().q_star)
            .collect();
        assert_eq!(truths.len(), 12);
        // Each joint's variance over the participants, relative to a uniform draw's.
        let relative: f64 = ranges
            .iter()
            .enumerate()
            .map(|(j, &(lo, hi))| {
                let x: Vec<f64> = truths.iter().map(|t| t[j]).collect();
                assert!(x.iter().all(|v| (lo..=hi).contains(v)), "inside the prior's support");
                let m = x.iter().sum::<f64>() / x.len() as f64;
                let var = x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (x.len() - 1) as f64;
                var / ((hi - lo).powi(2) / 12.0)
            })
            .sum::<f64>()
            / ranges.len() as f64;
        relative
    };
    let (prior, protocol) = (spread("prior"), spread("protocol"));
    assert!(prior > 0.7 && protocol < 0.6, "relative variance: prior {prior}, protocol {protocol}");
}
