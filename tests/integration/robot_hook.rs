//! Any robot through `--robot-command PROGRAM`: dry runs against scripts that record their
//! input and exit 0, exit 1, or hang.

use crate::support::{small_protocol, tmpdir};

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use handover::record::{LogContents, mcap_files, read_log};
use handover::session::{Event, RobotState, VoidReason};

pub(crate) fn script(dir: &Path, name: &str, body: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, format!("#!/bin/sh\n{body}\n")).unwrap();
    std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o755)).unwrap();
    p
}

fn dry_run(dir: &Path, logs: &str, extra: &[&str]) -> (i32, String) {
    let protocol = small_protocol(dir);
    let out = Command::new(env!("CARGO_BIN_EXE_handover"))
        .args(["dry-run", "--seed", "4", "--protocol", protocol.to_str().unwrap(), "--body-height", "1.75"])
        .args(["--handedness", "right", "--logs", dir.join(logs).to_str().unwrap()])
        .args(extra)
        .output()
        .unwrap();
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into_owned())
}

fn the_log(dir: &Path) -> LogContents {
    let files = mcap_files(dir);
    assert_eq!(files.len(), 1, "{files:?}");
    read_log(&files[0]).unwrap()
}

fn is_robot(e: &Event) -> bool {
    matches!(e, Event::RobotCommanded { .. } | Event::RobotReported { .. })
}

