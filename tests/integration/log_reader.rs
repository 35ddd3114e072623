//! Every per-session table `analyze` writes agrees with an independent reader of the logs
//! (`tests/readers/tables_from_log.py`: Python and the `mcap` package, none of this crate's
//! code) on a generated corpus:
//!
//! - sessions driven through the headless console by a seeded random operator pressing the
//!   keys the key table says act now (`keys_that_act`): grasps, undos, voids before and after
//!   presenting and after a grasp, undos across a phase boundary, notes (`NA`, `N/A`, `None`,
//!   commas, quotes), pauses, quits and kills each followed (mostly) by a resume, aborts, both
//!   hands, three body heights, the region and configuration observation models, and a robot
//!   in the loop that answers, moves first, fails, says something else, answers twice, answers
//!   late (after the next command) or says nothing;
//! - dry runs with measured arms, and with robot programs that fail or hang past the timeout;
//! - the golden logs of formats 1–3;
//! - a withdrawn participant, whom both must leave out.
//!
//! The test prints how many sessions, events, rows and cells were compared.

use crate::support::{handover, missing, tmpdir};

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::Sender;
use std::time::Duration;

use handover::protocol::{DEFAULT_PROTOCOL, Study};
use handover::record::{mcap_files, read_log};
use handover::robot::{Link, Report, Robot, RobotCommand, RobotSettings};
use handover::session::{RobotLinkKind, RobotState};
use handover::study_dir::StudyDirs;
use handover::tui::keys::{Action, Mode, action_for, keys_that_act};
use handover::tui::{App, AppConfig};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

const T0: u64 = 1_800_000_000_000_000_000;

/// Console sessions generated (each of them may be quit or killed and resumed: more logs), in
/// study folders of [`PER_STUDY`] (a new participant's counterbalancing reads every log of
/// their study).
const CONSOLE_SESSIONS: u64 = 440;
const PER_STUDY: u64 = 30;

/// What the robot does with one command.
#[derive(Clone, Copy, Debug)]
enum Answer {
    AtPose,
    MovingThenAtPose,
    Failed,
    Other,
    Twice,
    /// Its answer comes with the next command (a late answer).
    Late,
    Silent,
}

/// A robot in the loop, in the process: it answers each command as its seeded draw says.
struct ScriptedRobot {
    tx: Sender<Report>,
    rng: StdRng,
    held: Option<Report>,
}

impl Link for ScriptedRobot {
    fn kind(&self) -> RobotLinkKind {
        RobotLinkKind::Command
    }

    fn send(&mut self, command: &RobotCommand) -> Result<(), String> {
        if let Some(late) = self.held.take() {
            let _ = self.tx.send(late);
        }
        let report = |state, detail: &str| command.report(state, detail);
        let answer = match self.rng.random_range(0..100) {
            0..55 => Answer::AtPose,
            55..70 => Answer::MovingThenAtPose,
            70..77 => Answer::Failed,
            77..81 => Answer::Other,
            81..87 => Answer::Twice,
            87..95 => Answer::Late,
            _ => Answer::Silent,
        };
        let send = |r: Report| {
            let _ = self.tx.send(r);
        };
        match answer {
            Answer::AtPose => send(report(RobotState::AtPose, "")),
            Answer::MovingThenAtPose => {
                send(report(RobotState::Moving, ""));
                send(report(RobotState::AtPose, ""));
            }
            Answer::Failed => send(report(RobotState::Failed, "failed: joint 4 at its limit")),
            Answer::Other => send(report(RobotState::Other, "recalibrating, \"wait\"")),
            Answer::Twice => {
                send(report(RobotState::AtPose, ""));
                send(report(RobotState::AtPose, "again"));
            }
            Answer::Late => self.held = Some(report(RobotState::AtPose, "late")),
            Answer::Silent => {}
        }
        Ok(())
    }

    fn describe(&self) -> String {
        "scripted robot".into()
    }
}

/// Notes an operator may type: missing-value spellings, CSV's own characters, non-ASCII.
const NOTES: [&str; 8] = ["NA", "N/A", "None", "", "a, \"quoted\" note", "naïve — ünïcode", "TRUE", " 12 "];

