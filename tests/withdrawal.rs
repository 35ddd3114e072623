//! A participant's right to withdraw: `participant withdraw`, with and without deleting
//! their data, as an experimenter runs it.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Arc;
use std::time::Duration;

use handover::counterbalance::completed_per_slot;
use handover::dryrun::{drive, now_ns, plan};
use handover::participant::ParticipantRecord;
use handover::protocol::Study;
use handover::record::{RecordedSession, mcap_files, new_log_path};
use handover::session::Session;

fn handover(args: &[&str]) -> (i32, String, String) {
    handover_in(&std::env::temp_dir(), args)
}

/// The command run from `cwd`: a folder that is not the study's.
fn handover_in(cwd: &Path, args: &[&str]) -> (i32, String, String) {
    let out =
        Command::new(env!("CARGO_BIN_EXE_handover")).args(args).current_dir(cwd).stdin(Stdio::null()).output().unwrap();
    (out.status.code().unwrap_or(-1), String::from_utf8(out.stdout).unwrap(), String::from_utf8(out.stderr).unwrap())
}

fn study_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("handover-withdraw-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A new participant (by the CLI) with one completed real session in their slot.
fn participant_with_a_session(dir: &Path) -> (String, usize) {
    participant_with(dir, true)
}

/// A new participant with one real session, completed or cut off after a few events (a crash).
fn participant_with(dir: &Path, complete: bool) -> (String, usize) {
    let (code, out, err) = handover(&["participant", "new", "--study-dir", dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let id = out.trim().to_string();
    let rec = ParticipantRecord::load(&dir.join("participants"), &id).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 150.into();
    v["session"]["trials_per_condition"] = 2.into();
    let text = v.to_string();
    let study = Arc::new(Study::from_json(&text, "small").unwrap());
    let mut p = plan(&study, 3, rec.slot, None, "2026-11-22T00:00:00Z".into());
    p.start.pilot = false;
    p.start.participant = id.clone();
    p.start.slot = rec.slot;
    p.start.simulated_truth = None;
    p.start.condition_order = handover::session::condition_order(&study, rec.slot);
    let session = Session::new(Arc::clone(&study), p.start.clone()).unwrap();
    let path = new_log_path(&dir.join("logs"), &id, chrono::Utc::now());
    let mut rec_s = RecordedSession::create(&path, &text, session, now_ns()).unwrap();
    if complete {
        drive(&mut rec_s, &p.participant, Duration::ZERO).unwrap();
        rec_s.finish().unwrap();
    } else {
        for _ in 0..3 {
            let event = p.participant.respond(rec_s.session()).unwrap();
            rec_s.submit(handover::session::Stamped { time_ns: now_ns(), event }).unwrap();
        }
    }
    (id, rec.slot)
}

#[test]
fn a_withdrawn_participant_is_left_out_and_frees_their_slot() {
    let dir = study_dir("keep");
    let (id, slot) = participant_with_a_session(&dir);
    let (logs, participants) = (dir.join("logs"), dir.join("participants"));
    let mut before = vec![0, 0];
    before[slot] = 1;
    assert_eq!(completed_per_slot(&logs, &participants, 2).completed, before);
    let analyse = || {
        handover(&[
            "analyze",
            logs.to_str().unwrap(),
            "--study-dir",
            dir.to_str().unwrap(),
            "--format",
            "json",
            "--alpha-particles",
            "200",
        ])
    };
    let (code, json, err) = analyse();
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["real"]["sessions"], 1);

    let (code, _, err) = handover(&["participant", "withdraw", &id, "--study-dir", dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("withdrew"), "{err}");
    let rec = ParticipantRecord::load(&participants, &id).unwrap();
    assert!(rec.is_withdrawn());
    assert_eq!(rec.slot, slot, "the rest of the record is kept");
    assert_eq!(mcap_files(&logs).len(), 1, "without --delete-data the log is kept");
    assert_eq!(completed_per_slot(&logs, &participants, 2).completed, vec![0, 0], "the slot is free again");
    let (code, json, err) = analyse();
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("left out 1 session(s) of 1 participant(s) who withdrew"), "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert!(v["real"].is_null(), "no real session is counted: {}", v["real"]);
    assert_eq!(v["withdrawn_left_out"]["sessions"], 1);
    // Run from another folder, without --study-dir: the log's own study decides, and says so.
    let elsewhere = study_dir("keep-elsewhere");
    let (code, json, err) =
        handover_in(&elsewhere, &["analyze", logs.to_str().unwrap(), "--format", "json", "--alpha-particles", "200"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("left out 1 session(s) of 1 participant(s) who withdrew"), "{err}");
    assert!(err.contains(&participants.display().to_string()), "the study folder used is named: {err}");
    assert!(serde_json::from_str::<serde_json::Value>(&json).unwrap()["real"].is_null());
    // Withdrawing again keeps the first time.
    let first = rec.withdrawn_at.clone();
    let (code, _, _) = handover(&["participant", "withdraw", &id, "--study-dir", dir.to_str().unwrap()]);
    assert_eq!(code, 0);
    assert_eq!(ParticipantRecord::load(&participants, &id).unwrap().withdrawn_at, first);
}

#[test]
fn an_interrupted_session_of_a_withdrawn_participant_is_not_continued() {
    let dir = study_dir("resume");
    let (id, _) = participant_with(&dir, false);
    let log = mcap_files(&dir.join("logs")).pop().unwrap();
    let (code, _, err) = handover(&["participant", "withdraw", &id, "--study-dir", dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let (code, _, err) = handover(&["resume", log.to_str().unwrap(), "--study-dir", dir.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("withdrew from the study; their session is not continued"), "{err}");
    // From any folder, without --study-dir: the log's own study decides.
    let elsewhere = study_dir("resume-elsewhere");
    let (code, _, err) = handover_in(&elsewhere, &["resume", log.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("withdrew from the study; their session is not continued"), "{err}");
    assert_eq!(mcap_files(&dir.join("logs")).len(), 1, "no continuation written");
}

#[test]
fn delete_data_removes_every_file_of_theirs_only_once_confirmed() {
    let dir = study_dir("delete");
    let (id, _) = participant_with_a_session(&dir);
    let (other, _) = participant_with_a_session(&dir);
    let (logs, participants) = (dir.join("logs"), dir.join("participants"));
    let args = |extra: &[&str]| {
        let mut a = vec!["participant", "withdraw", id.as_str(), "--delete-data", "--study-dir", dir.to_str().unwrap()];
        a.extend_from_slice(extra);
        a.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let run = |a: Vec<String>| handover(&a.iter().map(String::as_str).collect::<Vec<_>>());
    // Not on a terminal and without --yes: nothing is deleted (but the withdrawal stands).
    let (code, out, err) = run(args(&[]));
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--yes"), "{err}");
    assert!(out.contains(&format!("{id}.json")) && out.contains(".mcap"), "the files are listed first\n{out}");
    assert!(logs.join(&id).is_dir() && participants.join(format!("{id}.json")).exists());
    assert!(ParticipantRecord::load(&participants, &id).unwrap().is_withdrawn());
    let (code, out, err) = run(args(&["--yes"]));
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("will be deleted"), "{out}");
    assert!(!logs.join(&id).exists(), "their log folder is gone");
    assert!(!participants.join(format!("{id}.json")).exists(), "their record is gone");
    let rest: Vec<String> = walk(&dir).iter().map(|p| p.display().to_string()).collect();
    assert!(rest.iter().all(|p| !p.contains(&id)), "no file of theirs is left: {rest:?}");
    assert!(logs.join(&other).is_dir() && participants.join(format!("{other}.json")).exists(), "others are kept");
    let (code, _, err) = run(args(&["--yes"]));
    assert_eq!(code, 2, "a deleted participant is not there to withdraw: {err}");
    // Input is checked before anything is touched.
    let (code, _, err) = handover(&["participant", "withdraw", "../x", "--study-dir", dir.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p.clone());
            }
            out.push(p);
        }
    }
    out
}