#[test]
fn every_command_reaches_the_program_and_the_answers_are_those_of_a_run_without_a_robot() {
    let dir = tmpdir("ok");
    let seen = dir.join("stdin.jsonl");
    let ok = script(&dir, "ok.sh", &format!("cat >> '{}'\nexit 0", seen.display()));
    let (code, err) = dry_run(&dir, "robot", &["--robot-command", ok.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let log = the_log(&dir.join("robot"));
    let commands: Vec<_> = log
        .events
        .iter()
        .filter_map(|e| match &e.event {
            Event::RobotCommanded { query, link, pose, .. } => Some((query, link, pose)),
            _ => None,
        })
        .collect();
    let presented = log.events.iter().filter(|e| matches!(e.event, Event::QueryPresented { .. })).count();
    assert_eq!(presented, 26);
    assert_eq!(commands.len(), 26, "one command per trial");
    let statuses: Vec<_> = log
        .events
        .iter()
        .filter_map(|e| match &e.event {
            Event::RobotReported { state, .. } => Some(*state),
            _ => None,
        })
        .collect();
    assert_eq!(statuses, vec![RobotState::AtPose; 26]);
    // What the program read is what the log says was sent.
    let lines: Vec<serde_json::Value> =
        std::fs::read_to_string(&seen).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 26);
    for (line, (query, link, pose)) in lines.iter().zip(&commands) {
        assert_eq!(line["query"], query.as_str());
        assert_eq!(link.name(), "command");
        assert_eq!(line["frame"], "shoulder");
        assert_eq!(pose.frame, "shoulder");
        for (k, axis) in ["x", "y", "z", "w"].iter().enumerate() {
            assert_eq!(line["orientation"][axis].as_f64().unwrap(), pose.orientation[k]);
        }
        for k in 0..3 {
            assert_eq!(line["position"][k].as_f64().unwrap(), pose.position[k]);
        }
        assert_eq!(line["attempt"], 1);
        assert!(!line["grips"].as_array().unwrap().is_empty());
        assert!(["training", "test"].contains(&line["phase"].as_str().unwrap()));
    }
    // Each command is logged before its report, and its report before the presentation.
    for w in log.events.windows(3).filter(|w| matches!(w[0].event, Event::RobotCommanded { .. })) {
        assert!(matches!(w[1].event, Event::RobotReported { state: RobotState::AtPose, .. }));
        assert!(matches!(w[2].event, Event::QueryPresented { .. }));
        assert!(w[0].time_ns < w[1].time_ns && w[1].time_ns < w[2].time_ns);
    }
    // The same seed without a robot: the same session, less the robot's events.
    let (code, err) = dry_run(&dir, "plain", &[]);
    assert_eq!(code, 0, "{err}");
    let plain = the_log(&dir.join("plain"));
    assert!(!plain.messages.iter().any(|m| m.topic.starts_with("/robot/command") || m.topic == "/robot/status"));
    let without: Vec<&Event> = log.events.iter().map(|e| &e.event).filter(|e| !is_robot(e)).collect();
    let expected: Vec<&Event> = plain.events.iter().map(|e| &e.event).collect();
    assert_eq!(without, expected);
    // analyze reports the timings.
    let out = Command::new(env!("CARGO_BIN_EXE_handover"))
        .args(["analyze", dir.join("robot").to_str().unwrap(), "--out", dir.join("out").to_str().unwrap()])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("Robot (1 session(s)): 26 commands: 26 at pose, 0 failed, 0 timed out"), "{text}");
    let csv = std::fs::read_to_string(dir.join("out/pilot/robot.csv")).unwrap();
    assert_eq!(csv.lines().count(), 27);
    assert!(csv.lines().nth(1).unwrap().contains(",command,shoulder,"), "{csv}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_failing_program_voids_the_trial_and_three_in_a_row_end_the_session() {
    let dir = tmpdir("fail");
    let fail = script(&dir, "fail.sh", "cat > /dev/null\necho 'gripper jammed' >&2\nexit 3");
    let (code, err) = dry_run(&dir, "logs", &["--robot-command", fail.to_str().unwrap()]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("the robot failed 3 times in a row"), "{err}");
    let log = the_log(&dir.join("logs"));
    let events: Vec<&Event> = log.events.iter().map(|e| &e.event).collect();
    // Each failure answers its own command (its id), never a stale one.
    let failed = |k: usize| match &events[3 * k] {
        Event::RobotCommanded { query, command: Some(command), .. } => Event::RobotReported {
            query: query.clone(),
            state: RobotState::Failed,
            detail: "exit status 3: gripper jammed".into(),
            command: Some(command.clone()),
            stale: false,
        },
        e => panic!("{e:?}"),
    };
    let void = Event::TrialVoided {
        reason: VoidReason::RobotFault,
        detail: "robot failed: exit status 3: gripper jammed".into(),
    };
    assert_eq!(events.len(), 10, "{events:?}");
    for k in 0..3 {
        assert_eq!(events[3 * k + 1], &failed(k));
        assert_eq!(events[3 * k + 2], &void);
    }
    assert!(matches!(events[9], Event::Aborted { reason } if reason.contains("exit status 3")));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_program_that_hangs_is_killed_at_the_timeout_with_what_it_started() {
    let dir = tmpdir("hang");
    let pids = dir.join("pids");
    let hang = script(&dir, "hang.sh", &format!("sleep 600 &\necho $! >> '{}'\nwait", pids.display()));
    let settings = dir.join("lab.json");
    std::fs::write(&settings, r#"{"timeout_s": 1}"#).unwrap();
    let t = Instant::now();
    let (code, err) = dry_run(
        &dir,
        "logs",
        &["--robot-command", hang.to_str().unwrap(), "--robot-config", settings.to_str().unwrap()],
    );
    assert_eq!(code, 1, "{err}");
    assert!(t.elapsed() < Duration::from_secs(30), "{:?}", t.elapsed());
    let log = the_log(&dir.join("logs"));
    let timeouts = log
        .events
        .iter()
        .filter(|e| matches!(&e.event, Event::RobotReported { state: RobotState::Timeout, detail, .. } if detail == "no answer within 1 s"))
        .count();
    assert_eq!(timeouts, 3);
    // Every `sleep` the program started is gone.
    std::thread::sleep(Duration::from_millis(300));
    let started: Vec<String> = std::fs::read_to_string(&pids).unwrap().lines().map(String::from).collect();
    assert_eq!(started.len(), 3);
    for pid in started {
        let alive = std::fs::read_to_string(format!("/proc/{pid}/cmdline")).is_ok_and(|c| c.starts_with("sleep"));
        assert!(!alive, "sleep {pid} still runs");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_program_that_exits_leaves_nothing_running() {
    let dir = tmpdir("orphans");
    let pids = dir.join("pids");
    // Exits 0 at once, with two children still running (one detached from its output).
    let ok = script(
        &dir,
        "ok.sh",
        &format!(
            "cat > /dev/null\nsleep 600 &\necho $! >> '{0}'\nsleep 600 > /dev/null 2>&1 &\necho $! >> '{0}'\nexit 0",
            pids.display()
        ),
    );
    let (code, err) = dry_run(&dir, "logs", &["--robot-command", ok.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let started: Vec<String> = std::fs::read_to_string(&pids).unwrap().lines().map(String::from).collect();
    let commands =
        the_log(&dir.join("logs")).events.iter().filter(|e| matches!(e.event, Event::RobotCommanded { .. })).count();
    assert_eq!(started.len(), 2 * commands, "two children per command");
    std::thread::sleep(Duration::from_millis(300));
    let alive: Vec<&String> = started
        .iter()
        .filter(|pid| std::fs::read_to_string(format!("/proc/{pid}/cmdline")).is_ok_and(|c| c.starts_with("sleep")))
        .collect();
    assert!(alive.is_empty(), "{} of {} children still run: {alive:?}", alive.len(), started.len());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_bad_robot_option_is_bad_input() {
    let dir = tmpdir("bad");
    let settings = dir.join("lab.json");
    std::fs::write(&settings, r#"{"ros2": {"domain_id": 999}}"#).unwrap();
    let ok = script(&dir, "ok.sh", "exit 0");
    let (code, err) =
        dry_run(&dir, "logs", &["--robot-command", ok.to_str().unwrap(), "--robot-config", settings.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("lab.json: ros2.domain_id: is 999, expected 0 to 232"), "{err}");
    let (code, err) = dry_run(&dir, "logs", &["--robot-config", settings.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(err.contains("--robot-config is given without --robot, --robot-command or --measure"), "{err}");
    let (code, err) = dry_run(&dir, "logs", &["--measure", "ros2"]);
    assert_eq!(code, 2);
    assert!(err.contains("--measure needs a protocol with \"observation\": \"measured\""), "{err}");
    let not_exec = dir.join("plain.txt");
    std::fs::write(&not_exec, "exit 0").unwrap();
    let (code, err) = dry_run(&dir, "logs", &["--robot-command", not_exec.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(err.contains("not an executable file"), "{err}");
    assert!(mcap_files(&dir.join("logs")).is_empty(), "no session started");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_robot_in_the_loop_keeps_the_dry_runs_pace() {
    let dir = tmpdir("pace");
    let ok = script(&dir, "ok.sh", "cat > /dev/null\nexit 0");
    let (code, err) = dry_run(&dir, "paced", &["--robot-command", ok.to_str().unwrap(), "--pace", "40"]);
    assert_eq!(code, 0, "{err}");
    let log = the_log(&dir.join("paced"));
    // Each of the participant's answers comes at least the pace after the event before it.
    let mut answers = 0;
    for pair in log.events.windows(2) {
        if matches!(pair[1].event, Event::GraspRecorded { .. } | Event::LikertAnswered { .. }) {
            answers += 1;
            let gap_ms = (pair[1].time_ns - pair[0].time_ns) / 1_000_000;
            assert!(gap_ms >= 40, "{:?} {gap_ms} ms after {:?}", pair[1].event, pair[0].event);
        }
    }
    assert!(answers >= 26 + 8, "{answers}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A robot fault before a trial is presented voids that trial, not the one taken before it:
/// trials.csv gives the taken trial `taken` and the trial the robot never reached a row of
/// its own, `voided` for `robot-fault` with no presentation time (issue 58's reproduction).
#[test]
fn a_fault_before_presenting_voids_the_trial_the_robot_was_sent_to() {
    let dir = tmpdir("fail-once");
    let count = dir.join("calls");
    let fail_once = script(
        &dir,
        "fail-once.sh",
        &format!(
            "cat > /dev/null\nn=$(( $(cat '{c}' 2>/dev/null || echo 0) + 1 ))\necho $n > '{c}'\n\
             [ $n -eq 5 ] && {{ echo 'lost the object' >&2; exit 3; }}\nexit 0",
            c = count.display()
        ),
    );
    let (code, err) = dry_run(&dir, "logs", &["--robot-command", fail_once.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let out = dir.join("out");
    let (code, stdout, err) = crate::support::handover(&[
        "analyze",
        dir.join("logs").to_str().unwrap(),
        "--verify",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stdout}{err}");
    let mut r = csv::Reader::from_path(out.join("pilot/trials.csv")).unwrap();
    let head = r.headers().unwrap().clone();
    let col = |name: &str| head.iter().position(|h| h == name).unwrap();
    let rows: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
    let first_run: Vec<&csv::StringRecord> = rows.iter().filter(|x| &x[col("program")] == "A").collect();
    let status: Vec<(&str, &str)> = first_run.iter().take(6).map(|x| (&x[col("trial")], &x[col("status")])).collect();
    assert_eq!(
        status,
        [("1", "taken"), ("2", "taken"), ("3", "taken"), ("4", "taken"), ("5", "voided"), ("5", "taken")],
        "{rows:?}"
    );
    let void = first_run[4];
    assert_eq!(&void[col("void_reason")], "robot-fault");
    assert_eq!(&void[col("void_detail")], "robot failed: exit status 3: lost the object");
    assert_eq!(&void[col("presented_at")], "", "never presented");
    assert_eq!(&void[col("region")], "");
    assert_eq!(&first_run[3][col("region")].is_empty(), &false, "trial 4 keeps its grasp");
    assert_eq!(rows.iter().filter(|x| &x[col("status")] == "taken").count(), 26);
    assert_eq!(rows.iter().filter(|x| &x[col("status")] == "voided").count(), 1);
    // The void row's event index is the /trial/void event's.
    let log = the_log(&dir.join("logs"));
    let index: usize = void[col("event_index")].parse().unwrap();
    assert!(matches!(log.events[index - 1].event, Event::TrialVoided { reason: VoidReason::RobotFault, .. }));
}
