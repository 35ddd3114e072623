//! `handover analyze` as a researcher runs it on a folder of logs.

use crate::support::{handover, small_protocol_text};

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;
use std::time::Duration;

use handover::dryrun::{DryRunPlan, drive, now_ns, plan_from};
use handover::protocol::Study;
use handover::record::{RecordedSession, new_log_path};
use handover::session::Session;

/// Runs a planned session to its end and logs it in `dir`.
fn record(dir: &Path, text: &str, study: &Arc<Study>, p: &DryRunPlan) {
    let session = Session::new(Arc::clone(study), p.start.clone()).unwrap();
    let path = new_log_path(dir, &p.start.participant, chrono::Utc::now());
    let mut rec = RecordedSession::create(&path, text, session, now_ns()).unwrap();
    drive(&mut rec, &p.participant, Duration::ZERO).unwrap();
    rec.finish().unwrap();
}

/// Logs: `pilots` dry-run sessions and one real (not pilot) completed session.
fn logs(name: &str, pilots: usize) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("handover-analyze-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let text = small_protocol_text();
    let study = Arc::new(Study::from_json(&text, "small").unwrap());
    for i in 0..=pilots {
        let mut p = plan_from(&study, &study.prior_population(), 77, i, None, "2026-11-22T00:00:00Z".into());
        if i == pilots {
            p.start.pilot = false;
            p.start.participant = "p-real0001".into();
        }
        record(&dir, &text, &study, &p);
    }
    dir
}

fn files(dir: &Path) -> Vec<PathBuf> {
    handover::record::mcap_files(dir)
}

