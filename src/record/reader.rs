//! The reader: a log read back, every field validated as when it was written, tolerant of a
//! truncated tail.

use std::collections::HashMap;
use std::io::Read;
use std::path::{Path, PathBuf};

use serde_json::Value;

use super::{PROTOCOL_ATTACHMENT, RecordError, Topic, event_from_message, integrity, io, is_log_file_name, mcap_err};
use crate::protocol::Study;
use crate::session::{Event, SessionStart, Stamped};

/// One message read back from a log.
#[derive(Clone, Debug)]
pub struct LoggedMessage {
    pub topic: String,
    pub sequence: u32,
    pub log_time: u64,
    pub value: Value,
}

/// Everything a log holds.
#[derive(Clone, Debug)]
pub struct LogContents {
    pub path: PathBuf,
    pub protocol_text: String,
    pub start: SessionStart,
    pub start_time_ns: u64,
    /// Its log format ([`super::LOG_FORMAT`]; 1 for a log that does not say).
    pub format: u32,
    /// The events in order.
    pub events: Vec<Stamped>,
    /// Every message, in file order.
    pub messages: Vec<LoggedMessage>,
    /// Whether the file ends with a summary and footer (false: a crash or a quit not yet
    /// finished; everything up to the last whole message is here).
    pub finished: bool,
    /// Whether the file ends in a partial record (cut off by a crash).
    pub cut_tail: bool,
    /// What the file's CRCs and its schema and channel records say is wrong (reported by
    /// `analyze --verify`; empty for an intact log).
    pub integrity: Vec<String>,
}

/// The largest log read (a whole study session is well under 10 MiB).
pub const MAX_LOG_BYTES: u64 = 256 << 20;
/// The longest note or void detail in a log, in bytes.
pub const MAX_TEXT_BYTES: usize = 10_000;

/// Checks a log's start record with the same rules as on creation: ids that become file
/// names, labels, the slot, the times and the simulated truth.
pub fn validate_start(start: &SessionStart) -> Result<(), String> {
    crate::participant::validate_id(&start.participant).map_err(|e| format!("participant: {e}"))?;
    let session_ok = (1..=64).contains(&start.session_id.len())
        && start.session_id.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-');
    if !session_ok {
        return Err(format!(
            "session_id '{}' is invalid: expected 1 to 64 characters from A–Z, a–z, 0–9 and '-'",
            start.session_id.escape_debug()
        ));
    }
    // The protocol validator's rule (`crate::text`), so every protocol it accepts logs a
    // start this reader accepts.
    let printable =
        |field: &str, v: &str, max: usize| crate::text::check_label(v, max).map_err(|e| format!("{field} {e}"));
    printable("protocol_name", &start.protocol_name, crate::text::NAME_BYTES)?;
    printable("software_version", &start.software_version, 64)?;
    if start.protocol_sha256.len() != 64 || !start.protocol_sha256.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err("protocol_sha256 is not 64 hexadecimal digits".into());
    }
    for (i, l) in start.program_labels.iter().enumerate() {
        printable(&format!("program_labels[{i}]"), l, crate::text::PROGRAM_LABEL_BYTES)?;
    }
    if start.slot >= 2 {
        return Err(format!("slot is {}, expected 0 or 1 (the orders AB and BA)", start.slot));
    }
    if chrono::DateTime::parse_from_rfc3339(&start.started_at).is_err() {
        return Err(format!("started_at '{}' is not an RFC 3339 time", start.started_at.escape_debug()));
    }
    if let Some(name) = &start.resumed_from
        && !is_log_file_name(name)
    {
        return Err(format!(
            "resumed_from '{}' is not a log file name (A–Z, a–z, 0–9, '-', '_', ending in .mcap)",
            name.escape_debug()
        ));
    }
    if let Some(t) = &start.simulated_truth {
        let ok = t.q_star.len() == t.w.len()
            && t.q_star.len() <= 64
            && t.q_star.iter().all(|v| v.is_finite() && v.abs() <= 10.0)
            && t.w.iter().all(|v| v.is_finite() && (0.0..=1e3).contains(v));
        if !ok {
            return Err("simulated_truth is not a λ of finite angles (|q*| ≤ 10 rad) and weights in [0, 1000]".into());
        }
    }
    Ok(())
}

