//! Golden logs: small pseudonymous logs of every log format this version reads, kept under
//! `tests/golden/format-N/` with the analysis `analyze` made of each when it was written
//! (`expected/NAME/`). Today's code must read each whole, verify it, analyse it to the same
//! tables, open a finished one read-only (its events replayed) and continue a killed one to
//! its end. `tests/golden/README.md` says how they were made and when to add a format.
//!
//! The logs of the current format are written by `write_current_format` (ignored: run it by
//! hand, once, when the log format changes, and commit what it writes):
//! `cargo test --test integration golden::write_current_format -- --ignored`.

use crate::console::{answer, app, keys, past_transition, press};
use crate::robot_hook::script;
use crate::support::{handover_in, small_protocol, small_protocol_with, tmpdir};

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use handover::record::{LOG_FORMAT, mcap_files, read_log};
use handover::session::Prompt;
use handover::tui::app::Screen;
use ratatui::crossterm::event::KeyCode;

/// A golden session: its name, the log files it is made of (a killed log and its
/// continuation are one session), whether it ended, and which formats hold it.
struct Golden {
    name: &'static str,
    files: &'static [&'static str],
    finished: bool,
    formats: &'static [u32],
}

const GOLDEN: &[Golden] = &[
    // A dry run: a simulated participant, every phase, the questionnaire.
    Golden { name: "dry-run", files: &["dry-run.mcap"], finished: true, formats: &[1, 2, 3, 4, 5] },
    // A console session by keys: a grasp undone, a trial voided, a note, a pause.
    Golden { name: "console", files: &["console.mcap"], finished: true, formats: &[2, 3, 4, 5] },
    // A dry run with a robot program in the loop: every pose commanded and reported.
    Golden { name: "robot", files: &["robot.mcap"], finished: true, formats: &[2, 3, 4, 5] },
    // A dry run whose participant's arm is measured at every grasp.
    Golden { name: "measured", files: &["measured.mcap"], finished: true, formats: &[2, 3, 4, 5] },
    // A dry run killed (SIGKILL) half-way: what was acknowledged is there, nothing more.
    Golden { name: "killed", files: &["killed.mcap"], finished: false, formats: &[2, 3, 4, 5] },
    // The killed session resumed to its end: the killed log and its continuation.
    Golden { name: "resumed", files: &["killed.mcap", "resumed.mcap"], finished: true, formats: &[2, 3, 4, 5] },
];

fn format_dir(format: u32) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("tests/golden/format-{format}"))
}

/// Every format this version reads has golden logs, and nothing newer than it writes.
fn formats() -> Vec<u32> {
    (1..=LOG_FORMAT).collect()
}

fn sessions_of(format: u32) -> impl Iterator<Item = &'static Golden> {
    GOLDEN.iter().filter(move |g| g.formats.contains(&format))
}

/// Copies a golden session's logs into a fresh folder (tests never write beside the golden
/// files), read-write for the owner as a log the console wrote is.
fn copy_of(format: u32, g: &Golden) -> crate::support::TestDir {
    let dir = tmpdir(&format!("golden-{format}-{}", g.name));
    for f in g.files {
        let to = dir.join(f);
        std::fs::copy(format_dir(format).join(f), &to).unwrap();
        std::fs::set_permissions(&to, std::fs::Permissions::from_mode(0o600)).unwrap();
    }
    dir
}

/// `analyze` of the session's logs (named relative to `dir`, so the `log` column is their
/// name) into `dir/out`.
fn analyse(dir: &Path, g: &Golden, extra: &[&str]) -> (i32, String) {
    let mut args = vec!["analyze"];
    args.extend(g.files);
    args.extend(["--out", "out"]);
    args.extend(extra);
    let (code, _, err) = handover_in(dir, &args);
    (code, err)
}

/// Every CSV below `dir`, relative to it.
fn csv_files(dir: &Path) -> Vec<PathBuf> {
    fn walk(root: &Path, at: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(at).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(root, &p, out);
            } else if p.extension().is_some_and(|x| x == "csv") {
                out.push(p.strip_prefix(root).unwrap().to_path_buf());
            }
        }
    }
    let mut out = Vec::new();
    if dir.is_dir() {
        walk(dir, dir, &mut out);
    }
    out.sort();
    out
}

