//! The JSON Schema of every topic (documented field by field in docs/log-format.md).

use serde_json::{Value, json};

use super::Topic;

fn object(required: &[&str], properties: Value) -> Value {
    json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "type": "object",
        "required": required,
        "properties": properties,
    })
}

fn lambda() -> Value {
    json!({"type": "object", "required": ["q_star", "w"], "properties": {
        "q_star": {"type": "array", "items": {"type": "number"}},
        "w": {"type": "array", "items": {"type": "number"}}}})
}

fn trial_fields() -> Value {
    json!({
        "event_index": {"type": "integer", "minimum": 0},
        "phase": {"enum": ["training", "test"]},
        "condition": {"type": "string"},
        "program": {"type": "string"},
        "trial": {"type": "integer", "minimum": 1},
        "query": {"type": "string"},
        "object": {"type": "string"}
    })
}

fn merge(mut a: Value, b: Value) -> Value {
    if let (Some(a), Value::Object(b)) = (a.as_object_mut(), b) {
        a.extend(b);
    }
    a
}

fn time() -> Value {
    json!({"type": "object", "required": ["sec", "nsec"], "properties": {
        "sec": {"type": "integer", "minimum": 0}, "nsec": {"type": "integer", "minimum": 0, "maximum": 999_999_999}}})
}

fn vector3() -> Value {
    json!({"type": "object", "required": ["x", "y", "z"], "properties": {
        "x": {"type": "number"}, "y": {"type": "number"}, "z": {"type": "number"}}})
}

fn pose() -> Value {
    json!({"type": "object", "required": ["position", "orientation"], "properties": {
        "position": vector3(),
        "orientation": {"type": "object", "required": ["x", "y", "z", "w"], "properties": {
            "x": {"type": "number"}, "y": {"type": "number"}, "z": {"type": "number"}, "w": {"type": "number"}}}}})
}

