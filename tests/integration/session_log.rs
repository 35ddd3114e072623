//! Session logs: durable, private, never overwritten, readable after a crash, resumable.

use crate::support::tmpdir;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use handover::dryrun::{drive, now_ns, plan};
use handover::protocol::{DEFAULT_PROTOCOL, Study};
use handover::record::{RecordedSession, new_log_path, read_log};
use handover::session::{Event, Session};

fn study() -> Arc<Study> {
    let mut s = Study::default_study();
    s.protocol.learning.particles = 300;
    Arc::new(s)
}

fn protocol_text(study: &Study) -> String {
    // The log embeds the protocol it ran; keep the test's particle count in it.
    let mut v: serde_json::Value = serde_json::from_str(DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = study.protocol.learning.particles.into();
    v.to_string()
}

/// Runs one simulated session to the end; returns the log path.
fn dry_session(logs: &Path, seed: u64) -> PathBuf {
    let study = study();
    let p = plan(&study, seed, 0, None, "2026-11-22T00:00:00Z".into());
    let session = Session::new(Arc::clone(&study), p.start.clone()).unwrap();
    let path = new_log_path(logs, &p.start.participant, chrono::Utc::now());
    let mut rec = RecordedSession::create(&path, &protocol_text(&study), session, now_ns()).unwrap();
    drive(&mut rec, &p.participant, Duration::ZERO).unwrap();
    rec.finish().unwrap()
}

fn events(path: &Path) -> Vec<Event> {
    read_log(path).unwrap().events.into_iter().map(|s| s.event).collect()
}

#[test]
fn a_complete_session_logs_every_event_privately() {
    let logs = tmpdir("complete");
    let path = dry_session(&logs, 3);
    let log = read_log(&path).unwrap();
    assert!(log.finished && !log.cut_tail);
    let count = |t: &str| log.messages.iter().filter(|m| m.topic == t).count();
    assert_eq!(count("/trial/response"), 26);
    assert_eq!(count("/trial/query"), 26);
    assert_eq!(count("/questionnaire/likert"), 8);
    assert_eq!(count("/questionnaire/choice"), 1);
    assert_eq!(count("/session/end"), 1);
    assert_eq!(
        count("/belief/active") + count("/belief/passive"),
        2 + 10,
        "the two priors and one per training response, each on its condition's topic"
    );
    assert_eq!(count("/belief/active"), count("/belief/passive"));
    assert_eq!(count("/human/joints"), 26);
    assert_eq!(count("/scene/object"), 26);
    assert_eq!(
        (count("/test/log_likelihood/active"), count("/test/log_likelihood/passive")),
        (1, 1),
        "one per condition at the end, each on its condition's topic"
    );
    assert!(log.start.pilot);
    // The seed is below 2^53, so every JSON reader (JavaScript's included) reads it exactly,
    // and it needs no second field.
    let start = &log.messages.iter().find(|m| m.topic == "/session/start").unwrap().value;
    assert!(start.get("seed_decimal").is_none(), "{start}");
    assert_eq!(start["seed"].as_u64(), Some(log.start.seed));
    assert!(log.start.seed <= handover::MAX_SESSION_SEED);
    assert_eq!(start["seed"].as_f64().map(|f| f as u64), Some(log.start.seed), "exact as a double");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        assert_eq!(std::fs::metadata(&path).unwrap().permissions().mode() & 0o777, 0o600);
        assert_eq!(std::fs::metadata(path.parent().unwrap()).unwrap().permissions().mode() & 0o777, 0o700);
    }
    std::fs::remove_dir_all(logs).unwrap();
}

#[test]
fn an_existing_log_is_never_overwritten() {
    let logs = tmpdir("overwrite");
    let path = dry_session(&logs, 4);
    let before = std::fs::read(&path).unwrap();
    let study = study();
    let p = plan(&study, 4, 0, None, "x".into());
    let session = Session::new(Arc::clone(&study), p.start).unwrap();
    // Two sessions that want the same name (started in the same second): the second gets
    // its own file, and the first is untouched.
    let second = RecordedSession::create(&path, &protocol_text(&study), session, now_ns()).unwrap();
    assert_ne!(second.path(), path, "a taken name gets a suffix");
    assert!(second.path().to_string_lossy().ends_with("-2.mcap"), "{}", second.path().display());
    assert_eq!(std::fs::read(&path).unwrap(), before);
    std::fs::remove_dir_all(logs).unwrap();
}

#[test]
fn the_same_seed_gives_the_same_events() {
    let logs = tmpdir("same-seed");
    let (a, b) = (dry_session(&logs.join("a"), 9), dry_session(&logs.join("b"), 9));
    assert_eq!(events(&a), events(&b));
    assert_eq!(read_log(&a).unwrap().start.participant, read_log(&b).unwrap().start.participant);
    assert_ne!(events(&a), events(&dry_session(&logs.join("c"), 10)));
    std::fs::remove_dir_all(logs).unwrap();
}

#[test]
fn crash_after_fsync_loses_nothing_and_resume_gives_the_uninterrupted_events() {
    let logs = tmpdir("crash");
    let full = dry_session(&logs.join("full"), 5);
    let bytes = std::fs::read(&full).unwrap();
    let all = events(&full);
    // Cut the file at several points, as a crash would leave it.
    // Cut before the start record was written: nothing of the session exists, and the
    // reader says so instead of panicking.
    let early = logs.join("early.mcap");
    std::fs::write(&early, &bytes[..2000]).unwrap();
    assert!(read_log(&early).unwrap_err().to_string().contains("not a handover session log"));
    for frac in [0.35, 0.55, 0.75, 0.95] {
        let cut = (bytes.len() as f64 * frac) as usize;
        let dir = logs.join(format!("cut{cut}"));
        std::fs::create_dir_all(dir.join("p")).unwrap();
        let crashed = dir.join("p").join("crashed.mcap");
        std::fs::write(&crashed, &bytes[..cut]).unwrap();
        let log = read_log(&crashed).unwrap();
        assert!(!log.finished);
        let kept: Vec<Event> = log.events.iter().map(|s| s.event.clone()).collect();
        assert_eq!(kept[..], all[..kept.len()], "a prefix of the events, each whole");
        let new = new_log_path(&dir, "p", chrono::Utc::now());
        let mut rec = RecordedSession::resume(&log, &new, now_ns()).unwrap();
        let truth = log.start.simulated_truth.clone().unwrap();
        let person =
            handover::participant::SimulatedPerson { truth, alpha: rec.session().study().protocol.learning.alpha };
        drive(&mut rec, &handover::participant::ScriptedParticipant { person }, Duration::ZERO).unwrap();
        let done = rec.finish().unwrap();
        assert_eq!(events(&done), all, "cut at {cut} bytes");
        assert_eq!(std::fs::read(&crashed).unwrap(), &bytes[..cut], "the crashed file is kept as it was");
        let resumed = read_log(&done).unwrap();
        assert_eq!(resumed.start.session_id, read_log(&full).unwrap().start.session_id);
        assert_eq!(resumed.start.resumed_from.as_deref(), Some("crashed.mcap"));
    }
    std::fs::remove_dir_all(logs).unwrap();
}

#[test]
fn a_file_that_is_not_a_log_is_refused() {
    let dir = tmpdir("foreign");
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("x.mcap");
    std::fs::write(&p, b"hello").unwrap();
    let e = read_log(&p).unwrap_err().to_string();
    assert!(e.contains("not a handover session log"), "{e}");
    std::fs::remove_dir_all(dir).unwrap();
}
