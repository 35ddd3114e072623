use std::sync::Arc;
use std::sync::mpsc::Sender;
use std::time::{Duration, Instant};

use super::*;
use crate::dryrun::plan;
use crate::protocol::{DEFAULT_PROTOCOL, Study};

fn session() -> Session {
    let study = Arc::new(Study::from_json(DEFAULT_PROTOCOL, "default").unwrap());
    let p = plan(&study, 3, 0, None, "2026-12-01T00:00:00Z".into());
    Session::new(study, p.start).unwrap()
}

#[test]
fn settings_default_to_the_ros2_conventions_and_check_every_field() {
    let s = RobotSettings::from_json("{}", "lab.json").unwrap();
    assert_eq!(s, RobotSettings::default());
    assert_eq!(s.ros2.pose_topic, "/handover/target_pose");
    assert_eq!(s.ros2.status_topic, "/handover/robot_status");
    assert_eq!(s.ros2.domain_id, None);
    assert_eq!(s.frame_id(), "shoulder");
    for (text, field) in [
        (r#"{"timeout_s": 0}"#, "timeout_s"),
        (r#"{"timeout_s": 1e9}"#, "timeout_s"),
        (r#"{"ros2": {"domain_id": 300}}"#, "ros2.domain_id"),
        (r#"{"ros2": {"pose_topic": "handover/pose"}}"#, "ros2.pose_topic"),
        (r#"{"ros2": {"status_topic": "/a//b"}}"#, "ros2.status_topic"),
        (r#"{"ros2": {"trial_topic": "/1trial"}}"#, "ros2.trial_topic"),
        (r#"{"ros2": {"networks": ["not an address"]}}"#, "ros2.networks"),
        (r#"{"ros2": {"resend_s": 0}}"#, "ros2.resend_s"),
        (r#"{"shoulder_frame_id": "a b"}"#, "shoulder_frame_id"),
        (
            r#"{"base_frame": {"frame_id": "base_link", "shoulder_position": [0, 0, 99], "shoulder_rpy_deg": [0, 0, 0]}}"#,
            "base_frame.shoulder_position",
        ),
        (r#"{"base_frame": {"frame_id": "base_link"}}"#, "base_frame"),
        (r#"{"present_on": "voice"}"#, "present_on"),
        (r#"{"robot": "ros2"}"#, "robot"),
    ] {
        let e = RobotSettings::from_json(text, "lab.json").unwrap_err();
        // The field is named: checked in range (`Field`) or refused by its shape (`Shape`).
        let named = match &e {
            SettingsError::Field { file, problem } => file == "lab.json" && problem.field == field,
            SettingsError::Shape { file, path, .. } => file == "lab.json" && path.starts_with(field),
            _ => false,
        };
        assert!(named && e.to_string().starts_with("lab.json: "), "{text}: {e:?}");
    }
    // A second document after the first is refused, as every other input refuses it.
    for text in [r#"{} {"timeout_s": 5}"#, "{}\n{}", r#"{"timeout_s": 5} x"#] {
        let e = RobotSettings::from_json(text, "lab.json").unwrap_err();
        assert!(e.to_string().contains("expected nothing after the settings' one JSON document"), "{text}: {e}");
    }
    assert!(RobotSettings::from_json("{}\n\n", "lab.json").is_ok(), "trailing white space is fine");
    let big = format!("{{\"x\": \"{}\"}}", "y".repeat(MAX_BYTES));
    let e = RobotSettings::from_json(&big, "lab.json").unwrap_err();
    assert!(matches!(e, SettingsError::TooLarge { .. }) && e.to_string().contains("budget"), "{e}");
}

const MAX_BYTES: usize = 70_000;

#[test]
fn the_domain_is_the_settings_else_ros_domain_id_else_zero() {
    let unset = RobotSettings::default().ros2;
    let env = |v: &str| Some(std::ffi::OsString::from(v));
    assert_eq!(unset.domain_with(None).unwrap(), Domain { id: 0, from: "default" });
    assert_eq!(unset.domain_with(env("")).unwrap(), Domain { id: 0, from: "default" });
    assert_eq!(unset.domain_with(env("7")).unwrap(), Domain { id: 7, from: "ROS_DOMAIN_ID" });
    assert_eq!(unset.domain_with(env("7")).unwrap().to_string(), "domain 7 (ROS_DOMAIN_ID)");
    let set = RobotSettings::from_json(r#"{"ros2": {"domain_id": 3}}"#, "lab.json").unwrap().ros2;
    assert_eq!(set.domain_with(env("7")).unwrap(), Domain { id: 3, from: "ros2.domain_id" });
    for bad in ["233", "-1", "seven", "7\u{1b}[2J"] {
        let e = unset.domain_with(env(bad)).unwrap_err();
        let e = e.to_string();
        assert!(e.starts_with("ROS_DOMAIN_ID is '") && e.contains("expected a whole number from 0 to 232"), "{e}");
        assert!(!e.contains('\u{1b}'), "{e}");
    }
    assert!(set.domain_with(env("seven")).is_ok(), "the settings file overrides the environment");
}

#[test]
fn statuses_are_read_as_the_robot_says_them() {
    let st = |state, command: Option<&str>, detail: &str| Status {
        state,
        command: command.map(str::to_string),
        detail: detail.to_string(),
    };
    let id = "1765130000.012345678";
    // Bare statuses, as robot nodes before command ids say them.
    assert_eq!(parse_status("moving"), st(RobotState::Moving, None, ""));
    assert_eq!(parse_status(" at_pose\n"), st(RobotState::AtPose, None, ""));
    assert_eq!(parse_status("failed"), st(RobotState::Failed, None, ""));
    assert_eq!(parse_status("failed: joint limit"), st(RobotState::Failed, None, "failed: joint limit"));
    // Statuses that name their command.
    assert_eq!(parse_status(&format!("moving {id}")), st(RobotState::Moving, Some(id), ""));
    assert_eq!(parse_status(&format!("at_pose  {id} ")), st(RobotState::AtPose, Some(id), ""));
    assert_eq!(parse_status(&format!("failed {id}")), st(RobotState::Failed, Some(id), ""));
    assert_eq!(
        parse_status(&format!("failed {id}: no IK solution")),
        st(RobotState::Failed, Some(id), "failed: no IK solution")
    );
    assert_eq!(parse_status("failed gripper fault"), st(RobotState::Failed, None, "failed: gripper fault"));
    // Not an id, or words after one: the whole text, as `other` (a failure stays one).
    assert_eq!(parse_status("at_pose 17"), st(RobotState::Other, None, "at_pose 17"));
    assert_eq!(parse_status(&format!("at_pose {id} ok")), st(RobotState::Other, None, &format!("at_pose {id} ok")));
    assert_eq!(parse_status("at_poses"), st(RobotState::Other, None, "at_poses"));
    assert_eq!(parse_status("idle\u{7}"), st(RobotState::Other, None, "idle"));
    assert_eq!(parse_status(""), st(RobotState::Other, None, "(empty status)"));
    assert_eq!(parse_status(&"x".repeat(10_000)).detail.len(), 500);
}

#[test]
fn command_ids_are_unique_increasing_and_valid() {
    let ids: Vec<(String, u64)> = (0..10_000).map(|_| CommandId::issue()).collect();
    assert!(ids.windows(2).all(|w| w[0].1 < w[1].1), "ids increase");
    for (id, ns) in &ids {
        crate::session::validate_command_id(id).unwrap();
        assert_eq!(*id, CommandId::text(*ns));
    }
    assert_eq!(CommandId::text(1_765_130_000_000_000_007), "1765130000.000000007");
    for bad in ["", "1", "1.5", "1.1234567890", "a.123456789", ".123456789", "1234567890123.123456789", "1,123456789"] {
        assert!(crate::session::validate_command_id(bad).is_err(), "{bad}");
    }
}

#[test]
fn a_command_is_the_waiting_query_in_the_shoulder_frame_or_the_base_frame() {
    let s = session();
    let Prompt::Present(view) = s.prompt() else { panic!("a new session waits for a query") };
    let q = s.query(view.query);
    let c = command_for(&s, &RobotSettings::default()).unwrap();
    assert_eq!((c.query.as_str(), c.trial, c.attempt, c.phase), (q.query.id.as_str(), 1, 1, Phase::Training));
    assert_eq!(c.frame, "shoulder");
    assert_eq!(c.position, q.pose.position);
    for (a, b) in c.rpy_deg.iter().zip(q.pose.rpy_deg) {
        assert!((a - b).abs() < 1e-9, "{:?} vs {:?}", c.rpy_deg, q.pose.rpy_deg);
    }
    assert_eq!(c.grips.len(), q.regions.len());
    crate::session::validate_sent_pose(&c.sent_pose()).unwrap();
    // A base frame 1 m ahead of the shoulder, turned half a turn about z: x and y flip sign.
    let settings = RobotSettings {
        base_frame: Some(BaseFrame {
            frame_id: "base_link".into(),
            shoulder_position: [1.0, 0.0, 0.5],
            shoulder_rpy_deg: [0.0, 0.0, 180.0],
        }),
        ..RobotSettings::default()
    };
    let b = command_for(&s, &settings).unwrap();
    assert_eq!(b.frame, "base_link");
    let [x, y, z] = q.pose.position;
    for (got, want) in b.position.iter().zip([1.0 - x, -y, 0.5 + z]) {
        assert!((got - want).abs() < 1e-12, "{:?}", b.position);
    }
    let yaw = (b.rpy_deg[2] - q.pose.rpy_deg[2] - 180.0).rem_euclid(360.0);
    assert!(yaw < 1e-9 || 360.0 - yaw < 1e-9, "{:?}", b.rpy_deg);
}

/// A link that reports what the test scripts.
struct Scripted {
    tx: Sender<Report>,
    answer: Option<RobotState>,
    cancelled: Arc<std::sync::atomic::AtomicBool>,
}

impl Link for Scripted {
    fn kind(&self) -> RobotLinkKind {
        RobotLinkKind::Command
    }
    fn send(&mut self, command: &RobotCommand) -> Result<(), String> {
        if let Some(state) = self.answer {
            let _ = self.tx.send(command.report(state, ""));
        }
        Ok(())
    }
    fn cancel(&mut self) {
        self.cancelled.store(true, std::sync::atomic::Ordering::SeqCst);
    }
    fn describe(&self) -> String {
        "scripted".into()
    }
}

fn robot(answer: Option<RobotState>, timeout_s: f64) -> (Robot, Arc<std::sync::atomic::AtomicBool>) {
    let cancelled = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let c = Arc::clone(&cancelled);
    let settings = RobotSettings { timeout_s, ..RobotSettings::default() };
    let r = Robot::new(settings, move |tx, _| Ok(Box::new(Scripted { tx, answer, cancelled: c }))).unwrap();
    (r, cancelled)
}

#[test]
fn a_final_report_ends_the_command_and_silence_times_it_out() {
    let s = session();
    let command = command_for(&s, &RobotSettings::default()).unwrap();
    let (mut r, cancelled) = robot(Some(RobotState::AtPose), 60.0);
    assert!(!r.busy());
    r.send(&command).unwrap();
    assert!(r.busy());
    let got = r.next_report(Duration::from_secs(1)).unwrap();
    assert_eq!((got.state, got.query.as_str()), (RobotState::AtPose, command.query.as_str()));
    assert!(!r.busy());
    assert!(!cancelled.load(std::sync::atomic::Ordering::SeqCst));

    let (mut r, cancelled) = robot(None, 1.0);
    r.send(&command).unwrap();
    let t = Instant::now();
    assert_eq!(r.next_report(Duration::ZERO), None, "not yet");
    let got = loop {
        if let Some(report) = r.next_report(Duration::from_millis(200)) {
            break report;
        }
        assert!(t.elapsed() < Duration::from_secs(5), "the timeout never came");
    };
    assert_eq!(got.state, RobotState::Timeout);
    assert_eq!(got.detail, "no answer within 1 s");
    assert!(t.elapsed() >= Duration::from_millis(950));
    assert!(cancelled.load(std::sync::atomic::Ordering::SeqCst), "the link was told to give up");
    assert!(!r.busy());
    assert_eq!(r.next_report(Duration::ZERO), None, "one timeout per command");
}

#[test]
fn the_session_takes_robot_events_only_where_they_fit() {
    use crate::session::{SessionError, VoidReason};
    let mut s = session();
    let c = command_for(&s, &RobotSettings::default()).unwrap();
    let report = |state| c.report(state, "").event();
    // A report is logged whenever it comes; a command only for the waiting query.
    s.apply(&report(RobotState::Moving)).unwrap();
    assert_eq!(s.robot(), None, "no command yet: nothing to attach it to");
    let wrong =
        Event::RobotCommanded { query: "nope".into(), link: RobotLinkKind::Ros2, pose: c.sent_pose(), command: None };
    assert!(matches!(s.apply(&wrong), Err(SessionError::WrongQuery { .. })));
    // Voiding an unpresented trial needs a command sent for it.
    let void = Event::TrialVoided { reason: VoidReason::RobotFault, detail: "timeout".into() };
    assert!(s.apply(&void).is_err());
    s.apply(&c.event(RobotLinkKind::Ros2)).unwrap();
    s.apply(&report(RobotState::Failed)).unwrap();
    let track = s.robot().unwrap();
    assert_eq!((track.attempts, track.last.clone()), (1, Some((RobotState::Failed, String::new()))));
    let again = command_for(&s, &RobotSettings::default()).unwrap();
    assert_eq!(again.attempt, 2);
    s.apply(&again.event(RobotLinkKind::Ros2)).unwrap();
    assert_eq!(s.robot().unwrap().attempts, 2);
    s.apply(&void).unwrap();
    assert_eq!(s.robot(), None, "a void starts the trial over");
    assert!(matches!(s.prompt(), Prompt::Present(_)));
    // Reports are logged while paused; commands are not sent.
    s.apply(&Event::Paused).unwrap();
    s.apply(&report(RobotState::AtPose)).unwrap();
    assert!(s.apply(&c.event(RobotLinkKind::Ros2)).is_err());
    s.apply(&Event::Resumed).unwrap();
    assert_eq!(s.event_count(), 8);
    assert_eq!(s.participant_events(), 3, "the void, the pause and the resume");
}

#[test]
fn a_command_to_the_next_pose_makes_the_last_grasp_final() {
    let mut s = session();
    let Prompt::Present(v) = s.prompt() else { panic!() };
    let id = s.query(v.query).query.id.clone();
    s.apply(&Event::QueryPresented { query: id }).unwrap();
    let Prompt::Grasp(v) = s.prompt() else { panic!() };
    let q = s.query(v.query);
    let region = s.study().object(q).regions[q.regions[0]].id.clone();
    s.apply(&Event::GraspRecorded { region, measured: None }).unwrap();
    assert!(s.can_undo());
    let c = command_for(&s, &RobotSettings::default()).unwrap();
    assert_eq!(c.trial, 2);
    s.apply(&c.event(RobotLinkKind::Command)).unwrap();
    assert!(!s.can_undo(), "the robot has moved on");
    // A void now is of the new trial (its command), not of the last grasp.
    let applied =
        s.apply(&Event::TrialVoided { reason: crate::session::VoidReason::RobotFault, detail: String::new() }).unwrap();
    assert!(matches!(applied, crate::session::Applied::Voided { retracted: false, .. }));
    assert_eq!(s.trials().len(), 1);
}

#[test]
fn the_documented_lab_settings_are_valid() {
    let s =
        RobotSettings::from_json(include_str!("../../docs/examples/robot.json"), "docs/examples/robot.json").unwrap();
    assert_eq!(s.frame_id(), "base_link");
    assert_eq!(s.ros2, Ros2Settings::default());
}