/// The protocol of session `k`: few particles and trials, a hand, a height, an observation.
fn protocol(rng: &mut StdRng) -> String {
    let mut v: serde_json::Value = serde_json::from_str(DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 100.into();
    v["session"]["trials_per_condition"] = rng.random_range(2..=4).into();
    let tests = v["test_set"].as_array().unwrap().len();
    v["test_set"].as_array_mut().unwrap().truncate(rng.random_range(2..=tests.min(4)));
    let side = if rng.random_bool(0.35) { "left" } else { "right" };
    let height = [1.50, 1.75, 1.95][rng.random_range(0..3)];
    v["arm"] = serde_json::json!({"body_height_m": height, "side": side});
    if rng.random_bool(0.3) {
        v["learning"]["observation"] = "configuration".into();
    }
    v.to_string()
}

fn config(dir: &Path, text: &str, seed: u64) -> AppConfig {
    AppConfig {
        study: Arc::new(Study::from_json(text, "generated").unwrap()),
        protocol_text: text.to_string(),
        dirs: StudyDirs::resolve(Some(dir), None, None),
        participant: "new".into(),
        simulate: false,
        pilot: false,
        pilot_body: Default::default(),
        practice: false,
        pace: Duration::ZERO,
        seed: Some(seed),
        tap: None,
    }
}

fn robot(rng: &mut StdRng) -> Option<Robot> {
    if !rng.random_bool(0.4) {
        return None;
    }
    let present_on = if rng.random_bool(0.5) { "at_pose" } else { "operator" };
    let settings =
        RobotSettings::from_json(&format!(r#"{{"present_on": "{present_on}", "timeout_s": 1}}"#), "lab.json").unwrap();
    let seed = rng.random();
    Some(
        Robot::new(settings, move |tx, _| {
            Ok(Box::new(ScriptedRobot { tx, rng: StdRng::seed_from_u64(seed), held: None }) as Box<dyn Link>)
        })
        .unwrap(),
    )
}

/// How often the operator presses what a key does, against the others that act now.
fn weight(mode: Mode, action: Action) -> f64 {
    match (mode, action) {
        (Mode::Setup, Action::Confirm) => 1.0,
        (Mode::Setup, _) => 0.0,
        (_, Action::Region(_) | Action::Likert(_) | Action::Confirm | Action::Retry) => 10.0,
        (_, Action::Next | Action::HandOver) => 5.0,
        (_, Action::Choice(_)) => 1.0,
        (_, Action::HandBack | Action::No | Action::VoidReason(_) | Action::SendRobot) => 3.0,
        (_, Action::Yes) => 2.0,
        (_, Action::Undo | Action::Prev | Action::Cancel | Action::ScrollDown) => 1.2,
        (_, Action::Void) => 0.9,
        (_, Action::Abort) => 0.3,
        (_, Action::Note | Action::Pause) => 0.5,
        (_, Action::Quit) => 0.12,
        _ => 0.2,
    }
}

/// Drives `app` with random keys until its session ends, it is quit, or it is "killed"
/// (dropped without a word, as kill -9 leaves it). Whether the session is over.
fn operate(app: &mut App, rng: &mut StdRng, now: &mut u64) -> bool {
    for _ in 0..2000 {
        *now += rng.random_range(20_000_000..3_000_000_000);
        app.tick(*now);
        app.wait_idle();
        let mode = app.mode();
        if mode == Mode::Summary {
            return true;
        }
        if app.session().is_some() && rng.random_bool(0.004) {
            return false; // killed
        }
        if mode == Mode::LineEdit {
            for c in NOTES[rng.random_range(0..NOTES.len())].chars() {
                app.key(KeyEvent::new(KeyCode::Char(c), KeyModifiers::NONE));
            }
            let done = if rng.random_bool(0.9) { KeyCode::Enter } else { KeyCode::Esc };
            app.key(KeyEvent::new(done, KeyModifiers::NONE));
            app.wait_idle();
            continue;
        }
        let counts = app.counts();
        let keys: Vec<(KeyEvent, f64)> = keys_that_act(mode, counts)
            .into_iter()
            .filter_map(|k| Some((k, weight(mode, action_for(mode, k, counts)?))))
            .filter(|(_, w)| *w > 0.0)
            .collect();
        let total: f64 = keys.iter().map(|(_, w)| w).sum();
        if total == 0.0 {
            // Nothing acts (a robot's answer is awaited): time passes.
            std::thread::sleep(Duration::from_millis(5));
            continue;
        }
        let mut pick = rng.random_range(0.0..total);
        let key = keys.iter().find(|(_, w)| {
            pick -= w;
            pick < 0.0
        });
        let key = key.map_or(keys[0].0, |k| k.0);
        app.key(key);
        app.wait_idle();
        if app.session().is_some_and(|s| s.robot().is_some_and(|r| r.last.is_none())) {
            // A silent robot times out in real time: wait for it now and then.
            std::thread::sleep(Duration::from_millis(2));
        }
        if matches!(app.mode(), Mode::Setup) && app.log_path().is_some() {
            return false; // quit: the log is closed
        }
    }
    false
}

/// Runs the console sessions into study folders under `root`; their count.
fn console_sessions(root: &Path, n: u64) -> usize {
    let mut started = 0;
    for k in 0..n {
        let study = root.join(format!("study-{}", k / PER_STUDY));
        let dir = study.as_path();
        let mut rng = StdRng::seed_from_u64(0x5eed_0000 + k);
        let text = protocol(&mut rng);
        let mut now = T0 + k * 10_000_000_000_000;
        let mut app = App::new(config(dir, &text, k)).with_robot(robot(&mut rng));
        app.tick(now);
        let mut over = operate(&mut app, &mut rng, &mut now);
        let Some(mut log) = app.log_path() else { continue };
        started += 1;
        drop(app);
        while !over && rng.random_bool(0.85) {
            let old = read_log(&log).unwrap();
            let Ok(resumed) = App::resume(config(dir, &text, k), &old) else { break };
            app = resumed.with_robot(robot(&mut rng));
            now += 60_000_000_000;
            over = operate(&mut app, &mut rng, &mut now);
            log = app.log_path().unwrap_or(log);
            drop(app);
        }
    }
    started
}

fn run(args: &[&str]) {
    let (code, out, err) = handover(args);
    assert_eq!(code, 0, "handover {args:?}:\n{out}{err}");
}

#[test]
fn every_table_agrees_with_an_independent_reader_of_the_logs() {
    let Ok(python) = std::env::var("HANDOVER_PYTHON") else {
        return missing("HANDOVER_PYTHON, a Python with the mcap package (.ci/run makes one)");
    };
    // Logs on tmpfs where there is one: every event is synced, and the corpus is large.
    let base = if Path::new("/dev/shm").is_dir() {
        tempfile::tempdir_in("/dev/shm").unwrap()
    } else {
        tempfile::tempdir().unwrap()
    };
    let logs = base.path().join("studies");
    let clock = std::time::Instant::now();
    let console = console_sessions(&logs, CONSOLE_SESSIONS);
    eprintln!("{console} console sessions in {:.1} s", clock.elapsed().as_secs_f64());

    // Dry runs: measured arms, both hands drawn, and robot programs that fail or hang.
    let d = tmpdir("reader-dry");
    let measured = {
        let mut v: serde_json::Value = serde_json::from_str(DEFAULT_PROTOCOL).unwrap();
        v["learning"]["particles"] = 100.into();
        v["learning"]["observation"] = "measured".into();
        v["learning"]["measurement"] = serde_json::json!({"sigma_deg": vec![5.0; 7]});
        let p = d.join("measured.json");
        std::fs::write(&p, v.to_string()).unwrap();
        p
    };
    let small = crate::support::small_protocol(&d);
    let logs_s = logs.to_str().unwrap();
    let dry = logs.join("dry-runs");
    let dry_s = dry.to_str().unwrap();
    run(&[
        "dry-run",
        "--participants",
        "40",
        "--seed",
        "71",
        "--protocol",
        small.to_str().unwrap(),
        "--left-handed-share",
        "0.5",
        "--logs",
        dry_s,
    ]);
    run(&[
        "dry-run",
        "--participants",
        "30",
        "--seed",
        "72",
        "--protocol",
        measured.to_str().unwrap(),
        "--left-handed-share",
        "0.5",
        "--logs",
        dry_s,
    ]);
    // A robot program that fails or hangs past the timeout now and then, by a fixed pattern
    // over its calls (never three failures in a row, which would end the session).
    let calls = d.join("calls");
    let flaky = crate::robot_hook::script(
        &d,
        "flaky.sh",
        &format!(
            "cat > /dev/null\nn=$(( $(cat '{c}' 2>/dev/null || echo 0) + 1 ))\necho $n > '{c}'\n\
             if [ $((n % 9)) -eq 4 ]; then echo 'lost it' >&2; exit 3; fi\n\
             if [ $((n % 23)) -eq 11 ]; then exec sleep 5; fi\nexit 0",
            c = calls.display()
        ),
    );
    let settings = d.join("robot.json");
    std::fs::write(&settings, r#"{"timeout_s": 1}"#).unwrap();
    run(&[
        "dry-run",
        "--participants",
        "12",
        "--seed",
        "73",
        "--protocol",
        small.to_str().unwrap(),
        "--robot-command",
        flaky.to_str().unwrap(),
        "--robot-config",
        settings.to_str().unwrap(),
        "--logs",
        dry_s,
    ]);
    // The golden logs of every format, each in a folder of its own.
    let golden = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden");
    for format in ["format-1", "format-2", "format-3", "format-4"] {
        let to = logs.join(format!("golden-{format}"));
        std::fs::create_dir_all(&to).unwrap();
        for f in mcap_files(&golden.join(format)) {
            if f.parent() == Some(&golden.join(format)) {
                std::fs::copy(&f, to.join(f.file_name().unwrap())).unwrap();
            }
        }
    }
    // One participant withdraws: analyze and the reader both leave them out.
    let study = logs.join("study-0");
    let withdrawn = std::fs::read_dir(study.join("participants"))
        .unwrap()
        .filter_map(|e| e.unwrap().file_name().to_str()?.strip_suffix(".json").map(String::from))
        .min()
        .expect("a participant of the console's");
    run(&["participant", "withdraw", &withdrawn, "--study-dir", study.to_str().unwrap()]);

    eprintln!("dry runs by {:.1} s", clock.elapsed().as_secs_f64());
    // Each log's study folder says who withdrew.
    let out = base.path().join("out");
    run(&["analyze", logs_s, "--out", out.to_str().unwrap(), "--alpha-particles", "100"]);
    eprintln!("analyzed by {:.1} s", clock.elapsed().as_secs_f64());
    let reader = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/readers/tables_from_log.py");
    let o = std::process::Command::new(&python)
        .arg(&reader)
        .args([logs_s, out.to_str().unwrap(), "--withdrawn", &withdrawn])
        .output()
        .unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    eprintln!("{console} console sessions generated\n{text}");
    assert!(o.status.success(), "{text}");
    let sessions: usize = text
        .lines()
        .find_map(|l| l.strip_prefix("reader: ")?.split(' ').next()?.parse().ok())
        .expect("the reader's count");
    assert!(sessions >= 500, "{sessions} sessions compared, expected at least 500");

    // The same study-sized tables read with their documented Read lines in pandas, readr and
    // read.csv: every value kept, only empty fields missing.
    let trials = std::fs::read_to_string(out.join("trials.csv")).unwrap();
    let first_void = trials.lines().position(|l| l.contains(",voided,")).expect("a void");
    let rows = trials.lines().count() - 1;
    let late_voids = trials.lines().skip(1001).filter(|l| l.contains(",voided,")).count();
    assert!(rows >= 2000 && late_voids > 0, "{rows} trial rows, {late_voids} voids after row 1,000");
    let notes = std::fs::read_to_string(out.join("notes.csv")).unwrap();
    for text in [",NA\n", ",N/A\n", ",None\n"] {
        assert!(notes.contains(text), "a note {text:?}");
    }
    let dict = crate::outputs::dictionary();
    let mut paths: Vec<PathBuf> = Vec::new();
    for dir in [out.clone(), out.join("pilot")] {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "csv") {
                paths.push(p);
            }
        }
    }
    paths.sort();
    let by_pandas = crate::outputs::read_with_pandas(&paths, &dict);
    let by_r = crate::outputs::read_with_r(&paths, &dict);
    eprintln!(
        "{} tables ({rows} trial rows, the first void at row {first_void}, {late_voids} voids after row 1,000) read \
         with their Read lines: {by_pandas} cells by pandas, {by_r} by readr and read.csv, every value kept",
        paths.len()
    );
}
