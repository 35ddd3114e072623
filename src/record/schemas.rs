//! The JSON Schema of every topic: derived from the `handover.*` message structs
//! ([`super::types`]) in the form every JSON-schema viewer reads ([`viewer_form`]), or
//! Foxglove's published schema ([`super::foxglove`]).

use schemars::JsonSchema;
use schemars::generate::{Contract, SchemaSettings};
use serde::Serialize;
use serde_json::{Map, Value};

use super::Topic;
use super::foxglove::{self, OfficialSchema};
use super::types::{
    BeliefMessage, ForcedChoice, JointAngles, LikertAnswer, RobotCommand, RobotStatus, SessionEnd, SessionMark,
    SessionStartMessage, SessionTransition, TestLogLikelihood, TrialQuery, TrialResponse, TrialUndo, TrialVoid,
};

fn derived<T: JsonSchema>(name: &'static str) -> (&'static str, String) {
    let mut settings = SchemaSettings::draft2020_12();
    // A log holds what was serialised; every subschema in place, no `$ref`.
    settings.contract = Contract::Serialize;
    settings.inline_subschemas = true;
    let schema = settings.into_generator().into_root_schema_for::<T>();
    let mut value = schema.to_value();
    viewer_form(&mut value);
    (name, serde_json::to_string(&value).expect("a schema serialises"))
}

fn official((name, text): OfficialSchema) -> (&'static str, String) {
    (name, text.to_string())
}

/// Rewrites a derived schema into the subset JSON-schema viewers parse: one `type` string per
/// field, no `$ref`/`$defs`, no type arrays, no `anyOf`/`oneOf`. An optional field (`T` or
/// `null`) becomes `T`: the writer leaves an absent field out of the message instead of
/// writing `null`, and `required` says which may be absent. A `oneOf` of string constants
/// (an enum with documented variants) becomes a string `enum`.
pub(crate) fn viewer_form(schema: &mut Value) {
    let Some(obj) = schema.as_object_mut() else { return };
    obj.remove("$defs");
    if let Some(Value::Array(types)) = obj.get("type") {
        let not_null: Vec<Value> = types.iter().filter(|t| t.as_str() != Some("null")).cloned().collect();
        if let [one] = not_null.as_slice() {
            obj.insert("type".into(), one.clone());
        }
    }
    if let Some(Value::Array(e)) = obj.get_mut("enum") {
        e.retain(|v| !v.is_null());
    }
    for key in ["anyOf", "oneOf"] {
        let Some(Value::Array(alternatives)) = obj.get(key) else { continue };
        let not_null: Vec<Value> =
            alternatives.iter().filter(|a| a.get("type").and_then(Value::as_str) != Some("null")).cloned().collect();
        let consts: Option<Vec<Value>> =
            not_null.iter().map(|a| a.get("const").filter(|c| c.is_string()).cloned()).collect();
        if let Some(values) = consts.filter(|v| !v.is_empty()) {
            obj.remove(key);
            obj.insert("type".into(), Value::from("string"));
            obj.insert("enum".into(), Value::Array(values));
        } else if let [Value::Object(only)] = not_null.as_slice() {
            let only: Map<String, Value> = only.clone();
            obj.remove(key);
            for (k, v) in only {
                // The field's own description wins over the type's.
                obj.entry(k).or_insert(v);
            }
        }
    }
    if let Some(Value::Object(props)) = obj.get_mut("properties") {
        props.values_mut().for_each(viewer_form);
    }
    if let Some(items) = obj.get_mut("items") {
        viewer_form(items);
    }
}