fn validate_event(event: &Event) -> Result<(), String> {
    let long = |field: &str, v: &str| {
        if v.len() > MAX_TEXT_BYTES {
            Err(format!("{field} has {} bytes, expected at most {MAX_TEXT_BYTES}", v.len()))
        } else {
            Ok(())
        }
    };
    match event {
        Event::Note { text } => long("text", text),
        Event::TrialVoided { detail, .. } => long("detail", detail),
        Event::Aborted { reason } => long("reason", reason),
        Event::RobotReported { detail, command, .. } => {
            long("detail", detail)?;
            command.as_deref().map_or(Ok(()), |c| crate::session::validate_command_id(c).map_err(|e| e.to_string()))
        }
        Event::RobotCommanded { pose, command, .. } => {
            crate::session::validate_sent_pose(pose).map_err(|e| e.to_string())?;
            command.as_deref().map_or(Ok(()), |c| crate::session::validate_command_id(c).map_err(|e| e.to_string()))
        }
        Event::GraspRecorded { measured: Some(m), .. } if m.source == crate::session::MeasurementSource::File => {
            Err("measured.source is 'file', expected 'simulated' or 'ros2' (a file is aligned after a session, never logged)"
                .into())
        }
        // The session checks a measurement against its set and the protocol; here its size.
        Event::GraspRecorded { measured: Some(m), .. } if m.q_rad.len() > crate::kinematics::JOINTS => {
            Err(format!("measured.q_rad has {} angles, expected {}", m.q_rad.len(), crate::kinematics::JOINTS))
        }
        _ => Ok(()),
    }
}

/// Reads a log up to its last whole message. Everything in it is untrusted: the size is
/// bounded, the start record is validated and every event is checked before use.
pub fn read_log(path: &Path) -> Result<LogContents, RecordError> {
    let not_log = |why: &str| RecordError::NotALog { path: path.to_path_buf(), why: why.to_string() };
    // Only a regular file, opened without blocking: a FIFO named like a log is refused.
    let file = crate::input_file::open_regular(path).map_err(io(path))?;
    let len = file.metadata().map_err(io(path))?.len();
    if len > MAX_LOG_BYTES {
        return Err(not_log(&format!("it has {len} bytes, over the budget of {MAX_LOG_BYTES} bytes for a log")));
    }
    let mut bytes = Vec::new();
    file.take(MAX_LOG_BYTES + 1).read_to_end(&mut bytes).map_err(io(path))?;
    if bytes.len() as u64 > MAX_LOG_BYTES {
        return Err(not_log(&format!("it is over the budget of {MAX_LOG_BYTES} bytes for a log")));
    }
    read_log_bytes(path, &bytes)
}

