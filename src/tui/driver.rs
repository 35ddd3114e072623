//! The console's session driver: what the console does to a session, apart from what it
//! shows. It owns the recorder's worker thread, the participant's lock, the robot with the
//! command waiting to be sent, and the live arm; the view (`App`) submits events through it
//! and reacts to what it hears back.

use std::path::PathBuf;
use std::time::Duration;

use super::worker::{Done, Worker};
use crate::dryrun::now_ns;
use crate::record::RecordedSession;
use crate::robot::joint_states::JointStateSource;
use crate::robot::{PresentOn, Robot, RobotCommand, command_for};
use crate::session::{ArmMeasurement, Event, Prompt, RobotState, Session, Stamped};
use crate::setup::{Plan, SetupError, lock_for, start_session};
use crate::study_dir::{ParticipantLock, StudyDirs};

/// A running (or not yet started) session and the lab's devices around it.
#[derive(Default)]
pub struct Driver {
    /// The thread that owns the recorded session while it runs.
    worker: Option<Worker>,
    /// This console's hold on the participant (one live session per participant).
    lock: Option<ParticipantLock>,
    /// The session as last reported by the worker (what the screens show).
    shown: Option<Session>,
    /// The event whose log write failed, waiting for a retry.
    unwritten: Option<Stamped>,
    /// The log finished at a quit: its path, and why it could not be finished.
    closed: Option<(PathBuf, Option<String>)>,
    /// The robot in the loop, if the lab has one.
    robot: Option<Robot>,
    /// The command whose event is being logged: sent once it is on disk.
    robot_outbox: Option<RobotCommand>,
    /// The participant's arm measured live, if the lab measures it.
    arm: Option<JointStateSource>,
}

impl Driver {
    pub fn set_robot(&mut self, robot: Option<Robot>) {
        self.robot = robot;
    }

    pub fn set_arm(&mut self, arm: Option<JointStateSource>) {
        self.arm = arm;
    }

    /// Takes the participant's lock (once) and starts the planned session's log.
    pub fn lock_and_start(&mut self, plan: &mut Plan, dirs: &StudyDirs) -> Result<RecordedSession, SetupError> {
        if let Some(e) = &plan.error {
            return Err(SetupError::Plan(e.clone()));
        }
        if self.lock.is_none() {
            self.lock = Some(lock_for(plan)?);
        }
        start_session(plan, dirs)
    }

    /// Holds `lock` for a session continued from another log.
    pub fn hold(&mut self, lock: ParticipantLock) {
        self.lock = Some(lock);
    }

    /// Runs the recorded session on the worker thread from now on.
    pub fn run(&mut self, rec: RecordedSession) {
        self.shown = Some(rec.session().clone());
        self.worker = Some(Worker::spawn(rec));
    }

    /// The session as last reported by the worker.
    pub fn session(&self) -> Option<&Session> {
        self.shown.as_ref()
    }

    /// Whether a session's log is open.
    pub fn running(&self) -> bool {
        self.worker.is_some()
    }

    /// The log being written.
    pub fn log_path(&self) -> Option<PathBuf> {
        self.worker.as_ref().map(|w| w.path().clone())
    }

    /// Whether the worker has events under way.
    pub fn busy(&self) -> bool {
        self.worker.as_ref().is_some_and(Worker::busy)
    }

    /// Events submitted and not yet reported.
    pub fn outstanding(&self) -> usize {
        self.worker.as_ref().map_or(0, Worker::outstanding)
    }

    pub fn robot(&self) -> Option<&Robot> {
        self.robot.as_ref()
    }

    pub fn arm(&self) -> Option<&JointStateSource> {
        self.arm.as_ref()
    }

    /// Sends an event to the session through the recorder, off the drawing loop.
    pub fn submit(&mut self, event: Event) {
        self.submit_stamped(Stamped { time_ns: now_ns(), event });
    }

    pub fn submit_stamped(&mut self, stamped: Stamped) {
        if let Some(w) = self.worker.as_mut() {
            w.submit(stamped);
        }
    }

    /// Submits again the event whose write failed, if there is one.
    pub fn retry(&mut self) {
        if let Some(event) = self.unwritten.clone() {
            self.submit_stamped(event);
        }
    }

    /// Whether an event could not be written and is not in the log.
    pub fn has_unwritten(&self) -> bool {
        self.unwritten.is_some()
    }

