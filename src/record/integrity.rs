//! The checks `analyze --verify` makes of a log's bytes, beyond replaying its events: every
//! CRC the file carries (attachments, the data section, the summary) and every schema and
//! channel record against what this version writes.

use super::Topic;
use super::schemas::schema;

/// A schema or channel record as read.
#[derive(Clone, Debug, Default)]
pub struct Declared {
    /// Every schema record, the data section's and the summary's copies alike: (id, name,
    /// encoding, data).
    pub schemas: Vec<(u16, String, String, Vec<u8>)>,
    /// Every channel record: (id, topic, schema id, message encoding).
    pub channels: Vec<(u16, String, u16, String)>,
}

fn le_u32(b: &[u8]) -> u32 {
    u32::from_le_bytes(b[..4].try_into().unwrap_or([0; 4]))
}

fn le_u64(b: &[u8]) -> u64 {
    u64::from_le_bytes(b[..8].try_into().unwrap_or([0; 8]))
}

const MAGIC: &[u8] = b"\x89MCAP0\r\n";
/// A footer record: opcode, length 20, summary start, summary offset start, summary CRC.
const FOOTER_LEN: usize = 1 + 8 + 20;
/// A data end record: opcode, length 4, the data section's CRC.
const DATA_END_LEN: usize = 1 + 8 + 4;

/// Where a file that ends as a finished log does (its footer and end magic): the offset of its
/// data end record, or why its end is not a log's.
fn finished_end(bytes: &[u8]) -> Option<Result<usize, String>> {
    let len = bytes.len();
    if len < MAGIC.len() + FOOTER_LEN + DATA_END_LEN + MAGIC.len() || !bytes.ends_with(MAGIC) {
        return None;
    }
    let footer = len - MAGIC.len() - FOOTER_LEN;
    if bytes[footer] != 0x02 || le_u64(&bytes[footer + 1..]) != 20 {
        return Some(Err(format!("it ends with the MCAP magic but no footer before it (at byte {footer})")));
    }
    let summary_start = le_u64(&bytes[footer + 9..]) as usize;
    let data_end = match summary_start {
        0 => footer.checked_sub(DATA_END_LEN),
        s if s <= footer => s.checked_sub(DATA_END_LEN),
        _ => None,
    };
    let Some(data_end) = data_end.filter(|&d| d >= MAGIC.len()) else {
        return Some(Err(format!("its footer's summary start {summary_start} is outside the file")));
    };
    if bytes[data_end] != 0x0F || le_u64(&bytes[data_end + 1..]) != 4 {
        return Some(Err(format!("there is no data end record at byte {data_end}, before its summary")));
    }
    Some(Ok(data_end))
}

/// Whether the file's records follow one another from its magic to its end: for a finished
/// log (footer and end magic), exactly to its data end, then its summary exactly to its
/// footer, nothing after the end magic; for an unfinished one, up to a cut tail. A finished
/// log whose records stop short is damaged (a changed length field), not cut off by a crash.
pub fn check_structure(bytes: &[u8]) -> Result<(), String> {
    let walk = |from: usize, to: usize| -> usize {
        let mut at = from;
        while at + 9 <= to {
            let len = le_u64(&bytes[at + 1..]);
            match usize::try_from(len).ok().and_then(|l| (at + 9).checked_add(l)).filter(|&e| e <= to) {
                Some(end) => at = end,
                None => break,
            }
        }
        at
    };
    match finished_end(bytes) {
        Some(Err(why)) => Err(format!("the log is damaged: {why}")),
        Some(Ok(data_end)) => {
            let reached = walk(MAGIC.len(), data_end);
            if reached != data_end {
                return Err(format!(
                    "the log is damaged: its records stop at byte {reached}, before its data end at byte {data_end} \
                     (a changed byte; a crash leaves no footer)"
                ));
            }
            let footer = bytes.len() - MAGIC.len() - FOOTER_LEN;
            let summary_start = le_u64(&bytes[footer + 9..]) as usize;
            let summary_from = if summary_start == 0 { footer } else { summary_start };
            if data_end + DATA_END_LEN != summary_from || walk(summary_from, footer) != footer {
                return Err(format!(
                    "the log is damaged: its summary's records do not lead to its footer at byte {footer}"
                ));
            }
            Ok(())
        }
        None => {
            // Unfinished: a footer inside means content after a finished log's end.
            let mut at = MAGIC.len();
            while at + 9 <= bytes.len() {
                let len = le_u64(&bytes[at + 1..]);
                let Some(end) =
                    usize::try_from(len).ok().and_then(|l| (at + 9).checked_add(l)).filter(|&e| e <= bytes.len())
                else {
                    break;
                };
                if bytes[at] == 0x02 {
                    return Err(match bytes.len().checked_sub(end + MAGIC.len()) {
                        Some(0) => "the log is damaged: its end magic is changed".to_string(),
                        Some(extra) => format!("the log is damaged: {extra} bytes follow its footer and end magic"),
                        None => "the log is damaged: its end magic is cut".to_string(),
                    });
                }
                at = end;
            }
            Ok(())
        }
    }
}

