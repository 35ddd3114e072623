//! The messages each event is logged as, and the event each event message is read back as.

use nalgebra::UnitQuaternion;
use serde_json::{Value, json};

use super::Topic;
use crate::kinematics::ArmConfig;
use crate::session::{Applied, BeliefSummary, Event, Session, Stamped, TrialView, VoidReason, program_letter};

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
        Event::LikertAnswered { .. } => Topic::QuestionnaireLikert,
        Event::ForcedChoice { .. } => Topic::QuestionnaireChoice,
        Event::Ended | Event::Aborted { .. } => Topic::SessionEnd,
    }
}

fn foxglove_time(ns: u64) -> Value {
    json!({"sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000})
}

fn trial_fields(index: usize, view: &TrialView, session: &Session) -> Value {
    let q = session.query(view.query);
    let mut v = json!({
        "event_index": index,
        "phase": view.phase.name(),
        "trial": view.trial,
        "query": q.query.id,
        "object": q.query.object,
    });
    if let Some(c) = view.condition {
        v["condition"] = json!(c.name());
    }
    if let Some(p) = view.program {
        v["program"] = json!(program_letter(p));
    }
    v
}

fn belief_message(index: usize, run: usize, b: &BeliefSummary, session: &Session) -> Value {
    json!({
        "event_index": index,
        "condition": session.learners()[run].condition.name(),
        "program": program_letter(run),
        "iteration": b.iteration,
        "observation": session.context().observation.name(),
        "mean": {"q_star": b.mean.q_star, "w": b.mean.w},
        "map": {"q_star": b.map.q_star, "w": b.map.w},
        "ci90": {
            "low": {"q_star": b.ci_low.q_star, "w": b.ci_low.w},
            "high": {"q_star": b.ci_high.q_star, "w": b.ci_high.w}
        },
        "grid_mode": {"q_star": b.grid_mode.q_star, "w": b.grid_mode.w},
        "entropy": b.entropy,
        "ess": b.ess,
    })
}

/// The messages of a session's start: `/session/start` and the `/belief` of both
/// conditions' priors.
pub fn start_messages(session: &Session) -> Vec<(Topic, Value)> {
    let mut start = serde_json::to_value(session.start()).expect("a session start serialises");
    start["event_index"] = Value::from(0);
    // JavaScript (Foxglove) reads integers above 2^53 rounded: the seed as text too.
    start["seed_decimal"] = Value::from(session.start().seed.to_string());
    let mut out = vec![(Topic::SessionStart, start)];
    out.extend(
        (0..session.learners().len())
            .map(|run| (Topic::Belief, belief_message(0, run, &session.learners()[run].summary, session))),
    );
    out
}

fn arm_message(time_ns: u64, session: &Session, q: &ArmConfig) -> Value {
    let pts: Vec<Value> = session.study().arm.points(q).iter().map(|p| json!({"x": p.x, "y": p.y, "z": p.z})).collect();
    let identity =
        json!({"position": {"x": 0.0, "y": 0.0, "z": 0.0}, "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}});
    json!({
        "deletions": [],
        "entities": [{
            "timestamp": foxglove_time(time_ns),
            "frame_id": "shoulder",
            "id": "human_arm",
            "lifetime": {"sec": 0, "nsec": 0},
            "frame_locked": false,
            "metadata": [],
            "arrows": [], "cubes": [], "spheres": [], "cylinders": [],
            "lines": [{
                "type": 0,
                "pose": identity,
                "thickness": 0.03,
                "scale_invariant": false,
                "points": pts,
                "color": {"r": 0.9, "g": 0.6, "b": 0.2, "a": 1.0},
                "colors": [],
                "indices": []
            }],
            "triangles": [], "texts": [], "models": []
        }]
    })
}

/// Every message of one applied event.
pub fn messages_for(s: &Stamped, index: usize, applied: &Applied, session: &Session) -> Vec<(Topic, Value)> {
    let mut out = Vec::new();
    match (&s.event, applied) {
        (Event::QueryPresented { .. }, Applied::Presented { view, scores }) => {
            let q = session.query(view.query);
            let object = session.study().object(q);
            let mut v = trial_fields(index, view, session);
            v["label"] = json!(q.query.label);
            v["robot_pose"] = json!({"frame": "shoulder", "position": q.pose.position, "rpy_deg": q.pose.rpy_deg});
            v["regions"] = json!(q.regions.iter().map(|&r| object.regions[r].id.clone()).collect::<Vec<_>>());
            v["scores"] = json!(
                scores
                    .iter()
                    .zip(&session.study().training)
                    .map(|(s, m)| json!({"query": m.query.id, "information_gain": s.information_gain, "expected_cost": s.expected_cost}))
                    .collect::<Vec<_>>()
            );
            out.push((Topic::TrialQuery, v));
            let [r, p, y] = q.pose.rpy_deg.map(f64::to_radians);
            let o = UnitQuaternion::from_euler_angles(r, p, y);
            let [x, yy, z] = q.pose.position;
            out.push((
                Topic::RobotHandoverPose,
                json!({
                    "timestamp": foxglove_time(s.time_ns),
                    "frame_id": "shoulder",
                    "pose": {"position": {"x": x, "y": yy, "z": z},
                             "orientation": {"x": o.i, "y": o.j, "z": o.k, "w": o.w}}
                }),
            ));
        }
        (Event::GraspRecorded { region }, Applied::Responded { view, record, belief }) => {
            let q: ArmConfig = session.set(view.query).configs().config(record.config).try_into().expect("7 joints");
            let mut v = trial_fields(index, view, session);
            v["region"] = json!(region);
            v["config_index"] = json!(record.config);
            v["configuration"] = json!(q);
            out.push((Topic::TrialResponse, v));
            out.push((Topic::HumanArm, arm_message(s.time_ns, session, &q)));
            if let (Some(b), Some(run)) = (belief, view.program) {
                out.push((Topic::Belief, belief_message(index, run, b, session)));
            }
        }
        (Event::TrialVoided { reason, detail }, Applied::Voided { view, retracted }) => {
            let mut v = trial_fields(index, view, session);
            v["reason"] = serde_json::to_value(reason).expect("serialisable");
            v["detail"] = json!(detail);
            v["retracted"] = json!(retracted);
            out.push((Topic::TrialVoid, v));
        }
        (Event::GraspUndone, Applied::Undone { view, belief }) => {
            out.push((Topic::TrialUndo, trial_fields(index, view, session)));
            if let (Some(b), Some(run)) = (belief, view.program) {
                out.push((Topic::Belief, belief_message(index, run, b, session)));
            }
        }
        (Event::Note { text }, _) => out.push((
            Topic::Notes,
            json!({"timestamp": foxglove_time(s.time_ns), "level": 2, "message": text, "name": "operator",
                   "file": "", "line": 0, "event_index": index}),
        )),
        (Event::Paused, _) => out.push((Topic::SessionPause, json!({"event_index": index}))),
        (Event::Resumed, _) => out.push((Topic::SessionResume, json!({"event_index": index}))),
        (Event::LikertAnswered { program, item, value }, _) => {
            let qn = &session.study().protocol.questionnaire;
            let it = qn.items.iter().find(|i| i.id == *item).expect("applied: a known item");
            let label = &session.start().program_labels[*program];
            out.push((
                Topic::QuestionnaireLikert,
                json!({
                    "event_index": index,
                    "program": program_letter(*program),
                    "program_label": label,
                    "condition": session.learners()[*program].condition.name(),
                    "item": item,
                    "statement": it.statement.replace("{program}", label),
                    "value": value,
                    "label": qn.scale.iter().find(|p| p.value == *value).map(|p| p.label.clone()).unwrap_or_default(),
                }),
            ));
        }
        (Event::ForcedChoice { program }, _) => out.push((
            Topic::QuestionnaireChoice,
            json!({
                "event_index": index,
                "program": program_letter(*program),
                "program_label": session.start().program_labels[*program],
                "condition": session.learners()[*program].condition.name(),
                "question": session.study().protocol.questionnaire.forced_choice,
            }),
        )),
        (Event::Ended, _) => out.push((Topic::SessionEnd, json!({"event_index": index, "status": "completed"}))),
        (Event::Aborted { reason }, _) => {
            out.push((Topic::SessionEnd, json!({"event_index": index, "status": "aborted", "reason": reason})))
        }
        (e, a) => unreachable!("event {e:?} applied as {a:?}"),
    }
    out
}

fn program_index(v: &Value) -> Option<usize> {
    let s = v.as_str()?;
    let c = s.bytes().next()?;
    (s.len() == 1 && c.is_ascii_uppercase()).then(|| (c - b'A') as usize)
}

/// The event an event message records (None if it is malformed).
pub fn event_from_message(topic: Topic, v: &Value) -> Option<Event> {
    let s = |k: &str| v.get(k).and_then(Value::as_str).map(String::from);
    Some(match topic {
        Topic::TrialQuery => Event::QueryPresented { query: s("query")? },
        Topic::TrialResponse => Event::GraspRecorded { region: s("region")? },
        Topic::TrialVoid => Event::TrialVoided {
            reason: serde_json::from_value::<VoidReason>(v.get("reason")?.clone()).ok()?,
            detail: s("detail").unwrap_or_default(),
        },
        Topic::TrialUndo => Event::GraspUndone,
        Topic::Notes => Event::Note { text: s("message")? },
        Topic::SessionPause => Event::Paused,
        Topic::SessionResume => Event::Resumed,
        Topic::QuestionnaireLikert => Event::LikertAnswered {
            program: program_index(v.get("program")?)?,
            item: s("item")?,
            value: v.get("value")?.as_i64()?,
        },
        Topic::QuestionnaireChoice => Event::ForcedChoice { program: program_index(v.get("program")?)? },
        Topic::SessionEnd => match s("status")?.as_str() {
            "completed" => Event::Ended,
            _ => Event::Aborted { reason: s("reason").unwrap_or_default() },
        },
        _ => return None,
    })
}