    /// A grasp keyed now, measured by the live source when there is one: the latest sample
    /// at or before now within `window_s` (none: the trial learns from the handle).
    pub fn grasp(&mut self, region: String, simulated: Option<ArmMeasurement>, window_s: Option<f64>) {
        let now = now_ns();
        let measured = match (&self.arm, window_s) {
            (Some(arm), Some(w)) => arm.at(now, w),
            _ => simulated,
        };
        self.submit_stamped(Stamped { time_ns: now, event: Event::GraspRecorded { region, measured } });
    }

    /// Sends the waiting query's pose to the robot: its command is logged first and sent
    /// once on disk.
    pub fn send_robot(&mut self) {
        let Some(robot) = self.robot.as_ref() else { return };
        let Some(command) = self.session().and_then(|s| command_for(s, &robot.settings)) else { return };
        let event = command.event(robot.kind());
        self.robot_outbox = Some(command);
        self.submit(event);
    }

    /// Logs what the robot reported; on `at_pose`, presents the query when the lab says so
    /// (or `always_at_pose`: in a rehearsal).
    pub fn hear_robot(&mut self, always_at_pose: bool) {
        let Some(robot) = self.robot.as_mut() else { return };
        let present_on_at_pose = robot.settings.present_on == PresentOn::AtPose || always_at_pose;
        let Some(report) = robot.next_report(Duration::ZERO) else { return };
        self.submit(report.event());
        if let (RobotState::AtPose, true, false) = (report.state, present_on_at_pose, report.stale)
            && let Some(Prompt::Present(v)) = self.session().map(Session::prompt)
        {
            let id = self.session().map(|s| s.query(v.query).query.id.clone());
            if id.as_deref() == Some(report.query.as_str()) {
                self.submit(Event::QueryPresented { query: report.query });
            }
        }
    }

    /// Sends the logged robot command; why it could not be sent (the failure is logged).
    fn dispatch_robot(&mut self) -> Option<String> {
        let (Some(robot), Some(command)) = (self.robot.as_mut(), self.robot_outbox.take()) else { return None };
        let why = robot.send(&command).err()?;
        let report = command.report(RobotState::Failed, why.clone());
        self.submit(report.event());
        Some(why)
    }

    /// The worker's next report, waiting up to `wait` for it; `None` when there is none (or
    /// no worker). What concerns the session is taken here (the session shown, a robot
    /// command sent once its event is on disk, the event to retry); the rest is the view's.
    pub fn poll(&mut self, wait: Duration) -> Option<Result<Heard, &'static str>> {
        let done = match self.worker.as_mut()?.poll(wait) {
            Ok(Some(done)) => done,
            Ok(None) => return None,
            Err(e) => return Some(Err(e)),
        };
        Some(Ok(match done {
            Done::Submitted(session, result) => {
                self.shown = Some(*session);
                match result {
                    Ok(event) => {
                        self.unwritten = None;
                        let robot_failed =
                            if matches!(event, Event::RobotCommanded { .. }) { self.dispatch_robot() } else { None };
                        Heard::Written { event, robot_failed }
                    }
                    Err(super::worker::Failure::Rejected(why)) => Heard::Rejected(why),
                    Err(super::worker::Failure::Log { message, last_event, event }) => {
                        self.unwritten = Some(*event);
                        Heard::WriteFailed { message, last_event }
                    }
                }
            }
            Done::Finished(view) => {
                self.worker = None;
                Heard::Finished(view)
            }
            Done::Closed { path, error } => {
                self.worker = None;
                self.closed = Some((path, error));
                Heard::Closed
            }
        }))
    }

    /// Asks the worker to finish the log (the session is over).
    pub fn finish_log(&mut self, completed: bool) {
        if let Some(w) = self.worker.as_mut() {
            w.finish(completed);
        }
    }

    /// Asks the worker to close the log unfinished (a quit).
    pub fn close(&mut self) {
        if let Some(w) = self.worker.as_mut() {
            w.close();
        }
    }

    /// The log closed at a quit: its path and why it could not be finished.
    pub fn take_closed(&mut self) -> Option<(PathBuf, Option<String>)> {
        self.closed.take()
    }
}

/// What the worker reported, for the view.
pub enum Heard {
    /// The event is on disk and has taken effect; a robot command it carried could not be
    /// sent, why (the failure is logged).
    Written { event: Event, robot_failed: Option<String> },
    /// The session refused the event (nothing was written).
    Rejected(String),
    /// The log could not be written: nothing moves on until the event is retried.
    WriteFailed { message: String, last_event: usize },
    /// The session is over and its log finished.
    Finished(Box<super::app::SummaryView>),
    /// The log was closed at a quit.
    Closed,
}