/// Whether a viewer parses `schema` into message definitions: the rule of Lichtblick's
/// `packages/mcap-support/src/parseJsonSchema.ts` (the Foxglove Studio code it forked): the
/// root and every nested object `"type": "object"` with `properties`; every field's `type` a
/// single string among `boolean`, `string` (no `contentEncoding` but `base64`), `number`,
/// `integer`, `object`, `array`, or a `oneOf` whose every alternative is a numeric `const`;
/// an array's `items` inline with a `type` among `boolean`, `string` (no `contentEncoding`),
/// `number`, `integer`, `object`. `$ref`, `anyOf`, `allOf` and type arrays are refused, and one
/// refused field refuses the whole topic. The error names the field's path.
#[cfg(test)]
pub(crate) fn viewer_accepts(schema: &Value) -> Result<(), String> {
    fn object(schema: &Value, path: &str) -> Result<(), String> {
        if schema.get("type").and_then(Value::as_str) != Some("object") {
            return Err(format!(
                "{path}: expected \"type\": \"object\", got {}",
                schema.get("type").unwrap_or(&Value::Null)
            ));
        }
        let Some(props) = schema.get("properties").and_then(Value::as_object) else {
            return Err(format!("{path}: an object without properties"));
        };
        for (name, field) in props {
            let path = if path.is_empty() { name.clone() } else { format!("{path}.{name}") };
            if let Some(alternatives) = field.get("oneOf") {
                let numeric = alternatives
                    .as_array()
                    .is_some_and(|a| a.iter().all(|alt| alt.get("const").is_some_and(Value::is_number)));
                if !numeric {
                    return Err(format!("{path}: oneOf alternatives must have number values"));
                }
                continue;
            }
            match field.get("type").and_then(Value::as_str) {
                Some("boolean" | "number" | "integer") => {}
                Some("string") => match field.get("contentEncoding") {
                    None => {}
                    Some(e) if e == "base64" => {}
                    Some(e) => return Err(format!("{path}: unsupported contentEncoding {e}")),
                },
                Some("object") => object(field, &path)?,
                Some("array") => {
                    let Some(items) = field.get("items").filter(|i| i.is_object()) else {
                        return Err(format!("{path}: an array without an inline items schema"));
                    };
                    match items.get("type").and_then(Value::as_str) {
                        Some("boolean" | "number" | "integer") => {}
                        Some("string") if items.get("contentEncoding").is_none() => {}
                        Some("object") => object(items, &path)?,
                        _ => {
                            let t = items.get("type").unwrap_or(&Value::Null);
                            return Err(format!("{path}: unsupported type {t} for an array item"));
                        }
                    }
                }
                _ => return Err(format!("{path}: unsupported type {}", field.get("type").unwrap_or(&Value::Null))),
            }
        }
        Ok(())
    }
    object(schema, "")
}