/// What is wrong with a log's bytes, without reading its messages: its structure
/// ([`check_structure`]) and every CRC it carries ([`check_crcs`]). Empty for an intact log or
/// one cut off by a crash.
pub fn problems(bytes: &[u8]) -> Vec<String> {
    match check_structure(bytes) {
        Err(why) => vec![why],
        Ok(()) => check_crcs(bytes),
    }
}

/// Walks the records of an MCAP file and checks its CRCs: each attachment's and chunk's, the data end's
/// CRC of the data section and the footer's CRC of the summary (a CRC of 0 means "not
/// computed", as the format allows). An unfinished file has only attachment CRCs to check.
pub fn check_crcs(bytes: &[u8]) -> Vec<String> {
    let mut problems = Vec::new();
    let mut at = 8usize;
    while at + 9 <= bytes.len() {
        let opcode = bytes[at];
        let len = le_u64(&bytes[at + 1..]);
        let Some(end) = usize::try_from(len).ok().and_then(|l| (at + 9).checked_add(l)).filter(|&e| e <= bytes.len())
        else {
            break; // a cut tail: the reader reports it
        };
        let body = &bytes[at + 9..end];
        match opcode {
            0x09 if body.len() >= 4 => {
                let (content, crc) = body.split_at(body.len() - 4);
                let crc = le_u32(crc);
                if crc != 0 && crc32fast::hash(content) != crc {
                    problems.push(format!("the attachment record at byte {at} fails its CRC"));
                }
            }
            // A chunk: start and end time, uncompressed size and CRC, compression, records.
            0x06 if body.len() >= 32 => {
                let crc = le_u32(&body[24..]);
                let compression_len = le_u32(&body[28..]) as usize;
                let records = body.get(32 + compression_len + 8..);
                if crc != 0 && compression_len == 0 && records.is_none_or(|r| crc32fast::hash(r) != crc) {
                    problems.push(format!(
                        "the chunk at byte {at} fails its CRC (a byte of an event's messages was changed)"
                    ));
                }
            }
            0x0F if body.len() >= 4 => {
                let crc = le_u32(body);
                if crc != 0 && crc32fast::hash(&bytes[..at]) != crc {
                    problems.push("the data section fails its CRC (a byte of a record was changed)".into());
                }
            }
            0x02 if body.len() >= 20 => {
                let summary_start = le_u64(body) as usize;
                let crc = le_u32(&body[16..]);
                let upto = at + 9 + 16;
                if crc != 0 && (summary_start > upto || crc32fast::hash(&bytes[summary_start..upto]) != crc) {
                    problems.push("the summary section fails its CRC".into());
                }
            }
            _ => {}
        }
        at = end;
    }
    problems
}

/// Checks that every channel is one of this program's topics (or a topic an earlier format
/// had), in JSON, with that topic's schema; for a log of the format this version writes, that
/// every schema is byte for byte the one it writes (a log of an earlier format: that it is
/// JSON).
pub fn check_declarations(d: &Declared, current_format: bool) -> Vec<String> {
    let mut problems = Vec::new();
    for (id, topic, schema_id, encoding) in &d.channels {
        let Some(known) = Topic::from_name(topic) else {
            if !Topic::FORMER_NAMES.contains(&topic.as_str()) {
                problems.push(format!("channel {id} has the unknown topic '{}'", topic.escape_debug()));
            }
            continue;
        };
        if encoding != "json" {
            problems.push(format!("channel {topic}: message encoding '{}', expected 'json'", encoding.escape_debug()));
        }
        let copies: Vec<_> = d.schemas.iter().filter(|s| s.0 == *schema_id).collect();
        if copies.is_empty() {
            problems.push(format!("channel {topic}: schema {schema_id} is not in the log"));
        }
        let (want_name, want) = schema(known);
        for (_, name, schema_encoding, data) in copies {
            if schema_encoding != "jsonschema" {
                problems.push(format!(
                    "{topic}: schema encoding '{}', expected 'jsonschema'",
                    schema_encoding.escape_debug()
                ));
            }
            if name != want_name {
                problems.push(format!("{topic}: schema name '{}', expected '{want_name}'", name.escape_debug()));
            }
            if current_format {
                if data.as_slice() != want.as_bytes() {
                    problems.push(format!("{topic}: the schema differs from the one this version writes"));
                }
            } else if serde_json::from_slice::<serde_json::Value>(data).map_or(true, |v| !v.is_object()) {
                problems.push(format!("{topic}: the schema is not a JSON object"));
            }
        }
    }
    problems.sort();
    problems.dedup();
    problems
}
