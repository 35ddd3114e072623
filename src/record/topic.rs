//! The one list of the log's topics: their names, and which record events.

use crate::select::SelectorKind;

/// A topic of the session log.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Topic {
    SessionStart,
    TrialQuery,
    TrialResponse,
    TrialVoid,
    TrialUndo,
    /// The belief of one training condition.
    Belief(SelectorKind),
    QuestionnaireLikert,
    QuestionnaireChoice,
    SessionPause,
    SessionResume,
    /// The experimenter's confirmation of a transition between phases.
    SessionTransition,
    SessionEnd,
    RobotHandoverPose,
    HumanArm,
    HumanJoints,
    Transforms,
    ObjectScene,
    /// The test-set log-likelihood of one training condition (written at the session's end).
    TestLogLikelihood(SelectorKind),
    Notes,
    /// What was sent to the robot (sessions with a robot only).
    RobotCommand,
    /// What the robot answered, or the console's timeout (sessions with a robot only).
    RobotStatus,
}

impl Topic {
    /// Every topic, in a fixed order (channels are registered in it).
    pub const ALL: [Topic; 31] = [
        Topic::SessionStart,
        Topic::TrialQuery,
        Topic::TrialResponse,
        Topic::TrialVoid,
        Topic::TrialUndo,
        Topic::Belief(SelectorKind::Active),
        Topic::Belief(SelectorKind::ActivePaper),
        Topic::Belief(SelectorKind::Passive),
        Topic::Belief(SelectorKind::Random),
        Topic::Belief(SelectorKind::Hybrid),
        Topic::Belief(SelectorKind::Budgeted),
        Topic::QuestionnaireLikert,
        Topic::QuestionnaireChoice,
        Topic::SessionPause,
        Topic::SessionResume,
        Topic::SessionTransition,
        Topic::SessionEnd,
        Topic::RobotHandoverPose,
        Topic::HumanArm,
        Topic::HumanJoints,
        Topic::Transforms,
        Topic::ObjectScene,
        Topic::TestLogLikelihood(SelectorKind::Active),
        Topic::TestLogLikelihood(SelectorKind::ActivePaper),
        Topic::TestLogLikelihood(SelectorKind::Passive),
        Topic::TestLogLikelihood(SelectorKind::Random),
        Topic::TestLogLikelihood(SelectorKind::Hybrid),
        Topic::TestLogLikelihood(SelectorKind::Budgeted),
        Topic::Notes,
        Topic::RobotCommand,
        Topic::RobotStatus,
    ];

    /// The MCAP channel's topic name.
    pub fn name(self) -> &'static str {
        match self {
            Topic::SessionStart => "/session/start",
            Topic::TrialQuery => "/trial/query",
            Topic::TrialResponse => "/trial/response",
            Topic::TrialVoid => "/trial/void",
            Topic::TrialUndo => "/trial/undo",
            Topic::Belief(k) => match k {
                SelectorKind::Active => "/belief/active",
                SelectorKind::ActivePaper => "/belief/active-paper",
                SelectorKind::Passive => "/belief/passive",
                SelectorKind::Random => "/belief/random",
                SelectorKind::Hybrid => "/belief/hybrid",
                SelectorKind::Budgeted => "/belief/budgeted",
            },
            Topic::QuestionnaireLikert => "/questionnaire/likert",
            Topic::QuestionnaireChoice => "/questionnaire/choice",
            Topic::SessionPause => "/session/pause",
            Topic::SessionResume => "/session/resume",
            Topic::SessionTransition => "/session/transition",
            Topic::SessionEnd => "/session/end",
            Topic::RobotHandoverPose => "/robot/handover_pose",
            Topic::HumanArm => "/human/arm",
            Topic::HumanJoints => "/human/joints",
            Topic::Transforms => "/tf",
            Topic::ObjectScene => "/scene/object",
            Topic::TestLogLikelihood(k) => match k {
                SelectorKind::Active => "/test/log_likelihood/active",
                SelectorKind::ActivePaper => "/test/log_likelihood/active-paper",
                SelectorKind::Passive => "/test/log_likelihood/passive",
                SelectorKind::Random => "/test/log_likelihood/random",
                SelectorKind::Hybrid => "/test/log_likelihood/hybrid",
                SelectorKind::Budgeted => "/test/log_likelihood/budgeted",
            },
            Topic::Notes => "/notes",
            Topic::RobotCommand => "/robot/command",
            Topic::RobotStatus => "/robot/status",
        }
    }

    /// The topic of a channel name, if it is one of ours.
    pub fn from_name(name: &str) -> Option<Topic> {
        Self::ALL.into_iter().find(|t| t.name() == name)
    }

    /// Whether its messages are events (the others are derived from them and the protocol).
    pub fn is_event(self) -> bool {
        matches!(
            self,
            Topic::TrialQuery
                | Topic::TrialResponse
                | Topic::TrialVoid
                | Topic::TrialUndo
                | Topic::QuestionnaireLikert
                | Topic::QuestionnaireChoice
                | Topic::SessionPause
                | Topic::SessionResume
                | Topic::SessionTransition
                | Topic::SessionEnd
                | Topic::Notes
                | Topic::RobotCommand
                | Topic::RobotStatus
        )
    }

    /// Topics of logs written by earlier formats, still read: derived topics since renamed
    /// (`/test/log_likelihood`, one topic for every condition, before one topic per condition).
    pub const FORMER_NAMES: [&'static str; 1] = ["/test/log_likelihood"];

    /// Whether a session with training conditions `conditions` registers its channel at the
    /// start (a belief and a test topic per condition run, and every other topic but the
    /// robot's).
    pub fn used_by(self, conditions: &[SelectorKind]) -> bool {
        match self {
            Topic::Belief(k) | Topic::TestLogLikelihood(k) => conditions.contains(&k),
            _ => !self.registered_on_use(),
        }
    }

    /// Whether its channel is registered with its first message: the robot's topics, so
    /// that a session without a robot has no robot channel at all.
    pub fn registered_on_use(self) -> bool {
        matches!(self, Topic::RobotCommand | Topic::RobotStatus)
    }
}

impl std::fmt::Display for Topic {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::{SelectorKind, Topic};

    #[test]
    fn names_are_unique_and_read_back() {
        for t in Topic::ALL {
            assert_eq!(Topic::from_name(t.name()), Some(t));
        }
        assert_eq!(Topic::from_name("/nope"), None);
        let names: std::collections::HashSet<_> = Topic::ALL.iter().map(|t| t.name()).collect();
        assert_eq!(names.len(), Topic::ALL.len());
        for k in SelectorKind::ALL {
            assert!(Topic::ALL.contains(&Topic::Belief(k)), "{k:?} has a belief topic");
            assert!(Topic::ALL.contains(&Topic::TestLogLikelihood(k)), "{k:?} has a test topic");
        }
        assert_eq!(Topic::ALL.iter().filter(|t| t.is_event()).count(), 13);
    }
}
