//! The study commands as a user runs them: protocol check, participant new/show, dry-run,
//! resume.
//!
//! Its length: the study commands a researcher runs (participant, protocol check, dry runs,
//! help), one test each.

use crate::support::{handover, tmpdir};

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use handover::record::read_log;
use handover::session::Event;

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
    let proto = concat!(env!("CARGO_MANIFEST_DIR"), "/protocols/bike-handover.json");
    let (code, out, err) = handover(&["protocol", "check", proto]);
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
    let (code, out, err) = handover(&[
        "participant",
        "new",
        "--participants-dir",
        parts.to_str().unwrap(),
        "--logs",
        logs.to_str().unwrap(),
    ]);
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
    let (_, out2, _) = handover(&[
        "participant",
        "new",
        "--participants-dir",
        parts.to_str().unwrap(),
        "--logs",
        logs.to_str().unwrap(),
    ]);
    let v2: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(parts.join(format!("{}.json", out2.trim()))).unwrap()).unwrap();
    assert_eq!(v2["slot"], 1, "the first participant, registered and waiting, holds slot 0");
    // A day's participants registered in a row are balanced, and the balance is said.
    let mut slots = vec![0, 1];
    for _ in 0..4 {
        let (code, out, err) = handover(&[
            "participant",
            "new",
            "--participants-dir",
            parts.to_str().unwrap(),
            "--logs",
            logs.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{err}");
        assert!(err.contains("counterbalancing so far: slot 0: ") && err.contains("waiting"), "{err}");
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(parts.join(format!("{}.json", out.trim()))).unwrap())
                .unwrap();
        slots.push(v["slot"].as_u64().unwrap());
    }
    assert_eq!(slots, vec![0, 1, 0, 1, 0, 1]);
    let (code, show, _) = handover(&["participant", "show", id, "--participants-dir", parts.to_str().unwrap()]);
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
    let (code, out, err) = handover(&[
        "participant",
        "new",
        "--participants-dir",
        parts.to_str().unwrap(),
        "--logs",
        logs.to_str().unwrap(),
    ]);
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
        let (code, _, err) = handover(&["participant", "show", bad, "--participants-dir", dir.to_str().unwrap()]);
        assert_eq!(code, 2, "{bad}: {err}");
        assert!(err.contains("invalid"), "{err}");
        let (code, _, err) = handover(&["run", "--participant", bad]);
        assert_eq!(code, 2, "run --participant {bad}: {err}");
    }
    let (code, _, err) = handover(&["participant", "show", "p-unknown", "--participants-dir", dir.to_str().unwrap()]);
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
        vec!["resume", truth.to_str().unwrap(), "--no-console"],
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
        if k == 0 {
            // A resource that is not there (the live view's port is taken) is found before
            // the continuation's file is made.
            let busy = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
            let addr = busy.local_addr().unwrap().to_string();
            let (code, _, err) = handover(&["resume", crashed[0].to_str().unwrap(), "--no-console", "--live", &addr]);
            assert_ne!(code, 0, "a busy port: {err}");
            assert!(err.contains(&addr), "names the port: {err}");
            assert_eq!(logs_in(&logs).len(), 1, "no continuation file is left: {err}");
        }
        let (code, _, err) = handover(&["resume", crashed[0].to_str().unwrap(), "--no-console"]);
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
    // Beside the mean: the median and the share of participants with the first higher.
    let spread: Vec<&str> =
        out.lines().filter(|l| l.contains("(active − passive at the last iteration: median ")).collect();
    assert_eq!(spread.len(), 2, "one per measure: {out}");
    assert!(spread.iter().all(|l| l.contains(" % of 6 participants with the first higher)")), "{spread:?}");

    // The 90 % intervals' coverage of the true q*, counted again from the logs at the last
    // iteration: the logged interval against the logged truth.
    assert!(out.contains("90 % credible intervals of q* holding the true value (of 42 participant-joints)"), "{out}");
    assert!(out.contains("mean |error| of the posterior mean's q* per joint at iteration 5"), "{out}");
    for condition in ["active", "passive"] {
        let (mut held, mut of) = (0, 0);
        let mut error_q1 = 0.0;
        for f in logs_in(&logs) {
            let log = read_log(&f).unwrap();
            let start = log.messages.iter().find(|m| m.topic == "/session/start").unwrap();
            let truth = &start.value["simulated_truth"]["q_star"];
            let last = log.messages.iter().rfind(|m| m.topic == format!("/belief/{condition}")).unwrap();
            assert_eq!(last.value["iteration"], 5);
            error_q1 +=
                (last.value["mean"]["q_star"][0].as_f64().unwrap() - truth[0].as_f64().unwrap()).abs().to_degrees()
                    / 6.0;
            for j in 0..7 {
                let (lo, hi) = (&last.value["ci90"]["low"]["q_star"][j], &last.value["ci90"]["high"]["q_star"][j]);
                let t = truth[j].as_f64().unwrap();
                of += 1;
                held += usize::from(lo.as_f64().unwrap() <= t && t <= hi.as_f64().unwrap());
            }
        }
        let line = out.lines().find(|l| l.starts_with(&format!("  ({condition} at iteration 5, by joint: "))).unwrap();
        assert_eq!(of, 42, "{line}");
        let row5 = out
            .lines()
            .skip_while(|l| !l.contains("90 % credible intervals of q*"))
            .find(|l| l.trim_start().starts_with("5 "))
            .unwrap();
        let shares: Vec<&str> = row5.split_whitespace().collect();
        let column = if condition == "active" { 1 } else { 3 };
        assert_eq!(shares[column], format!("{:.1}", 100.0 * held as f64 / of as f64), "{row5}");
        let q1: Vec<&str> =
            out.lines().find(|l| l.trim_start().starts_with("q*1 ")).unwrap().split_whitespace().collect();
        assert_eq!(q1[if condition == "active" { 2 } else { 3 }], format!("{error_q1:.1}"), "{q1:?}");
    }
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
    // The default protocol serves 1.50–1.95 m (its poses scale with the reach, the objects
    // do not): a 1.40 m participant cannot reach some grips. Refused at creation.
    let dir = tmpdir("body");
    let (code, out, err) = handover(&[
        "participant",
        "new",
        "--body-height",
        "1.40",
        "--handedness",
        "left",
        "--study-dir",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(out.is_empty(), "no id is printed: {out}");
    assert!(
        err.contains("a 1.4 m participant's left arm cannot be served")
            && err.contains("no feasible arm configuration"),
        "{err}"
    );
    assert!(!dir.join("participants").exists(), "no record, no folder");
    let (code, out, err) = handover(&[
        "participant",
        "new",
        "--body-height",
        "1.50",
        "--handedness",
        "left",
        "--study-dir",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let id = out.trim();
    let record = std::fs::read_to_string(dir.join("participants").join(format!("{id}.json"))).unwrap();
    assert!(record.contains("\"handedness\": \"left\"") && record.contains("1.5"), "{record}");
}

#[test]
fn protocol_check_checks_one_body_or_reports_the_bodies_it_serves() {
    let proto = Path::new(env!("CARGO_MANIFEST_DIR")).join("protocols/bike-handover.json");
    let p = proto.to_str().unwrap();
    let (code, out, err) = handover(&["protocol", "check", p, "--body-height", "1.80"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("a 1.8 m participant's right arm") && out.contains("upper arm 0.335 m"), "{out}");
    assert!(out.contains("poses written for a 1.75 m body, scaled ×1.029"), "{out}");
    let (code, out, err) = handover(&["protocol", "check", p, "--body-height", "1.50", "--handedness", "left"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("left arm") && out.contains("scaled ×0.857"), "{out}");
    let (code, _, err) = handover(&["protocol", "check", p, "--body-height", "1.40"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("no feasible arm configuration"), "{err}");
    let (code, _, err) = handover(&["protocol", "check", p, "--body-height", "9"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--body-height is 9"), "{err}");
    // Every 5 cm from 1.50 to 1.95 m with either hand: all served, and the rows agree with
    // the one-body checks above.
    let (code, out, err) = handover(&["protocol", "check", p, "--bodies"]);
    assert_eq!(code, 0, "{err}");
    let rows: Vec<&str> = out.lines().filter(|l| l.trim_start().starts_with("1.")).collect();
    assert_eq!(rows.len(), 20, "{out}");
    assert!(rows.iter().all(|r| r.contains("  served (feasible sets of")), "{out}");
    assert!(rows.iter().any(|r| r.starts_with("  1.50 m  left   served")), "{out}");
    assert!(out.contains("20 of 20 bodies served"), "{out}");
}

/// Dry runs draw bodies from adult stature with a share left-handed, each session run (and
/// logged) for its body; a fixed body runs whole sessions at both ends of the range with
/// either hand.
#[test]
fn dry_runs_draw_bodies_and_run_whole_sessions_at_the_ends_of_the_range() {
    let dir = tmpdir("bodies");
    let mut v: serde_json::Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 100.into();
    v["session"]["trials_per_condition"] = 1.into();
    let proto = dir.join("small.json");
    std::fs::write(&proto, v.to_string()).unwrap();
    let (p, logs) = (proto.to_str().unwrap(), dir.join("logs"));
    let (code, out, err) = handover(&[
        "dry-run",
        "--protocol",
        p,
        "--participants",
        "6",
        "--left-handed-share",
        "0.5",
        "--logs",
        logs.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let bodies: Vec<&str> = out.lines().filter(|l| l.starts_with("pilot-")).collect();
    assert_eq!(bodies.len(), 6, "{out}");
    assert!(bodies.iter().any(|l| l.contains("left arm")) && bodies.iter().any(|l| l.contains("right arm")), "{out}");
    let mut heights = Vec::new();
    for f in handover::record::mcap_files(&logs) {
        let log = read_log(&f).unwrap();
        let study = handover::record::study_of(&log).unwrap();
        let h = study.protocol.arm.body_height_m.expect("a drawn height is written into the protocol as run");
        assert!((1.50..=1.95).contains(&h), "{h}");
        assert!(bodies.iter().any(|l| l.starts_with(&log.start.participant) && l.contains(&format!("a {h} m"))));
        heights.push(h);
    }
    heights.dedup();
    assert!(heights.len() > 1, "heights vary: {heights:?}");
    assert!(out.contains("by body (height band"), "{out}");
    for (h, hand) in [("1.50", "left"), ("1.50", "right"), ("1.95", "left"), ("1.95", "right")] {
        let logs = dir.join(format!("logs-{h}-{hand}"));
        let (code, out, err) = handover(&[
            "dry-run",
            "--protocol",
            p,
            "--body-height",
            h,
            "--handedness",
            hand,
            "--logs",
            logs.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{h} {hand}: {err}");
        assert!(out.contains("(completed; a ") && out.contains(&format!("{hand} arm")), "{out}");
    }
    let (code, _, err) = handover(&["dry-run", "--protocol", p, "--left-handed-share", "1.5"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--left-handed-share is 1.5"), "{err}");
    let (code, _, err) = handover(&["dry-run", "--protocol", p, "--body-height", "1.3", "--handedness", "left"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("no feasible arm configuration"), "{err}");
}

/// Shell completions and the manual page are generated from the one command-line definition.
#[test]
fn completions_and_the_man_page_cover_every_subcommand() {
    let (code, bash, err) = handover(&["completions", "bash"]);
    assert_eq!(code, 0, "{err}");
    let (code, man, err) = handover(&["man"]);
    assert_eq!(code, 0, "{err}");
    assert!(man.contains(".TH handover 1"), "{man}");
    for sub in ["run", "dry-run", "analyze", "participant", "protocol", "resume", "research", "feasible"] {
        assert!(
            bash.contains(&format!("handover__subcmd__{}", sub.replace('-', "__subcmd__"))),
            "bash completes {sub}"
        );
        assert!(man.contains(&format!("handover\\-{}(1)", sub.replace('-', "\\-"))), "man lists {sub}");
    }
    assert!(bash.contains("--participants-dir") && bash.contains("--body-height"));
    let (code, _, err) = handover(&["completions", "nosh"]);
    assert_eq!(code, 2, "{err}");
}

/// Every command's `--help` says what it writes (or that it writes no file).
#[test]
fn every_help_says_what_the_command_writes() {
    let help = |args: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_handover")).args(args).output().unwrap();
        assert!(out.status.success(), "{args:?}");
        String::from_utf8(out.stdout).unwrap()
    };
    let commands = [
        vec!["run"],
        vec!["feasible"],
        vec!["research"],
        vec!["research", "simulate"],
        vec!["research", "front"],
        vec!["research", "observations"],
        vec!["research", "score"],
        vec!["protocol", "check"],
        vec!["participant", "new"],
        vec!["participant", "withdraw"],
        vec!["participant", "show"],
        vec!["dry-run"],
        vec!["resume"],
        vec!["follow"],
        vec!["status"],
        vec!["analyze"],
        vec!["completions"],
        vec!["man"],
    ];
    let listed = help(&["--help"]);
    for c in &commands {
        assert!(listed.contains(&format!("  {} ", c[0])), "{} is a command: {listed}", c[0]);
        let mut args = c.clone();
        args.push("--help");
        let text = help(&args);
        assert!(text.contains("Writes:"), "handover {} --help says what it writes:\n{text}", c.join(" "));
    }
}

/// `handover status`: participants by state, pilots, the slots and the next one, the sessions
/// not over with the whole command that continues each, and unreadable logs (exit 1), as a
/// table and as JSON.
#[test]
fn status_shows_where_the_study_stands() {
    use std::sync::Arc;
    let dir = tmpdir("status");
    let (parts, logs) = (dir.join("participants"), dir.join("logs"));
    let d = dir.to_str().unwrap();
    // Before anything is in it, the folder is not a study: said, exit 2, not an empty study.
    let (code, out, err) = handover(&["status", "--study-dir", d]);
    assert_eq!((code, out.as_str()), (2, ""), "{err}");
    assert!(err.contains(&format!("{d} is not a study: it has neither {d}/participants nor {d}/logs")), "{err}");
    let mut ids = Vec::new();
    for _ in 0..4 {
        let (code, out, err) = handover(&["participant", "new", "--study-dir", d]);
        assert_eq!(code, 0, "{err}");
        ids.push(out.trim().to_string());
    }
    let text = std::fs::read_to_string(small_protocol(&dir)).unwrap();
    let study = Arc::new(handover::protocol::Study::from_json(&text, "small").unwrap());
    // ids[0] completes a session, ids[1] stops half-way, ids[3] withdraws; ids[2] waits.
    for (k, finish) in [(0usize, true), (1, false)] {
        let rec_slot = handover::participant::ParticipantRecord::load(&parts, &ids[k]).unwrap().slot;
        let mut p = handover::dryrun::plan(&study, 3, k, None, "2026-11-22T00:00:00Z".into());
        p.start.pilot = false;
        p.start.simulated_truth = None;
        p.start.participant = ids[k].clone();
        p.start.slot = rec_slot;
        p.start.condition_order = handover::session::condition_order(&study, rec_slot);
        let session = handover::session::Session::new(Arc::clone(&study), p.start.clone()).unwrap();
        let path = handover::record::new_log_path(&logs, &ids[k], chrono::Utc::now());
        let mut rec = handover::record::RecordedSession::create(&path, &text, session, 1).unwrap();
        if finish {
            handover::dryrun::drive(&mut rec, &p.participant, Duration::ZERO).unwrap();
        } else {
            for _ in 0..4 {
                let e = p.participant.respond(rec.session()).unwrap();
                rec.submit(handover::session::Stamped { time_ns: 2, event: e }).unwrap();
            }
        }
        rec.finish().unwrap();
    }
    assert_eq!(handover(&["participant", "withdraw", &ids[3], "--study-dir", d]).0, 0);
    assert_eq!(
        handover(&[
            "dry-run",
            "--protocol",
            dir.join("small.json").to_str().unwrap(),
            "--logs",
            logs.to_str().unwrap()
        ])
        .0,
        0
    );
    let (code, out, err) = handover(&["status", "--study-dir", d]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("4 registered: 1 completed, 1 in progress, 1 waiting, 0 dropped out, 1 withdrawn"), "{out}");
    assert!(out.contains(&format!("waiting: {}", ids[2])), "{out}");
    assert!(out.contains("Pilot sessions (dry runs, rehearsals, pilots): 1 completed"), "{out}");
    assert!(out.contains(&format!("continue: handover resume --participant {} --study-dir {d}", ids[1])), "{out}");
    assert!(out.contains("2 trials"), "{out}");
    assert!(out.contains("← the next new participant"), "{out}");
    let (code, json, _) = handover(&["status", "--study-dir", d, "--format", "json"]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["participants"].as_array().unwrap().len(), 4);
    assert_eq!(v["open_sessions"].as_array().unwrap().len(), 1);
    assert_eq!(v["open_sessions"][0]["participant"], ids[1].as_str());
    let waiting: u64 = v["slots"].as_array().unwrap().iter().map(|s| s["waiting"].as_u64().unwrap()).sum();
    let completed: u64 = v["slots"].as_array().unwrap().iter().map(|s| s["completed"].as_u64().unwrap()).sum();
    assert_eq!((completed, waiting), (1, 2), "the withdrawn participant holds no slot");
    // A log that cannot be read is named, and the exit status says so.
    std::fs::write(logs.join("broken.mcap"), b"not a log").unwrap();
    let (code, out, _) = handover(&["status", "--study-dir", d]);
    assert_eq!(code, 1);
    assert!(out.contains("broken.mcap") && out.contains("MCAP magic"), "{out}");
}

/// docs/reference.md is the program's own `man --format markdown`: it cannot drift from the
/// commands and flags the program accepts.
#[test]
fn the_reference_is_generated_from_the_command_line() {
    let (code, out, err) = handover(&["man", "--format", "markdown"]);
    assert_eq!(code, 0, "{err}");
    let file = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/reference.md")).unwrap();
    assert!(
        file == out,
        "docs/reference.md is out of date: regenerate it with `cargo run -- man --format markdown > docs/reference.md`"
    );
    for command in ["run", "resume", "status", "analyze", "participant new", "dry-run", "follow"] {
        assert!(out.contains(&format!("`handover {command}`")), "{command}");
    }
}

/// `HANDOVER_STUDY_DIR` names the study folder for the commands that take `--study-dir`'s
/// shared folders (`run`, `participant`, `status`; `analyze` with no log and `resume
/// --participant` in `durability.rs`); the flag wins over it.
#[test]
fn the_study_folder_can_come_from_the_environment() {
    let dir = tmpdir("env-study");
    let run = |envdir: &std::path::Path, args: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_handover"))
            .args(args)
            .env("HANDOVER_STUDY_DIR", envdir)
            .current_dir(std::env::temp_dir())
            .output()
            .unwrap();
        (out.status.code(), String::from_utf8_lossy(&out.stdout).into_owned())
    };
    let (code, id) = run(&dir, &["participant", "new"]);
    assert_eq!(code, Some(0));
    assert!(dir.join("participants").join(format!("{}.json", id.trim())).is_file());
    let (_, status) = run(&dir, &["status"]);
    assert!(status.contains("1 registered"), "{status}");
    let other = tmpdir("env-study-flag");
    std::fs::create_dir(other.join("participants")).unwrap();
    let (_, status) = run(&dir, &["status", "--study-dir", other.to_str().unwrap()]);
    assert!(status.contains("0 registered"), "the flag wins: {status}");
}

/// What cannot be read is named and never dropped from a count in silence: a log folder that
/// cannot be listed (`status` and `analyze` exit 1 naming it), and a participant record with
/// another id inside or a second JSON document (`status` exits 1 naming it, `participant
/// new` names it as not counted toward counterbalancing).
#[test]
fn unreadable_folders_and_records_are_named_not_dropped() {
    let dir = tmpdir("unreadable");
    let d = dir.to_str().unwrap();
    let p = small_protocol(&dir);
    let (code, _, err) =
        handover(&["dry-run", "--protocol", p.to_str().unwrap(), "--participants", "2", "--study-dir", d]);
    assert_eq!(code, 0, "{err}");
    let folders: Vec<PathBuf> = std::fs::read_dir(dir.join("logs")).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(folders.len(), 2);
    let hidden = &folders[0];
    // Unlistable: mode 0 for an unprivileged user; as root (who lists any folder), the
    // commands run as `nobody` on a study owned by nobody.
    use std::os::unix::fs::PermissionsExt;
    let root = unsafe { libc::geteuid() } == 0;
    let run = |args: &[&str]| -> (i32, String, String) {
        if !root {
            return handover(args);
        }
        let o = Command::new("setpriv")
            .args(["--reuid", "65534", "--regid", "65534", "--clear-groups", env!("CARGO_BIN_EXE_handover")])
            .args(args)
            .stdin(Stdio::null())
            .output()
            .unwrap();
        (
            o.status.code().unwrap_or(-1),
            String::from_utf8_lossy(&o.stdout).into(),
            String::from_utf8_lossy(&o.stderr).into(),
        )
    };
    if root {
        let chown = Command::new("chown").args(["-R", "65534:65534", d]).status().unwrap();
        assert!(chown.success());
        std::fs::set_permissions(&*dir, std::fs::Permissions::from_mode(0o755)).unwrap();
        std::fs::set_permissions(dir.parent().unwrap(), std::fs::Permissions::from_mode(0o1777)).ok();
    }
    std::fs::set_permissions(hidden, std::fs::Permissions::from_mode(0o000)).unwrap();
    let (code, out, err) = run(&["status", "--study-dir", d, "--protocol", p.to_str().unwrap()]);
    assert_eq!(code, 1, "{out}{err}");
    assert!(out.contains(&format!("{}: the folder cannot be listed", hidden.display())), "{out}");
    let (code, out, err) = run(&["analyze", "--study-dir", d, "--alpha-particles", "20"]);
    assert_eq!(code, 1, "{out}{err}");
    assert!(err.contains(&format!("skipped {}: the folder cannot be listed", hidden.display())), "{err}");
    std::fs::set_permissions(hidden, std::fs::Permissions::from_mode(0o700)).unwrap();

    // A record whose id is not its file's, and one with trailing JSON.
    let (code, out, err) = handover(&["participant", "new", "--study-dir", d]);
    assert_eq!(code, 0, "{err}");
    let id = out.trim();
    let record = dir.join(format!("participants/{id}.json"));
    let text = std::fs::read_to_string(&record).unwrap();
    std::fs::write(dir.join("participants/p-zzzzzzzz.json"), &text).unwrap();
    std::fs::write(&record, format!("{text}{{}}")).unwrap();
    let (code, out, err) = handover(&["status", "--study-dir", d, "--protocol", p.to_str().unwrap()]);
    assert_eq!(code, 1, "{out}{err}");
    assert!(out.contains("Participant records that cannot be read"), "{out}");
    assert!(out.contains("p-zzzzzzzz.json") && out.contains(&format!("{id}.json")), "{out}");
    let (code, _, err) = handover(&["participant", "new", "--study-dir", d]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("p-zzzzzzzz.json is not counted toward counterbalancing"), "{err}");
}

/// `follow` started with the log path the setup screen shows, before the session starts,
/// waits for the log to appear and then reads it (here it then stops, with no terminal to
/// draw on); a path in no study's `logs/` is refused at once.
#[test]
fn follow_waits_for_a_log_the_console_has_named() {
    let dir = tmpdir("follow-wait");
    std::fs::create_dir(dir.join("logs")).unwrap();
    let log = dir.join("logs/p-abcdefgh/p-abcdefgh_20261207T120000Z.mcap");
    let mut child = Command::new(env!("CARGO_BIN_EXE_handover"))
        .args(["follow", log.to_str().unwrap()])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    assert!(child.try_wait().unwrap().is_none(), "it waits for the log");
    std::fs::create_dir(log.parent().unwrap()).unwrap();
    let golden = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/format-4/dry-run.mcap");
    std::fs::copy(golden, &log).unwrap();
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("not there yet; waiting for the console to start the session"), "{err}");
    // It read the log: what stops it now is the missing terminal, not the log.
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("needs an interactive terminal"), "{err}");
    let (code, _, err) = handover(&["follow", dir.join("nowhere/p-x/p-x_1.mcap").to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(!err.contains("waiting"), "{err}");
}
