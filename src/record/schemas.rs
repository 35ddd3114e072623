//! The JSON Schema of every topic: derived from the `handover.*` message structs
//! ([`super::types`]), or Foxglove's published schema ([`super::foxglove`]).

use schemars::{JsonSchema, generate::SchemaSettings};

use super::Topic;
use super::foxglove::{self, OfficialSchema};
use super::types::{
    BeliefMessage, ForcedChoice, JointAngles, LikertAnswer, RobotCommand, RobotStatus, SessionEnd, SessionMark,
    SessionStartMessage, TestLogLikelihood, TrialQuery, TrialResponse, TrialUndo, TrialVoid,
};

fn derived<T: JsonSchema>(name: &'static str) -> (&'static str, String) {
    let schema = SchemaSettings::draft2020_12().into_generator().into_root_schema_for::<T>();
    (name, serde_json::to_string(&schema).expect("a schema serialises"))
}

fn official((name, text): OfficialSchema) -> (&'static str, String) {
    (name, text.to_string())
}

/// (schema name, schema text) of a topic: the bytes embedded in the log.
pub fn schema(topic: Topic) -> (&'static str, String) {
    match topic {
        Topic::SessionStart => derived::<SessionStartMessage>("handover.SessionStart"),
        Topic::TrialQuery => derived::<TrialQuery>("handover.TrialQuery"),
        Topic::TrialResponse => derived::<TrialResponse>("handover.TrialResponse"),
        Topic::TrialVoid => derived::<TrialVoid>("handover.TrialVoid"),
        Topic::TrialUndo => derived::<TrialUndo>("handover.TrialUndo"),
        Topic::Belief(_) => derived::<BeliefMessage>("handover.Belief"),
        Topic::QuestionnaireLikert => derived::<LikertAnswer>("handover.LikertAnswer"),
        Topic::QuestionnaireChoice => derived::<ForcedChoice>("handover.ForcedChoice"),
        Topic::SessionPause | Topic::SessionResume => derived::<SessionMark>("handover.SessionMark"),
        Topic::SessionEnd => derived::<SessionEnd>("handover.SessionEnd"),
        Topic::HumanJoints => derived::<JointAngles>("handover.JointAngles"),
        Topic::TestLogLikelihood => derived::<TestLogLikelihood>("handover.TestLogLikelihood"),
        Topic::RobotHandoverPose => official(foxglove::POSE_IN_FRAME),
        Topic::HumanArm | Topic::ObjectScene => official(foxglove::SCENE_UPDATE),
        Topic::Transforms => official(foxglove::FRAME_TRANSFORMS),
        Topic::Notes => official(foxglove::LOG),
        Topic::RobotCommand => derived::<RobotCommand>("handover.RobotCommand"),
        Topic::RobotStatus => derived::<RobotStatus>("handover.RobotStatus"),
    }
}
