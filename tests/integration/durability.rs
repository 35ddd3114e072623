//! What a crash, a full disk or a second resume does to the logs: nothing acknowledged is
//! lost, nothing is left empty or half-written, and a session is never continued twice.

use crate::support::{handover_in, tmpdir};

use std::path::{Path, PathBuf};
use std::process::Command;

use handover::record::{mcap_files, read_log};

fn small_protocol(dir: &Path) {
    let mut v: serde_json::Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 150.into();
    v["session"]["trials_per_condition"] = 2.into();
    std::fs::write(dir.join("small.json"), v.to_string()).unwrap();
}

/// The first `keep` fraction of a log's bytes (a crash part-way).
fn cut(path: &Path, keep: f64) -> Vec<u8> {
    let b = std::fs::read(path).unwrap();
    b[..(b.len() as f64 * keep) as usize].to_vec()
}

#[test]
fn a_session_is_continued_once_and_a_finished_one_is_only_read() {
    let dir = tmpdir("lineage");
    small_protocol(&dir);
    assert_eq!(handover_in(&dir, &["dry-run", "--protocol", "small.json", "--seed", "4", "--logs", "logs"]).0, 0);
    let complete = mcap_files(&dir.join("logs")).pop().unwrap();
    let folder = complete.parent().unwrap().to_path_buf();
    let count = || mcap_files(&dir.join("logs")).len();
    // A completed session opens read-only: nothing is written.
    let (code, _, err) = handover_in(&dir, &["resume", "--no-console", complete.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("the session is over; opening it read-only"), "{err}");
    assert_eq!(count(), 1);
    // A crash half-way: the cut log is continued beside it, once.
    let crashed = folder.join("crashed.mcap");
    std::fs::write(&crashed, cut(&complete, 0.5)).unwrap();
    let (code, _, err) = handover_in(&dir, &["resume", "--no-console", crashed.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(count(), 3);
    let continuation = mcap_files(&folder)
        .into_iter()
        .find(|p| read_log(p).unwrap().start.resumed_from.as_deref() == Some("crashed.mcap"))
        .expect("a continuation beside the log");
    // Resuming the crashed log again resumes its newest continuation, which is complete:
    // read-only, nothing written.
    let (code, _, err) = handover_in(&dir, &["resume", "--no-console", crashed.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("resuming its newest continuation") && err.contains("read-only"), "{err}");
    assert_eq!(count(), 3);
    // --fork branches from the crashed log itself.
    let (code, _, err) = handover_in(&dir, &["resume", "--no-console", "--fork", crashed.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("--fork: branching from it as asked"), "{err}");
    let forks: Vec<PathBuf> = mcap_files(&folder)
        .into_iter()
        .filter(|p| read_log(p).unwrap().start.resumed_from.as_deref() == Some("crashed.mcap"))
        .filter(|p| *p != continuation)
        .collect();
    assert_eq!(forks.len(), 1);
    // The fork crashes; resuming the crashed log now continues the fork (the newest).
    let newest = &forks[0];
    let bytes = cut(newest, 0.6);
    std::fs::remove_file(newest).unwrap();
    std::fs::write(newest, &bytes).unwrap();
    let rewritten = read_log(newest).unwrap();
    assert!(!rewritten.finished && rewritten.start.resumed_from.as_deref() == Some("crashed.mcap"));
    let before = count();
    let (code, _, err) = handover_in(&dir, &["resume", "--no-console", crashed.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("was already continued; resuming its newest continuation"), "{err}");
    assert_eq!(count(), before + 1, "{err}");
    let newest_name = newest.file_name().unwrap().to_string_lossy().into_owned();
    let latest = mcap_files(&folder)
        .into_iter()
        .find(|p| read_log(p).unwrap().start.resumed_from.as_deref() == Some(newest_name.as_str()))
        .expect("the newest continuation was continued");
    let final_log = read_log(&latest).unwrap();
    let original = read_log(&complete).unwrap();
    let events = |l: &handover::record::LogContents| l.events.iter().map(|e| e.event.clone()).collect::<Vec<_>>();
    assert_eq!(events(&final_log), events(&original), "the same session, event for event");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Mounts a small tmpfs at `at` (root only); false where that is not possible.
fn mount_small(at: &Path, kib: u32) -> bool {
    std::fs::create_dir_all(at).unwrap();
    Command::new("mount")
        .args(["-t", "tmpfs", "-o", &format!("size={kib}k,mode=0700"), "tmpfs", at.to_str().unwrap()])
        .output()
        .is_ok_and(|o| o.status.success())
}

struct Unmount(PathBuf);

impl Drop for Unmount {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

/// Fills the rest of a file system.
fn fill(dir: &Path) {
    use std::io::Write;
    let mut f = std::fs::File::create(dir.join("filler")).unwrap();
    let block = vec![0u8; 4096];
    while f.write_all(&block).is_ok() {}
    let _ = f.sync_all();
}

#[test]
fn a_full_disk_names_its_cause_and_leaves_only_whole_files() {
    let dir = tmpdir("full");
    small_protocol(&dir);
    // A disk that holds three and a half sessions' logs, measured on one, so that the fourth
    // log fills it half-way whatever today's log size.
    let one = dir.join("one");
    let (code, _, err) = handover_in(
        &dir,
        &["dry-run", "--protocol", "small.json", "--participants", "1", "--logs", one.to_str().unwrap()],
    );
    assert_eq!(code, 0, "{err}");
    let log_kib = std::fs::metadata(&mcap_files(&one)[0]).unwrap().len().div_ceil(1024) as u32;
    let disk = dir.join("disk");
    if !mount_small(&disk, log_kib * 7 / 2 + 64) {
        crate::support::missing("a small tmpfs to fill (mount needs root)");
        return;
    }
    let _unmount = Unmount(disk.clone());
    let logs = disk.join("logs");
    let (code, _, err) = handover_in(
        &dir,
        &["dry-run", "--protocol", "small.json", "--participants", "6", "--logs", logs.to_str().unwrap()],
    );
    assert_eq!(code, 1, "the disk fills up: {err}");
    assert!(err.contains("No space left on device"), "the OS cause is named: {err}");
    assert!(err.contains("nothing after event"), "what is lost is said: {err}");
    let check_whole = || {
        for p in mcap_files(&logs) {
            let len = std::fs::metadata(&p).unwrap().len();
            assert!(len > 0, "no empty log: {}", p.display());
            let log = read_log(&p).unwrap_or_else(|e| panic!("{} does not read: {e}", p.display()));
            assert!(!log.cut_tail, "{}: a failed write was cut back to the last whole event", p.display());
        }
    };
    check_whole();
    let partial = mcap_files(&logs)
        .into_iter()
        .find(|p| !read_log(p).unwrap().finished)
        .unwrap_or_else(|| panic!("the log being written: {err}\n{:?}", mcap_files(&logs)));
    fill(&disk);
    // A new participant on a full disk: the cause, and no empty record left behind.
    let parts = disk.join("participants");
    let (code, _, err) = handover_in(
        &dir,
        &["participant", "new", "--participants-dir", parts.to_str().unwrap(), "--logs", logs.to_str().unwrap()],
    );
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("No space left on device"), "{err}");
    let records: Vec<_> = std::fs::read_dir(&parts).map(|r| r.flatten().collect()).unwrap_or_default();
    assert!(records.is_empty(), "no partial record: {records:?}");
    // Resuming on a full disk: the cause, and no 0-byte log.
    let before = mcap_files(&logs).len();
    let (code, _, err) = handover_in(&dir, &["resume", "--no-console", partial.to_str().unwrap()]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("No space left on device"), "{err}");
    assert_eq!(mcap_files(&logs).len(), before, "no empty continuation left behind");
    check_whole();
    // Space is freed (the filler and the finished pilot logs go): the interrupted session
    // resumes to its end.
    std::fs::remove_file(disk.join("filler")).unwrap();
    for p in mcap_files(&logs) {
        if read_log(&p).unwrap().finished {
            std::fs::remove_file(p).unwrap();
        }
    }
    let (code, _, err) = handover_in(&dir, &["resume", "--no-console", partial.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    drop(_unmount);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_console_blocks_on_a_failed_write_until_it_is_retried() {
    use handover::protocol::Study;
    use handover::study_dir::StudyDirs;
    use handover::tui::app::{Overlay, Screen};
    use handover::tui::{App, AppConfig};
    use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
    let dir = tmpdir("console-full");
    let disk = dir.join("disk");
    if !mount_small(&disk, 1300) {
        crate::support::missing("a small tmpfs to fill (mount needs root)");
        return;
    }
    let _unmount = Unmount(disk.clone());
    let mut v: serde_json::Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 150.into();
    let text = v.to_string();
    let study = std::sync::Arc::new(Study::from_json(&text, "small").unwrap());
    let config = AppConfig {
        study,
        protocol_text: text,
        dirs: StudyDirs::resolve(Some(&disk), None, None),
        participant: "new".into(),
        simulate: false,
        pilot: false,
        pilot_body: Default::default(),
        practice: false,
        pace: std::time::Duration::ZERO,
        seed: Some(3),
        tap: None,
    };
    let mut a = App::new(config);
    let press = |a: &mut App, c: KeyCode| {
        a.key(KeyEvent::new(c, KeyModifiers::NONE));
        a.wait_idle();
    };
    press(&mut a, KeyCode::Enter);
    assert!(matches!(a.screen, Screen::Session), "{}", a.status);
    let log_path = a.log_path().unwrap();
    fill(&disk);
    // The log file's last page may still take an event or two; trials go on until a write
    // meets the full disk.
    for k in 0..10 {
        press(&mut a, KeyCode::Enter);
        if a.overlay.is_some() {
            break;
        }
        press(&mut a, KeyCode::Char(if k % 2 == 0 { '1' } else { '2' }));
        if a.overlay.is_some() {
            break;
        }
    }
    let Some(Overlay::WriteFailed { message, last_event }) = a.overlay.clone() else { panic!("{:?}", a.overlay) };
    assert!(message.contains("No space left on device"), "{message}");
    let applied = a.session().unwrap().event_count();
    assert_eq!(last_event, applied, "the overlay names the last event on disk");
    // Nothing moves on behind the overlay.
    press(&mut a, KeyCode::Char('1'));
    press(&mut a, KeyCode::Enter);
    assert!(matches!(a.overlay, Some(Overlay::WriteFailed { .. })));
    assert_eq!(a.session().unwrap().event_count(), applied);
    // Space is freed: r writes the event, once, and the session goes on.
    std::fs::remove_file(disk.join("filler")).unwrap();
    press(&mut a, KeyCode::Char('r'));
    assert!(a.overlay.is_none(), "{:?}", a.overlay);
    assert_eq!(a.session().unwrap().event_count(), applied + 1);
    let log = read_log(&log_path).unwrap();
    assert_eq!(log.events.len(), applied + 1, "each event once");
    let indices: Vec<u64> = log
        .messages
        .iter()
        .filter(|m| handover::record::Topic::from_name(&m.topic).is_some_and(handover::record::Topic::is_event))
        .map(|m| m.value["event_index"].as_u64().unwrap())
        .collect();
    assert_eq!(indices, (1..=applied as u64 + 1).collect::<Vec<_>>());
    drop(a);
    drop(_unmount);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `resume --participant ID` finds the participant's unfinished session in the study's
/// logs and continues it; with none left it says so and how to start one (exit 2).
#[test]
fn resume_by_participant_finds_the_unfinished_session() {
    let dir = tmpdir("by-participant");
    small_protocol(&dir);
    assert_eq!(handover_in(&dir, &["dry-run", "--protocol", "small.json", "--seed", "4", "--logs", "logs"]).0, 0);
    let complete = mcap_files(&dir.join("logs")).pop().unwrap();
    let folder = complete.parent().unwrap().to_path_buf();
    let id = folder.file_name().unwrap().to_string_lossy().into_owned();
    // Only a finished session: nothing to continue.
    let (code, _, err) = handover_in(&dir, &["resume", "--no-console", "--participant", &id, "--study-dir", "."]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains(&format!("participant {id} has no unfinished session")), "{err}");
    // It crashed half-way instead: found and continued.
    let bytes = cut(&complete, 0.5);
    std::fs::remove_file(&complete).unwrap();
    std::fs::write(&complete, bytes).unwrap();
    let name = complete.file_name().unwrap().to_string_lossy().into_owned();
    let (code, _, err) = handover_in(&dir, &["resume", "--no-console", "--participant", &id]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("resumed") && err.contains(&name), "{err}");
    assert_eq!(mcap_files(&folder).len(), 2);
    let (code, _, err) = handover_in(&dir, &["resume", "--no-console", "--participant", &id]);
    assert_eq!(code, 2, "everything is finished again: {err}");
    // From another folder, the study named by HANDOVER_STUDY_DIR: found there, as `status`
    // finds it; `analyze` with no log reads that study's logs.
    assert_eq!(handover_in(&dir, &["dry-run", "--protocol", "small.json", "--seed", "5", "--logs", "logs"]).0, 0);
    let other = mcap_files(&dir.join("logs")).into_iter().find(|f| !f.starts_with(&folder)).unwrap();
    let other_id = other.parent().unwrap().file_name().unwrap().to_string_lossy().into_owned();
    let bytes = cut(&other, 0.5);
    std::fs::write(&other, bytes).unwrap();
    let elsewhere = tmpdir("by-participant-elsewhere");
    let in_study = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_handover"))
            .args(args)
            .current_dir(&*elsewhere)
            .env("HANDOVER_STUDY_DIR", &*dir)
            .stdin(std::process::Stdio::null())
            .output()
            .unwrap();
        (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (code, err) = in_study(&["resume", "--no-console", "--participant", &other_id]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("resumed"), "{err}");
    let (code, err) = in_study(&["analyze", "--out", elsewhere.join("out").to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(elsewhere.join("out/pilot/sessions.csv").exists() || elsewhere.join("out/sessions.csv").exists(), "{err}");
    // A log and --participant together, or an id that is not one, are refused.
    let (code, _, _) = handover_in(&dir, &["resume", "--participant", &id, complete.to_str().unwrap()]);
    assert_eq!(code, 2);
    let (code, _, err) = handover_in(&dir, &["resume", "--participant", "../x"]);
    assert_eq!(code, 2);
    assert!(err.contains("--participant"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Runs `args` in `dir` and sends it SIGTERM after `after`; whether it had finished first.
fn terminated_after(dir: &Path, args: &[&str], after: std::time::Duration) -> bool {
    let mut child = Command::new(env!("CARGO_BIN_EXE_handover"))
        .args(args)
        .current_dir(dir)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(after);
    let done = child.try_wait().unwrap().is_some();
    // SAFETY: kill(2) on our own child's id, which it keeps until we wait for it.
    unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
    child.wait().unwrap();
    done
}

/// The files under `dir` whose names do not start with a dot, by path relative to it.
fn visible_files(dir: &Path) -> std::collections::BTreeMap<PathBuf, Vec<u8>> {
    let mut out = std::collections::BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else { continue };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if e.file_name() == "manifest.json" {
                // Whole, and naming when it was written: the time differs run by run.
                let m: serde_json::Value =
                    serde_json::from_slice(&std::fs::read(&p).unwrap()).expect("a whole manifest");
                out.insert(p.strip_prefix(dir).unwrap().to_path_buf(), m["files"].to_string().into_bytes());
            } else if !e.file_name().to_string_lossy().starts_with('.') {
                out.insert(p.strip_prefix(dir).unwrap().to_path_buf(), std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

/// SIGTERM at any moment of `protocol with` or `analyze --out` leaves each file it writes
/// whole or absent, and a rerun completes: 24 terminations of each, spread over the
/// command's own run time.
#[test]
fn a_command_terminated_while_writing_leaves_only_whole_files() {
    let dir = tmpdir("sigterm");
    small_protocol(&dir);
    let prior: serde_json::Value = serde_json::from_str::<serde_json::Value>(handover::protocol::DEFAULT_PROTOCOL)
        .unwrap()["learning"]["prior"]
        .clone();
    std::fs::write(dir.join("prior.json"), prior.to_string()).unwrap();
    assert_eq!(
        handover_in(&dir, &["dry-run", "--protocol", "small.json", "--participants", "2", "--logs", "logs"]).0,
        0
    );
    let cases: [(&str, Vec<&str>); 2] = [
        ("next", vec!["protocol", "with", "small.json", "--prior-file", "prior.json", "--out"]),
        ("out", vec!["analyze", "logs", "--alpha-particles", "100", "--out"]),
    ];
    for (name, args) in cases {
        let reference = dir.join(format!("{name}-reference"));
        let mut whole = args.clone();
        whole.push(reference.to_str().unwrap());
        let t = std::time::Instant::now();
        let (code, out, err) = handover_in(&dir, &whole);
        assert_eq!(code, 0, "{out}{err}");
        let took = t.elapsed();
        let expected = visible_files(&reference);
        let mut finished = 0;
        for k in 0..24u32 {
            let at = dir.join(format!("{name}-{k}"));
            let mut run = args.clone();
            run.push(at.to_str().unwrap());
            finished += usize::from(terminated_after(&dir, &run, took.mul_f64(f64::from(k) / 20.0)));
            for (file, bytes) in visible_files(&at) {
                // A manifest of a run cut short lists nothing yet; every other file is whole.
                let whole = expected.get(&file) == Some(&bytes) || (file.ends_with("manifest.json") && bytes == b"[]");
                assert!(
                    whole,
                    "{name} terminated at {k}/20 of its time: {} is cut ({} bytes)",
                    file.display(),
                    bytes.len()
                );
            }
            // The rerun completes (a protocol written whole is never overwritten: refused).
            let existed = at.join("protocol.json").exists();
            let (code, out, err) = handover_in(&dir, &run);
            if name == "next" && existed {
                assert_eq!(code, 2, "{out}{err}");
                assert!(err.contains("exists"), "{err}");
            } else {
                assert_eq!(code, 0, "{name} after a termination: {out}{err}");
                assert!(visible_files(&at) == expected, "{name}: the rerun's files differ from an uninterrupted run's");
            }
        }
        assert!(finished < 24, "{name}: every run finished before its SIGTERM");
    }
}
