//! The messages each event is logged as, and the event each event message is read back as.

use serde_json::Value;

use super::Topic;
use super::foxglove::{self, PoseInFrame, Time};
use super::scene;
use super::schemas::LogMessage;
use super::types::{
    BeliefMessage, EndStatus, ForcedChoice, Interval, JointAngles, LearnedFrom, LikertAnswer, MeasuredResponse,
    QueryScore, RobotCommand, RobotPose, RobotStatus, SessionEnd, SessionMark, SessionStartMessage, SessionTransition,
    TestLogLikelihood, TransitionName, TrialFields, TrialQuery, TrialResponse, TrialUndo, TrialVoid, program_index,
};
use crate::kinematics::ArmConfig;
use crate::protocol::ObservationModel;
use crate::session::{
    Applied, ArmMeasurement, BeliefSummary, Event, Session, Stamped, Transition, TrialView, program_letter,
};

/// The topic an event is logged on.
pub fn topic_of(e: &Event) -> Topic {
    match e {
        Event::QueryPresented { .. } => Topic::TrialQuery,
        Event::GraspRecorded { .. } => Topic::TrialResponse,
        Event::TrialVoided { .. } => Topic::TrialVoid,
        Event::GraspUndone => Topic::TrialUndo,
        Event::Note { .. } => Topic::Notes,
        Event::Paused => Topic::SessionPause,
        Event::Resumed => Topic::SessionResume,
        Event::TransitionConfirmed { .. } => Topic::SessionTransition,
        Event::LikertAnswered { .. } => Topic::QuestionnaireLikert,
        Event::ForcedChoice { .. } => Topic::QuestionnaireChoice,
        Event::Ended | Event::Aborted { .. } => Topic::SessionEnd,
        Event::RobotCommanded { .. } => Topic::RobotCommand,
        Event::RobotReported { .. } => Topic::RobotStatus,
    }
}

/// A message on its topic, refused (a programming error, caught by every test that logs) on
/// a topic its type does not claim.
fn on<M: LogMessage>(topic: Topic, m: &M) -> (Topic, Value) {
    assert!(M::carried_by(topic), "{topic} does not carry {}", std::any::type_name::<M>());
    (topic, serde_json::to_value(m).expect("a message struct serialises to JSON"))
}

fn trial_fields(index: usize, view: &TrialView, session: &Session) -> TrialFields {
    let q = session.query(view.query);
    TrialFields {
        event_index: index as u32,
        phase: view.phase.into(),
        condition: view.condition.map(|c| c.name().to_string()),
        program: view.program.map(program_letter),
        trial: view.trial as u32,
        query: q.query.id.clone(),
        object: q.query.object.clone(),
    }
}

fn belief_message(index: usize, run: usize, b: &BeliefSummary, session: &Session) -> (Topic, Value) {
    let condition = session.learners()[run].condition;
    let m = BeliefMessage {
        event_index: index as u32,
        condition: condition.name().to_string(),
        program: program_letter(run),
        iteration: b.iteration as u32,
        observation: session.context().observation.name().to_string(),
        mean: b.mean.clone(),
        map: b.map.clone(),
        ci90: Interval { low: b.ci_low.clone(), high: b.ci_high.clone() },
        grid_mode: b.grid_mode.clone(),
        entropy: b.entropy,
        ess: b.ess,
    };
    on(Topic::Belief(condition), &m)
}

/// The messages of a session's start: `/session/start`, the frames and the body, and the
/// `/belief/<condition>` of both conditions' priors.
pub fn start_messages(session: &Session, time_ns: u64) -> Vec<(Topic, Value)> {
    let start = SessionStartMessage {
        event_index: 0,
        start: session.start().clone(),
        // Only a seed past 2^53 (a session before seeds were bounded, resumed) needs its text.
        seed_decimal: (session.start().seed > crate::MAX_SESSION_SEED).then(|| session.start().seed.to_string()),
        log_format: Some(super::LOG_FORMAT),
    };
    let arm = &session.study().arm;
    let mut out = vec![
        on(Topic::SessionStart, &start),
        on(Topic::Transforms, &scene::start_transforms(time_ns, arm)),
        on(Topic::HumanArm, &scene::body_only(time_ns, arm)),
    ];
    out.extend(
        (0..session.learners().len()).map(|run| belief_message(0, run, &session.learners()[run].summary, session)),
    );
    out
}