/// [`read_log`] of a log's bytes already in memory (`path` names it in errors).
pub fn read_log_bytes(path: &Path, bytes: &[u8]) -> Result<LogContents, RecordError> {
    let not_log = |why: &str| RecordError::NotALog { path: path.to_path_buf(), why: why.to_string() };
    if !bytes.starts_with(mcap::MAGIC) {
        return Err(not_log("it does not start with the MCAP magic bytes"));
    }
    integrity::check_structure(bytes).map_err(|why| not_log(&why))?;
    // Chunks are unpacked in place (each event's messages are one chunk). Their CRCs are
    // checked by `integrity`, so that a changed byte is named, not taken for a cut tail.
    let reader = mcap::read::ChunkFlattener::new_with_options(bytes, mcap::read::Options::IgnoreEndMagic.into())
        .map_err(mcap_err(path))?;
    let mut topics: HashMap<u16, String> = HashMap::new();
    let mut declared = integrity::Declared::default();
    let mut protocol_text = None;
    let mut messages = Vec::new();
    let mut finished = false;
    let mut cut = false;
    for record in reader {
        let Ok(record) = record else {
            cut = true;
            break;
        };
        match record {
            mcap::records::Record::Channel(c) => {
                declared.channels.push((c.id, c.topic.clone(), c.schema_id, c.message_encoding));
                topics.insert(c.id, c.topic);
            }
            mcap::records::Record::Schema { header, data } => {
                declared.schemas.push((header.id, header.name, header.encoding, data.into_owned()));
            }
            mcap::records::Record::Attachment { header, data, .. } if header.name == PROTOCOL_ATTACHMENT => {
                protocol_text = Some(String::from_utf8_lossy(&data).into_owned());
            }
            mcap::records::Record::Message { header, data } => {
                let Some(topic) = topics.get(&header.channel_id) else { continue };
                let Ok(value) = serde_json::from_slice::<Value>(&data) else {
                    return Err(not_log(&format!("a {topic} message is not JSON")));
                };
                messages.push(LoggedMessage {
                    topic: topic.clone(),
                    sequence: header.sequence,
                    log_time: header.log_time,
                    value,
                });
            }
            mcap::records::Record::Footer(_) => finished = true,
            _ => {}
        }
    }
    let protocol_text = protocol_text.ok_or_else(|| not_log("it has no protocol attachment"))?;
    let first = messages
        .iter()
        .find(|m| m.topic == Topic::SessionStart.name())
        .ok_or_else(|| not_log("it has no /session/start"))?;
    let start_time_ns = first.log_time;
    let mut start_value = first.value.clone();
    let (mut seed_decimal, mut format) = (None, None);
    if let Some(o) = start_value.as_object_mut() {
        o.remove("event_index");
        seed_decimal = o.remove("seed_decimal");
        format = o.remove("log_format");
    }
    let format = match format {
        None => 1,
        Some(v) => match v.as_u64() {
            Some(f @ 2..) if f <= u64::from(super::LOG_FORMAT) => f as u32,
            Some(f) if f > u64::from(super::LOG_FORMAT) => {
                return Err(not_log(&format!(
                    "/session/start: log_format is {f}: written by a newer handover (this one reads formats 1 to {})",
                    super::LOG_FORMAT
                )));
            }
            _ => {
                return Err(not_log(&format!(
                    "/session/start: log_format is {v}, expected an integer from 2 to {}",
                    super::LOG_FORMAT
                )));
            }
        },
    };
    let mut start: SessionStart =
        serde_json::from_value(start_value).map_err(|e| not_log(&format!("/session/start: {e}")))?;
    if format <= 2 {
        // Sessions of formats 1 and 2 scored region outcomes, whatever they learned from.
        start.selection.get_or_insert(crate::session::SelectionOutcome::Region);
    }
    validate_start(&start).map_err(|e| not_log(&format!("/session/start: {e}")))?;
    // Logs before the text seed lack it; when present it must be the seed.
    if let Some(d) = seed_decimal
        && d.as_str() != Some(start.seed.to_string().as_str())
    {
        return Err(not_log(&format!("/session/start: seed_decimal {d} is not the seed {}", start.seed)));
    }
    let mut events = Vec::new();
    for (m, topic) in messages.iter().filter_map(|m| Some((m, Topic::from_name(&m.topic).filter(|t| t.is_event())?))) {
        let event = event_from_message(topic, &m.value).ok_or_else(|| {
            not_log(&format!("a {} message (event {}) cannot be read as an event", m.topic, m.sequence))
        })?;
        validate_event(&event).map_err(|e| not_log(&format!("{} (event {}): {e}", m.topic, m.sequence)))?;
        events.push((m.sequence, Stamped { time_ns: m.log_time, event }));
    }
    events.sort_by_key(|(s, _)| *s);
    let mut problems = integrity::check_crcs(bytes);
    problems.extend(integrity::check_declarations(&declared, format == super::LOG_FORMAT));
    Ok(LogContents {
        path: path.to_path_buf(),
        protocol_text,
        start,
        start_time_ns,
        format,
        events: events.into_iter().map(|(_, e)| e).collect(),
        messages,
        finished,
        cut_tail: cut,
        integrity: problems,
    })
}

/// The study of a log's embedded protocol.
pub fn study_of(log: &LogContents) -> Result<Study, RecordError> {
    Study::from_json(&log.protocol_text, &format!("{} (embedded protocol)", log.path.display()))
        .map_err(|source| RecordError::Protocol { path: log.path.clone(), source })
}
