use std::io::{Cursor, Seek, SeekFrom, Write};
use std::sync::{Arc, Mutex};

use std::collections::HashMap;
use std::path::Path;

use serde_json::Value;

use super::paths::created_key;
use super::*;
use crate::dryrun::plan;
use crate::participant::ScriptedParticipant;
use crate::protocol::DEFAULT_PROTOCOL;
use crate::protocol::Study;
use crate::session::VoidReason;
use crate::session::{Event, Session, Stamped};

/// A disk in memory that can fill up: a write past `capacity` writes what fits and fails
/// with ENOSPC, as a full file system does.
#[derive(Clone, Default)]
struct Disk(Arc<Mutex<(Cursor<Vec<u8>>, usize)>>);

impl Disk {
    fn with_room(room: usize) -> Self {
        Self(Arc::new(Mutex::new((Cursor::new(Vec::new()), room))))
    }
    fn set_room(&self, room: usize) {
        self.0.lock().unwrap().1 = room;
    }
    fn bytes(&self) -> Vec<u8> {
        self.0.lock().unwrap().0.get_ref().clone()
    }
}

impl Write for Disk {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let mut g = self.0.lock().unwrap();
        let (cursor, room) = &mut *g;
        let pos = cursor.position() as usize;
        let fits = room.saturating_sub(pos).min(buf.len());
        if fits == 0 && !buf.is_empty() {
            return Err(std::io::Error::from_raw_os_error(28));
        }
        cursor.write(&buf[..fits])
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Seek for Disk {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.0.lock().unwrap().0.seek(pos)
    }
}

impl Sink for Disk {
    fn sync(&mut self) -> std::io::Result<()> {
        Ok(())
    }
    fn truncate(&mut self, len: u64) -> std::io::Result<()> {
        self.0.lock().unwrap().0.get_mut().truncate(len as usize);
        Ok(())
    }
}