/// Two cells agree: the same text, the same boolean, or numbers within 1e-9 relative (a float summed in another
/// order on another CPU may differ in its last bits; the events themselves are compared
/// exactly by `--verify`).
fn cells_agree(a: &str, b: &str) -> bool {
    if a == b {
        return true;
    }
    // A boolean means the same however it is spelt (`true` when the golden tables were
    // written, `TRUE` since).
    let boolean = |x: &str| ["true", "false"].contains(&x.to_ascii_lowercase().as_str());
    if boolean(a) && boolean(b) && a.eq_ignore_ascii_case(b) {
        return true;
    }
    match (a.parse::<f64>(), b.parse::<f64>()) {
        (Ok(x), Ok(y)) => (x - y).abs() <= 1e-9 * x.abs().max(y.abs()).max(1.0),
        _ => false,
    }
}

/// The differences between two tables, each naming the file, line and column.
fn table_differences(name: &Path, expected: &str, got: &str) -> Vec<String> {
    let (e, g): (Vec<&str>, Vec<&str>) = (expected.lines().collect(), got.lines().collect());
    let mut out = Vec::new();
    if e.len() != g.len() {
        out.push(format!("{}: {} lines, expected {}", name.display(), g.len(), e.len()));
    }
    let header: Vec<&str> = e.first().map(|h| h.split(',').collect()).unwrap_or_default();
    for (i, (le, lg)) in e.iter().zip(&g).enumerate() {
        let (ce, cg): (Vec<&str>, Vec<&str>) = (le.split(',').collect(), lg.split(',').collect());
        if ce.len() != cg.len() {
            out.push(format!("{} line {}: {} cells, expected {}", name.display(), i + 1, cg.len(), ce.len()));
            continue;
        }
        for (k, (a, b)) in ce.iter().zip(&cg).enumerate() {
            if !cells_agree(a, b) {
                let column = header.get(k).copied().unwrap_or("?");
                out.push(format!("{} line {} column {column}: {b}, expected {a}", name.display(), i + 1));
            }
        }
    }
    out
}

#[test]
fn every_format_this_version_reads_has_golden_logs() {
    for format in formats() {
        for g in sessions_of(format) {
            for f in g.files {
                assert!(format_dir(format).join(f).is_file(), "format {format}: {f} is missing");
            }
            assert!(
                !csv_files(&format_dir(format).join("expected").join(g.name)).is_empty(),
                "format {format}: no expected analysis of {}",
                g.name
            );
        }
    }
}

/// Each golden session reads whole in its format, `analyze --verify` recomputes every derived
/// value from its events, and `analyze` writes the tables it wrote when the log was made.
#[test]
fn golden_logs_read_verify_and_analyse_to_their_expected_tables() {
    for format in formats() {
        for g in sessions_of(format) {
            let dir = copy_of(format, g);
            for f in g.files {
                let log = read_log(&dir.join(f)).unwrap_or_else(|e| panic!("format {format} {f}: {e}"));
                assert_eq!(log.format, format, "{f}");
                assert!(log.integrity.is_empty(), "format {format} {f}: {:?}", log.integrity);
            }
            let last = read_log(&dir.join(g.files.last().unwrap())).unwrap();
            assert_eq!(last.finished, g.finished, "format {format} {}", g.name);
            let (code, err) = analyse(&dir, g, &["--verify"]);
            assert_eq!(code, 0, "format {format} {}: {err}", g.name);
            let expected = format_dir(format).join("expected").join(g.name);
            let (want, got) = (csv_files(&expected), csv_files(&dir.join("out")));
            assert_eq!(got, want, "format {format} {}: the tables written", g.name);
            let mut differences = Vec::new();
            for f in &want {
                let e = std::fs::read_to_string(expected.join(f)).unwrap();
                let o = std::fs::read_to_string(dir.join("out").join(f)).unwrap();
                differences.extend(table_differences(f, &e, &o));
            }
            assert!(differences.is_empty(), "format {format} {}:\n{}", g.name, differences.join("\n"));
        }
    }
}

/// A finished golden session opens read-only: its events are replayed into the session and
/// nothing is written.
#[test]
fn finished_golden_logs_replay_read_only() {
    for format in formats() {
        for g in sessions_of(format).filter(|g| g.finished && g.files.len() == 1) {
            let dir = copy_of(format, g);
            let (code, _, err) = handover_in(&dir, &["resume", "--no-console", g.files[0]]);
            assert_eq!(code, 0, "format {format} {}: {err}", g.name);
            assert!(err.contains("the session is over; opening it read-only"), "format {format} {}: {err}", g.name);
            assert_eq!(mcap_files(&dir).len(), 1, "nothing written");
        }
    }
}

