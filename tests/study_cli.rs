//! The study commands as a user runs them: protocol check, participant new/show, dry-run,
//! resume.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use handover::record::read_log;
use handover::session::Event;

fn handover(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_handover")).args(args).output().unwrap();
    (out.status.code().unwrap_or(-1), String::from_utf8(out.stdout).unwrap(), String::from_utf8(out.stderr).unwrap())
}

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("handover-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A protocol with few particles, so that dry runs in debug builds are quick.
fn small_protocol(dir: &Path) -> PathBuf {
    let mut v: serde_json::Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 300.into();
    let p = dir.join("small.json");
    std::fs::write(&p, v.to_string()).unwrap();
    p
}

fn logs_in(dir: &Path) -> Vec<PathBuf> {
    handover::record::mcap_files(dir)
}

fn events(path: &Path) -> Vec<Event> {
    read_log(path).unwrap().events.into_iter().map(|s| s.event).collect()
}

#[test]
fn protocol_check_summarises_or_lists_every_problem() {
    let (code, out, err) = handover(&["protocol", "check", "protocols/bike-handover.json"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("valid protocol 'bike-handover'") && out.contains("4 items × 2 programs"), "{out}");
    let dir = tmpdir("badproto");
    let bad = dir.join("bad.json");
    let mut v: serde_json::Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["session"]["trials_per_condition"] = (-1).into();
    std::fs::write(&bad, v.to_string()).unwrap();
    let (code, _, err) = handover(&["protocol", "check", bad.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(err.contains("session.trials_per_condition"), "{err}");
    v["session"]["trials_per_condition"] = 5.into();
    v["questionnaire"]["scale"][2]["value"] = 1.into();
    std::fs::write(&bad, v.to_string()).unwrap();
    let (code, _, err) = handover(&["protocol", "check", bad.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(err.contains("questionnaire.scale[2].value") && err.contains("strictly increasing"), "{err}");
    std::fs::write(&bad, "{").unwrap();
    assert_eq!(handover(&["protocol", "check", bad.to_str().unwrap()]).0, 2);
}

#[test]
fn participant_new_creates_a_pseudonymous_record_in_the_least_filled_slot() {
    let dir = tmpdir("participants");
    let (parts, logs) = (dir.join("participants"), dir.join("logs"));
    let (code, out, err) =
        handover(&["participant", "new", "--participants", parts.to_str().unwrap(), "--logs", logs.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let id = out.trim();
    assert!(handover::participant::validate_id(id).is_ok(), "{id}");
    let text = std::fs::read_to_string(parts.join(format!("{id}.json"))).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["slot"], 0, "no completed sessions: the first order");
    assert!(v.get("name").is_none());
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(parts.join(format!("{id}.json"))).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o600);
    }
    // Pilot (dry-run) sessions never shift the counterbalancing.
    let proto = small_protocol(&dir);
    let (code, _, err) =
        handover(&["dry-run", "--protocol", proto.to_str().unwrap(), "--logs", logs.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(
        !parts.join("pilot").exists() && std::fs::read_dir(&parts).unwrap().count() == 1,
        "dry runs never touch participants/"
    );
    let (_, out2, _) =
        handover(&["participant", "new", "--participants", parts.to_str().unwrap(), "--logs", logs.to_str().unwrap()]);
    let v2: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(parts.join(format!("{}.json", out2.trim()))).unwrap()).unwrap();
    assert_eq!(v2["slot"], 0);
    let (code, show, _) = handover(&["participant", "show", id, "--participants", parts.to_str().unwrap()]);
    assert_eq!(code, 0);
    assert!(show.contains(id));
}

#[test]
fn a_completed_real_session_fills_its_slot() {
    use std::sync::Arc;
    let dir = tmpdir("slots");
    let (parts, logs) = (dir.join("participants"), dir.join("logs"));
    // One completed real session in slot 0 (and a dropout in slot 1, which does not count).
    let text = std::fs::read_to_string(small_protocol(&dir)).unwrap();
    let study = Arc::new(handover::protocol::Study::from_json(&text, "small").unwrap());
    for (i, finish) in [(0usize, true), (1, false)] {
        let mut p = handover::dryrun::plan(&study, 3, i, None, "2026-11-22T00:00:00Z".into());
        p.start.pilot = false;
        let session = handover::session::Session::new(Arc::clone(&study), p.start.clone()).unwrap();
        let path = handover::record::new_log_path(&logs, &p.start.participant, chrono::Utc::now());
        let mut rec = handover::record::RecordedSession::create(&path, &text, session, 1).unwrap();
        if finish {
            handover::dryrun::drive(&mut rec, &p.participant, Duration::ZERO).unwrap();
        }
        rec.finish().unwrap();
    }
    let (code, out, err) =
        handover(&["participant", "new", "--participants", parts.to_str().unwrap(), "--logs", logs.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(parts.join(format!("{}.json", out.trim()))).unwrap()).unwrap();
    assert_eq!(v["slot"], 1, "slot 0 has a completed session, slot 1 only a dropout");
    assert!(err.contains("Program A = passive"), "{err}");
}

#[test]
fn participant_ids_that_are_not_pseudonyms_are_refused() {
    let dir = tmpdir("ids");
    for bad in ["../etc/passwd", "a b", "p.1", "", "x/y", &"x".repeat(33)] {
        let (code, _, err) = handover(&["participant", "show", bad, "--participants", dir.to_str().unwrap()]);
        assert_eq!(code, 2, "{bad}: {err}");
        assert!(err.contains("invalid"), "{err}");
        let (code, _, err) = handover(&["run", "--participant", bad]);
        assert_eq!(code, 2, "run --participant {bad}: {err}");
    }
    let (code, _, err) = handover(&["participant", "show", "p-unknown", "--participants", dir.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
}

#[test]
fn dry_run_bad_input_exits_2() {
    let dir = tmpdir("drybad");
    let truth = dir.join("truth.json");
    std::fs::write(&truth, r#"{"q_star_deg": [1, 2], "w": [1, 1, 1, 1, 1, 1, 1]}"#).unwrap();
    let logs = dir.join("logs");
    for args in [
        vec!["dry-run", "--participants", "0", "--logs", logs.to_str().unwrap()],
        vec!["dry-run", "--truth", truth.to_str().unwrap(), "--logs", logs.to_str().unwrap()],
        vec!["dry-run", "--protocol", "/nonexistent.json"],
        vec!["resume", truth.to_str().unwrap(), "--dry-run"],
    ] {
        let (code, _, err) = handover(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// Kills a paced dry run at several points, resumes each with `resume --dry-run`, and
/// compares the events with an uninterrupted run.
#[test]
fn a_killed_dry_run_resumes_to_the_same_events() {
    let dir = tmpdir("kill");
    let proto = small_protocol(&dir);
    let full_logs = dir.join("full");
    let (code, _, err) = handover(&[
        "dry-run",
        "--protocol",
        proto.to_str().unwrap(),
        "--seed",
        "21",
        "--logs",
        full_logs.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let full = events(&logs_in(&full_logs)[0]);
    // Kill points: after 3 events (training), 17 (the second run) and 40 (test phase).
    for (k, target) in [3usize, 17, 40].into_iter().enumerate() {
        let logs = dir.join(format!("killed{k}"));
        let mut child = Command::new(env!("CARGO_BIN_EXE_handover"))
            .args(["dry-run", "--protocol", proto.to_str().unwrap(), "--seed", "21", "--pace", "15"])
            .args(["--logs", logs.to_str().unwrap()])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let waited = std::time::Instant::now();
        loop {
            std::thread::sleep(Duration::from_millis(5));
            let n = logs_in(&logs).first().and_then(|p| read_log(p).ok()).map_or(0, |l| l.events.len());
            if n >= target {
                break;
            }
            assert!(waited.elapsed() < Duration::from_secs(60), "the dry run did not reach {target} events");
        }
        let delay_ms = target;
        child.kill().unwrap();
        child.wait().unwrap();
        let crashed = logs_in(&logs);
        assert_eq!(crashed.len(), 1, "one log after the kill");
        let before = std::fs::read(&crashed[0]).unwrap();
        let partial = read_log(&crashed[0]).unwrap();
        assert!(!partial.finished, "killed after {delay_ms} events, before the end");
        let (code, _, err) = handover(&["resume", crashed[0].to_str().unwrap(), "--dry-run"]);
        assert_eq!(code, 0, "{err}");
        let all = logs_in(&logs);
        assert_eq!(all.len(), 2, "the crashed log and its continuation");
        let resumed = all.iter().find(|p| **p != crashed[0]).unwrap();
        assert_eq!(events(resumed), full, "killed after {delay_ms} events");
        assert_eq!(std::fs::read(&crashed[0]).unwrap(), before, "the crashed file is kept");
    }
}

#[test]
fn a_dry_run_over_seeds_reports_intervals_and_paired_differences() {
    let dir = tmpdir("seeds");
    let proto = small_protocol(&dir);
    let logs = dir.join("logs");
    let (code, out, err) = handover(&[
        "dry-run",
        "--protocol",
        proto.to_str().unwrap(),
        "--participants",
        "3",
        "--seeds",
        "2",
        "--seed",
        "7",
        "--logs",
        logs.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(logs_in(&logs).len(), 6, "3 participants × 2 seeds, each logged");
    assert!(out.contains("3 participants × 2 seed(s) (seeds 7–8)"), "{out}");
    assert!(out.contains("active offered:") && out.contains("passive offered:"), "{out}");
    // Iteration 0 is the same prior for both conditions: no difference, so no test.
    let row0 = out.lines().find(|l| l.trim_start().starts_with("0 ")).unwrap();
    assert!(row0.contains("no difference"), "{row0}");
    assert!(out.contains("paired difference") && out.contains("p="), "{out}");
    assert!(out.contains("distance of the posterior mean to the true q* (degrees)"), "{out}");
}

#[test]
fn a_dry_run_versus_a_second_protocol_pairs_the_same_participants() {
    let dir = tmpdir("versus");
    let proto = small_protocol(&dir);
    let logs = dir.join("logs");
    let run = |versus: &Path| {
        handover(&[
            "dry-run",
            "--protocol",
            proto.to_str().unwrap(),
            "--versus",
            versus.to_str().unwrap(),
            "--participants",
            "2",
            "--seeds",
            "2",
            "--seed",
            "3",
            "--logs",
            logs.to_str().unwrap(),
        ])
    };
    // The same protocol twice: the same participants give the same sessions, so every paired
    // difference is exactly zero — which holds only if participants are matched correctly.
    let (code, out, err) = run(&proto);
    assert_eq!(code, 0, "{err}");
    assert_eq!(logs_in(&logs).len(), 8, "2 participants × 2 seeds × 2 protocols, each logged");
    let across = &out[out.find("A − B for the same participants").expect(&out)..];
    assert!(across.contains("test log-likelihood"), "the same observation model: both measures\n{across}");
    let rows: Vec<&str> =
        across.lines().filter(|l| l.trim_start().chars().next().is_some_and(|c| c.is_ascii_digit())).collect();
    assert_eq!(rows.len(), 12, "6 iterations × 2 measures\n{across}");
    assert!(rows.iter().all(|r| r.matches("no difference").count() == 2), "{across}");
    // The paper's configuration-observation variant: the participants are the same, the
    // updates differ.
    let mut v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&proto).unwrap()).unwrap();
    v["learning"]["observation"] = "configuration".into();
    let configuration = dir.join("configuration.json");
    std::fs::write(&configuration, v.to_string()).unwrap();
    let (code, out, err) = run(&configuration);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("protocol B = ") && out.contains("(observation: configuration)"), "{out}");
    let across = &out[out.find("A − B for the same participants").expect(&out)..];
    assert!(!across.contains("test log-likelihood of the posterior mean,"), "{across}");
    assert!(across.contains("not compared"), "{across}");
    assert!(across.contains("p="), "some difference is tested\n{across}");
}

#[test]
fn participant_new_refuses_a_body_the_protocol_cannot_serve_without_taking_a_slot() {
    // The default protocol's poses are fixed in metres today: a 1.60 m participant cannot
    // reach some grips (issue: poses that scale with the body). Refused at creation.
    let dir = tmpdir("body");
    let (code, out, err) =
        handover(&["participant", "new", "--body-height", "1.60", "--study-dir", dir.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(out.is_empty(), "no id is printed: {out}");
    assert!(
        err.contains("a 1.6 m participant cannot take part") && err.contains("no feasible arm configuration"),
        "{err}"
    );
    assert!(!dir.join("participants").exists(), "no record, no folder");
    let (code, out, err) =
        handover(&["participant", "new", "--body-height", "1.80", "--study-dir", dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(out.trim().starts_with("p-"), "{out}");
}

#[test]
fn protocol_check_checks_one_body_or_reports_the_heights_it_serves() {
    let proto = Path::new(env!("CARGO_MANIFEST_DIR")).join("protocols/bike-handover.json");
    let p = proto.to_str().unwrap();
    let (code, out, err) = handover(&["protocol", "check", p, "--body-height", "1.80"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("arm of a 1.8 m participant") && out.contains("upper arm 0.335 m"), "{out}");
    let (code, _, err) = handover(&["protocol", "check", p, "--body-height", "1.60"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("no feasible arm configuration"), "{err}");
    let (code, _, err) = handover(&["protocol", "check", p, "--body-height", "9"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--body-height is 9"), "{err}");
    // Every 5 cm from 1.50 to 1.95 m, each served or not with its first problem; the count
    // agrees with one-body checks (today's fixed poses serve 1.70 m and up).
    let (code, out, err) = handover(&["protocol", "check", p, "--bodies"]);
    assert_eq!(code, 0, "{err}");
    let rows: Vec<&str> = out.lines().filter(|l| l.trim_start().starts_with("1.")).collect();
    assert_eq!(rows.len(), 10, "{out}");
    let served = rows.iter().filter(|r| r.ends_with("served") && !r.contains("not served")).count();
    assert!(out.contains(&format!("{served} of 10 heights served")), "{out}");
    assert!(rows.iter().any(|r| r.starts_with("  1.80 m  served")), "{out}");
    assert!(rows.iter().any(|r| r.starts_with("  1.60 m  not served")), "{out}");
}