/// A query's commanded pose in the shoulder frame, as the log's messages carry it.
fn shoulder_pose(q: &crate::protocol::ResolvedQuery) -> RobotPose {
    RobotPose { frame: scene::SHOULDER.into(), position: q.pose.position, rpy_deg: q.pose.rpy_deg }
}

fn region_labels(session: &Session, view: &TrialView) -> Vec<(String, String)> {
    let q = session.query(view.query);
    let object = session.study().object(q);
    q.regions.iter().map(|&r| (object.regions[r].id.clone(), object.regions[r].label.clone())).collect()
}

/// Every message of one applied event.
pub fn messages_for(s: &Stamped, index: usize, applied: &Applied, session: &Session) -> Vec<(Topic, Value)> {
    let mut out = Vec::new();
    let study = session.study();
    match (&s.event, applied) {
        (Event::QueryPresented { .. }, Applied::Presented { view, scores }) => {
            let q = session.query(view.query);
            let (regions, region_labels): (Vec<_>, Vec<_>) = region_labels(session, view).into_iter().unzip();
            let m = TrialQuery {
                trial: trial_fields(index, view, session),
                label: q.query.label.clone(),
                robot_pose: shoulder_pose(q),
                regions,
                region_labels,
                scores: scores
                    .iter()
                    .zip(&study.training)
                    .map(|(s, m)| QueryScore {
                        query: m.query.id.clone(),
                        information_gain: s.information_gain,
                        expected_cost: s.expected_cost,
                    })
                    .collect(),
            };
            out.push(on(Topic::TrialQuery, &m));
            let pose = PoseInFrame {
                timestamp: Time::from_ns(s.time_ns),
                frame_id: scene::SHOULDER.into(),
                pose: foxglove::Pose::from_isometry(&q.pose.to_isometry()),
            };
            out.push(on(Topic::RobotHandoverPose, &pose));
            out.push(on(Topic::Transforms, &scene::query_transforms(s.time_ns, &study.arm, q)));
            out.push(on(Topic::HumanArm, &scene::arm_cleared(s.time_ns, &study.arm)));
            out.push(on(Topic::ObjectScene, &scene::object(s.time_ns, study.object(q), q, study.arm.side)));
        }
        (Event::GraspRecorded { region, .. }, Applied::Responded { view, record, belief }) => {
            let configuration = session.set(view.query).configs().config(record.config);
            let q: ArmConfig = std::array::from_fn(|j| configuration.get(j).copied().unwrap_or(0.0));
            let labels = region_labels(session, view);
            let label = labels.iter().find(|(id, _)| id == region).map(|(_, l)| l.clone());
            let measuring = session.context().observation == ObservationModel::Measured;
            let m = TrialResponse {
                trial: trial_fields(index, view, session),
                region: region.clone(),
                region_label: label,
                config_index: record.config as u32,
                configuration: configuration.to_vec(),
                learned_from: measuring.then_some(if record.measured.is_some() {
                    LearnedFrom::Measured
                } else {
                    LearnedFrom::Region
                }),
                measured: record.measured.as_ref().map(|g| MeasuredResponse {
                    q_rad: g.measurement.q_rad.clone(),
                    source: g.measurement.source,
                    offset_s: g.measurement.offset_s,
                    nearest_config_index: g.nearest as u32,
                    implied_region: labels[g.implied_region].0.clone(),
                    agrees: g.agrees(record.region),
                }),
            };
            out.push(on(Topic::TrialResponse, &m));
            let mut arm = scene::arm(s.time_ns, &study.arm, &q);
            if measuring {
                let measured: Option<ArmConfig> =
                    record.measured.as_ref().and_then(|g| g.measurement.q_rad[..].try_into().ok());
                scene::measured_arm(&mut arm, s.time_ns, &study.arm, measured.as_ref());
            }
            out.push(on(Topic::HumanArm, &arm));
            let joints = JointAngles {
                trial: trial_fields(index, view, session),
                config_index: record.config as u32,
                deg: q.map(f64::to_degrees).into(),
                rad: q.into(),
            };
            out.push(on(Topic::HumanJoints, &joints));
            if let (Some(b), Some(run)) = (belief, view.program) {
                out.push(belief_message(index, run, b, session));
            }
        }
        (Event::TrialVoided { reason, detail }, Applied::Voided { view, retracted }) => {
            let m = TrialVoid {
                trial: trial_fields(index, view, session),
                reason: *reason,
                detail: detail.clone(),
                retracted: *retracted,
            };
            out.push(on(Topic::TrialVoid, &m));
            if *retracted {
                out.push(on(Topic::HumanArm, &scene::arm_cleared(s.time_ns, &study.arm)));
            }
        }
        (Event::GraspUndone, Applied::Undone { view, belief }) => {
            out.push(on(Topic::TrialUndo, &TrialUndo { trial: trial_fields(index, view, session) }));
            out.push(on(Topic::HumanArm, &scene::arm_cleared(s.time_ns, &study.arm)));
            if let (Some(b), Some(run)) = (belief, view.program) {
                out.push(belief_message(index, run, b, session));
            }
        }
        (Event::Note { text }, _) => {
            let m = foxglove::Log {
                timestamp: Time::from_ns(s.time_ns),
                level: 2,
                message: text.clone(),
                name: "operator".into(),
                file: String::new(),
                line: 0,
            };
            out.push(on(Topic::Notes, &m));
        }
        (Event::Paused, _) => out.push(on(Topic::SessionPause, &SessionMark { event_index: index as u32 })),
        (Event::Resumed, _) => out.push(on(Topic::SessionResume, &SessionMark { event_index: index as u32 })),
        (Event::TransitionConfirmed { transition }, _) => {
            let (name, program) = match *transition {
                Transition::Program(k) => (TransitionName::Program, Some(program_letter(k))),
                Transition::Test => (TransitionName::Test, None),
                Transition::Questionnaire => (TransitionName::Questionnaire, None),
            };
            let m = SessionTransition { event_index: index as u32, transition: name, program };
            out.push(on(Topic::SessionTransition, &m));
        }
        (Event::LikertAnswered { program, item, value: answer }, _) => {
            let qn = &study.protocol.questionnaire;
            let label = &session.start().program_labels[*program];
            let m = LikertAnswer {
                event_index: index as u32,
                program: program_letter(*program),
                program_label: label.clone(),
                condition: session.learners()[*program].condition.name().to_string(),
                item: item.clone(),
                statement: qn
                    .items
                    .iter()
                    .find(|i| i.id == *item)
                    .map(|i| i.statement.replace("{program}", label))
                    .unwrap_or_default(),
                value: *answer,
                label: qn.scale.iter().find(|p| p.value == *answer).map(|p| p.label.clone()).unwrap_or_default(),
            };
            out.push(on(Topic::QuestionnaireLikert, &m));
        }
        (Event::ForcedChoice { program }, _) => {
            let m = ForcedChoice {
                event_index: index as u32,
                program: program_letter(*program),
                program_label: session.start().program_labels[*program].clone(),
                condition: session.learners()[*program].condition.name().to_string(),
                question: study.protocol.questionnaire.forced_choice.clone(),
            };
            out.push(on(Topic::QuestionnaireChoice, &m));
        }
        (Event::Ended, _) => {
            out.push(on(
                Topic::SessionEnd,
                &SessionEnd { event_index: index as u32, status: EndStatus::Completed, reason: None },
            ));
            let tests = session.test_examples();
            for run in 0..session.learners().len() {
                let log_likelihood = session.test_log_likelihoods(run, &tests);
                if log_likelihood.is_empty() {
                    continue;
                }
                let condition = session.learners()[run].condition;
                let m = TestLogLikelihood {
                    event_index: index as u32,
                    condition: condition.name().to_string(),
                    program: program_letter(run),
                    log_likelihood,
                    test_trials: tests.len() as u32,
                };
                out.push(on(Topic::TestLogLikelihood(condition), &m));
            }
        }
        (Event::RobotCommanded { link, pose, command, .. }, Applied::RobotCommanded { view, attempt }) => {
            let q = session.query(view.query);
            let (regions, region_labels): (Vec<_>, Vec<_>) = region_labels(session, view).into_iter().unzip();
            let [x, y, z, w] = pose.orientation;
            let (r, p, yaw) =
                nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z)).euler_angles();
            let m = RobotCommand {
                trial: trial_fields(index, view, session),
                label: q.query.label.clone(),
                attempt: *attempt,
                link: *link,
                command: command.clone(),
                pose: pose.clone(),
                rpy_deg: [r, p, yaw].map(f64::to_degrees),
                shoulder_pose: shoulder_pose(q),
                regions,
                region_labels,
            };
            out.push(on(Topic::RobotCommand, &m));
        }
        (Event::RobotReported { query, state, detail, command, stale }, Applied::RobotReported { attempt }) => {
            let m = RobotStatus {
                event_index: index as u32,
                query: query.clone(),
                attempt: *attempt,
                command: command.clone(),
                stale: *stale,
                state: *state,
                detail: detail.clone(),
            };
            out.push(on(Topic::RobotStatus, &m));
        }
        (Event::Aborted { reason }, _) => out.push(on(
            Topic::SessionEnd,
            &SessionEnd { event_index: index as u32, status: EndStatus::Aborted, reason: Some(reason.clone()) },
        )),
        // An event is logged with what the session made of it; no other pairs arise.
        _ => {}
    }
    out
}