/// A killed session of every format resumes to its end: the continuation starts with the
/// killed log's events, finishes, and the two analyse and verify as one session. Format 1
/// has no killed golden log; its dry run cut half-way is one (it wrote its records in order,
/// unindexed, as a kill leaves them).
#[test]
fn killed_golden_sessions_resume_to_their_end() {
    for format in formats() {
        let dir = match sessions_of(format).find(|g| !g.finished) {
            Some(g) => copy_of(format, g),
            None => {
                let dir = tmpdir(&format!("golden-{format}-cut"));
                let bytes = std::fs::read(format_dir(format).join("dry-run.mcap")).unwrap();
                std::fs::write(dir.join("killed.mcap"), &bytes[..bytes.len() / 2]).unwrap();
                dir
            }
        };
        let killed = read_log(&dir.join("killed.mcap")).unwrap();
        assert!(!killed.finished && !killed.events.is_empty(), "format {format}");
        let (code, _, err) = handover_in(&dir, &["resume", "--no-console", "killed.mcap"]);
        assert_eq!(code, 0, "format {format}: {err}");
        let continuation = mcap_files(&dir)
            .into_iter()
            .find(|p| p.file_name().unwrap() != "killed.mcap")
            .unwrap_or_else(|| panic!("format {format}: no continuation: {err}"));
        let log = read_log(&continuation).unwrap();
        assert!(log.finished, "format {format}");
        assert_eq!(log.format, LOG_FORMAT, "a continuation is written in this version's format");
        assert_eq!(log.start.resumed_from.as_deref(), Some("killed.mcap"));
        let events = |l: &handover::record::LogContents| l.events.iter().map(|e| e.event.clone()).collect::<Vec<_>>();
        assert_eq!(events(&log)[..killed.events.len()], events(&killed)[..], "format {format}: replayed first");
        let name = continuation.file_name().unwrap().to_str().unwrap();
        let (code, _, err) = handover_in(&dir, &["analyze", "killed.mcap", name, "--verify", "--out", "out"]);
        assert_eq!(code, 0, "format {format}: {err}");
        let sessions = std::fs::read_to_string(dir.join("out/pilot/sessions.csv")).unwrap();
        assert_eq!(sessions.lines().count(), 2, "one session: {sessions}");
    }
}

// ---- Writing the current format's golden logs -------------------------------------------

/// One dry run's log, written into `dir/logs`.
fn dry_run(dir: &Path, protocol: &Path, extra: &[&str]) -> PathBuf {
    let logs = dir.join("logs");
    let mut args = vec!["dry-run", "--seed", "11", "--body-height", "1.70", "--handedness", "right"];
    args.extend(["--protocol", protocol.to_str().unwrap(), "--logs", logs.to_str().unwrap()]);
    args.extend(extra);
    let (code, _, err) = handover_in(dir, &args);
    assert_eq!(code, 0, "{err}");
    let mut files = mcap_files(&logs);
    assert_eq!(files.len(), 1, "{files:?}");
    files.pop().unwrap()
}

/// A console session by keys (the console's own test harness, with its fixed clock): a
/// grasp undone and recorded again, a trial voided, a note, a pause, then every trial and
/// the questionnaire.
fn console_session(dir: &Path) -> PathBuf {
    let mut a = app(dir);
    press(&mut a, KeyCode::Enter);
    press(&mut a, KeyCode::Enter);
    keys(&mut a, "1");
    keys(&mut a, "u");
    keys(&mut a, "2");
    press(&mut a, KeyCode::Enter);
    keys(&mut a, "x3");
    keys(&mut a, "n");
    keys(&mut a, "dropped the object, picked it up");
    press(&mut a, KeyCode::Enter);
    keys(&mut a, "p");
    keys(&mut a, "p");
    let mut grip = '1';
    loop {
        past_transition(&mut a);
        match a.session().unwrap().prompt() {
            Prompt::Present(_) => press(&mut a, KeyCode::Enter),
            Prompt::Grasp(_) => {
                keys(&mut a, &grip.to_string());
                grip = if grip == '1' { '2' } else { '1' };
            }
            _ => break,
        }
    }
    answer(&mut a, "45342512b");
    press(&mut a, KeyCode::Enter);
    a.wait_idle();
    let Screen::Summary(view) = &a.screen else { panic!("expected the summary screen") };
    assert!(view.completed);
    view.log_path.clone()
}

