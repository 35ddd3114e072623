use std::io::{Cursor, Seek, SeekFrom, Write};
use std::sync::{Arc, Mutex};

use super::*;
use crate::dryrun::plan;
use crate::participant::ScriptedParticipant;
use crate::protocol::DEFAULT_PROTOCOL;

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

#[test]
fn a_failed_write_changes_nothing_and_a_retry_logs_the_event_once() {
    let (study, text) = small_study();
    let p = plan(&study, 5, 0, None, "2026-11-22T00:00:00Z".into());
    let disk = Disk::with_room(usize::MAX);
    let session = Session::new(Arc::clone(&study), p.start.clone()).unwrap();
    let recorder = Recorder::with_sink(Box::new(disk.clone()), &text, &session).unwrap();
    let mut rec = RecordedSession { session, recorder };
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
    let dir = std::env::temp_dir().join(format!("handover-retry-{}", std::process::id()));
    crate::private_files::create_dir(&dir).unwrap();
    let path = dir.join("retry.mcap");
    let _ = std::fs::remove_file(&path);
    std::fs::write(&path, disk.bytes()).unwrap();
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
