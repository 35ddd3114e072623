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
use handover::session::{Event, MeasurementSource, RobotLinkKind, RobotState, VoidReason};

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

/// Runs `body` (bash) in a new network namespace with only the loopback, multicast routed on
/// it and Cyclone DDS bound to it, with `PY` (the Python), `DIR`, `HANDOVER` (the binary) and
/// `vars` in its environment; its exit status, and its standard error with the stand-in's.
fn in_namespace(python: &str, dir: &Path, body: &str, vars: &[(&str, String)]) -> (i32, String) {
    let script = format!(
        r#"
set -u
ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo
export CYCLONEDDS_URI='<CycloneDDS><Domain><General><Interfaces><NetworkInterface name="lo" multicast="true"/></Interfaces></General></Domain></CycloneDDS>'
{body}"#
    );
    let mut cmd = Command::new("unshare");
    cmd.args(["--net", "bash", "-c", &script])
        .env("PY", python)
        .env("DIR", dir)
        .env("HANDOVER", env!("CARGO_BIN_EXE_handover"));
    for (k, v) in vars {
        cmd.env(k, v);
    }
    let out = cmd.output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned()
        + &std::fs::read_to_string(dir.join("standin.err")).unwrap_or_default();
    (out.status.code().unwrap_or(-1), err)
}

/// A stand-in script of `tests/robot/`.
fn standin(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/robot").join(name).display().to_string()
}

/// Runs the stand-in robot and a dry run together in a new network namespace; the dry run's
/// exit status.
fn dry_run_with_standin(python: &str, dir: &Path, answer: &str, timeout_s: f64) -> (i32, String) {
    let mut v: serde_json::Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 300.into();
    std::fs::write(dir.join("small.json"), v.to_string()).unwrap();
    let lab = serde_json::json!({"timeout_s": timeout_s, "ros2": {"networks": ["127.0.0.1"], "resend_s": 1.0}});
    std::fs::write(dir.join("lab.json"), lab.to_string()).unwrap();
    let body = r#"
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
    in_namespace(python, dir, body, &[("STANDIN", standin("standin_robot.py")), ("ANSWER", answer.to_string())])
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

/// A dry run of a measured protocol whose arm is measured over ROS 2 (`--measure ros2`),
/// with the stand-in measuring system publishing (or not) in the same network namespace.
fn measured_dry_run(python: &str, dir: &Path, publish: bool) -> (i32, String) {
    let mut v: serde_json::Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 300.into();
    v["learning"]["observation"] = "measured".into();
    let names: Vec<String> = (0..7).map(|d| format!("mocap_r_{d}")).collect();
    v["learning"]["measurement"] = serde_json::json!({"sigma_deg": vec![5; 7], "joint_names": names, "window_s": 0.25});
    std::fs::write(dir.join("measured.json"), v.to_string()).unwrap();
    let lab = serde_json::json!({"ros2": {"networks": ["127.0.0.1"]}});
    std::fs::write(dir.join("lab.json"), lab.to_string()).unwrap();
    // Published in reverse order: the names, not the order, say which joint is which.
    let published: Vec<String> = names.iter().rev().cloned().collect();
    let positions: Vec<String> = (0..7).rev().map(|d| format!("{}", 0.1 * (d as f64 + 1.0))).collect();
    let body = r#"
pub=""
if [ "$PUBLISH" = yes ]; then
  "$PY" "$PUBLISHER" --names "$NAMES" --positions "$POSITIONS" --seconds 120 > "$DIR/pub.out" 2> "$DIR/standin.err" &
  pub=$!
  for _ in $(seq 100); do grep -q ready "$DIR/pub.out" 2>/dev/null && break; sleep 0.1; done
  sleep 1
fi
"$HANDOVER" dry-run --seed 4 --protocol "$DIR/measured.json" --logs "$DIR/logs" --pace 5 \
  --measure ros2 --robot-config "$DIR/lab.json"
code=$?
[ -n "$pub" ] && kill $pub && wait $pub 2>/dev/null
exit $code
"#;
    let vars = [
        ("PUBLISHER", standin("joint_state_publisher.py")),
        ("PUBLISH", if publish { "yes" } else { "no" }.to_string()),
        ("NAMES", published.join(",")),
        ("POSITIONS", positions.join(",")),
    ];
    in_namespace(python, dir, body, &vars)
}

#[test]
fn a_joint_state_topic_measures_every_grasp_and_its_silence_falls_back_to_the_region() {
    let Some(python) = prerequisites() else { return };
    let dir = tmpdir("joint-states");
    let (code, err) = measured_dry_run(&python, &dir, true);
    assert_eq!(code, 0, "{err}");
    let log = the_log(&dir);
    let measured: Vec<_> = log
        .events
        .iter()
        .filter_map(|e| match &e.event {
            Event::GraspRecorded { measured, .. } => Some(measured.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(measured.len(), 26);
    for m in &measured {
        let m = m.as_ref().expect("a sample within the window of every grasp");
        assert_eq!(m.source, MeasurementSource::Ros2);
        // Mapped by name: model joint d is mocap_r_d, published at 0.1 (d + 1).
        let expected: Vec<f64> = (0..7).map(|d| 0.1 * (d as f64 + 1.0)).collect();
        assert_eq!(m.q_rad, expected);
        assert!(m.offset_s.abs() <= 0.25, "{}", m.offset_s);
    }
    let (code, _, verify) = {
        let out = Command::new(env!("CARGO_BIN_EXE_handover"))
            .args(["analyze", "--alpha-particles", "50", "--verify"])
            .arg(dir.join("logs"))
            .output()
            .unwrap();
        (out.status.code(), (), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    assert_eq!(code, Some(0), "{verify}");

    // Nothing published: every grasp learns from the region, each logged as the fallback.
    let quiet = tmpdir("joint-states-quiet");
    let (code, err) = measured_dry_run(&python, &quiet, false);
    assert_eq!(code, 0, "{err}");
    let log = the_log(&quiet);
    let fallbacks = log
        .messages
        .iter()
        .filter(|m| m.topic == "/trial/response")
        .inspect(|m| assert!(m.value.get("measured").is_none(), "{:?}", m.value))
        .filter(|m| m.value["learned_from"] == "region")
        .count();
    assert_eq!(fallbacks, 26);
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&quiet);
}