/// (schema name, schema) of a topic.
pub fn schema(topic: Topic) -> (&'static str, Value) {
    match topic {
        Topic::SessionStart => (
            "handover.SessionStart",
            object(
                &[
                    "session_id",
                    "participant",
                    "protocol_name",
                    "protocol_sha256",
                    "seed",
                    "seed_decimal",
                    "condition_order",
                    "program_labels",
                    "software_version",
                    "pilot",
                    "slot",
                    "started_at",
                ],
                json!({
                    "session_id": {"type": "string"},
                    "participant": {"type": "string", "pattern": "^[A-Za-z0-9-]{1,32}$"},
                    "protocol_name": {"type": "string"},
                    "protocol_sha256": {"type": "string", "pattern": "^[0-9a-f]{64}$"},
                    "seed": {"type": "integer", "minimum": 0},
                    "seed_decimal": {"type": "string", "pattern": "^[0-9]{1,20}$"},
                    "condition_order": {"type": "array", "items": {"type": "string"}},
                    "program_labels": {"type": "array", "items": {"type": "string"}},
                    "software_version": {"type": "string"},
                    "pilot": {"type": "boolean"},
                    "slot": {"type": "integer", "minimum": 0},
                    "started_at": {"type": "string"},
                    "resumed_from": {"type": "string"},
                    "simulated_truth": lambda()
                }),
            ),
        ),
        Topic::TrialQuery => (
            "handover.TrialQuery",
            object(
                &["event_index", "phase", "trial", "query", "object", "robot_pose", "regions", "scores"],
                merge(
                    trial_fields(),
                    json!({
                        "label": {"type": "string"},
                        "robot_pose": {"type": "object", "required": ["frame", "position", "rpy_deg"], "properties": {
                            "frame": {"type": "string"},
                            "position": {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3},
                            "rpy_deg": {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3}}},
                        "regions": {"type": "array", "items": {"type": "string"}},
                        "scores": {"type": "array", "items": {"type": "object",
                            "required": ["query", "information_gain", "expected_cost"], "properties": {
                            "query": {"type": "string"},
                            "information_gain": {"type": "number"},
                            "expected_cost": {"type": "number"}}}}
                    }),
                ),
            ),
        ),
        Topic::TrialResponse => (
            "handover.TrialResponse",
            object(
                &["event_index", "phase", "trial", "query", "object", "region", "config_index", "configuration"],
                merge(
                    trial_fields(),
                    json!({
                        "region": {"type": "string"},
                        "config_index": {"type": "integer", "minimum": 0},
                        "configuration": {"type": "array", "items": {"type": "number"}}
                    }),
                ),
            ),
        ),
        Topic::TrialVoid => (
            "handover.TrialVoid",
            object(
                &["event_index", "phase", "trial", "query", "reason", "detail", "retracted"],
                merge(
                    trial_fields(),
                    json!({
                        "reason": {"enum": ["dropped", "robot-fault", "participant-not-ready", "other"]},
                        "detail": {"type": "string"},
                        "retracted": {"type": "boolean"}
                    }),
                ),
            ),
        ),
        Topic::TrialUndo => ("handover.TrialUndo", object(&["event_index", "phase", "trial", "query"], trial_fields())),
        Topic::Belief => (
            "handover.Belief",
            object(
                &[
                    "condition",
                    "program",
                    "iteration",
                    "observation",
                    "mean",
                    "map",
                    "ci90",
                    "grid_mode",
                    "entropy",
                    "ess",
                ],
                json!({
                    "event_index": {"type": "integer", "minimum": 0},
                    "condition": {"type": "string"},
                    "program": {"type": "string"},
                    "iteration": {"type": "integer", "minimum": 0},
                    "observation": {"enum": ["configuration", "region"]},
                    "mean": lambda(),
                    "map": lambda(),
                    "ci90": {"type": "object", "required": ["low", "high"],
                             "properties": {"low": lambda(), "high": lambda()}},
                    "grid_mode": lambda(),
                    "entropy": {"type": "number"},
                    "ess": {"type": "number"}
                }),
            ),
        ),
        Topic::QuestionnaireLikert => (
            "handover.LikertAnswer",
            object(
                &["event_index", "program", "program_label", "condition", "item", "statement", "value", "label"],
                json!({
                    "event_index": {"type": "integer", "minimum": 0},
                    "program": {"type": "string"},
                    "program_label": {"type": "string"},
                    "condition": {"type": "string"},
                    "item": {"type": "string"},
                    "statement": {"type": "string"},
                    "value": {"type": "integer"},
                    "label": {"type": "string"}
                }),
            ),
        ),
        Topic::QuestionnaireChoice => (
            "handover.ForcedChoice",
            object(
                &["event_index", "program", "program_label", "condition", "question"],
                json!({
                    "event_index": {"type": "integer", "minimum": 0},
                    "program": {"type": "string"},
                    "program_label": {"type": "string"},
                    "condition": {"type": "string"},
                    "question": {"type": "string"}
                }),
            ),
        ),
        Topic::SessionPause | Topic::SessionResume => (
            if topic == Topic::SessionPause { "handover.SessionPause" } else { "handover.SessionResume" },
            object(&["event_index"], json!({"event_index": {"type": "integer", "minimum": 0}})),
        ),
        Topic::SessionEnd => (
            "handover.SessionEnd",
            object(
                &["event_index", "status"],
                json!({
                    "event_index": {"type": "integer", "minimum": 0},
                    "status": {"enum": ["completed", "aborted"]},
                    "reason": {"type": "string"}
                }),
            ),
        ),
        Topic::RobotHandoverPose => (
            "foxglove.PoseInFrame",
            object(
                &["timestamp", "frame_id", "pose"],
                json!({"timestamp": time(), "frame_id": {"type": "string"}, "pose": pose()}),
            ),
        ),
        Topic::HumanArm => (
            "foxglove.SceneUpdate",
            object(
                &["deletions", "entities"],
                json!({
                    "deletions": {"type": "array"},
                    "entities": {"type": "array", "items": {"type": "object",
                        "required": ["timestamp", "frame_id", "id", "lifetime", "frame_locked", "lines"],
                        "properties": {
                            "timestamp": time(),
                            "frame_id": {"type": "string"},
                            "id": {"type": "string"},
                            "lifetime": time(),
                            "frame_locked": {"type": "boolean"},
                            "lines": {"type": "array", "items": {"type": "object",
                                "required": ["type", "pose", "thickness", "scale_invariant", "points", "color"],
                                "properties": {
                                    "type": {"type": "integer"},
                                    "pose": pose(),
                                    "thickness": {"type": "number"},
                                    "scale_invariant": {"type": "boolean"},
                                    "points": {"type": "array", "items": vector3()},
                                    "color": {"type": "object", "required": ["r", "g", "b", "a"]}}}}}}}
                }),
            ),
        ),
        Topic::Notes => (
            "foxglove.Log",
            object(
                &["timestamp", "level", "message", "name", "file", "line"],
                json!({
                    "timestamp": time(),
                    "level": {"type": "integer", "minimum": 0, "maximum": 5},
                    "message": {"type": "string"},
                    "name": {"type": "string"},
                    "file": {"type": "string"},
                    "line": {"type": "integer", "minimum": 0},
                    "event_index": {"type": "integer", "minimum": 0}
                }),
            ),
        ),
    }
}
