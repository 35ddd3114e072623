//! Dry runs: whole sessions answered by simulated participants, logged as `pilot`.

use std::time::Duration;

use rand::SeedableRng;

use crate::ergo::Lambda;
use crate::kinematics::Hand;
use crate::participant::{ScriptedParticipant, SimulatedPerson};
use crate::protocol::{Body, Population, Study};
use crate::record::{RecordedSession, SubmitError};
use crate::robot::joint_states::JointStateSource;
use crate::robot::{Robot, command_for};
use crate::session::{Event, RobotState, Session, SessionStart, Stamped, VoidReason, condition_order};
use crate::{SeededRng, derive_seed};

mod purpose {
    pub const ID: u64 = 301;
    pub(crate) const SESSION: u64 = 302;
    pub const BODY: u64 = 304;
}

/// The bodies simulated participants are drawn from: adult stature as an equal mix of women,
/// N(1.63 m, 0.065 m), and men, N(1.77 m, 0.07 m) (national anthropometric surveys, rounded),
/// truncated to [`HEIGHT_RANGE_M`]; a share `left_handed` of them left-handed (≈ 10 % of
/// people are). A fixed height or hand replaces the draw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyPopulation {
    pub height_m: Option<f64>,
    pub hand: Option<Hand>,
    pub left_handed: f64,
}

/// The heights the population is truncated to (m): 5th percentile women to beyond the 95th
/// of men.
pub(crate) const HEIGHT_RANGE_M: (f64, f64) = (1.50, 1.95);
/// The default share of left-handed simulated participants.
pub const LEFT_HANDED_SHARE: f64 = 0.10;
/// (mean, sd) of stature (m): women, men.
const STATURE_M: [(f64, f64); 2] = [(1.63, 0.065), (1.77, 0.07)];

impl Default for BodyPopulation {
    fn default() -> Self {
        Self { height_m: None, hand: None, left_handed: LEFT_HANDED_SHARE }
    }
}

impl BodyPopulation {
    /// Simulated participant `index`'s body, determined by the dry run's seed.
    pub fn draw(&self, seed: u64, index: usize) -> Body {
        use rand::RngExt;
        let mut rng = SeededRng::seed_from_u64(derive_seed(seed, index as u64, purpose::BODY));
        let (mean, sd) = STATURE_M[usize::from(rng.random::<bool>())];
        let h = (crate::protocol::truncated_normal(mean, sd, HEIGHT_RANGE_M, &mut rng) * 1000.0).round() / 1000.0;
        let left = rng.random::<f64>() < self.left_handed;
        Body {
            height_m: Some(self.height_m.unwrap_or(h)),
            hand: self.hand.unwrap_or(if left { Hand::Left } else { Hand::Right }),
        }
    }
}

/// One simulated participant's session, fully determined by the dry run's seed.
#[derive(Clone, Debug)]
pub struct DryRunPlan {
    pub start: SessionStart,
    pub participant: ScriptedParticipant,
}

/// The plan of simulated participant `index` (0-based): id, counterbalancing slot
/// (alternating), session seed, and ground truth (drawn from the protocol's population
/// unless given), answering with the population's α.
pub fn plan(study: &Study, seed: u64, index: usize, truth: Option<&Lambda>, started_at: String) -> DryRunPlan {
    plan_from(study, &study.population(), seed, index, truth, started_at)
}

/// [`plan`] with the participant drawn from `population` rather than the protocol's.
pub fn plan_from(
    study: &Study,
    population: &Population,
    seed: u64,
    index: usize,
    truth: Option<&Lambda>,
    started_at: String,
) -> DryRunPlan {
    let i = index as u64;
    let id = format!("pilot-{:06x}-{:02}", derive_seed(seed, 0, purpose::ID) & 0xff_ffff, index + 1);
    let slot = index % 2;
    let truth = truth.cloned().unwrap_or_else(|| population.draw(seed, index));
    let session_seed = crate::session_seed(derive_seed(seed, i, purpose::SESSION));
    let order = condition_order(study, slot);
    let start = SessionStart {
        session_id: format!("{session_seed:016x}"),
        participant: id,
        protocol_name: study.protocol.name.clone(),
        protocol_sha256: study.sha256.clone(),
        seed: session_seed,
        program_labels: study.protocol.session.program_labels.clone(),
        condition_order: order,
        software_version: env!("CARGO_PKG_VERSION").to_string(),
        pilot: true,
        slot,
        started_at,
        simulated_truth: Some(truth.clone()),
        resumed_from: None,
        selection: None,
    };
    let person = SimulatedPerson { truth, alpha: population.alpha };
    DryRunPlan { start, participant: ScriptedParticipant { person } }
}

pub use crate::now_ns;

/// How long each action takes in a dry run's log time (seconds): the robot moving the object
/// to the pose and the participant taking it, reading and answering a statement, choosing.
/// A stated assumption, so that a dry-run log plays back in Foxglove as a session would.
pub fn simulated_seconds(event: &Event) -> u64 {
    match event {
        Event::QueryPresented { .. } => 8,
        Event::GraspRecorded { .. } => 4,
        Event::LikertAnswered { .. } => 6,
        Event::ForcedChoice { .. } => 10,
        _ => 2,
    }
}

