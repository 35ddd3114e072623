//! `--verify`: every derived value written in a log, recomputed from its events.

use std::collections::BTreeMap;

use serde_json::Value;

use crate::record::{LogContents, ReplayStep, Topic, messages_for, start_messages};
use crate::session::Session;

/// One logged message that the recomputation does not reproduce.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Difference {
    pub topic: String,
    /// The event the message belongs to (0: the start).
    pub event_index: u32,
    pub detail: String,
}

/// The first place where two JSON values differ, as a path.
fn first_difference(path: &str, a: &Value, b: &Value) -> Option<String> {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            for k in x.keys().chain(y.keys()) {
                match (x.get(k), y.get(k)) {
                    (Some(u), Some(v)) => {
                        if let Some(d) = first_difference(&format!("{path}.{k}"), u, v) {
                            return Some(d);
                        }
                    }
                    (u, v) => return Some(format!("{path}.{k}: logged {u:?}, recomputed {v:?}")),
                }
            }
            None
        }
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => {
            x.iter().zip(y).enumerate().find_map(|(i, (u, v))| first_difference(&format!("{path}[{i}]"), u, v))
        }
        _ if a == b => None,
        _ => Some(format!("{path}: logged {a}, recomputed {b}")),
    }
}

/// Collects, during a replay, every message the log should hold.
pub(crate) struct Verifier {
    expected: BTreeMap<u32, Vec<(Topic, Value)>>,
    /// The log time of the start (the start's derived messages carry it).
    start_time_ns: u64,
}

impl Verifier {
    pub fn new(start_time_ns: u64) -> Self {
        Self { expected: BTreeMap::new(), start_time_ns }
    }

    /// Records the messages of the start (no step) or of one replayed event.
    pub fn visit(&mut self, session: &Session, step: Option<ReplayStep>) {
        match step {
            None => {
                self.expected.insert(0, start_messages(session, self.start_time_ns));
            }
            Some((index, stamped, applied)) => {
                self.expected.insert(index as u32, messages_for(stamped, index, applied, session));
            }
        }
    }

    /// Compares the log's messages with those recomputed: for each event, the messages on
    /// event topics and those on derived topics as two sequences, so that a difference is
    /// named by the kind of topic it is on (an earlier format's derived topics differ by design).
    pub fn differences(&self, log: &LogContents) -> Vec<Difference> {
        // Per event: its logged messages on event topics, then those on derived topics.
        type Split<'a> = [Vec<(&'a str, &'a Value)>; 2];
        let mut logged: BTreeMap<u32, Split> = BTreeMap::new();
        for m in &log.messages {
            let derived = !Topic::from_name(&m.topic).is_some_and(Topic::is_event);
            logged.entry(m.sequence).or_default()[usize::from(derived)].push((m.topic.as_str(), &m.value));
        }
        let last = logged.keys().next_back().copied();
        let mut differences = Vec::new();
        for (&index, split) in &logged {
            let Some(exp) = self.expected.get(&index) else { continue };
            for (derived, logged) in split.iter().enumerate() {
                let exp: Vec<_> = exp.iter().filter(|m| m.0.is_event() != (derived == 1)).collect();
                compare(index, Some(index) == last, logged, &exp, &mut differences);
            }
        }
        differences
    }
}

/// Compares one event's logged messages of one kind with those recomputed, in order. A
/// truncated log may lack the tail of its last event's messages.
fn compare(index: u32, last: bool, logged: &[(&str, &Value)], exp: &[&(Topic, Value)], out: &mut Vec<Difference>) {
    if logged.len() != exp.len() && !(last && logged.len() < exp.len()) {
        let topic = logged.first().map(|m| m.0).or_else(|| exp.first().map(|m| m.0.name()));
        out.push(Difference {
            topic: topic.unwrap_or_default().to_string(),
            event_index: index,
            detail: format!("{} messages logged, {} recomputed", logged.len(), exp.len()),
        });
        return;
    }
    for ((topic, value), (etopic, evalue)) in logged.iter().zip(exp.iter().map(|m| (&m.0, &m.1))) {
        if *topic != etopic.name() {
            out.push(Difference {
                topic: topic.to_string(),
                event_index: index,
                detail: format!("logged on {topic}, recomputed on {etopic}"),
            });
        } else if let Some(d) = first_difference("", value, evalue) {
            out.push(Difference { topic: topic.to_string(), event_index: index, detail: d });
        }
    }
}
