//! A finished log read through its index, as viewers and indexed readers seek, gives exactly
//! the messages a stream reader gives: the mcap crate's summary and chunk indexes here, and
//! in CI the Python `mcap` reader's seeking path (HANDOVER_PYTHON) and npm `@mcap/core`'s
//! `McapIndexedReader` (HANDOVER_NODE_MODULES, a `node_modules` holding it). A log cut off
//! anywhere still replays up to its last whole event, and a log of the earlier, unindexed
//! format still reads and analyses.

use crate::support::tmpdir;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;
use std::time::Duration;

use handover::dryrun::{drive, now_ns, plan};
use handover::protocol::{DEFAULT_PROTOCOL, Study};
use handover::record::{LOG_FORMAT, RecordedSession, new_log_path, read_log};
use handover::session::Session;
use serde_json::Value;

/// (topic, sequence, log time, data) of one message.
type Row = (String, u32, String, String);

fn finished_log(dir: &Path) -> PathBuf {
    let mut s = Study::default_study();
    s.protocol.learning.particles = 300;
    let study = Arc::new(s);
    let mut v: Value = serde_json::from_str(DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 300.into();
    let p = plan(&study, 5, 0, None, "2026-11-22T00:00:00Z".into());
    let session = Session::new(Arc::clone(&study), p.start.clone()).unwrap();
    let path = new_log_path(dir, &p.start.participant, chrono::Utc::now());
    let mut rec = RecordedSession::create(&path, &v.to_string(), session, now_ns()).unwrap();
    drive(&mut rec, &p.participant, Duration::ZERO).unwrap();
    rec.finish().unwrap()
}

/// Every message in file order, by the mcap crate's stream reader (CRCs checked).
fn streamed(bytes: &[u8]) -> Vec<Row> {
    let options = mcap::read::Options::ValidateChunkCrcs.into();
    mcap::MessageStream::new_with_options(bytes, options)
        .unwrap()
        .map(|m| {
            let m = m.unwrap();
            (m.channel.topic.clone(), m.sequence, m.log_time.to_string(), String::from_utf8(m.data.to_vec()).unwrap())
        })
        .collect()
}

/// Every message through the summary: chunk indexes, then each chunk's message indexes.
fn through_the_index(bytes: &[u8]) -> Vec<Row> {
    let summary = mcap::Summary::read(bytes).unwrap().expect("a finished log has a summary");
    assert!(!summary.chunk_indexes.is_empty(), "a finished log has chunk indexes");
    let mut out = Vec::new();
    for chunk in &summary.chunk_indexes {
        let indexes = summary.read_message_indexes(bytes, chunk).unwrap();
        let mut entries: Vec<(u64, u64)> = indexes.values().flatten().map(|e| (e.log_time, e.offset)).collect();
        entries.sort_by_key(|e| e.1);
        assert_eq!(entries.len() as u64, chunk_messages(&summary, bytes, chunk), "every message is indexed");
        for (_, offset) in entries {
            let m =
                summary.seek_message(bytes, chunk, &mcap::records::MessageIndexEntry { log_time: 0, offset }).unwrap();
            out.push((
                m.channel.topic.clone(),
                m.sequence,
                m.log_time.to_string(),
                String::from_utf8(m.data.to_vec()).unwrap(),
            ));
        }
    }
    out
}

fn chunk_messages(summary: &mcap::Summary, bytes: &[u8], chunk: &mcap::records::ChunkIndex) -> u64 {
    summary.stream_chunk(bytes, chunk).unwrap().count() as u64
}

fn rows(v: &Value) -> Vec<Row> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|r| {
            (
                r[0].as_str().unwrap().to_string(),
                r[1].as_u64().unwrap() as u32,
                r[2].as_str().unwrap().to_string(),
                r[3].as_str().unwrap().to_string(),
            )
        })
        .collect()
}

fn sorted(mut r: Vec<Row>) -> Vec<Row> {
    r.sort();
    r
}

