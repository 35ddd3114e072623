//! The ROS 2 bridge against an independent DDS implementation: a stand-in robot written with
//! the Cyclone DDS Python binding (`tests/robot/standin_robot.py`) receives every pose of a
//! dry run and answers `at_pose`, `failed` or nothing.
//!
//! Both run in a network namespace of their own (`unshare --net`, loopback only), so no DDS
//! traffic leaves the test. Needs root, `unshare` and `ip`, and HANDOVER_PYTHON: a Python with
//! `cyclonedds` (`.ci/run` makes one). Without them the tests say so and pass, except under
//! CI (`CI=true`), where a missing prerequisite fails them.

use std::path::{Path, PathBuf};
use std::process::Command;

use handover::record::{LogContents, mcap_files, read_log};
use handover::session::{Event, RobotLinkKind, RobotState, VoidReason};

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("handover-ros2-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The Python with cyclonedds, if this machine can run the interop test.
fn prerequisites() -> Option<String> {
    let missing = |why: &str| -> Option<String> {
        assert!(std::env::var("CI").as_deref() != Ok("true"), "the ROS 2 interop test cannot run under CI: {why}");
        eprintln!("skipped: {why} (the ROS 2 interop test runs in CI, .ci/run)");
        None
    };
    let Ok(python) = std::env::var("HANDOVER_PYTHON") else { return missing("HANDOVER_PYTHON is not set") };
    let has = |cmd: &mut Command| cmd.output().is_ok_and(|o| o.status.success());
    if !has(Command::new(&python).args(["-c", "import cyclonedds"])) {
        return missing("HANDOVER_PYTHON has no cyclonedds");
    }
    if !has(Command::new("unshare").args(["--net", "true"])) {
        return missing("cannot make a network namespace (unshare --net needs root)");
    }
    Some(python)
}

/// Runs the stand-in robot and a dry run together in a new network namespace; the dry run's
/// exit status.
fn dry_run_with_standin(python: &str, dir: &Path, answer: &str, timeout_s: f64) -> (i32, String) {
    let mut v: serde_json::Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 300.into();
    std::fs::write(dir.join("small.json"), v.to_string()).unwrap();
    let lab = serde_json::json!({"timeout_s": timeout_s, "ros2": {"networks": ["127.0.0.1"], "resend_s": 1.0}});
    std::fs::write(dir.join("lab.json"), lab.to_string()).unwrap();
    let script = r#"
set -u
ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo
export CYCLONEDDS_URI='<CycloneDDS><Domain><General><Interfaces><NetworkInterface name="lo" multicast="true"/></Interfaces></General></Domain></CycloneDDS>'
"$PY" "$STANDIN" --answer "$ANSWER" --out "$DIR/received.jsonl" --seconds 120 > "$DIR/standin.out" 2> "$DIR/standin.err" &
robot=$!
for _ in $(seq 100); do grep -q ready "$DIR/standin.out" 2>/dev/null && break; sleep 0.1; done
"$HANDOVER" dry-run --seed 4 --protocol "$DIR/small.json" --body-height 1.75 --handedness right \
  --logs "$DIR/logs" --robot ros2 --robot-config "$DIR/lab.json"
code=$?
kill $robot
wait $robot 2>/dev/null
exit $code
"#;
    let out = Command::new("unshare")
        .args(["--net", "bash", "-c", script])
        .env("PY", python)
        .env("STANDIN", Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/robot/standin_robot.py"))
        .env("ANSWER", answer)
        .env("DIR", dir)
        .env("HANDOVER", env!("CARGO_BIN_EXE_handover"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned()
        + &std::fs::read_to_string(dir.join("standin.err")).unwrap_or_default();
    (out.status.code().unwrap_or(-1), err)
}

fn the_log(dir: &Path) -> LogContents {
    let files = mcap_files(&dir.join("logs"));
    assert_eq!(files.len(), 1, "{files:?}");
    read_log(&files[0]).unwrap()
}

fn received(dir: &Path, topic: &str) -> Vec<serde_json::Value> {
    std::fs::read_to_string(dir.join("received.jsonl"))
        .unwrap_or_default()
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|v| v["topic"] == topic)
        .collect()
}

#[test]
fn a_ros2_robot_receives_every_pose_and_its_answers_are_logged() {
    let Some(python) = prerequisites() else { return };
    let dir = tmpdir("at-pose");
    let (code, err) = dry_run_with_standin(&python, &dir, "at_pose", 30.0);
    assert_eq!(code, 0, "{err}");
    let log = the_log(&dir);
    let sent: Vec<_> = log
        .events
        .iter()
        .filter_map(|e| match &e.event {
            Event::RobotCommanded { query, link, pose } => Some((query.clone(), *link, pose.clone())),
            _ => None,
        })
        .collect();
    assert_eq!(sent.len(), 26);
    assert!(sent.iter().all(|(_, link, _)| *link == RobotLinkKind::Ros2));
    // The robot got each pose once, with the numbers and the frame the log says were sent.
    let poses = received(&dir, "/handover/target_pose");
    assert_eq!(poses.len(), 26, "{poses:?}");
    for (got, (_, _, pose)) in poses.iter().zip(&sent) {
        assert_eq!(got["frame_id"], "shoulder");
        assert_eq!(got["frame_id"].as_str().unwrap(), pose.frame);
        for k in 0..3 {
            assert_eq!(got["position"][k].as_f64().unwrap(), pose.position[k]);
        }
        for k in 0..4 {
            assert_eq!(got["orientation"][k].as_f64().unwrap(), pose.orientation[k]);
        }
    }
    let trials = received(&dir, "/handover/trial");
    assert_eq!(trials.len(), 26);
    for (t, (query, _, _)) in trials.iter().zip(&sent) {
        assert_eq!(t["trial"]["query"].as_str().unwrap(), query);
    }
    // Its answers are in the log: moving, then at_pose, for every command, each before the
    // query is presented.
    let states: Vec<RobotState> = log
        .events
        .iter()
        .filter_map(|e| match &e.event {
            Event::RobotReported { state, .. } => Some(*state),
            _ => None,
        })
        .collect();
    assert_eq!(states, [RobotState::Moving, RobotState::AtPose].repeat(26));
    let presented = log.events.iter().filter(|e| matches!(e.event, Event::QueryPresented { .. })).count();
    assert_eq!(presented, 26);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_ros2_robot_that_fails_or_says_nothing_voids_the_trial_and_ends_the_dry_run() {
    let Some(python) = prerequisites() else { return };
    for (answer, state, timeout_s) in [("failed", RobotState::Failed, 30.0), ("silent", RobotState::Timeout, 2.0)] {
        let dir = tmpdir(answer);
        let (code, err) = dry_run_with_standin(&python, &dir, answer, timeout_s);
        assert_eq!(code, 1, "{answer}: {err}");
        assert!(err.contains("the robot failed 3 times in a row"), "{answer}: {err}");
        let log = the_log(&dir);
        let finals = log
            .events
            .iter()
            .filter(|e| matches!(&e.event, Event::RobotReported { state: s, .. } if *s == state))
            .count();
        assert_eq!(finals, 3, "{answer}");
        let voids = log
            .events
            .iter()
            .filter(|e| matches!(&e.event, Event::TrialVoided { reason: VoidReason::RobotFault, .. }))
            .count();
        assert_eq!(voids, 3, "{answer}");
        assert!(matches!(log.events.last().map(|e| &e.event), Some(Event::Aborted { .. })));
        assert!(!log.events.iter().any(|e| matches!(e.event, Event::QueryPresented { .. })), "nothing was presented");
        // The robot heard every command, re-sent until it answered (the silent one: until the
        // timeout).
        assert!(received(&dir, "/handover/target_pose").len() >= 3, "{answer}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
