//! The one list of the log's topics: their names, schema names, and which record events.

/// A topic of the session log.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Topic {
    SessionStart,
    TrialQuery,
    TrialResponse,
    TrialVoid,
    TrialUndo,
    Belief,
    QuestionnaireLikert,
    QuestionnaireChoice,
    SessionPause,
    SessionResume,
    SessionEnd,
    RobotHandoverPose,
    HumanArm,
    Notes,
}

impl Topic {
    /// Every topic, in a fixed order (channels are registered in it).
    pub const ALL: [Topic; 14] = [
        Topic::SessionStart,
        Topic::TrialQuery,
        Topic::TrialResponse,
        Topic::TrialVoid,
        Topic::TrialUndo,
        Topic::Belief,
        Topic::QuestionnaireLikert,
        Topic::QuestionnaireChoice,
        Topic::SessionPause,
        Topic::SessionResume,
        Topic::SessionEnd,
        Topic::RobotHandoverPose,
        Topic::HumanArm,
        Topic::Notes,
    ];

    /// The MCAP channel's topic name.
    pub fn name(self) -> &'static str {
        match self {
            Topic::SessionStart => "/session/start",
            Topic::TrialQuery => "/trial/query",
            Topic::TrialResponse => "/trial/response",
            Topic::TrialVoid => "/trial/void",
            Topic::TrialUndo => "/trial/undo",
            Topic::Belief => "/belief",
            Topic::QuestionnaireLikert => "/questionnaire/likert",
            Topic::QuestionnaireChoice => "/questionnaire/choice",
            Topic::SessionPause => "/session/pause",
            Topic::SessionResume => "/session/resume",
            Topic::SessionEnd => "/session/end",
            Topic::RobotHandoverPose => "/robot/handover_pose",
            Topic::HumanArm => "/human/arm",
            Topic::Notes => "/notes",
        }
    }

    /// The topic of a channel name, if it is one of ours.
    pub fn from_name(name: &str) -> Option<Topic> {
        Self::ALL.into_iter().find(|t| t.name() == name)
    }

    /// Whether its messages are events (the others are derived from them and the protocol).
    pub fn is_event(self) -> bool {
        !matches!(self, Topic::SessionStart | Topic::Belief | Topic::RobotHandoverPose | Topic::HumanArm)
    }
}

impl std::fmt::Display for Topic {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::Topic;

    #[test]
    fn names_are_unique_and_read_back() {
        for t in Topic::ALL {
            assert_eq!(Topic::from_name(t.name()), Some(t));
        }
        assert_eq!(Topic::from_name("/nope"), None);
        assert_eq!(Topic::ALL.iter().filter(|t| t.is_event()).count(), 10);
    }
}
