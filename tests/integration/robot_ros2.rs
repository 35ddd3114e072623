//! The ROS 2 bridge against real ROS 2: rclpy from the ROS 2 wheels on PyPI (Kilted and
//! Jazzy, each on Fast DDS, its default RMW), with no ROS install. The shipped
//! `docs/examples/robot_node.py` runs unchanged; `tests/robot/` holds a recorder node, a
//! robot that fails, says nothing or cannot match, and a measuring system publishing
//! `sensor_msgs/msg/JointState` with the sensor-data or the default QoS.
//!
//! Every run is in a network namespace of its own (`unshare --net`, loopback only, multicast
//! routed on it), so no DDS traffic leaves it and tests run side by side. The releases come
//! from HANDOVER_ROS_KILTED and HANDOVER_ROS_JAZZY (each a venv's Python, which `.ci/run`
//! makes); when either is set, a missing prerequisite fails the test. With neither, the tests
//! say so and pass.

use crate::support::{small_protocol, tmpdir};

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use handover::record::{LogContents, mcap_files, read_log};
use handover::session::{Event, MeasurementSource, RobotLinkKind, RobotState, VoidReason};

/// The ROS 2 releases to test against: (name, a Python with its rclpy).
fn releases() -> Vec<(&'static str, String)> {
    let found: Vec<(&str, String)> = [("kilted", "HANDOVER_ROS_KILTED"), ("jazzy", "HANDOVER_ROS_JAZZY")]
        .into_iter()
        .filter_map(|(name, var)| std::env::var(var).ok().map(|python| (name, python)))
        .collect();
    if found.is_empty() {
        eprintln!("skipped: neither HANDOVER_ROS_KILTED nor HANDOVER_ROS_JAZZY is set (.ci/run sets both)");
        return found;
    }
    let works = |cmd: &mut Command| cmd.output().is_ok_and(|o| o.status.success());
    for (name, python) in &found {
        let imports = "import rclpy, std_msgs.msg, geometry_msgs.msg, sensor_msgs.msg";
        assert!(works(Command::new(python).args(["-c", imports])), "{name}: {python} cannot import rclpy");
    }
    assert!(
        works(Command::new("unshare").args(["--net", "true"])),
        "cannot make a network namespace (unshare --net needs root, util-linux and iproute2)"
    );
    found
}

/// Runs `body` (bash) in a new network namespace with only the loopback, multicast routed on
/// it, with `PY` (the release's Python), `DIR`, `HANDOVER` (the binary), `TESTS` (this
/// folder's `robot/`), `EXAMPLES` (`docs/examples`) and `vars` in its environment; its exit
/// status and its standard error.
fn in_namespace(python: &str, dir: &Path, body: &str, vars: &[(&str, String)]) -> (i32, String) {
    let script = format!(
        r#"
set -u
ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo
# Waits until FILE says ready (a node's endpoints exist), at most 30 s.
ready() {{ for _ in $(seq 300); do grep -q ready "$1" 2>/dev/null && return 0; sleep 0.1; done; echo "$1 never ready" >&2; return 1; }}
{body}"#
    );
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    // A hung run is killed rather than left to hang the test binary.
    let mut cmd = Command::new("timeout");
    cmd.args(["-s", "KILL", "300", "unshare", "--net", "bash", "-c", &script])
        .env("PY", python)
        .env("DIR", dir)
        .env("HANDOVER", env!("CARGO_BIN_EXE_handover"))
        .env("TESTS", root.join("tests/robot"))
        .env("EXAMPLES", root.join("docs/examples"))
        .env_remove("ROS_DOMAIN_ID");
    for (k, v) in vars {
        cmd.env(k, v);
    }
    let out = cmd.output().unwrap();
    let mut err = String::from_utf8_lossy(&out.stderr).into_owned();
    for side in ["robot.err", "recorder.err", "mocap.err"] {
        if let Ok(text) = std::fs::read_to_string(dir.join(side)) {
            err += &format!("\n--- {side}\n{text}");
        }
    }
    (out.status.code().unwrap_or(-1), err)
}

/// The lab's settings: no domain (the environment's), DDS on the loopback.
fn lab(dir: &Path, timeout_s: f64, resend_s: f64) {
    let lab = serde_json::json!({"timeout_s": timeout_s, "ros2": {"networks": ["127.0.0.1"], "resend_s": resend_s}});
    std::fs::write(dir.join("lab.json"), lab.to_string()).unwrap();
}