/// Lets the participant answer every prompt until the session is over. With a `pace`, it
/// waits that long between actions and stamps them with the clock (a rehearsal to watch);
/// without, it does not wait and stamps each action [`simulated_seconds`] after the last one
/// logged.
pub fn drive(rec: &mut RecordedSession, participant: &ScriptedParticipant, pace: Duration) -> Result<(), SubmitError> {
    while let Some(event) = participant.respond(rec.session()) {
        let time_ns = if pace.is_zero() {
            rec.last_time_ns() + simulated_seconds(&event) * 1_000_000_000
        } else {
            std::thread::sleep(pace);
            now_ns()
        };
        rec.submit(Stamped { time_ns, event })?;
    }
    Ok(())
}

/// Failed robot commands in a row after which a dry run gives the session up.
pub(crate) const MAX_ROBOT_FAILURES: u32 = 3;

/// How a dry run with a robot ended.
#[derive(Clone, Debug, PartialEq)]
pub enum RobotDrive {
    /// Every prompt was answered.
    Completed,
    /// The robot failed [`MAX_ROBOT_FAILURES`] times in a row; the session was aborted (the
    /// log says why).
    GaveUp(String),
}

/// [`drive`] with a robot in the loop, stamped with the clock, each of the participant's
/// answers `pace` after the last: each query is commanded (the command logged before it is
/// sent), every report is logged as it comes, and the query is presented on `at_pose`. A
/// failure or a timeout voids the trial as a robot fault and the command is sent again;
/// after [`MAX_ROBOT_FAILURES`] in a row the session is aborted.
pub(crate) fn drive_with_robot(
    rec: &mut RecordedSession,
    participant: &ScriptedParticipant,
    robot: &mut Robot,
    arm: Option<&JointStateSource>,
    pace: Duration,
) -> Result<RobotDrive, SubmitError> {
    let stamp = |rec: &RecordedSession, event: Event| {
        let time_ns = now_ns().max(rec.last_time_ns() + 1);
        Stamped { time_ns, event: measured_live(event, time_ns, arm, rec.session()) }
    };
    let mut failures = 0;
    while let Some(event) = participant.respond(rec.session()) {
        std::thread::sleep(pace);
        if !matches!(event, Event::QueryPresented { .. }) {
            rec.submit(stamp(rec, event))?;
            continue;
        }
        let Some(command) = command_for(rec.session(), &robot.settings) else {
            rec.submit(stamp(rec, event))?;
            continue;
        };
        rec.submit(stamp(rec, command.event(robot.kind())))?;
        let outcome = match robot.send(&command) {
            Ok(()) => loop {
                let Some(report) = robot.next_report(Duration::from_millis(100)) else { continue };
                rec.submit(stamp(rec, report.event()))?;
                if report.ends(&command) {
                    break report;
                }
            },
            Err(why) => {
                let report = command.report(RobotState::Failed, why);
                rec.submit(stamp(rec, report.event()))?;
                report
            }
        };
        if outcome.state == RobotState::AtPose {
            failures = 0;
            rec.submit(stamp(rec, event))?;
            continue;
        }
        failures += 1;
        let detail = format!(
            "robot {}{}",
            outcome.state.name(),
            if outcome.detail.is_empty() { String::new() } else { format!(": {}", outcome.detail) }
        );
        rec.submit(stamp(rec, Event::TrialVoided { reason: VoidReason::RobotFault, detail: detail.clone() }))?;
        if failures >= MAX_ROBOT_FAILURES {
            let reason = format!("the robot failed {failures} times in a row (last: {detail})");
            rec.submit(stamp(rec, Event::Aborted { reason: reason.clone() }))?;
            return Ok(RobotDrive::GaveUp(reason));
        }
    }
    Ok(RobotDrive::Completed)
}

/// A grasp measured by a live source instead of the simulated measuring system: the sample
/// nearest its time within the protocol's window (none: the trial learns from the region).
fn measured_live(event: Event, time_ns: u64, arm: Option<&JointStateSource>, session: &Session) -> Event {
    match (event, arm, session.study().protocol.learning.measurement.as_ref()) {
        (Event::GraspRecorded { region, .. }, Some(arm), Some(m)) => {
            Event::GraspRecorded { region, measured: arm.at(time_ns, m.window_s) }
        }
        (event, _, _) => event,
    }
}

/// [`drive`] stamped with the clock at `pace`, every grasp measured by `arm`.
fn drive_measured(
    rec: &mut RecordedSession,
    participant: &ScriptedParticipant,
    arm: &JointStateSource,
    pace: Duration,
) -> Result<(), SubmitError> {
    while let Some(event) = participant.respond(rec.session()) {
        std::thread::sleep(pace);
        let time_ns = now_ns().max(rec.last_time_ns() + 1);
        let event = measured_live(event, time_ns, Some(arm), rec.session());
        rec.submit(Stamped { time_ns, event })?;
    }
    Ok(())
}

/// A dry run's session driven to its end at `pace`: through `robot` when there is one
/// ([`drive_with_robot`]), else [`drive`]; with `arm`, every grasp is measured by it (stamped
/// with the clock, as the samples are).
pub fn drive_session(
    rec: &mut RecordedSession,
    participant: &ScriptedParticipant,
    robot: Option<&mut Robot>,
    arm: Option<&JointStateSource>,
    pace: Duration,
) -> Result<RobotDrive, SubmitError> {
    match (robot, arm) {
        (Some(robot), arm) => drive_with_robot(rec, participant, robot, arm, pace),
        (None, Some(arm)) => drive_measured(rec, participant, arm, pace).map(|()| RobotDrive::Completed),
        (None, None) => drive(rec, participant, pace).map(|()| RobotDrive::Completed),
    }
}