/// A dry run killed with SIGKILL once its log holds 20 events.
fn killed_dry_run(dir: &Path, protocol: &Path) -> PathBuf {
    let logs = dir.join("killed-logs");
    let mut child = Command::new(env!("CARGO_BIN_EXE_handover"))
        .args(["dry-run", "--seed", "12", "--pace", "100", "--protocol", protocol.to_str().unwrap()])
        .args(["--logs", logs.to_str().unwrap()])
        .stdin(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t = Instant::now();
    loop {
        let events = mcap_files(&logs).first().and_then(|p| read_log(p).ok()).map_or(0, |l| l.events.len());
        if events >= 20 {
            break;
        }
        assert!(t.elapsed() < Duration::from_secs(60), "the dry run never logged 20 events");
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    mcap_files(&logs).pop().unwrap()
}

/// Copies every table `analyze` wrote below `from` to the same place below `to`.
fn keep_tables(from: &Path, to: &Path) {
    for f in csv_files(from) {
        std::fs::create_dir_all(to.join(&f).parent().unwrap()).unwrap();
        std::fs::copy(from.join(&f), to.join(&f)).unwrap();
        std::fs::set_permissions(to.join(&f), std::fs::Permissions::from_mode(0o644)).unwrap();
    }
}

/// Writes the golden logs of the current format and their expected analyses into
/// `tests/golden/format-N/` (a folder that must not exist yet).
#[test]
#[ignore = "writes tests/golden: run by hand when the log format changes"]
fn write_current_format() {
    let out = format_dir(LOG_FORMAT);
    assert!(
        !out.exists(),
        "{} exists: a released format's golden logs are not rewritten (remove it first if it never was)",
        out.display()
    );
    std::fs::create_dir_all(&out).unwrap();
    let place = |from: &Path, name: &str| {
        std::fs::copy(from, out.join(name)).unwrap();
        std::fs::set_permissions(out.join(name), std::fs::Permissions::from_mode(0o644)).unwrap();
    };

    let d = tmpdir("golden-dry-run");
    place(&dry_run(&d, &small_protocol(&d), &[]), "dry-run.mcap");

    let d = tmpdir("golden-console");
    place(&console_session(&d), "console.mcap");

    let d = tmpdir("golden-robot");
    let robot = script(&d, "robot.sh", "cat > /dev/null\nexit 0");
    place(&dry_run(&d, &small_protocol(&d), &["--robot-command", robot.to_str().unwrap()]), "robot.mcap");

    let d = tmpdir("golden-measured");
    let measured = small_protocol_with(&d, |v| {
        v["learning"]["observation"] = "measured".into();
        v["learning"]["measurement"] = serde_json::json!({ "sigma_deg": vec![5.0; 7] });
    });
    place(&dry_run(&d, &measured, &[]), "measured.mcap");

    // The killed log and its continuation, named as the golden set names them: the
    // continuation records the killed log's name, so the killed log is renamed first.
    let d = tmpdir("golden-killed");
    let killed = killed_dry_run(&d, &small_protocol(&d));
    let folder = killed.parent().unwrap();
    std::fs::rename(&killed, folder.join("killed.mcap")).unwrap();
    place(&folder.join("killed.mcap"), "killed.mcap");
    let (code, _, err) = handover_in(folder, &["resume", "--no-console", "killed.mcap"]);
    assert_eq!(code, 0, "{err}");
    let continuation = mcap_files(folder).into_iter().find(|p| p.file_name().unwrap() != "killed.mcap").unwrap();
    place(&continuation, "resumed.mcap");

    // What `analyze` makes of each, as this version makes it.
    for g in sessions_of(LOG_FORMAT) {
        let dir = copy_of(LOG_FORMAT, g);
        let (code, err) = analyse(&dir, g, &[]);
        assert_eq!(code, 0, "{}: {err}", g.name);
        keep_tables(&dir.join("out"), &out.join("expected").join(g.name));
    }
    // Older formats keep the expected analysis they were given when it was first written.
    for format in 1..LOG_FORMAT {
        for g in sessions_of(format) {
            if format_dir(format).join("expected").join(g.name).is_dir() {
                continue;
            }
            let dir = copy_of(format, g);
            let (code, err) = analyse(&dir, g, &[]);
            assert_eq!(code, 0, "format {format} {}: {err}", g.name);
            keep_tables(&dir.join("out"), &format_dir(format).join("expected").join(g.name));
        }
    }
}