#[test]
fn writes_tidy_csv_plots_and_table_one_keeping_pilots_apart() {
    let dir = logs("outputs", 3);
    let out = dir.join("out");
    let (code, stdout, err) =
        handover(&["analyze", "--alpha-particles", "300", dir.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(stdout.contains("== REAL SESSIONS: 1 sessions (1 completed) =="), "{stdout}");
    assert!(stdout.contains("== PILOT SESSIONS (dry runs, rehearsals): 3 sessions (3 completed) =="), "{stdout}");
    assert!(stdout.contains("Fig. 10") && stdout.contains("| prefer |") && stdout.contains("forced choice"));
    for f in [
        "sessions.csv",
        "trials.csv",
        "test_log_likelihood.csv",
        "questionnaire.csv",
        "fig10.svg",
        "objects.svg",
        "table1.md",
        "alpha.csv",
        "alpha_curve.csv",
        "fig10_tests.csv",
        "alpha.svg",
        "objects_by_body.csv",
        "belief_summary.csv",
        "notes.csv",
    ] {
        assert!(out.join(f).exists(), "{f}");
        assert!(out.join("pilot").join(f).exists(), "pilot/{f}");
    }
    let mut q = csv::Reader::from_path(out.join("pilot/questionnaire.csv")).unwrap();
    assert!(q.headers().unwrap().iter().any(|h| h == "value"));
    assert_eq!(q.records().count(), 3 * 8, "one row per answer");
    let mut t = csv::Reader::from_path(out.join("pilot/test_log_likelihood.csv")).unwrap();
    assert_eq!(t.records().count(), 3 * 2 * 6, "session × condition × iteration 0..=5");
    let mut f = csv::Reader::from_path(out.join("pilot/fig10_tests.csv")).unwrap();
    let tests: Vec<_> = f.records().map(|r| r.unwrap()).collect();
    assert_eq!(tests.len(), 6, "one paired test per iteration 0..=5");
    assert_eq!(tests[0][4].parse::<f64>().unwrap(), 0.0, "iteration 0: the same prior");
    assert_eq!(&tests[0][9], "", "iteration 0: no test");
    assert!(tests[1..].iter().all(|t| &t[3] == "3"), "3 pairs per iteration");
    assert!(stdout.contains("active − passive: mean [CI], median, share higher (p)"), "{stdout}");
    // beliefs.csv is long: session × condition × iteration × parameter × joint × estimate.
    let mut b = csv::Reader::from_path(out.join("pilot/beliefs.csv")).unwrap();
    let head: Vec<String> = b.headers().unwrap().iter().map(String::from).collect();
    assert_eq!(
        head,
        [
            "session_id",
            "participant",
            "condition",
            "program",
            "iteration",
            "parameter",
            "joint",
            "estimate",
            "value",
            "unit"
        ]
    );
    let rows: Vec<csv::StringRecord> = b.records().map(|r| r.unwrap()).collect();
    assert_eq!(
        rows.len(),
        3 * 2 * 6 * 2 * 7 * 5,
        "the replayed belief after each iteration, every component and estimate"
    );
    let elbow_mean = rows
        .iter()
        .find(|r| &r[5] == "q_star" && &r[6] == "elbow_flexion" && &r[7] == "mean" && &r[4] == "0")
        .expect("the prior mean of the elbow");
    assert_eq!(&elbow_mean[9], "deg");
    let v: f64 = elbow_mean[8].parse().unwrap();
    assert!((40.0..=130.0).contains(&v), "inside the elbow's prior range in degrees: {v}");
    let mut e = csv::Reader::from_path(out.join("pilot/belief_summary.csv")).unwrap();
    assert_eq!(e.records().count(), 3 * 2 * 6);
    let mut s = csv::Reader::from_path(out.join("sessions.csv")).unwrap();
    let head = s.headers().unwrap().clone();
    let col = |name: &str| head.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name}"));
    let rows: Vec<_> = s.records().map(|r| r.unwrap()).collect();
    assert_eq!(rows.len(), 1);
    assert_eq!(&rows[0][1], "p-real0001");
    assert_eq!(&rows[0][col("hand")], "right");
    let real = handover::record::mcap_files(&dir)
        .into_iter()
        .map(|p| handover::record::read_log(&p).unwrap())
        .find(|l| l.start.participant == "p-real0001")
        .unwrap();
    assert_eq!(&rows[0][col("seed")], real.start.seed.to_string(), "the seed as exact decimal text");
    // The object finding per height band and hand: each condition's share and the paired
    // difference, for every band and hand with a session.
    let mut o = csv::Reader::from_path(out.join("pilot/objects_by_body.csv")).unwrap();
    let rows: Vec<_> = o.records().map(|r| r.unwrap()).collect();
    assert!(!rows.is_empty());
    let sessions: usize = {
        let mut groups: Vec<(String, String, usize)> =
            rows.iter().map(|r| (r[0].to_string(), r[1].to_string(), r[2].parse().unwrap())).collect();
        groups.dedup();
        groups.iter().map(|g| g.2).sum()
    };
    assert_eq!(sessions, 3, "every pilot session in one band and hand: {rows:?}");
    // The condition is a column: a share's condition, a difference's `<first> minus <second>`.
    let head = o.headers().unwrap().clone();
    let col = |name: &str| head.iter().position(|h| h == name).unwrap();
    for r in &rows {
        let mean: f64 = r[col("mean")].parse().unwrap();
        match &r[col("measure")] {
            "share" => assert!(["active", "passive"].contains(&&r[col("condition")]) && (0.0..=1.0).contains(&mean)),
            "difference" => assert!(&r[col("condition")] == "active minus passive" && mean.abs() <= 1.0),
            other => panic!("measure {other}: {r:?}"),
        }
    }
    let (code, json, _) = handover(&["analyze", "--alpha-particles", "300", dir.to_str().unwrap(), "--format", "json"]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["sessions"].as_array().unwrap().len(), 4);
    assert_eq!(v["pilot"]["sessions"], 3);
    assert_eq!(v["real"]["sessions"], 1);
    assert_eq!(v["sessions"][0]["runs"][0]["beliefs"].as_array().unwrap().len(), 6);
    assert_eq!(v["pilot_alpha"]["sessions"].as_array().unwrap().len(), 3);
    assert_eq!(v["pilot_alpha"]["pooled"]["choices"], 3 * 26, "every handover of the 3 pilots");
    let mut a = csv::Reader::from_path(out.join("pilot/alpha.csv")).unwrap();
    let rows: Vec<_> = a.records().map(|r| r.unwrap()).collect();
    assert_eq!(rows.len(), 4, "3 sessions and the pooled row");
    assert_eq!(&rows[3][0], "pooled");
}

/// Dry runs whose simulated people choose with a known α.
fn alpha_logs(alpha: f64, participants: usize) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("handover-analyze-{}-alpha-{alpha}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut v: serde_json::Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 200.into();
    v["learning"]["alpha"] = alpha.into();
    let text = v.to_string();
    let study = Arc::new(Study::from_json(&text, "alpha").unwrap());
    for i in 0..participants {
        record(
            &dir,
            &text,
            &study,
            &plan_from(&study, &study.prior_population(), 5, i, None, "2026-11-22T00:00:00Z".into()),
        );
    }
    dir
}

#[test]
fn the_alpha_estimate_recovers_the_alpha_people_chose_with() {
    let mut estimates = Vec::new();
    for alpha in [2.0, 5.0, 20.0] {
        let dir = alpha_logs(alpha, 10);
        let (code, json, err) =
            handover(&["analyze", dir.to_str().unwrap(), "--format", "json", "--alpha-particles", "4000"]);
        assert_eq!(code, 0, "{err}");
        let v: serde_json::Value = serde_json::from_str(&json).unwrap();
        let pooled = &v["pilot_alpha"]["pooled"];
        let (est, low, high) =
            (pooled["alpha"].as_f64().unwrap(), pooled["low"].as_f64().unwrap(), pooled["high"].as_f64().unwrap());
        assert_eq!(pooled["choices"], 10 * 26);
        assert!(low <= alpha && alpha <= high, "α = {alpha}: estimate {est} [{low}, {high}]");
        assert!(high / low < 8.0, "α = {alpha}: an informative interval, not the whole range: [{low}, {high}]");
        // The protocol's α is the true one, so it is not flagged.
        assert_eq!(v["pilot_alpha"]["protocol_alphas"][0][1], true);
        estimates.push(est);
    }
    assert!(estimates[0] < estimates[1] && estimates[1] < estimates[2], "{estimates:?}");
}

#[test]
fn a_protocol_alpha_the_data_reject_is_flagged() {
    // People choose with α = 20; analysed under a protocol that says so, the estimate is
    // near 20; the same choices cannot support α = 0.5, which a protocol would be flagged for.
    let dir = alpha_logs(20.0, 6);
    let (code, out, err) = handover(&["analyze", dir.to_str().unwrap(), "--alpha-particles", "2000"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("α by maximum marginal likelihood"), "{out}");
    assert!(out.contains("lies inside the pooled interval"), "{out}");
    let dir = std::env::temp_dir().join(format!("handover-analyze-{}-alpha-flag", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut v: serde_json::Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 200.into();
    v["learning"]["alpha"] = 0.5.into();
    let text = v.to_string();
    let study = Arc::new(Study::from_json(&text, "flag").unwrap());
    for i in 0..6 {
        let mut p = plan_from(&study, &study.prior_population(), 5, i, None, "2026-11-22T00:00:00Z".into());
        // The simulated people are more rational than the protocol assumes.
        p.participant.person.alpha = 20.0;
        record(&dir, &text, &study, &p);
    }
    let (code, out, err) = handover(&["analyze", dir.to_str().unwrap(), "--alpha-particles", "2000"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("FLAG: the protocol's α = 0.5 lies outside the pooled interval"), "{out}");
    let (code, _, err) = handover(&["analyze", dir.to_str().unwrap(), "--alpha-particles", "0"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--alpha-particles is 0"), "{err}");
}

#[test]
fn verify_accepts_honest_logs_and_reports_edited_ones() {
    let dir = logs("verify", 1);
    let (code, _, err) = handover(&["analyze", "--alpha-particles", "300", dir.to_str().unwrap(), "--verify"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("every derived value matches"), "{err}");
    // Edit one derived number (a belief's entropy) without changing the file's length.
    let f = &files(&dir)[0];
    let mut bytes = std::fs::read(f).unwrap();
    let key = b"\"entropy\":";
    let at = (0..bytes.len() - key.len())
        .find(|&i| &bytes[i..i + key.len()] == key && bytes[i + key.len()].is_ascii_digit())
        .unwrap()
        + key.len();
    let d = bytes[at];
    bytes[at] = if d == b'1' { b'2' } else { b'1' };
    std::fs::write(f, &bytes).unwrap();
    let (code, _, err) = handover(&["analyze", "--alpha-particles", "300", dir.to_str().unwrap(), "--verify"]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("/belief") && err.contains(".entropy"), "{err}");
}

#[test]
fn truncated_foreign_and_resumed_logs() {
    let dir = logs("odd", 1);
    let all = files(&dir);
    // A crash: the first log cut short is analysed up to its last whole message.
    let bytes = std::fs::read(&all[0]).unwrap();
    std::fs::write(&all[0], &bytes[..bytes.len() * 3 / 4]).unwrap();
    let (code, out, err) = handover(&["analyze", "--alpha-particles", "300", dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("ends early") && err.contains("analysed up to its last whole message"), "{err}");
    assert!(out.contains("partial"), "{out}");
    // Resuming it writes a second log of the same session: it is counted once.
    let (code, _, err) = handover(&["resume", all[0].to_str().unwrap(), "--no-console"]);
    assert_eq!(code, 0, "{err}");
    let (code, out, err) = handover(&["analyze", "--alpha-particles", "300", dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("PILOT SESSIONS (dry runs, rehearsals): 1 sessions (1 completed)"), "{out}");
    assert!(err.contains("superseded"), "{err}");
    // A foreign file is skipped with a message, and the exit status says so.
    std::fs::write(dir.join("notes.mcap"), b"not a log at all").unwrap();
    let (code, _, err) = handover(&["analyze", "--alpha-particles", "300", dir.to_str().unwrap()]);
    assert_eq!(code, 1);
    assert!(
        err.contains("notes.mcap") && err.contains("not a handover session log") && err.contains("skipped"),
        "{err}"
    );
    let (code, _, _) = handover(&["analyze", "/nonexistent/dir"]);
    assert_eq!(code, 2);
}

/// trials.csv has every presentation with what became of it (taken, undone, voided with its
/// reason), the region's id and label, the mapped configuration and the times; notes.csv
/// the notes. Both read back with the csv crate.
#[test]
fn trials_csv_keeps_undone_and_voided_trials_and_notes_csv_the_notes() {
    use handover::session::{Event, Stamped, VoidReason};
    let dir = std::env::temp_dir().join(format!("handover-analyze-{}-voids", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let text = small_protocol_text();
    let study = Arc::new(Study::from_json(&text, "small").unwrap());
    let p = plan_from(&study, &study.prior_population(), 5, 0, None, "2026-11-22T00:00:00Z".into());
    let session = Session::new(Arc::clone(&study), p.start.clone()).unwrap();
    let mut rec = RecordedSession::create(
        &new_log_path(&dir, &p.start.participant, chrono::Utc::now()),
        &text,
        session,
        1_000_000_000,
    )
    .unwrap();
    let mut t = 1_000_000_000u64;
    let mut submit = |rec: &mut RecordedSession, event: Event| {
        t += 1_500_000_000;
        rec.submit(Stamped { time_ns: t, event }).unwrap();
    };
    let next = |rec: &RecordedSession| p.participant.respond(rec.session()).unwrap();
    for event in ["presented", "taken", "undone", "taken again", "the second trial presented"] {
        let e = if event == "undone" { Event::GraspUndone } else { next(&rec) };
        submit(&mut rec, e);
    }
    submit(&mut rec, Event::TrialVoided { reason: VoidReason::Other, detail: "robot slipped".into() });
    submit(&mut rec, Event::Note { text: "participant, asked, said \"fine\"".into() });
    drive(&mut rec, &p.participant, Duration::ZERO).unwrap();
    rec.finish().unwrap();
    let out = dir.join("out");
    let (code, _, err) =
        handover(&["analyze", "--alpha-particles", "300", dir.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(!out.join("pilot/robot.csv").exists(), "no robot, no robot.csv (not a bare header)");
    let mut r = csv::Reader::from_path(out.join("pilot/trials.csv")).unwrap();
    let head = r.headers().unwrap().clone();
    let col = |name: &str| head.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name}"));
    let rows: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
    let status: Vec<&str> = rows.iter().map(|x| &x[col("status")]).collect();
    assert_eq!(&status[..4], ["undone", "taken", "voided", "taken"], "{status:?}");
    assert_eq!(status.iter().filter(|s| **s == "taken").count(), 26, "every trial taken once in the end");
    assert_eq!(&rows[2][col("void_reason")], "other");
    assert_eq!(&rows[2][col("void_detail")], "robot slipped");
    assert!(rows[2][col("region")].is_empty() && rows[2][col("config_index")].is_empty());
    assert_eq!(&rows[0][col("presented_at")], &rows[1][col("presented_at")], "the same presentation, answered again");
    assert_eq!(&rows[1][col("presented_at")], "1970-01-01T00:00:02.500Z");
    assert_eq!(&rows[1][col("responded_at")], "1970-01-01T00:00:07.000Z");
    let taken = &rows[1];
    let q = study.query(&taken[col("query")]).unwrap();
    let k: usize = taken[col("config_index")].parse().unwrap();
    let label = study.object(q).regions.iter().find(|g| g.id == taken[col("region")]).unwrap().label.clone();
    assert_eq!(&taken[col("region_label")], label);
    for (j, name) in handover::kinematics::JOINT_NAMES.iter().enumerate() {
        let v: f64 = taken[col(&format!("q_{name}_rad"))].parse().unwrap();
        assert_eq!(v, q.feasible.configs[k].q[j], "{name}");
    }
    let mut n = csv::Reader::from_path(out.join("pilot/notes.csv")).unwrap();
    let notes: Vec<csv::StringRecord> = n.records().map(|x| x.unwrap()).collect();
    assert_eq!(notes.len(), 1);
    assert_eq!(&notes[0][4], "participant, asked, said \"fine\"");
    assert_eq!(&notes[0][2], "7");
}

#[test]
fn a_quit_session_is_stopped_and_resumable_not_aborted() {
    use handover::session::{Event, Stamped};
    let dir = std::env::temp_dir().join(format!("handover-analyze-{}-quit", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let text = small_protocol_text();
    let study = Arc::new(Study::from_json(&text, "small").unwrap());
    // Three sessions: quit part-way (the file finished, no end event), aborted, completed.
    for (i, how) in ["quit", "abort", "complete"].into_iter().enumerate() {
        let mut p = plan_from(&study, &study.prior_population(), 8, i, None, "2026-11-22T00:00:00Z".into());
        p.start.participant = format!("p-{how}0001");
        let session = Session::new(Arc::clone(&study), p.start.clone()).unwrap();
        let path = new_log_path(&dir, &p.start.participant, chrono::Utc::now());
        let mut rec = RecordedSession::create(&path, &text, session, 1_000_000_000).unwrap();
        let mut t = 1_000_000_000u64;
        for _ in 0..4 {
            t += 1_000_000_000;
            let event = p.participant.respond(rec.session()).unwrap();
            rec.submit(Stamped { time_ns: t, event }).unwrap();
        }
        match how {
            "abort" => {
                rec.submit(Stamped { time_ns: t + 1, event: Event::Aborted { reason: "fire alarm".into() } }).unwrap();
            }
            "complete" => drive(&mut rec, &p.participant, Duration::ZERO).unwrap(),
            _ => {}
        }
        rec.finish().unwrap();
    }
    let (code, out, err) = handover(&["analyze", "--alpha-particles", "300", dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let status = |who: &str| -> String {
        let line = out.lines().find(|l| l.trim_start().starts_with(who)).unwrap_or_else(|| panic!("{who}: {out}"));
        line.split_whitespace().nth(1).unwrap().to_string()
    };
    assert_eq!(status("p-quit0001"), "stopped", "{out}");
    assert_eq!(status("p-abort0001"), "aborted", "{out}");
    assert_eq!(status("p-complete0001"), "completed", "{out}");
    assert!(out.contains("stopped: quit or a signal, resumable"), "{out}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn outputs_are_owner_only_under_any_umask() {
    use std::os::unix::fs::PermissionsExt;
    let dir = logs("umask", 1);
    let out = dir.join("out").join("deeper");
    let status = Command::new("sh")
        .arg("-c")
        .arg("umask 000; exec \"$0\" analyze --alpha-particles 300 \"$1\" --out \"$2\"")
        .arg(env!("CARGO_BIN_EXE_handover"))
        .arg(&dir)
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    let mut written = 0;
    for d in [dir.join("out"), out.clone(), out.join("pilot")] {
        assert_eq!(mode(&d), 0o700, "{}", d.display());
        for f in std::fs::read_dir(&d).unwrap().flatten().filter(|e| e.file_type().unwrap().is_file()) {
            assert_eq!(mode(&f.path()), 0o600, "{}", f.path().display());
            written += 1;
        }
    }
    assert!(written >= 10, "{written} files");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `analyze --study-dir DIR` alone analyses the study's logs/; with neither a path nor a
/// study folder it is a usage error (exit 2).
#[test]
fn the_study_dir_alone_names_the_logs() {
    let logs = logs("study-dir", 0);
    let study = logs.parent().unwrap().join(format!("handover-analyze-{}-study", std::process::id()));
    let _ = std::fs::remove_dir_all(&study);
    std::fs::create_dir_all(&study).unwrap();
    std::fs::rename(&logs, study.join("logs")).unwrap();
    let (code, out, err) = handover(&["analyze", "--study-dir", study.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("p-real0001"), "{out}");
    let (code, _, err) = handover(&["analyze"]);
    assert_eq!(code, 2, "{err}");
    std::fs::remove_dir_all(&study).unwrap();
}

/// One session's α plot names its one curve for what it is, lists nothing it does not draw,
/// and its title counts one session.
#[test]
fn a_single_sessions_alpha_plot_says_this_session() {
    let dir = std::env::temp_dir().join(format!("handover-alpha-one-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let logs = dir.join("logs");
    let (code, _, err) = handover(&["dry-run", "--participants", "1", "--logs", logs.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let out = dir.join("out");
    let (code, _, err) =
        handover(&["analyze", "--alpha-particles", "200", logs.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let svg = std::fs::read_to_string(out.join("pilot/alpha.svg")).unwrap();
    assert!(svg.contains("this session: α = "), "the curve is named");
    assert!(!svg.contains("one session") && !svg.contains("pooled"), "nothing listed that is not drawn");
    assert!(svg.contains("1 pilot (simulated) session") && !svg.contains("1 pilot (simulated) sessions"));
    let fig10 = std::fs::read_to_string(out.join("pilot/fig10.svg")).unwrap();
    assert!(fig10.contains("over 1 pilot (simulated) session") && !fig10.contains("Fig. 10:"), "data in the legend");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_population_fitted_from_pilots_plans_the_next_study() {
    let dir = logs("population", 6);
    let out = dir.join("out");
    let (code, stdout, stderr) = handover(&[
        "analyze",
        dir.to_str().unwrap(),
        "--fit-population",
        "--alpha-particles",
        "200",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("POPULATION — fitted from 6 pilot sessions"), "{stdout}");
    // One real session: no population of its own, said so.
    assert!(stderr.contains("one real session; a population is fitted from two or more"), "{stderr}");
    let analyzed = stderr;
    let file = out.join("pilot/population.json");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        assert_eq!(std::fs::metadata(&file).unwrap().permissions().mode() & 0o777, 0o600);
    }
    let section: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    assert_eq!(section["q_star_deg"].as_array().map(Vec::len), Some(7), "{section}");
    let csv = std::fs::read_to_string(out.join("pilot/population.csv")).unwrap();
    assert!(csv.starts_with("part,joint,unit,mean,mean_low,mean_high,sd,sd_low,sd_high,"), "{csv}");
    // Each pilot alone and pooled, beside their true values.
    let pooled = std::fs::read_to_string(out.join("pilot/pooled.csv")).unwrap();
    assert!(
        pooled.starts_with(
            "participant,session_id,part,joint,unit,session_mean,session_sd,pooled_mean,pooled_sd,truth\n"
        ),
        "{pooled}"
    );
    assert_eq!(pooled.lines().count() - 1, 6 * (csv.lines().count() - 1), "one row per pilot and learned component");
    assert!(pooled.lines().skip(1).all(|l| !l.ends_with(',')), "every pilot's truth is given: {pooled}");
    assert!(stdout.contains("partial pooling, 6 participants with a known truth"), "{stdout}");
    // The fitted population plans the next study.
    let protocol = dir.join("small.json");
    std::fs::write(&protocol, small_protocol_text()).unwrap();
    let (code, stdout, stderr) = handover(&[
        "plan",
        "--protocol",
        protocol.to_str().unwrap(),
        "--population",
        file.to_str().unwrap(),
        "--sizes",
        "2",
        "--studies",
        "1",
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("population.json's population"), "{stdout}");
    // The fitted population as the next study's prior, recomputed from the two tables: a
    // normal per learned joint whose mean and spread have intervals (and the spread is above
    // the floor) at the fitted mean, its sd the larger of the spread's upper end and the
    // median of the pilots' own session sds, where that is narrower than the support; the
    // written prior elsewhere.
    let prior_file = out.join("pilot/prior.json");
    let prior: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&prior_file).unwrap()).unwrap();
    assert!(analyzed.contains("pilot/prior.json: the fitted population is the prior of"), "{analyzed}");
    let kinds = check_next_prior(&csv, &pooled, &prior, &analyzed);
    eprintln!("prior.json: {} joints keep the written prior, {} are normals", kinds.0, kinds.1);
    let next_dir = dir.join("next");
    let (code, stdout, stderr) = handover(&[
        "protocol",
        "with",
        protocol.to_str().unwrap(),
        "--prior-file",
        prior_file.to_str().unwrap(),
        "--population-file",
        file.to_str().unwrap(),
        "--out",
        next_dir.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("with the prior of") && stdout.contains("the protocol's population"), "{stdout}");
    let next = next_dir.join("protocol.json");
    let written: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&next).unwrap()).unwrap();
    assert_eq!(written["learning"]["prior"], prior);
    assert_eq!(written["population"], section);
    // Never over an existing protocol.
    let with_prior = |prior: &Path, out: &Path| {
        handover(&["protocol", "with", "--prior-file", prior.to_str().unwrap(), "--out", out.to_str().unwrap()])
    };
    let (code, _, stderr) = with_prior(&prior_file, &next_dir);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("protocol.json: exists; a protocol is never overwritten"), "{stderr}");
    // A normal written by hand is the prior the summary names; a bad one is refused by field.
    let mut hand: serde_json::Value = prior.clone();
    hand["q_star_deg"][3] = serde_json::json!({"kind": "gaussian", "mean": 88, "sd": 12, "min": 40, "max": 130});
    let hand_file = dir.join("hand-prior.json");
    std::fs::write(&hand_file, hand.to_string()).unwrap();
    let (code, stdout, stderr) = with_prior(&hand_file, &dir.join("hand-next"));
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("q*4 normal 88.0 ± 12.0° on [40, 130]°"), "{stdout}");
    hand["q_star_deg"][3]["sd"] = (-1).into();
    std::fs::write(&hand_file, hand.to_string()).unwrap();
    let refused = dir.join("refused");
    let (code, _, stderr) = with_prior(&hand_file, &refused);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("learning.prior.q_star_deg[3]: sd is -1, expected a positive number"), "{stderr}");
    assert!(!refused.join("protocol.json").exists(), "nothing written for a refused protocol");
    let runs = dir.join("next-logs");
    let (code, _, stderr) =
        handover(&["dry-run", "--protocol", next.to_str().unwrap(), "--logs", runs.to_str().unwrap(), "--pace", "0"]);
    assert_eq!(code, 0, "the next protocol runs: {stderr}");
    // A population file that does not fit the protocol is refused, naming the field.
    let bad = dir.join("bad-population.json");
    std::fs::write(&bad, r#"{"q_star_deg": [{"mean": 0, "sd": 1}], "w": []}"#).unwrap();
    let (code, _, stderr) =
        handover(&["dry-run", "--protocol", protocol.to_str().unwrap(), "--population", bad.to_str().unwrap()]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("population.q_star_deg: has 1 entries, expected 7"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A table's rows by column name (a table of numbers and plain words: no quoted commas).
fn csv_rows(text: &str) -> Vec<std::collections::HashMap<String, String>> {
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    lines.map(|l| header.iter().cloned().zip(l.split(',').map(String::from)).collect()).collect()
}

/// prior.json checked against the rule, recomputed from population.csv and pooled.csv (`csv`,
/// `pooled`): a normal per learned joint whose mean and spread have intervals (and the spread
/// is above the floor) at the fitted mean, its sd the larger of the spread's upper end and
/// the median of the people's own session sds, where that is narrower than the support; the
/// written prior elsewhere, named in `analyzed` (the command's standard error). Returns how
/// many joints kept the written prior and how many are normals.
fn check_next_prior(csv: &str, pooled: &str, prior: &serde_json::Value, analyzed: &str) -> (usize, usize) {
    let people = csv_rows(pooled);
    let mut kinds = (0, 0);
    for row in csv_rows(csv) {
        let joint: usize = row["joint"].parse().unwrap();
        let num = |k: &str| row[k].parse::<f64>().unwrap();
        let mut session_sds: Vec<f64> = people
            .iter()
            .filter(|p| p["part"] == row["part"] && p["joint"] == row["joint"])
            .map(|p| p["session_sd"].parse().unwrap())
            .collect();
        session_sds.sort_by(f64::total_cmp);
        let n = session_sds.len();
        let median = if n % 2 == 1 { session_sds[n / 2] } else { (session_sds[n / 2 - 1] + session_sds[n / 2]) / 2.0 };
        let intervals = ["mean_low", "mean_high", "sd_low", "sd_high"].iter().all(|k| !row[*k].is_empty());
        let sd = if intervals { num("sd_high").max(median) } else { f64::NAN };
        let determined = row["sd_at_floor"] == "FALSE" && intervals && sd < num("support_max") - num("support_min");
        let c = &prior["q_star_deg"][joint - 1];
        if !determined {
            kinds.0 += 1;
            assert_eq!(c["kind"], "uniform", "joint {joint}, not determined, keeps its prior: {prior}");
            assert!(analyzed.contains(&format!("q*{joint}")), "joint {joint} is named: {analyzed}");
        } else {
            kinds.1 += 1;
            assert_eq!(c["kind"], "gaussian", "joint {joint}: {prior}");
            assert!((c["mean"].as_f64().unwrap() - num("mean")).abs() < 1e-9, "joint {joint}: {c} vs {}", row["mean"]);
            assert!((c["sd"].as_f64().unwrap() - sd).abs() < 1e-9 * sd, "joint {joint}: {c} vs sd {sd}");
        }
    }
    kinds
}

/// The hazard of a pilot's prior: 20 measured pilots (seed 3) whose fit puts a spread well
/// under a degree on joints whose people spread 12–15° (the default population: a sixth of
/// each range). The next prior's sd on those joints is what one person's session resolves,
/// not the fit's fraction of a degree, so the next study can still learn them.
#[test]
fn a_pilot_whose_people_fit_alike_does_not_freeze_a_joint() {
    let dir = crate::support::tmpdir("pilot-prior");
    let mut protocol: serde_json::Value = serde_json::from_str(&small_protocol_text()).unwrap();
    protocol["learning"]["observation"] = "measured".into();
    protocol["learning"]["measurement"] = serde_json::json!({"sigma_deg": vec![2.0; 7]});
    protocol["learning"]["particles"] = 300.into();
    protocol["session"]["trials_per_condition"] = 4.into();
    let file = dir.join("measured.json");
    std::fs::write(&file, protocol.to_string()).unwrap();
    let logs = dir.join("logs");
    let out = dir.join("out");
    let (code, _, stderr) = handover(&[
        "dry-run",
        "--protocol",
        file.to_str().unwrap(),
        "--participants",
        "20",
        "--seed",
        "3",
        "--pace",
        "0",
        "--logs",
        logs.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    let (code, _, analyzed) = handover(&[
        "analyze",
        logs.to_str().unwrap(),
        "--fit-population",
        "--alpha-particles",
        "200",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{analyzed}");
    let read = |name: &str| std::fs::read_to_string(out.join("pilot").join(name)).unwrap();
    let (csv, pooled) = (read("population.csv"), read("pooled.csv"));
    let prior: serde_json::Value = serde_json::from_str(&read("prior.json")).unwrap();
    let (kept, normals) = check_next_prior(&csv, &pooled, &prior, &analyzed);
    // Joints fitted under a degree with an interval (the hazard): each a normal of several
    // degrees in the next prior.
    let mut narrow = 0;
    for row in csv_rows(&csv) {
        let joint: usize = row["joint"].parse().unwrap();
        let fitted: f64 = row["sd"].parse().unwrap();
        if fitted < 1.0 && !row["sd_high"].is_empty() && row["sd_at_floor"] == "FALSE" {
            narrow += 1;
            let sd = prior["q_star_deg"][joint - 1]["sd"].as_f64().unwrap();
            assert!(sd > 5.0, "q*{joint}: fitted {fitted}°, next prior sd {sd}°: {prior}");
        }
    }
    eprintln!("{kept} joints keep the written prior, {normals} are normals; {narrow} fitted under 1°, none frozen");
    assert!(narrow >= 1 && normals >= narrow, "seed 3 fits a spread under 1° with an interval: {csv}");
    // Those spreads are said wherever the population is used; the prior made from them is
    // not narrow, and nothing is said of it.
    let population = out.join("pilot/population.json");
    let (code, _, stderr) = handover(&[
        "plan",
        "--protocol",
        file.to_str().unwrap(),
        "--population",
        population.to_str().unwrap(),
        "--sizes",
        "2",
        "--studies",
        "1",
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains("warning:") && stderr.contains("the population's q*1 sd 0.25°"), "{stderr}");
    let next = dir.join("next");
    let prior_file = out.join("pilot/prior.json");
    let (code, _, stderr) = handover(&[
        "protocol",
        "with",
        file.to_str().unwrap(),
        "--prior-file",
        prior_file.to_str().unwrap(),
        "--out",
        next.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(!stderr.contains("warning:"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}
