//! The ROS 2 bridge against real ROS 2: rclpy from the ROS 2 wheels on PyPI (Kilted and
//! Jazzy, each on Fast DDS, its default RMW), with no ROS install. The shipped
//! `docs/examples/robot_node.py` runs unchanged; `tests/robot/` holds a recorder node, a
//! robot that fails, says nothing or cannot match, and a measuring system publishing
//! `sensor_msgs/msg/JointState` with the sensor-data or the default QoS.
//!
//! Every run is in a network namespace of its own (`unshare --net`, loopback only, multicast
//! routed on it), so no DDS traffic leaves it and tests run side by side, and in a mount
//! namespace with a /dev/shm of its own (Fast DDS's shared memory): nodes are stopped with
//! SIGINT (SIGKILL only if they do not end within 10 s), and each run checks they left
//! nothing there. The releases come
//! from HANDOVER_ROS_KILTED and HANDOVER_ROS_JAZZY (each a venv's Python, which `.ci/run`
//! makes); when either is set, a missing prerequisite fails the test. With neither, the tests
//! say so and pass.

use crate::support::{small_protocol, small_protocol_with, tmpdir};

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
        crate::support::missing("a ROS 2 release: neither HANDOVER_ROS_KILTED nor HANDOVER_ROS_JAZZY is set");
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