fn small_study() -> (Arc<Study>, String) {
    let mut v: serde_json::Value = serde_json::from_str(DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 200.into();
    let text = v.to_string();
    (Arc::new(Study::from_json(&text, "test").unwrap()), text)
}

/// A dry run's session recording onto a disk whose room the test sets.
fn on_disk(seed: u64) -> (crate::dryrun::DryRunPlan, Disk, RecordedSession) {
    let (study, text) = small_study();
    let p = plan(&study, seed, 0, None, "2026-11-22T00:00:00Z".into());
    let disk = Disk::with_room(usize::MAX);
    let session = Session::new(Arc::clone(&study), p.start.clone()).unwrap();
    let recorder = Recorder::with_sink(Box::new(disk.clone()), &text, &session).unwrap();
    (p, disk, RecordedSession { session, recorder })
}

/// The bytes of a disk as a log file in a fresh folder named for the test.
fn as_file(disk: &Disk, name: &str) -> (std::path::PathBuf, std::path::PathBuf) {
    let dir = std::env::temp_dir().join(format!("handover-{name}-{}", std::process::id()));
    crate::private_files::create_dir(&dir).unwrap();
    let path = dir.join(format!("{name}.mcap"));
    let _ = std::fs::remove_file(&path);
    std::fs::write(&path, disk.bytes()).unwrap();
    (dir, path)
}

#[test]
fn a_failed_write_changes_nothing_and_a_retry_logs_the_event_once() {
    let (p, disk, mut rec) = on_disk(5);
    let answer = |rec: &RecordedSession, p: &ScriptedParticipant| p.respond(rec.session()).unwrap();
    for k in 0..4 {
        let e = answer(&rec, &p.participant);
        rec.submit(Stamped { time_ns: 10 + k, event: e }).unwrap();
    }
    let good = disk.bytes();
    let before = rec.session().prompt();
    // The disk fills up in the middle of the next event.
    disk.set_room(good.len() + 40);
    let event = answer(&rec, &p.participant);
    let err = rec.submit(Stamped { time_ns: 20, event: event.clone() }).unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains("No space left on device") && msg.contains("nothing after event 4"), "{msg}");
    assert_eq!(disk.bytes(), good, "the file is as it was after the last good event");
    assert_eq!(rec.session().prompt(), before, "the state did not move");
    assert_eq!(rec.recorder.last_index(), 4);
    // Space is freed: the retry writes the event once, with the next index.
    disk.set_room(usize::MAX);
    rec.submit(Stamped { time_ns: 21, event: event.clone() }).unwrap();
    drop(rec.recorder.finish().unwrap());
    let (dir, path) = as_file(&disk, "retry");
    let log = read_log(&path).unwrap();
    assert!(log.finished && !log.cut_tail);
    assert_eq!(log.events.len(), 5);
    assert_eq!(log.events[4].event, event);
    let indices: Vec<u64> = log
        .messages
        .iter()
        .filter(|m| Topic::from_name(&m.topic).is_some_and(Topic::is_event))
        .map(|m| m.value["event_index"].as_u64().unwrap())
        .collect();
    assert_eq!(indices, vec![1, 2, 3, 4, 5], "one message per event, indices without gaps");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The robot's channels are registered with their first message: a write of it that fails
/// leaves no channel behind, and the retry registers it once.
#[test]
fn a_robot_channel_whose_first_write_fails_is_registered_once_on_the_retry() {
    let (_, disk, mut rec) = on_disk(5);
    let command = crate::robot::command_for(rec.session(), &crate::robot::RobotSettings::default()).unwrap();
    let event = command.event(crate::session::RobotLinkKind::Ros2);
    let good = disk.bytes();
    disk.set_room(good.len() + 100);
    assert!(rec.submit(Stamped { time_ns: 10, event: event.clone() }).is_err());
    assert_eq!(disk.bytes(), good);
    disk.set_room(usize::MAX);
    rec.submit(Stamped { time_ns: 11, event: event.clone() }).unwrap();
    let report = command.report(crate::session::RobotState::AtPose, "").event();
    rec.submit(Stamped { time_ns: 12, event: report.clone() }).unwrap();
    drop(rec.recorder.finish().unwrap());
    let (dir, path) = as_file(&disk, "robot-retry");
    let log = read_log(&path).unwrap();
    assert!(log.integrity.is_empty(), "{:?}", log.integrity);
    let events: Vec<&Event> = log.events.iter().map(|e| &e.event).collect();
    assert_eq!(events, vec![&event, &report]);
    // The topic as a channel record writes it: its length (u32, little-endian), then its bytes.
    let record = [&14u32.to_le_bytes()[..], b"/robot/command"].concat();
    let robot_channels = std::fs::read(&path).unwrap().windows(record.len()).filter(|w| *w == record).count();
    assert_eq!(robot_channels, 2, "one channel record in the data section and one in the summary");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Reads a logged message back into the struct of its topic and writes it again.
fn read_back(topic: Topic, v: &Value) -> Result<Value, serde_json::Error> {
    use super::foxglove as fx;
    use super::types as t;
    fn again<T: serde::de::DeserializeOwned + serde::Serialize>(v: &Value) -> Result<Value, serde_json::Error> {
        serde_json::to_value(serde_json::from_value::<T>(v.clone())?)
    }
    match topic {
        Topic::SessionStart => again::<t::SessionStartMessage>(v),
        Topic::TrialQuery => again::<t::TrialQuery>(v),
        Topic::TrialResponse => again::<t::TrialResponse>(v),
        Topic::TrialVoid => again::<t::TrialVoid>(v),
        Topic::TrialUndo => again::<t::TrialUndo>(v),
        Topic::Belief(_) => again::<t::BeliefMessage>(v),
        Topic::QuestionnaireLikert => again::<t::LikertAnswer>(v),
        Topic::QuestionnaireChoice => again::<t::ForcedChoice>(v),
        Topic::SessionPause | Topic::SessionResume => again::<t::SessionMark>(v),
        Topic::SessionTransition => again::<t::SessionTransition>(v),
        Topic::SessionEnd => again::<t::SessionEnd>(v),
        Topic::HumanJoints => again::<t::JointAngles>(v),
        Topic::TestLogLikelihood(_) => again::<t::TestLogLikelihood>(v),
        Topic::RobotHandoverPose => again::<fx::PoseInFrame>(v),
        Topic::HumanArm | Topic::ObjectScene => again::<fx::SceneUpdate>(v),
        Topic::Transforms => again::<fx::FrameTransforms>(v),
        Topic::Notes => again::<fx::Log>(v),
        Topic::RobotCommand => again::<t::RobotCommand>(v),
        Topic::RobotStatus => again::<t::RobotStatus>(v),
    }
}

/// A whole session with every kind of event: each message validates against the schema its
/// channel embeds (Foxglove's own for `foxglove.*`) and reads back into the same value.
#[test]
fn every_logged_message_validates_against_its_schema_and_reads_back() {
    let (study, text) = small_study();
    let p = plan(&study, 9, 0, None, "2026-11-22T00:00:00Z".into());
    let dir = std::env::temp_dir().join(format!("handover-readback-{}", std::process::id()));
    let path = dir.join("p_20261122T000000Z.mcap");
    let session = Session::new(Arc::clone(&study), p.start.clone()).unwrap();
    let mut rec = RecordedSession::create(&path, &text, session, 1_000).unwrap();
    let mut t = 1_000;
    let mut submit = |rec: &mut RecordedSession, event: Event| {
        t += 1_000_000_000;
        rec.submit(Stamped { time_ns: t, event }).unwrap();
    };
    let (mut step, mut voided) = (0, false);
    while !matches!(rec.session().prompt(), crate::session::Prompt::Done { .. }) {
        let e = p.participant.respond(rec.session()).unwrap();
        let response = matches!(e, Event::GraspRecorded { .. });
        if step == 7 && matches!(e, Event::QueryPresented { .. }) {
            // A robot in the loop for this trial: its command and its reports.
            let settings = crate::robot::RobotSettings::default();
            let c = crate::robot::command_for(rec.session(), &settings).unwrap();
            submit(&mut rec, c.event(crate::session::RobotLinkKind::Ros2));
            for state in [crate::session::RobotState::Moving, crate::session::RobotState::AtPose] {
                submit(&mut rec, c.report(state, "").event());
            }
        }
        submit(&mut rec, e);
        step += 1;
        match step {
            2 => {
                submit(&mut rec, Event::GraspUndone);
                submit(&mut rec, Event::Note { text: "participant asked to repeat".into() });
            }
            4.. if response && !voided => {
                voided = true;
                submit(&mut rec, Event::TrialVoided { reason: VoidReason::Dropped, detail: "slipped".into() })
            }
            6 => {
                submit(&mut rec, Event::Paused);
                submit(&mut rec, Event::Resumed);
            }
            _ => {}
        }
    }
    let path = rec.finish().unwrap();
    let log = read_log(&path).unwrap();
    let mut schemas: HashMap<String, jsonschema::Validator> = HashMap::new();
    for topic in Topic::ALL.into_iter().filter(|t| t.used_by(&log.start.condition_order) || t.registered_on_use()) {
        let (_, text) = schema(topic);
        let v: Value = serde_json::from_str(&text).unwrap();
        schemas.insert(topic.name().to_string(), jsonschema::validator_for(&v).unwrap());
    }
    let mut seen = std::collections::BTreeSet::new();
    for m in &log.messages {
        let topic = Topic::from_name(&m.topic).unwrap();
        seen.insert(topic);
        let errors: Vec<String> = schemas[&m.topic].iter_errors(&m.value).map(|e| e.to_string()).collect();
        assert!(errors.is_empty(), "{} (event {}): {errors:?}", m.topic, m.sequence);
        assert_eq!(read_back(topic, &m.value).unwrap(), m.value, "{} reads back", m.topic);
    }
    // The schemas do constrain: a response without its region, or a note without its level, fails.
    for (topic, field) in [(Topic::TrialResponse, "region"), (Topic::Notes, "level")] {
        let m = log.messages.iter().find(|m| m.topic == topic.name()).unwrap();
        let mut broken = m.value.clone();
        broken.as_object_mut().unwrap().remove(field);
        assert!(!schemas[topic.name()].is_valid(&broken), "{topic} without {field} is refused");
    }
    // Every topic a session of these conditions can log was seen.
    let missing: Vec<_> = Topic::ALL
        .into_iter()
        .filter(|t| (t.used_by(&log.start.condition_order) || t.registered_on_use()) && !seen.contains(t))
        .collect();
    assert!(missing.is_empty(), "not logged: {missing:?}");
    assert!(log.integrity.is_empty(), "{:?}", log.integrity);
    layout_paths_resolve(&log);
    let _ = std::fs::remove_dir_all(dir);
}

/// Every topic and message path `docs/foxglove-layout.json` shows is one this log has.
fn layout_paths_resolve(log: &LogContents) {
    let layout: Value = serde_json::from_str(include_str!("../../docs/foxglove-layout.json")).unwrap();
    let mut paths = Vec::new();
    for config in layout["configById"].as_object().unwrap().values() {
        paths
            .extend(config["paths"].as_array().into_iter().flatten().map(|p| p["value"].as_str().unwrap().to_string()));
        paths.extend(config["topics"].as_object().into_iter().flatten().map(|(t, _)| t.clone()));
        for key in ["topicToRender", "topicPath"] {
            paths.extend(config[key].as_str().map(String::from));
        }
    }
    assert!(paths.len() > 15, "{paths:?}");
    for path in paths {
        let end = path.find(['.', '{']).unwrap_or(path.len());
        let (topic, rest) = path.split_at(end);
        let filter = rest.strip_prefix('{').and_then(|r| r.split_once('}'));
        let (filter, fields) = match filter {
            Some((f, r)) => (Some(f), r),
            None => (None, rest),
        };
        let message = log
            .messages
            .iter()
            .filter(|m| m.topic == topic)
            .find(|m| {
                filter.is_none_or(|f| {
                    let (k, v) = f.split_once("==").unwrap();
                    m.value[k] == serde_json::from_str::<Value>(v).unwrap()
                })
            })
            .unwrap_or_else(|| panic!("{path}: no {topic} message in the log"));
        let mut at = &message.value;
        for field in fields.split('.').filter(|f| !f.is_empty()) {
            let (name, index) =
                field.split_once('[').map_or((field, None), |(n, i)| (n, Some(i.trim_end_matches(']'))));
            at = &at[name];
            assert!(!at.is_null(), "{path}: no field {name}");
            match index {
                Some(":") => assert!(at.as_array().is_some_and(|a| !a.is_empty()), "{path}: {name} is no array"),
                Some(i) => {
                    at = &at[i.parse::<usize>().unwrap()];
                    assert!(at.is_number(), "{path}");
                }
                None => {}
            }
        }
    }
}

#[test]
fn a_log_name_says_when_it_was_created() {
    let key = |n: &str| created_key(Path::new(n));
    assert_eq!(key("logs/p-1/p-1_20261202T014904Z.mcap"), Some(("20261202T014904Z".into(), 1)));
    assert_eq!(key("p-1_20261202T014904Z-3.mcap"), Some(("20261202T014904Z".into(), 3)));
    assert!(key("p-1_20261202T014904Z-3.mcap") > key("p-1_20261202T014904Z.mcap"));
    assert!(key("p-1_20261202T014905Z.mcap") > key("p-1_20261202T014904Z-9.mcap"));
    assert_eq!(key("crashed.mcap"), None);
    assert_eq!(key("p-1_2026.mcap"), None);
}

/// A tap that keeps what it is given.
#[derive(Clone, Default)]
struct Collect(Arc<std::sync::Mutex<Vec<(Topic, u64)>>>);

impl super::Tap for Collect {
    fn publish(&mut self, topic: Topic, time_ns: u64, _data: &[u8]) {
        self.0.lock().unwrap().push((topic, time_ns));
    }
    fn boxed_clone(&self) -> Box<dyn super::Tap> {
        Box::new(self.clone())
    }
}

#[test]
fn a_tap_gets_the_start_then_each_event_once_it_is_on_disk() {
    let (p, disk, mut rec) = on_disk(6);
    let seen = Collect::default();
    rec.set_tap(Box::new(seen.clone()));
    let start: Vec<Topic> = seen.0.lock().unwrap().iter().map(|(t, _)| *t).collect();
    assert_eq!(start[0], Topic::SessionStart);
    assert!(start.contains(&Topic::Transforms) && start.contains(&Topic::HumanArm), "{start:?}");
    let event = p.participant.respond(rec.session()).unwrap();
    let good = disk.bytes();
    disk.set_room(good.len() + 10);
    assert!(rec.submit(Stamped { time_ns: 50, event: event.clone() }).is_err());
    assert_eq!(seen.0.lock().unwrap().len(), start.len(), "nothing of a failed write");
    disk.set_room(usize::MAX);
    rec.submit(Stamped { time_ns: 51, event }).unwrap();
    let after: Vec<(Topic, u64)> = seen.0.lock().unwrap()[start.len()..].to_vec();
    assert_eq!(after.first(), Some(&(Topic::TrialQuery, 51)));
    assert!(after.iter().all(|(_, t)| *t == 51));
}

/// A robot command read back is checked as one is made: its frame id and its pose.
#[test]
fn a_log_with_a_malformed_robot_command_is_refused_naming_the_field() {
    let (study, text) = small_study();
    let p = plan(&study, 8, 0, None, "2026-11-22T00:00:00Z".into());
    let dir = std::env::temp_dir().join(format!("handover-badrobot-{}", std::process::id()));
    let path = dir.join("p_20261122T000000Z.mcap");
    let _ = std::fs::remove_dir_all(&dir);
    let session = Session::new(Arc::clone(&study), p.start.clone()).unwrap();
    let mut rec = RecordedSession::create(&path, &text, session, 1_000).unwrap();
    let command = crate::robot::command_for(rec.session(), &crate::robot::RobotSettings::default()).unwrap();
    rec.submit(Stamped { time_ns: 2_000, event: command.event(crate::session::RobotLinkKind::Ros2) }).unwrap();
    let path = rec.finish().unwrap();
    assert!(read_log(&path).is_ok());
    let bytes = std::fs::read(&path).unwrap();
    let needle = br#""frame":"shoulder","orientation""#;
    let at = bytes.windows(needle.len()).position(|w| w == needle).unwrap();
    let mut bad = bytes.clone();
    bad[at + 9..at + 17].copy_from_slice(b"shoul er");
    std::fs::write(&path, &bad).unwrap();
    let e = read_log(&path).unwrap_err().to_string();
    assert!(e.contains("/robot/command") && e.contains("frame 'shoul er' is not a frame id"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
    // The pose's numbers: finite, within reach of the frame, a unit quaternion.
    let ok = command.sent_pose();
    for (position, orientation) in [
        ([f64::NAN, 0.0, 0.0], ok.orientation),
        ([11.0, 0.0, 0.0], ok.orientation),
        (ok.position, [0.0, 0.0, 0.0, 2.0]),
    ] {
        let pose = crate::session::SentPose { frame: ok.frame.clone(), position, orientation };
        assert!(crate::session::validate_sent_pose(&pose).is_err(), "{pose:?}");
    }
}

#[test]
fn the_version_names_the_log_format_written() {
    assert!(super::VERSION.contains(&format!("writes log format {}", super::LOG_FORMAT)), "{}", super::VERSION);
    assert!(super::VERSION.starts_with(env!("CARGO_PKG_VERSION")));
}
