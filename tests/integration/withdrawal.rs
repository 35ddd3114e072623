//! A participant's right to withdraw: `participant withdraw`, with and without deleting
//! their data, as an experimenter runs it.

use crate::support::{handover, handover_in};

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use handover::counterbalance::completed_per_slot;
use handover::dryrun::{drive, now_ns, plan};
use handover::participant::ParticipantRecord;
use handover::protocol::Study;
use handover::record::{RecordedSession, mcap_files, new_log_path};
use handover::session::Session;

fn study_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("handover-withdraw-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A new participant (by the CLI) with one completed real session in their slot.
fn participant_with_a_session(dir: &Path) -> (String, usize) {
    participant_with(dir, None)
}

/// A new participant with one real session, completed (`cut_after` None) or cut off after
/// that many events (a crash).
fn participant_with(dir: &Path, cut_after: Option<usize>) -> (String, usize) {
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
    p.start.session_id = format!("{:016x}", rand::random::<u64>());
    p.start.slot = rec.slot;
    p.start.simulated_truth = None;
    p.start.condition_order = handover::session::condition_order(&study, rec.slot);
    let session = Session::new(Arc::clone(&study), p.start.clone()).unwrap();
    let path = new_log_path(&dir.join("logs"), &id, chrono::Utc::now());
    let mut rec_s = RecordedSession::create(&path, &text, session, now_ns()).unwrap();
    if let Some(events) = cut_after {
        for _ in 0..events {
            let event = p.participant.respond(rec_s.session()).unwrap();
            rec_s.submit(handover::session::Stamped { time_ns: now_ns(), event }).unwrap();
        }
    } else {
        drive(&mut rec_s, &p.participant, Duration::ZERO).unwrap();
        rec_s.finish().unwrap();
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
    let (id, _) = participant_with(&dir, Some(3));
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
    // status offers no resume for them; a session that logged only its start is dated by it.
    let (started_only, _) = participant_with(&dir, Some(0));
    let (code, out, err) = handover(&["status", "--study-dir", dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{out}{err}");
    let theirs: Vec<&str> = out.lines().skip_while(|l| !l.trim_start().starts_with(&id)).take(2).collect();
    assert!(theirs[1].contains("the participant withdrew: not to be continued"), "{out}");
    assert!(!out.contains(&format!("participant {id}")), "no command continues them: {out}");
    let line = out.lines().find(|l| l.trim_start().starts_with(&started_only)).unwrap();
    assert!(line.contains("0 trials, last event 2026-11-22T00:00:00Z"), "{line}");
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
    let tombstone = participants.join(format!("{id}.deleted.json"));
    let rest: Vec<String> = walk(&dir).iter().filter(|p| **p != tombstone).map(|p| p.display().to_string()).collect();
    assert!(rest.iter().all(|p| !p.contains(&id)), "no file of theirs is left but the tombstone: {rest:?}");
    let kept: serde_json::Value = serde_json::from_slice(&std::fs::read(&tombstone).unwrap()).unwrap();
    let mut keys: Vec<&str> = kept.as_object().unwrap().keys().map(String::as_str).collect();
    keys.sort();
    assert_eq!(keys, ["data_deleted_at", "id", "withdrawn_at"], "the tombstone holds the id and dates only");
    assert!(logs.join(&other).is_dir() && participants.join(format!("{other}.json")).exists(), "others are kept");
    let (code, _, err) = run(args(&["--yes"]));
    assert_eq!(code, 0, "withdrawing a deleted participant again changes nothing: {err}");
    assert!(err.contains("data was deleted"), "{err}");
    // Input is checked before anything is touched.
    let (code, _, err) = handover(&["participant", "withdraw", "../x", "--study-dir", dir.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
}

#[cfg(unix)]
#[test]
fn delete_data_never_follows_a_link_and_deletes_nothing_it_did_not_write() {
    use std::os::unix::fs::symlink;
    let dir = study_dir("links");
    let (id, _) = participant_with_a_session(&dir);
    let (other, _) = participant_with_a_session(&dir);
    let (logs, participants) = (dir.join("logs"), dir.join("participants"));
    let outside = study_dir("links-outside");
    std::fs::write(outside.join("keep.mcap"), b"not the study's").unwrap();
    let theirs = logs.join(&id);
    symlink(format!("../{other}"), theirs.join("peer")).unwrap();
    symlink(&outside, theirs.join("ext")).unwrap();
    symlink(outside.join("keep.mcap"), theirs.join("linked.mcap")).unwrap();
    // What is there (the session lock a withdrawal takes aside).
    let files = || walk(&dir).into_iter().filter(|p| !p.ends_with(".session.lock")).collect::<Vec<_>>();
    let before = files();
    let withdraw =
        || handover(&["participant", "withdraw", &id, "--delete-data", "--yes", "--study-dir", dir.to_str().unwrap()]);
    let (code, _, err) = withdraw();
    assert_eq!(code, 2, "{err}");
    for name in ["peer (a link)", "ext (a link)", "linked.mcap (a link)", "nothing deleted"] {
        assert!(err.contains(name), "names {name}: {err}");
    }
    assert_eq!(files(), before, "nothing deleted");
    assert!(outside.join("keep.mcap").exists() && mcap_files(&logs.join(&other)).len() == 1);
    assert!(ParticipantRecord::load(&participants, &id).unwrap().is_withdrawn(), "the withdrawal stands");
    // A FIFO or a folder is not theirs either.
    for name in ["peer", "ext", "linked.mcap"] {
        std::fs::remove_file(theirs.join(name)).unwrap();
    }
    std::fs::create_dir(theirs.join("sub")).unwrap();
    let (code, _, err) = withdraw();
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("sub (a folder)"), "{err}");
    std::fs::remove_dir(theirs.join("sub")).unwrap();
    let (code, _, err) = withdraw();
    assert_eq!(code, 0, "with only its own files there it deletes them: {err}");
    assert!(!theirs.exists() && outside.join("keep.mcap").exists() && mcap_files(&logs.join(&other)).len() == 1);

    // Their whole log folder a link to another participant's: refused, nothing entered.
    let (third, _) = participant_with_a_session(&dir);
    let third_logs = logs.join(&third);
    std::fs::rename(&third_logs, dir.join("moved")).unwrap();
    symlink(&other, &third_logs).unwrap();
    let (code, _, err) =
        handover(&["participant", "withdraw", &third, "--delete-data", "--yes", "--study-dir", dir.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("is a link or a file"), "{err}");
    assert_eq!(mcap_files(&logs.join(&other)).len(), 1, "the other participant's log is kept");
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&outside);
}

#[test]
fn a_copy_of_a_deleted_participants_log_is_still_left_out_and_not_continued() {
    let dir = study_dir("tombstone");
    let (id, _) = participant_with(&dir, Some(3));
    let (done, _) = participant_with_a_session(&dir);
    let logs = dir.join("logs");
    let backup = study_dir("tombstone-backup");
    let interrupted = mcap_files(&logs.join(&id)).pop().unwrap();
    let copy = backup.join(interrupted.file_name().unwrap());
    std::fs::copy(&interrupted, &copy).unwrap();
    let (code, _, err) =
        handover(&["participant", "withdraw", &id, "--delete-data", "--yes", "--study-dir", dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    // The backup is restored into the study: its participant stays withdrawn.
    std::fs::create_dir(logs.join(&id)).unwrap();
    let restored = logs.join(&id).join(copy.file_name().unwrap());
    std::fs::copy(&copy, &restored).unwrap();
    let (code, json, err) =
        handover(&["analyze", logs.to_str().unwrap(), "--format", "json", "--alpha-particles", "200"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("left out 1 session(s) of 1 participant(s) who withdrew"), "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["withdrawn_left_out"]["sessions"], 1, "{v}");
    let (code, _, err) = handover(&["resume", restored.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("withdrew from the study"), "{err}");
    assert_eq!(mcap_files(&logs.join(&id)).len(), 1, "no continuation written");
    // And no new session is started under their id.
    let (code, _, err) = handover(&["participant", "show", &id, "--study-dir", dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("data was deleted"), "{err}");
    let _ = done;
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&backup);
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let e = e.unwrap();
            let p = e.path();
            if e.file_type().unwrap().is_dir() {
                stack.push(p.clone());
            }
            out.push(p);
        }
    }
    out
}

/// Every output folder says which sessions made it: after a withdrawal, `participant
/// withdraw` and `status` name each folder in the study that still holds the person (the
/// analysis, a fitted prior, a protocol made from it); analysing again into the same folder
/// leaves nothing of the earlier run beside the new files, and the person nowhere.
#[test]
fn every_output_that_still_holds_a_withdrawn_participant_is_named() {
    let dir = study_dir("outputs");
    let (gone, _) = participant_with_a_session(&dir);
    let (stays, _) = participant_with_a_session(&dir);
    let d = dir.to_str().unwrap();
    let results = dir.join("results");
    let r = results.to_str().unwrap();
    let (code, out, err) =
        handover(&["analyze", "--study-dir", d, "--fit-population", "--alpha-particles", "50", "--out", r]);
    assert_eq!(code, 0, "{out}{err}");
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(results.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["command"], "analyze");
    assert_eq!(manifest["complete"], true);
    let files: Vec<&str> = manifest["files"].as_array().unwrap().iter().map(|f| f.as_str().unwrap()).collect();
    for f in ["sessions.csv", "trials.csv", "pooled.csv", "population.json", "prior.json"] {
        assert!(files.contains(&f), "{f} in {files:?}");
    }
    let held: Vec<&str> =
        manifest["sessions"].as_array().unwrap().iter().map(|s| s["participant"].as_str().unwrap()).collect();
    assert!(held.contains(&gone.as_str()) && held.contains(&stays.as_str()), "{held:?}");
    let next = results.join("next");
    let (code, out, err) = handover(&[
        "protocol",
        "with",
        "--prior-file",
        results.join("prior.json").to_str().unwrap(),
        "--out",
        next.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{out}{err}");
    // A stale file of an earlier run (a figure format no longer asked for, say).
    std::fs::write(results.join("fig10.pdf"), "old").unwrap();
    let mut m = manifest.clone();
    m["files"].as_array_mut().unwrap().push("fig10.pdf".into());
    std::fs::write(results.join("manifest.json"), m.to_string()).unwrap();

    let (code, _, err) = handover(&["participant", "withdraw", &gone, "--study-dir", d]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("2 output folder(s)"), "{err}");
    assert!(err.contains(&format!("{} (handover analyze", results.display())), "{err}");
    assert!(err.contains(&format!("{} (handover protocol with", next.display())), "{err}");
    let (code, out, err) = handover(&["status", "--study-dir", d]);
    assert_eq!(code, 1, "{out}{err}");
    assert!(out.contains(&format!("holds the data of {gone} who withdrew")), "{out}");

    // Analysed again: the earlier run's files are gone, the person is in none of the new ones.
    let (code, out, err) = handover(&["analyze", "--study-dir", d, "--alpha-particles", "50", "--out", r]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(!results.join("fig10.pdf").exists(), "a stale file left beside the new ones");
    assert!(!results.join("prior.json").exists() && !results.join("pooled.csv").exists());
    for f in walk(&results).into_iter().filter(|f| !f.starts_with(&next)) {
        let text = String::from_utf8_lossy(&std::fs::read(&f).unwrap()).into_owned();
        assert!(!text.contains(&gone), "{} still holds {gone}", f.display());
    }
    // The protocol made from the old prior still holds them, and says so.
    let (code, out, _) = handover(&["status", "--study-dir", d]);
    assert_eq!(code, 1);
    assert!(out.contains(&format!("{} (handover protocol with", next.display())), "{out}");
    // A folder of someone's own is never written into.
    std::fs::write(results.join("notes.txt"), "mine").unwrap();
    let (code, _, err) = handover(&["analyze", "--study-dir", d, "--alpha-particles", "50", "--out", r]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("notes.txt") && !err.contains("next/"), "{err}");
    assert_eq!(std::fs::read_to_string(results.join("notes.txt")).unwrap(), "mine");
    let _ = std::fs::remove_dir_all(&dir);
}