/// The shell functions every run has: `ready FILE` waits until FILE says ready (a node's
/// endpoints exist), at most 30 s; `stop PID…` ends processes with SIGINT, again after 10 s
/// and 20 s (rclpy can miss one that comes as its executor starts waiting, and a loaded
/// machine's Python takes seconds to shut down), then SIGKILL after 30 s;
/// at exit, what is left in /dev/shm (but the LTTng tracer's per-user wait files) is listed
/// in `$DIR/shm-left.txt`.
const SHELL_FUNCTIONS: &str = r#"
ready() { for _ in $(seq 300); do grep -q ready "$1" 2>/dev/null && return 0; sleep 0.1; done; echo "$1 never ready" >&2; return 1; }
alive() { for p in "$@"; do kill -0 "$p" 2>/dev/null && return 0; done; return 1; }
stop() {
  [ $# -eq 0 ] && return 0
  for round in 1 2 3; do
    kill -INT "$@" 2>/dev/null
    for _ in $(seq 100); do alive "$@" || break; sleep 0.1; done
    alive "$@" || break
    echo "stop: still running after SIGINT $round: $*" >&2
  done
  kill -KILL "$@" 2>/dev/null; wait 2>/dev/null; return 0
}
trap 'ls -A /dev/shm | grep -v "^lttng-ust-wait" > "$DIR/shm-left.txt"' EXIT
"#;

/// Runs `body` (bash) in a new network namespace with only the loopback, multicast routed on
/// it, and a /dev/shm of its own, with `PY` (the release's Python), `DIR`, `HANDOVER` (the
/// binary), `TESTS` (this folder's `robot/`), `EXAMPLES` (`docs/examples`) and `vars` in its
/// environment; its exit status and its standard error. Fails if the nodes left shared
/// memory behind.
fn in_namespace(python: &str, dir: &Path, body: &str, vars: &[(&str, String)]) -> (i32, String) {
    let loopback = "ip link set lo up\nip link set lo multicast on\nip route add 224.0.0.0/4 dev lo";
    in_network(python, dir, loopback, body, vars)
}

/// [`in_namespace`] on the network `setup` (bash) makes.
fn in_network(python: &str, dir: &Path, setup: &str, body: &str, vars: &[(&str, String)]) -> (i32, String) {
    let script = format!(
        r#"
set -u
mount -t tmpfs -o mode=1777 tmpfs /dev/shm
{setup}
{SHELL_FUNCTIONS}
{body}"#
    );
    let (code, err) = run_script(python, dir, &["--net", "--mount", "--propagation", "private"], &script, vars);
    let left = std::fs::read_to_string(dir.join("shm-left.txt")).unwrap_or_else(|_| "(not listed)".into());
    assert!(left.trim().is_empty(), "the nodes left shared memory in /dev/shm: {left}\n{err}");
    (code, err)
}

/// Runs `script` under `unshare ARGS` with the environment [`in_namespace`] describes.
fn run_script(python: &str, dir: &Path, unshare: &[&str], script: &str, vars: &[(&str, String)]) -> (i32, String) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    // A hung run is killed rather than left to hang the test binary.
    let mut cmd = Command::new("timeout");
    cmd.args(["-s", "KILL", "300", "unshare"])
        .args(unshare)
        .args(["bash", "-c", script])
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
stop $recorder $robot
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
                Event::RobotCommanded { query, link, pose, .. } => Some((query.clone(), *link, pose.clone())),
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
        assert_eq!(delivered_bit_for_bit(release, &dir, &log), 26, "{release}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// Checks what went over ROS 2 (a recorder's `recorded.jsonl` in `dir`) against the log, bit
/// for bit: every logged command's pose was received under its id (the pose's stamp), every
/// copy (a command is published again until answered) the same as logged, and its trial
/// message with the same query and position; the number of commands so delivered.
fn delivered_bit_for_bit(case: &str, dir: &Path, log: &LogContents) -> usize {
    let recorded = lines(&dir.join("recorded.jsonl"));
    let mut delivered = 0;
    for e in &log.events {
        let Event::RobotCommanded { query, pose, command: Some(id), .. } = &e.event else { continue };
        let poses: Vec<_> = recorded.iter().filter(|r| r["topic"] == "pose" && r["stamp"] == id.as_str()).collect();
        assert!(!poses.is_empty(), "{case}: command {id} never arrived");
        for r in &poses {
            assert_eq!(r["frame_id"], pose.frame.as_str(), "{case}: {id}");
            assert_eq!(floats(&r["position"]), pose.position, "{case}: {id}");
            assert_eq!(floats(&r["orientation"]), pose.orientation, "{case}: {id}");
        }
        let trials: Vec<serde_json::Value> = recorded
            .iter()
            .filter(|r| r["topic"] == "trial")
            .map(|r| serde_json::from_str(r["data"].as_str().unwrap()).unwrap())
            .filter(|t: &serde_json::Value| t["command"] == id.as_str())
            .collect();
        assert!(!trials.is_empty(), "{case}: the trial of command {id} never arrived");
        for t in &trials {
            assert_eq!(t["query"], query.as_str(), "{case}: {id}");
            assert_eq!(floats(&t["position"]), pose.position, "{case}: {id}");
        }
        delivered += 1;
    }
    delivered
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
stop $(jobs -p)
exit $code
"#
    );
    let (code, err) = in_namespace(python, dir, &body, &[]);
    let log = the_log(dir);
    (code, err, log)
}

/// A robot that fails (naming each command: with a resend of 0.5 s a bare robot's answers to
/// the repeats could be taken for the next attempt, and are refused), says nothing, is not
/// there, subscribes transient-local or with another type: three trials voided, the dry run
/// aborted, and the reason in words.
#[test]
fn a_robot_that_fails_says_nothing_or_cannot_be_matched_voids_the_trial_and_is_said_in_words() {
    for (release, python) in releases() {
        // A robot that answers has time to (a loaded machine); one that cannot, 2 s.
        for (robot, state, says) in [
            (Some("--answer failed --names"), RobotState::Failed, "failed: gripper fault"),
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
            // The console's own endpoints are never cited as seen on other topics.
            assert!(!err.contains("seen on /handover/trial"), "{case}: {err}");
            // Three answers taken; under load the 0.5 s resend gets a repeat answered too, which
            // names its command and is logged stale.
            let finals = log
                .events
                .iter()
                .filter(|e| matches!(&e.event, Event::RobotReported { state: s, stale: false, .. } if *s == state))
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
stop $(jobs -p)
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
"$HANDOVER" robot-check --robot ros2 --measure ros2 --wait-s 3 > "$DIR/ready.txt"
echo $? > "$DIR/ready.code"
stop $(jobs -p)
"$PY" "$TESTS/joint_state_publisher.py" --names a,b,c,d,e,f,g --positions 0,0,0,0,0,0,0 --out /dev/null \
  > "$DIR/mocap.out" 2>> "$DIR/mocap.err" &
ready "$DIR/mocap.out" || exit 9
"$HANDOVER" robot-check --measure ros2 --wait-s 3 > "$DIR/measure.txt"
echo $? > "$DIR/measure.code"
stop $(jobs -p)
"$PY" "$TESTS/misbehaving_robot.py" --durability transient_local > "$DIR/robot.out" 2>> "$DIR/robot.err" &
ready "$DIR/robot.out" || exit 9
"$HANDOVER" robot-check --wait-s 3 > "$DIR/latched.txt"
echo $? > "$DIR/latched.code"
stop $(jobs -p)
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
        // A lab that measures the arm and moves the robot by hand: only the measuring system.
        let measure = read("measure.txt");
        assert_eq!(read("measure.code").trim(), "0", "{release}: {measure}\n{err}");
        assert!(
            measure.contains("console ← /handover/participant/joint_states (sensor_msgs/msg/JointState)  ok: 1 matching publisher, on this machine"),
            "{release}: {measure}"
        );
        assert!(!measure.contains("/handover/target_pose"), "{release}: {measure}");
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

/// A robot's statuses as it wrote them (`misbehaving_robot.py --out`): the command each
/// truly answers, and the text it sent.
fn said(file: &Path) -> Vec<(String, String)> {
    lines(file).iter().map(|l| (l["command"].as_str().unwrap().into(), l["text"].as_str().unwrap().into())).collect()
}

/// The robot's reports in a log (not the console's timeouts): (command, state, stale, detail).
fn robot_reports(log: &LogContents) -> Vec<(Option<String>, RobotState, bool, String)> {
    log.events
        .iter()
        .filter_map(|e| match &e.event {
            Event::RobotReported { command, state, stale, detail, .. } if *state != RobotState::Timeout => {
                Some((command.clone(), *state, *stale, detail.clone()))
            }
            _ => None,
        })
        .collect()
}

/// One robot behaviour: its name, how it is started, the console's timeout, whether the
/// session completes, and how many stale statuses (at least) the log holds.
struct Behaviour {
    name: &'static str,
    robot: String,
    timeout_s: f64,
    completes: bool,
    stale: std::ops::RangeInclusive<usize>,
}

/// A robot that blocks 5 s on each move (a MoveIt call) and answers only `at_pose`, started as
/// the console starts, so that the console publishes the first command again 0.5, 1 and 3 s
/// after the match: its answers to the repeats come while the next command is under way. A
/// robot that names the command is credited only with the answers to the command under way
/// (the repeats' answers are stale) and the session completes; one that takes a repeat once
/// has no stale answers; a bare robot is refused once its answers become ambiguous, each
/// refusal logged with what to change. The shipped node with a 5 s move, and a robot that
/// answers twice, complete with every answer credited to its command. Every status the
/// robot sent is matched, in order, with the log: none is credited to a command it does
/// not answer. 6 commands each, 5 behaviours × 2 releases, run side by side.
#[test]
fn each_robot_answer_is_credited_only_to_the_command_it_answers() {
    let m = r#""$PY" "$TESTS/misbehaving_robot.py" --out "$DIR/said.jsonl""#;
    let behaviours = [
        ("names", format!("{m} --answer at_pose_only --move-s 5 --names"), 60.0, true, 1..=usize::MAX),
        ("once", format!("{m} --answer at_pose_only --move-s 5 --names --once"), 60.0, true, 0..=0),
        ("bare", format!("{m} --answer at_pose_only --move-s 5"), 12.0, false, 1..=usize::MAX),
        // Every second answer is stale; the last command's may come after the log is finished,
        // and under load a repeat published before `moving` came back is answered too.
        ("twice", format!("{m} --names --twice"), 60.0, true, 5..=usize::MAX),
        ("shipped", r#""$PY" "$EXAMPLES/robot_node.py" --move-s 5"#.to_string(), 60.0, true, 0..=0),
    ]
    .map(|(name, robot, timeout_s, completes, stale)| Behaviour { name, robot, timeout_s, completes, stale });
    for (release, python) in releases() {
        std::thread::scope(|scope| {
            for b in &behaviours {
                let python = &python;
                scope.spawn(move || {
                    let case = format!("{release} {}", b.name);
                    let dir = tmpdir(&format!("answers-{release}-{}", b.name));
                    small_protocol_with(&dir, |v| {
                        v["session"]["trials_per_condition"] = 2.into();
                        v["test_set"].as_array_mut().unwrap().truncate(2);
                    });
                    lab(&dir, b.timeout_s, 30.0);
                    let body = format!(
                        r#"
export ROS_DOMAIN_ID=5
{robot} > "$DIR/robot.out" 2> "$DIR/robot.err" &
{DRY_RUN}
code=$?
stop $(jobs -p)
exit $code
"#,
                        robot = b.robot
                    );
                    let (code, err) = in_namespace(python, &dir, &body, &[]);
                    let log = the_log(&dir);
                    let commands = log
                        .events
                        .iter()
                        .filter(|e| matches!(e.event, Event::RobotCommanded { command: Some(_), .. }))
                        .count();
                    let presented =
                        log.events.iter().filter(|e| matches!(e.event, Event::QueryPresented { .. })).count();
                    let reports = robot_reports(&log);
                    let stale = reports.iter().filter(|r| r.2).count();
                    if b.completes {
                        assert_eq!(code, 0, "{case}: {err}");
                        assert_eq!(presented, 6, "{case}");
                    } else {
                        assert_eq!(code, 1, "{case}: {err}");
                        assert!(err.contains("the robot failed 3 times in a row"), "{case}: {err}");
                        let refused = reports.iter().filter(|r| r.2 && r.3.contains("must name the command")).count();
                        assert_eq!(refused, stale, "{case}: every bare stale status says what to change: {reports:?}");
                    }
                    assert!(b.stale.contains(&stale), "{case}: {stale} stale statuses: {reports:?}");
                    // Each report credited to a command answers the one under way.
                    let mut under_way = None;
                    for e in &log.events {
                        match &e.event {
                            Event::RobotCommanded { command, .. } => under_way = command.clone(),
                            Event::RobotReported { command, stale: false, .. } => {
                                assert_eq!(command, &under_way, "{case}: credited to another command")
                            }
                            _ => {}
                        }
                    }
                    // The robot's own account: the statuses the log holds are the first it sent,
                    // in order; each credited one answers the command it is credited to.
                    if let Ok(true) = std::fs::exists(dir.join("said.jsonl")) {
                        let sent = said(&dir.join("said.jsonl"));
                        assert!(reports.len() <= sent.len(), "{case}: {} logged, {} sent", reports.len(), sent.len());
                        for ((command, state, stale, _), (truth, text)) in reports.iter().zip(&sent) {
                            assert_eq!(state.name(), text.split([' ', ':']).next().unwrap(), "{case}: {text}");
                            if !stale {
                                assert_eq!(command.as_deref(), Some(truth.as_str()), "{case}: '{text}' misattributed");
                            }
                        }
                        eprintln!(
                            "{case}: {commands} commands, {} statuses sent, {} logged, {stale} stale, 0 misattributed",
                            sent.len(),
                            reports.len()
                        );
                    } else {
                        eprintln!("{case}: {commands} commands, {} statuses logged, {stale} stale", reports.len());
                    }
                });
            }
        });
    }
}

/// A lab LAN: the console's machine (this namespace) and the robot's (namespace `robot`; its
/// nodes run with `ip netns exec robot`, which becomes the node, so that `stop` reaches it),
/// joined by a veth pair, 10.77.0.1/24 (`veth-c`) and
/// 10.77.0.2/24 (`veth-r`). With `wifi`, the console also has a second interface, `wifi0`
/// (192.168.50.10/24, to an access point in namespace `ap`), which holds its default route
/// and its multicast route: only `veth-c` reaches the robot.
fn lan(wifi: bool) -> String {
    let mut setup = String::from(
        r#"
mount -t tmpfs tmpfs /run
mkdir -p /run/netns
ip link set lo up
ip netns add robot
on_robot() { ip netns exec robot "$@"; }
ip link add veth-c type veth peer name veth-r
ip link set veth-r netns robot
ip addr add 10.77.0.1/24 dev veth-c
ip link set veth-c up multicast on
on_robot ip link set lo up
on_robot ip addr add 10.77.0.2/24 dev veth-r
on_robot ip link set veth-r up multicast on
on_robot ip route add 224.0.0.0/4 dev veth-r
"#,
    );
    setup += if wifi {
        r#"
ip netns add ap
ip link add wifi0 type veth peer name wifi-ap
ip link set wifi-ap netns ap
ip netns exec ap ip addr add 192.168.50.1/24 dev wifi-ap
ip netns exec ap ip link set wifi-ap up
ip addr add 192.168.50.10/24 dev wifi0
ip link set wifi0 up multicast on
ip route add default via 192.168.50.1 dev wifi0
ip route add 224.0.0.0/4 dev wifi0
"#
    } else {
        "ip route add 224.0.0.0/4 dev veth-c\n"
    };
    setup
}

/// The lab's settings with DDS on `networks` (none: every network).
fn lab_on(dir: &Path, networks: &[&str]) {
    let lab = serde_json::json!({"timeout_s": 60, "ros2": {"networks": networks, "resend_s": 30}});
    std::fs::write(dir.join("lab.json"), lab.to_string()).unwrap();
}

/// The recorder and the shipped robot node on the robot's machine, a dry run on the
/// console's, then `robot-check`. The robot starts 3 s after the recorder, as in
/// [`the_shipped_robot_node_gets_every_pose_in_the_environments_domain_even_when_it_starts_late`],
/// so that the recorder has every command: once the robot answers, a command is not published
/// again for a subscriber that matches later.
const DRY_RUN_ON_LAN: &str = r#"
ip netns exec robot "$PY" "$TESTS/recorder.py" --out "$DIR/recorded.jsonl" > "$DIR/recorder.out" 2> "$DIR/recorder.err" &
ready "$DIR/recorder.out" || exit 9
(sleep 3; exec ip netns exec robot "$PY" "$EXAMPLES/robot_node.py" 2> "$DIR/robot.err") &
"$HANDOVER" dry-run --seed 4 --protocol "$DIR/small.json" --body-height 1.75 \
  --handedness right --logs "$DIR/logs" --robot ros2 --robot-config "$DIR/lab.json"
code=$?
"$HANDOVER" robot-check --robot-config "$DIR/lab.json" --wait-s 3 > "$DIR/check.txt"
echo $? > "$DIR/check.code"
stop $(jobs -p)
exit $code
"#;

/// The console and the robot on two machines of a lab LAN (network namespaces over a veth
/// pair): every pose arrives bit for bit, under its command's id, and `robot-check` says which
/// interface the robot is on. With a second interface on the console (wifi, holding the
/// default and multicast routes), the default settings and `ros2.networks` set to the
/// robot LAN's address both work; `ros2.networks` set to the wifi's fails in `robot-check`,
/// which names the address to add. Per release: 2 topologies, 3 settings.
#[test]
fn console_and_robot_on_two_machines_of_a_lab_lan_with_one_or_two_interfaces() {
    for (release, python) in releases() {
        for (wifi, networks) in [(false, &[][..]), (true, &[][..]), (true, &["10.77.0.1"][..])] {
            let case = format!("{release} wifi {wifi} networks {networks:?}");
            let dir = tmpdir(&format!("lan-{release}"));
            small_protocol(&dir);
            lab_on(&dir, networks);
            let (code, err) = in_network(&python, &dir, &lan(wifi), DRY_RUN_ON_LAN, &[]);
            assert_eq!(code, 0, "{case}: {err}");
            let check = std::fs::read_to_string(dir.join("check.txt")).unwrap();
            assert_eq!(std::fs::read_to_string(dir.join("check.code")).unwrap().trim(), "0", "{case}: {check}");
            for topic in ["/handover/target_pose", "/handover/robot_status"] {
                let line = check.lines().find(|l| l.contains(topic)).unwrap_or_default();
                assert!(
                    // The pose has two subscribers: the robot and the recorder.
                    line.contains(" ok: ") && line.ends_with("on 10.77.0.2 via veth-c (10.77.0.1/24)"),
                    "{case}: {check}"
                );
            }
            let log = the_log(&dir);
            assert_eq!(delivered_bit_for_bit(&case, &dir, &log), 26, "{case}");
            assert_eq!(log.events.iter().filter(|e| matches!(e.event, Event::QueryPresented { .. })).count(), 26);
            eprintln!("{case}: 26/26 poses bit for bit; robot-check: on 10.77.0.2 via veth-c");
        }
        // DDS kept to the wifi: nobody is found, and robot-check says what to add.
        let dir = tmpdir(&format!("lan-wifi-{release}"));
        lab_on(&dir, &["192.168.50.10"]);
        let body = r#"
ip netns exec robot "$PY" "$EXAMPLES/robot_node.py" 2> "$DIR/robot.err" &
sleep 2
"$HANDOVER" robot-check --robot-config "$DIR/lab.json" --wait-s 3 > "$DIR/check.txt"
code=$?
stop $(jobs -p)
exit $code
"#;
        let (code, err) = in_network(&python, &dir, &lan(true), body, &[]);
        let check = std::fs::read_to_string(dir.join("check.txt")).unwrap();
        assert_eq!(code, 1, "{release}: {check}\n{err}");
        for line in [
            "NOT READY: nobody subscribes to /handover/target_pose in ROS 2 domain 0 (default)",
            "other ROS 2 participants heard on: 10.77.0.2 via veth-c (10.77.0.1/24)",
            "ros2.networks leaves out the interface(s) they were heard on: add 10.77.0.1 to ros2.networks",
        ] {
            assert!(check.contains(line), "{release}: expected '{line}' in:\n{check}");
        }
    }
}