/// What an external reader printed (`{"statistics", "indexed", "stream"}`).
fn external(cmd: &mut Command) -> Value {
    let out = cmd.output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

fn check_external(name: &str, got: &Value, stream: &[Row]) {
    assert_eq!(got["statistics"].as_u64(), Some(stream.len() as u64), "{name}: the statistics count every message");
    assert_eq!(rows(&got["stream"]), stream, "{name}'s stream reader reads what the mcap crate's reads");
    let indexed = rows(&got["indexed"]);
    assert_eq!(indexed.len(), stream.len(), "{name}'s indexed reader reads every message");
    assert_eq!(sorted(indexed), sorted(stream.to_vec()), "{name}: the same messages, byte for byte");
}

#[test]
fn every_message_of_a_finished_log_reads_through_its_index() {
    let dir = tmpdir("finished");
    let path = finished_log(&dir);
    let bytes = std::fs::read(&path).unwrap();
    let stream = streamed(&bytes);
    assert!(stream.len() > 150, "{}", stream.len());
    assert_eq!(through_the_index(&bytes), stream, "the index finds every message, in file order");
    let stats = mcap::Summary::read(&bytes).unwrap().unwrap().stats.unwrap();
    assert_eq!(stats.message_count, stream.len() as u64);
    let log = read_log(&path).unwrap();
    assert_eq!(log.format, LOG_FORMAT);
    assert!(log.integrity.is_empty(), "{:?}", log.integrity);
    assert_eq!(log.messages.len(), stream.len());

    let readers = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/readers");
    match std::env::var("HANDOVER_PYTHON") {
        Ok(python) => {
            let got = external(Command::new(python).arg(readers.join("read_indexed.py")).arg(&path));
            assert_eq!(got["chunk_indexes"].as_u64(), Some(log.events.len() as u64 + 1), "one chunk per event");
            check_external("Python mcap", &got, &stream);
        }
        Err(_) => crate::support::missing("HANDOVER_PYTHON (a Python with mcap) is not set"),
    }
    match std::env::var("HANDOVER_NODE_MODULES") {
        Ok(modules) => {
            let got = external(
                Command::new("node").env("NODE_PATH", modules).arg(readers.join("read_indexed.cjs")).arg(&path),
            );
            check_external("@mcap/core", &got, &stream);
        }
        Err(_) => crate::support::missing("HANDOVER_NODE_MODULES (a node_modules with @mcap/core) is not set"),
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn a_log_cut_anywhere_replays_its_whole_events() {
    let dir = tmpdir("cut");
    let path = finished_log(&dir);
    let bytes = std::fs::read(&path).unwrap();
    let whole = read_log(&path).unwrap();
    let cut_path = dir.join("cut.mcap");
    let mut last = 0;
    // From the end of the start's commit (before it the file is no log yet, and a failed
    // start removes it) to the data end, every 997th byte: the prefix's whole events.
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    let first_event = summary.chunk_indexes[1].chunk_start_offset as usize;
    let data_end = summary.chunk_indexes.last().map(|c| c.chunk_start_offset + c.chunk_length).unwrap() as usize;
    for at in (first_event..data_end + 200).step_by(997) {
        std::fs::write(&cut_path, &bytes[..at]).unwrap();
        let log = read_log(&cut_path).unwrap_or_else(|e| panic!("cut at {at}: {e}"));
        assert!(!log.finished);
        assert!(log.events.len() >= last, "cut at {at}: fewer events than an earlier cut");
        assert_eq!(log.events[..], whole.events[..log.events.len()], "cut at {at}");
        assert!(log.integrity.is_empty(), "cut at {at}: {:?}", log.integrity);
        last = log.events.len();
    }
    assert!(last + 2 >= whole.events.len(), "{last} of {}", whole.events.len());
    std::fs::remove_dir_all(dir).unwrap();
}

/// A log of log format 1 (written by handover 0.1.0, before the index, the viewers' schemas
/// and the per-condition test topics) reads, analyses and verifies its events.
#[test]
fn a_log_of_the_earlier_format_still_reads_and_analyses() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/format-1/dry-run.mcap");
    let log = read_log(&path).unwrap();
    assert_eq!((log.format, log.finished, log.events.len()), (1, true, 62));
    assert!(log.integrity.is_empty(), "{:?}", log.integrity);
    assert!(log.start.seed > handover::MAX_SESSION_SEED, "its seed from before the bound, read exactly");
    let (analysis, differences) = handover::analysis::analyse_and_verify(&log, true).unwrap();
    assert!(analysis.completed);
    assert_eq!((analysis.runs.len(), analysis.test_trials.len(), analysis.likert.len()), (2, 16, 8));
    let events: Vec<_> = differences
        .iter()
        .filter(|d| handover::record::Topic::from_name(&d.topic).is_some_and(handover::record::Topic::is_event))
        .collect();
    assert!(events.is_empty(), "its events' messages are recomputed exactly: {events:?}");
    let out = Command::new(env!("CARGO_BIN_EXE_handover")).args(["analyze", "--verify"]).arg(&path).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let said = format!("log format 1 (this version writes {})", handover::record::LOG_FORMAT);
    assert!(err.contains(&said), "{err}");
}