/// A message type of the log and the topics that carry it: the one place a struct is tied to
/// its topics. [`schema`] gives a topic the schema of the type that claims it, and a message is
/// logged only on a topic its type claims (`messages::on`); a test checks that every topic is
/// claimed by exactly one type.
pub trait LogMessage: Serialize {
    /// The schema's name and text, as embedded in the log.
    fn schema() -> (&'static str, String);
    /// Whether `topic` carries this type.
    fn carried_by(topic: Topic) -> bool;
}

/// A `handover.*` message: its schema derived from the struct.
macro_rules! derived_message {
    ($ty:ty, $name:literal, $($topic:pat_param)|+) => {
        impl LogMessage for $ty {
            fn schema() -> (&'static str, String) {
                derived::<$ty>($name)
            }
            fn carried_by(topic: Topic) -> bool {
                matches!(topic, $($topic)|+)
            }
        }
    };
}

/// A `foxglove.*` message: Foxglove's published schema.
macro_rules! official_message {
    ($ty:ty, $schema:expr, $($topic:pat_param)|+) => {
        impl LogMessage for $ty {
            fn schema() -> (&'static str, String) {
                official($schema)
            }
            fn carried_by(topic: Topic) -> bool {
                matches!(topic, $($topic)|+)
            }
        }
    };
}

derived_message!(SessionStartMessage, "handover.SessionStart", Topic::SessionStart);
derived_message!(TrialQuery, "handover.TrialQuery", Topic::TrialQuery);
derived_message!(TrialResponse, "handover.TrialResponse", Topic::TrialResponse);
derived_message!(TrialVoid, "handover.TrialVoid", Topic::TrialVoid);
derived_message!(TrialUndo, "handover.TrialUndo", Topic::TrialUndo);
derived_message!(BeliefMessage, "handover.Belief", Topic::Belief(_));
derived_message!(LikertAnswer, "handover.LikertAnswer", Topic::QuestionnaireLikert);
derived_message!(ForcedChoice, "handover.ForcedChoice", Topic::QuestionnaireChoice);
derived_message!(SessionMark, "handover.SessionMark", Topic::SessionPause | Topic::SessionResume);
derived_message!(SessionTransition, "handover.SessionTransition", Topic::SessionTransition);
derived_message!(SessionEnd, "handover.SessionEnd", Topic::SessionEnd);
derived_message!(JointAngles, "handover.JointAngles", Topic::HumanJoints);
derived_message!(TestLogLikelihood, "handover.TestLogLikelihood", Topic::TestLogLikelihood(_));
derived_message!(RobotCommand, "handover.RobotCommand", Topic::RobotCommand);
derived_message!(RobotStatus, "handover.RobotStatus", Topic::RobotStatus);
official_message!(foxglove::PoseInFrame, foxglove::POSE_IN_FRAME, Topic::RobotHandoverPose);
official_message!(foxglove::SceneUpdate, foxglove::SCENE_UPDATE, Topic::HumanArm | Topic::ObjectScene);
official_message!(foxglove::FrameTransforms, foxglove::FRAME_TRANSFORMS, Topic::Transforms);
official_message!(foxglove::Log, foxglove::LOG, Topic::Notes);

/// A message type's schema and topics, as plain functions.
type Entry = (fn() -> (&'static str, String), fn(Topic) -> bool);

fn entry<M: LogMessage>() -> Entry {
    (M::schema, M::carried_by)
}

/// Every message type of the log.
fn message_types() -> [Entry; 19] {
    [
        entry::<SessionStartMessage>(),
        entry::<TrialQuery>(),
        entry::<TrialResponse>(),
        entry::<TrialVoid>(),
        entry::<TrialUndo>(),
        entry::<BeliefMessage>(),
        entry::<LikertAnswer>(),
        entry::<ForcedChoice>(),
        entry::<SessionMark>(),
        entry::<SessionTransition>(),
        entry::<SessionEnd>(),
        entry::<JointAngles>(),
        entry::<TestLogLikelihood>(),
        entry::<RobotCommand>(),
        entry::<RobotStatus>(),
        entry::<foxglove::PoseInFrame>(),
        entry::<foxglove::SceneUpdate>(),
        entry::<foxglove::FrameTransforms>(),
        entry::<foxglove::Log>(),
    ]
}

/// (schema name, schema text) of a topic: the bytes embedded in the log, of the message type
/// that claims the topic.
pub fn schema(topic: Topic) -> (&'static str, String) {
    let (schema, _) = message_types()
        .into_iter()
        .find(|(_, carried_by)| carried_by(topic))
        .expect("every topic is claimed by a message type (schemas::tests)");
    schema()
}

#[cfg(test)]
mod tests {
    use super::{Topic, message_types, schema, viewer_accepts, viewer_form};
    use serde_json::json;

    /// No topic half registered: each is claimed by exactly one message type, and each type
    /// claims a topic.
    #[test]
    fn every_topic_is_carried_by_exactly_one_message_type() {
        for topic in Topic::ALL {
            let claims = message_types().iter().filter(|(_, carried_by)| carried_by(topic)).count();
            assert_eq!(claims, 1, "{topic} is claimed by {claims} message types");
        }
        for (schema, carried_by) in message_types() {
            assert!(Topic::ALL.into_iter().any(carried_by), "{} carries no topic", schema().0);
        }
    }

    #[test]
    fn every_topic_schema_is_one_a_viewer_parses() {
        for topic in Topic::ALL {
            let (name, text) = schema(topic);
            let value: serde_json::Value = serde_json::from_str(&text).unwrap();
            if let Err(e) = viewer_accepts(&value) {
                panic!("{topic} ({name}) would be refused by the viewer: {e}");
            }
            assert!(!text.contains("$ref") && !text.contains("$defs") && !text.contains("\"null\""), "{topic}: {text}");
        }
    }

    #[test]
    fn the_rule_refuses_what_the_viewer_refuses() {
        let field = |f: serde_json::Value| json!({"type": "object", "properties": {"x": f}});
        assert!(viewer_accepts(&field(json!({"type": "string"}))).is_ok());
        assert!(viewer_accepts(&field(json!({"oneOf": [{"const": 0}, {"const": 1}]}))).is_ok());
        for refused in [
            json!({"type": ["string", "null"]}),
            json!({"$ref": "#/$defs/L"}),
            json!({"anyOf": [{"type": "string"}, {"type": "null"}]}),
            json!({"oneOf": [{"const": "a"}]}),
            json!({"type": "array", "items": {"$ref": "#/$defs/L"}}),
            json!({"type": "array"}),
            json!({"type": "object"}),
            json!({"type": "null"}),
        ] {
            assert!(viewer_accepts(&field(refused.clone())).is_err(), "{refused}");
        }
        assert!(viewer_accepts(&json!({"type": "array"})).is_err(), "the root must be an object");
    }

    #[test]
    fn viewer_form_inlines_options_and_documented_enums() {
        let mut s = json!({"type": "object", "properties": {
            "a": {"type": ["string", "null"], "description": "d"},
            "b": {"description": "field", "anyOf": [{"type": "object", "description": "type", "properties": {"v": {"type": "number"}}}, {"type": "null"}]},
            "c": {"oneOf": [{"type": "string", "const": "x"}, {"type": "string", "const": "y"}]},
            "d": {"type": "array", "items": {"type": ["integer", "null"]}}
        }, "$defs": {}});
        viewer_form(&mut s);
        assert_eq!(s["properties"]["a"], json!({"type": "string", "description": "d"}));
        assert_eq!(s["properties"]["b"]["type"], "object");
        assert_eq!(s["properties"]["b"]["description"], "field");
        assert_eq!(s["properties"]["c"], json!({"type": "string", "enum": ["x", "y"]}));
        assert_eq!(s["properties"]["d"]["items"], json!({"type": "integer"}));
        assert!(s.get("$defs").is_none());
        viewer_accepts(&s).unwrap();
    }
}