/// A message read as the type its topic carries (None if it is malformed).
fn typed<M: LogMessage + serde::de::DeserializeOwned>(topic: Topic, v: &Value) -> Option<M> {
    assert!(M::carried_by(topic), "{topic} does not carry {}", std::any::type_name::<M>());
    serde_json::from_value(v.clone()).ok()
}

/// The event an event message records (None if it is malformed).
pub fn event_from_message(topic: Topic, v: &Value) -> Option<Event> {
    Some(match topic {
        Topic::TrialQuery => Event::QueryPresented { query: typed::<TrialQuery>(topic, v)?.trial.query },
        Topic::TrialResponse => {
            let m = typed::<TrialResponse>(topic, v)?;
            let measured =
                m.measured.map(|g| ArmMeasurement { q_rad: g.q_rad, source: g.source, offset_s: g.offset_s });
            Event::GraspRecorded { region: m.region, measured }
        }
        Topic::TrialVoid => {
            let m = typed::<TrialVoid>(topic, v)?;
            Event::TrialVoided { reason: m.reason, detail: m.detail }
        }
        Topic::TrialUndo => {
            typed::<TrialUndo>(topic, v)?;
            Event::GraspUndone
        }
        Topic::Notes => Event::Note { text: typed::<foxglove::Log>(topic, v)?.message },
        Topic::SessionPause => {
            typed::<SessionMark>(topic, v)?;
            Event::Paused
        }
        Topic::SessionResume => {
            typed::<SessionMark>(topic, v)?;
            Event::Resumed
        }
        Topic::SessionTransition => {
            let m = typed::<SessionTransition>(topic, v)?;
            let transition = match (m.transition, m.program) {
                (TransitionName::Program, Some(p)) => Transition::Program(program_index(&p)?),
                (TransitionName::Test, None) => Transition::Test,
                (TransitionName::Questionnaire, None) => Transition::Questionnaire,
                _ => return None,
            };
            Event::TransitionConfirmed { transition }
        }
        Topic::QuestionnaireLikert => {
            let m = typed::<LikertAnswer>(topic, v)?;
            Event::LikertAnswered { program: program_index(&m.program)?, item: m.item, value: m.value }
        }
        Topic::QuestionnaireChoice => {
            Event::ForcedChoice { program: program_index(&typed::<ForcedChoice>(topic, v)?.program)? }
        }
        Topic::SessionEnd => {
            let m = typed::<SessionEnd>(topic, v)?;
            match m.status {
                EndStatus::Completed => Event::Ended,
                EndStatus::Aborted => Event::Aborted { reason: m.reason.unwrap_or_default() },
            }
        }
        Topic::RobotCommand => {
            let m = typed::<RobotCommand>(topic, v)?;
            Event::RobotCommanded { query: m.trial.query, link: m.link, pose: m.pose, command: m.command }
        }
        Topic::RobotStatus => {
            let m = typed::<RobotStatus>(topic, v)?;
            Event::RobotReported {
                query: m.query,
                state: m.state,
                detail: m.detail,
                command: m.command,
                stale: m.stale,
            }
        }
        _ => return None,
    })
}