const DRY_RUN: &str = r#""$HANDOVER" dry-run --seed 4 --protocol "$DIR/small.json" --body-height 1.75 \
  --handedness right --logs "$DIR/logs" --robot ros2 --robot-config "$DIR/lab.json""#;

fn the_log(dir: &Path) -> LogContents {
    let files = mcap_files(&dir.join("logs"));
    assert_eq!(files.len(), 1, "{files:?}");
    read_log(&files[0]).unwrap()
}

/// The JSON lines of `file`.
fn lines(file: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(file)
        .unwrap_or_default()
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .collect()
}

fn floats(v: &serde_json::Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

#[test]
fn the_shipped_robot_node_gets_every_pose_in_the_environments_domain_even_when_it_starts_late() {
    for (release, python) in releases() {
        let dir = tmpdir(&format!("node-{release}"));
        small_protocol(&dir);
        // A resend far beyond the run: a robot that starts after the recorder must not wait
        // for it.
        lab(&dir, 60.0, 30.0);
        let body = format!(
            r#"
export ROS_DOMAIN_ID=7
"$PY" "$TESTS/recorder.py" --out "$DIR/recorded.jsonl" > "$DIR/recorder.out" 2> "$DIR/recorder.err" &
recorder=$!
ready "$DIR/recorder.out" || exit 9
(sleep 3; exec "$PY" "$EXAMPLES/robot_node.py" 2> "$DIR/robot.err") &
robot=$!
{DRY_RUN}
code=$?
kill -KILL $recorder $robot 2>/dev/null; wait 2>/dev/null
exit $code
"#
        );
        let started = Instant::now();
        let (code, err) = in_namespace(&python, &dir, &body, &[]);
        let took = started.elapsed();
        assert_eq!(code, 0, "{release}: {err}");
        assert!(took < Duration::from_secs(25), "{release}: {took:?}: the late robot waited for a resend");
        let log = the_log(&dir);
        let sent: Vec<_> = log
            .events
            .iter()
            .filter_map(|e| match &e.event {
                Event::RobotCommanded { query, link, pose } => Some((query.clone(), *link, pose.clone())),
                _ => None,
            })
            .collect();
        assert_eq!(sent.len(), 26, "{release}");
        assert!(sent.iter().all(|(_, link, _)| *link == RobotLinkKind::Ros2));
        // The robot answered every command: moving, then at_pose.
        let states: Vec<RobotState> = log
            .events
            .iter()
            .filter_map(|e| match &e.event {
                Event::RobotReported { state, .. } => Some(*state),
                _ => None,
            })
            .collect();
        assert_eq!(states, [RobotState::Moving, RobotState::AtPose].repeat(26), "{release}");
        assert_eq!(log.events.iter().filter(|e| matches!(e.event, Event::QueryPresented { .. })).count(), 26);
        // What went over ROS 2, bit for bit: the poses (a pose is published again when a
        // subscriber matches, so consecutive copies count once) and the trials.
        let recorded = lines(&dir.join("recorded.jsonl"));
        let mut poses: Vec<(String, Vec<f64>, Vec<f64>)> = recorded
            .iter()
            .filter(|r| r["topic"] == "pose")
            .map(|r| (r["frame_id"].as_str().unwrap().to_string(), floats(&r["position"]), floats(&r["orientation"])))
            .collect();
        poses.dedup();
        let mut logged: Vec<(String, Vec<f64>, Vec<f64>)> =
            sent.iter().map(|(_, _, p)| (p.frame.clone(), p.position.to_vec(), p.orientation.to_vec())).collect();
        logged.dedup();
        assert_eq!(poses, logged, "{release}");
        let mut trials: Vec<(String, Vec<f64>)> = recorded
            .iter()
            .filter(|r| r["topic"] == "trial")
            .map(|r| {
                let t: serde_json::Value = serde_json::from_str(r["data"].as_str().unwrap()).unwrap();
                (t["query"].as_str().unwrap().to_string(), floats(&t["position"]))
            })
            .collect();
        trials.dedup();
        let mut expected: Vec<(String, Vec<f64>)> =
            sent.iter().map(|(q, _, p)| (q.clone(), p.position.to_vec())).collect();
        expected.dedup();
        assert_eq!(trials, expected, "{release}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// A dry run against `robot` (arguments of `misbehaving_robot.py`, none: no robot at all)
/// with a timeout of `timeout_s`: its exit status and standard error, and the log.
fn against(python: &str, dir: &Path, robot: Option<&str>, timeout_s: f64) -> (i32, String, LogContents) {
    small_protocol(dir);
    lab(dir, timeout_s, 0.5);
    let start_robot = robot.map_or(String::new(), |args| {
        format!(
            r#""$PY" "$TESTS/misbehaving_robot.py" {args} > "$DIR/robot.out" 2> "$DIR/robot.err" &
ready "$DIR/robot.out" || exit 9
sleep 1"#
        )
    });
    let body = format!(
        r#"
export ROS_DOMAIN_ID=7
{start_robot}
{DRY_RUN}
code=$?
kill -KILL $(jobs -p) 2>/dev/null; wait 2>/dev/null
exit $code
"#
    );
    let (code, err) = in_namespace(python, dir, &body, &[]);
    let log = the_log(dir);
    (code, err, log)
}

#[test]
fn a_robot_that_fails_says_nothing_or_cannot_be_matched_voids_the_trial_and_is_said_in_words() {
    for (release, python) in releases() {
        // A robot that answers has time to (a loaded machine); one that cannot, 2 s.
        for (robot, state, says) in [
            (Some("--answer failed"), RobotState::Failed, "failed: gripper fault"),
            (Some("--answer silent"), RobotState::Timeout, "last: robot timeout: no answer within 2 s"),
            (None, RobotState::Timeout, "nobody subscribes to /handover/target_pose in ROS 2 domain 7 (ROS_DOMAIN_ID)"),
            (
                Some("--durability transient_local"),
                RobotState::Timeout,
                "a subscriber of /handover/target_pose cannot match the console's QoS: DURABILITY VOLATILE offered, TRANSIENT_LOCAL requested",
            ),
            (
                Some("--pose-type string"),
                RobotState::Timeout,
                "a subscriber of /handover/target_pose takes std_msgs/msg/String, not geometry_msgs/msg/PoseStamped",
            ),
        ] {
            let name = robot.unwrap_or("none").replace(['-', ' '], "");
            let dir = tmpdir(&format!("{release}-{name}"));
            let timeout_s = if state == RobotState::Failed { 20.0 } else { 2.0 };
            let (code, err, log) = against(&python, &dir, robot, timeout_s);
            let case = format!("{release} {robot:?}");
            assert_eq!(code, 1, "{case}: {err}");
            assert!(err.contains("the robot failed 3 times in a row"), "{case}: {err}");
            assert!(err.contains(says), "{case}: expected '{says}' in: {err}");
            let finals = log
                .events
                .iter()
                .filter(|e| matches!(&e.event, Event::RobotReported { state: s, .. } if *s == state))
                .count();
            assert_eq!(finals, 3, "{case}");
            let voids = log
                .events
                .iter()
                .filter(|e| matches!(&e.event, Event::TrialVoided { reason: VoidReason::RobotFault, .. }))
                .count();
            assert_eq!(voids, 3, "{case}");
            assert!(matches!(log.events.last().map(|e| &e.event), Some(Event::Aborted { .. })), "{case}");
            assert!(!log.events.iter().any(|e| matches!(e.event, Event::QueryPresented { .. })), "{case}");
            let _ = std::fs::remove_dir_all(&dir);
        }
    }
}

/// The measuring system's joint names, in the model's order.
fn mocap_names() -> Vec<String> {
    (0..7).map(|d| format!("mocap_r_{d}")).collect()
}

/// A dry run of a measured protocol whose arm is measured over ROS 2 (`--measure ros2`),
/// with the measuring system publishing at 100 Hz with `qos` (none: not at all).
fn measured_dry_run(python: &str, dir: &Path, qos: Option<&str>) -> (i32, String) {
    let mut v: serde_json::Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 300.into();
    v["learning"]["observation"] = "measured".into();
    v["learning"]["measurement"] =
        serde_json::json!({"sigma_deg": vec![5; 7], "joint_names": mocap_names(), "window_s": 0.25});
    std::fs::write(dir.join("measured.json"), v.to_string()).unwrap();
    lab(dir, 60.0, 2.0);
    // Published in reverse order: the names, not the order, say which joint is which.
    let published: Vec<String> = mocap_names().into_iter().rev().collect();
    let positions: Vec<String> = (0..7).rev().map(|d| format!("{}", 0.1 * (d as f64 + 1.0))).collect();
    let start = qos.map_or(String::new(), |qos| {
        format!(
            r#""$PY" "$TESTS/joint_state_publisher.py" --qos {qos} --names "$NAMES" --positions "$POSITIONS" \
  --out "$DIR/published.jsonl" > "$DIR/mocap.out" 2> "$DIR/mocap.err" &
ready "$DIR/mocap.out" || exit 9"#
        )
    });
    let body = format!(
        r#"
{start}
"$HANDOVER" dry-run --seed 4 --protocol "$DIR/measured.json" --logs "$DIR/logs" --pace 20 \
  --measure ros2 --robot-config "$DIR/lab.json"
code=$?
kill -KILL $(jobs -p) 2>/dev/null; wait 2>/dev/null
exit $code
"#
    );
    in_namespace(python, dir, &body, &[("NAMES", published.join(",")), ("POSITIONS", positions.join(","))])
}

/// The published samples: (stamp, angles in the model's order).
fn published(dir: &Path) -> Vec<(u64, Vec<f64>)> {
    lines(&dir.join("published.jsonl"))
        .iter()
        .map(|s| {
            let mut q = floats(&s["position"]);
            q.reverse();
            (s["stamp_ns"].as_u64().unwrap(), q)
        })
        .collect()
}

#[test]
fn a_measuring_system_with_sensor_or_default_qos_measures_every_grasp_by_the_documented_rule() {
    for (release, python) in releases() {
        for qos in ["sensor", "default"] {
            let dir = tmpdir(&format!("mocap-{release}-{qos}"));
            let (code, err) = measured_dry_run(&python, &dir, Some(qos));
            let case = format!("{release} {qos}");
            assert_eq!(code, 0, "{case}: {err}");
            let samples = published(&dir);
            assert!(samples.len() > 100, "{case}: {} samples", samples.len());
            let log = the_log(&dir);
            let grasps: Vec<_> = log
                .events
                .iter()
                .filter_map(|e| match &e.event {
                    Event::GraspRecorded { measured, .. } => Some((e.time_ns, measured.clone())),
                    _ => None,
                })
                .collect();
            assert_eq!(grasps.len(), 26, "{case}");
            for (t, m) in &grasps {
                let m = m.as_ref().unwrap_or_else(|| panic!("{case}: a grasp without a sample"));
                assert_eq!(m.source, MeasurementSource::Ros2);
                // The latest sample published at or before the grasp, bit for bit.
                let (stamp, q) = samples.iter().rev().find(|(s, _)| s <= t).unwrap();
                assert_eq!(&m.q_rad, q, "{case}: grasp at {t}");
                assert_eq!(m.offset_s, -((t - stamp) as f64 / 1e9), "{case}");
            }
            // The same samples as a file give the same measurements post hoc: the measured
            // re-fit equals the live fit.
            let csv = dir.join("samples.csv");
            let mut w = csv::Writer::from_path(&csv).unwrap();
            let mut header = vec!["time".to_string()];
            header.extend(mocap_names().iter().map(|n| format!("{n}_rad")));
            w.write_record(&header).unwrap();
            for (stamp, q) in &samples {
                let time = chrono::DateTime::from_timestamp_nanos(*stamp as i64)
                    .to_rfc3339_opts(chrono::SecondsFormat::Nanos, true);
                let mut row = vec![time];
                row.extend(q.iter().map(|v| format!("{v:?}")));
                w.write_record(&row).unwrap();
            }
            w.flush().unwrap();
            let out = Command::new(env!("CARGO_BIN_EXE_handover"))
                .args(["analyze", "--alpha-particles", "50", "--verify", "--measurements"])
                .arg(&csv)
                .arg("--out")
                .arg(dir.join("analysis"))
                .arg(dir.join("logs"))
                .output()
                .unwrap();
            let stdout = String::from_utf8_lossy(&out.stdout);
            assert_eq!(out.status.code(), Some(0), "{case}: {}", String::from_utf8_lossy(&out.stderr));
            assert!(stdout.contains("26 of 26 grasps measured"), "{case}: {stdout}");
            let fit = std::fs::read_to_string(dir.join("analysis/pilot/measured_fit.csv")).unwrap();
            let rows: Vec<Vec<&str>> = fit.lines().map(|l| l.split(',').collect()).collect();
            let col = |name: &str| rows[0].iter().position(|c| *c == name).unwrap();
            let pick = |r: &Vec<&str>, names: [&str; 3]| names.map(|n| r[col(n)].to_string());
            let key = |r: &Vec<&str>| pick(r, ["program", "parameter", "joint"]);
            let value = |r: &Vec<&str>| pick(r, ["mean", "ci_low", "ci_high"]);
            for logged in rows.iter().filter(|r| r[col("fit")] == "logged") {
                let refit = rows.iter().find(|r| r[col("fit")] == "measured" && key(r) == key(logged)).unwrap();
                assert_eq!(value(logged), value(refit), "{case}");
            }
            let _ = std::fs::remove_dir_all(&dir);
        }
    }
}

#[test]
fn a_silent_measuring_system_falls_back_to_the_region_and_says_why() {
    for (release, python) in releases() {
        let dir = tmpdir(&format!("quiet-{release}"));
        let (code, err) = measured_dry_run(&python, &dir, None);
        assert_eq!(code, 0, "{release}: {err}");
        assert!(
            err.contains("no joint state from ros2 domain 0 (default) ← /handover/participant/joint_states")
                && err.contains("(nobody publishes /handover/participant/joint_states in ROS 2 domain 0 (default))"),
            "{release}: {err}"
        );
        let log = the_log(&dir);
        let fallbacks = log
            .messages
            .iter()
            .filter(|m| m.topic == "/trial/response")
            .inspect(|m| assert!(m.value.get("measured").is_none(), "{:?}", m.value))
            .filter(|m| m.value["learned_from"] == "region")
            .count();
        assert_eq!(fallbacks, 26, "{release}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}

#[test]
fn robot_check_says_which_topics_are_ready_without_moving_anything() {
    for (release, python) in releases() {
        let dir = tmpdir(&format!("check-{release}"));
        let body = r#"
export ROS_DOMAIN_ID=3
"$PY" "$EXAMPLES/robot_node.py" 2> "$DIR/robot.err" &
"$PY" "$TESTS/joint_state_publisher.py" --names a,b,c,d,e,f,g --positions 0,0,0,0,0,0,0 --out /dev/null \
  > "$DIR/mocap.out" 2> "$DIR/mocap.err" &
ready "$DIR/mocap.out" || exit 9
"$HANDOVER" robot-check --measure ros2 --wait-s 3 > "$DIR/ready.txt"
echo $? > "$DIR/ready.code"
kill -KILL $(jobs -p) 2>/dev/null; wait 2>/dev/null
"$PY" "$TESTS/misbehaving_robot.py" --durability transient_local > "$DIR/robot.out" 2>> "$DIR/robot.err" &
ready "$DIR/robot.out" || exit 9
"$HANDOVER" robot-check --wait-s 3 > "$DIR/latched.txt"
echo $? > "$DIR/latched.code"
kill -KILL $(jobs -p) 2>/dev/null; wait 2>/dev/null
"#;
        let (code, err) = in_namespace(&python, &dir, body, &[]);
        assert_eq!(code, 0, "{release}: {err}");
        let read = |name: &str| std::fs::read_to_string(dir.join(name)).unwrap();
        let ready = read("ready.txt");
        assert_eq!(read("ready.code").trim(), "0", "{release}: {ready}\n{err}");
        assert!(ready.starts_with("ROS 2 domain 3 (ROS_DOMAIN_ID)"), "{release}: {ready}");
        for line in [
            "console → /handover/target_pose (geometry_msgs/msg/PoseStamped)  ok: 1 matching subscriber",
            "console → /handover/trial (std_msgs/msg/String)  ok: 1 matching subscriber",
            "console ← /handover/robot_status (std_msgs/msg/String)  ok: 1 matching publisher",
            "console ← /handover/participant/joint_states (sensor_msgs/msg/JointState)  ok: 1 matching publisher",
        ] {
            assert!(ready.contains(line), "{release}: expected '{line}' in:\n{ready}");
        }
        let latched = read("latched.txt");
        assert_eq!(read("latched.code").trim(), "1", "{release}: {latched}");
        assert!(
            latched.contains(
                "/handover/target_pose (geometry_msgs/msg/PoseStamped)  NOT READY: a subscriber of /handover/target_pose cannot match the console's QoS: DURABILITY VOLATILE offered, TRANSIENT_LOCAL requested"
            ),
            "{release}: {latched}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
