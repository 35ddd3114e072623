//! The console's state and its update: intents in, events to the session out. Every event
//! goes through the recorder (durable on disk) before its consequence is shown; that work
//! runs on a worker thread, and keys pressed meanwhile wait in order.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use ratatui::crossterm::event::KeyEvent;

use super::keys::{Counts, Mode, action_for, why_not};
use super::worker::{Done, Failure, Worker};
use crate::analysis::{SessionAnalysis, analyse};
use crate::dryrun::now_ns;
use crate::participant::{ScriptedParticipant, SimulatedPerson};
use crate::protocol::Study;
use crate::record::{LogContents, RecordError, RecordedSession, SharedTap, continuation_path, log_folder};
use crate::robot::joint_states::JointStateSource;
use crate::robot::{PresentOn, Report, Robot, RobotCommand, command_for};
use crate::session::{ArmMeasurement, Event, Prompt, RobotState, Session, Stamped, Transition};
use crate::setup::{Plan, SetupConfig, SetupError, lock_for, plan_session, start_session};
use crate::study_dir::{ParticipantLock, StudyDirs};

/// How the console was started.
#[derive(Clone, Debug)]
pub struct AppConfig {
    pub study: Arc<Study>,
    pub protocol_text: String,
    /// The study's folders (participant records and logs).
    pub dirs: StudyDirs,
    /// "new" or an existing participant's id.
    pub participant: String,
    /// A simulated participant answers (a rehearsal; the log is flagged pilot).
    pub simulate: bool,
    /// A pilot with a real person (a colleague, a dress rehearsal): its own `pilot-` id, no
    /// participant record, the log flagged pilot (reported apart, never counterbalanced).
    pub pilot: bool,
    /// With `simulate`: the operator presses every key; the simulated participant only
    /// chooses, and the status line says what they did (a rehearsal to practise on).
    pub practice: bool,
    /// Wait between simulated actions.
    pub pace: Duration,
    /// The session seed (random when absent).
    pub seed: Option<u64>,
    /// Where the session's messages also go once on disk (the live view).
    pub tap: Option<SharedTap>,
}

/// Which screen is shown.
#[derive(Debug)]
pub enum Screen {
    Setup,
    Session,
    Summary(Box<SummaryView>),
}

/// What the summary screen shows.
#[derive(Debug)]
pub struct SummaryView {
    pub log_path: PathBuf,
    pub completed: bool,
    pub analysis: Option<SessionAnalysis>,
    pub error: Option<String>,
}

/// A dialog over the screen.
#[derive(Clone, Debug, PartialEq)]
pub enum Overlay {
    Help,
    ConfirmQuit,
    VoidReason,
    Note(String),
    ParticipantId(String),
    /// The reason for ending the session for good, asked after `q` then `a`.
    AbortReason(String),
    /// What happened, for a trial voided as "other".
    VoidDetail(String),
    /// The log could not be written: nothing moves on until the event is retried (`r`).
    WriteFailed {
        message: String,
        last_event: usize,
    },
}

/// Why the console could not open a session.
#[derive(Debug, thiserror::Error)]
pub enum ConsoleError {
    /// Another console or command holds the participant.
    #[error(transparent)]
    Lock(#[from] crate::study_dir::LockError),
    /// The log could not be read, replayed or continued.
    #[error(transparent)]
    Log(#[from] RecordError),
}

/// The console.
pub struct App {
    pub config: AppConfig,
    pub screen: Screen,
    pub overlay: Option<Overlay>,
    pub plan: Option<Plan>,
    /// The thread that owns the recorded session while it runs.
    pub(super) worker: Option<Worker>,
    /// This console's hold on the participant (one live session per participant).
    lock: Option<ParticipantLock>,
    /// The session as last reported by the worker (what the screens show).
    shown: Option<Session>,
    pending: VecDeque<KeyEvent>,
    /// The event whose log write failed, waiting for a retry.
    pub(super) unwritten: Option<Stamped>,
    /// Whether the terminal is large enough to show the screen (keys are ignored otherwise).
    pub visible: bool,
    /// The last message for the operator.
    pub status: String,
    /// What to say once the event under way has taken effect (see `submit_saying`).
    pub(super) say_after: Option<String>,
    /// Which pair of joints the particle view shows.
    pub joint_pair: usize,
    /// Position in the questionnaire: items, then the forced choice, then finish.
    pub cursor: usize,
    /// The questionnaire position whose skip Enter has asked to confirm (a second Enter
    /// there skips it).
    pub skip_asked: Option<usize>,
    /// The questionnaire is in the participant's hands.
    pub participant_mode: bool,
    /// How far the help overlay is scrolled (lines).
    pub help_scroll: u16,
    /// The clock, set by the loop (ns since the Unix epoch).
    pub now_ns: u64,
    /// When the session screen was first shown.
    pub session_started_ns: Option<u64>,
    last_simulated_ns: u64,
    pub quit: bool,
    /// The log finished at a quit: its path, and why it could not be finished.
    closed: Option<(PathBuf, Option<String>)>,
    /// Printed after the terminal is restored.
    pub exit_message: Option<String>,
    /// The robot in the loop, if the lab has one.
    pub(super) robot: Option<Robot>,
    /// The command whose event is being logged: sent once it is on disk.
    robot_outbox: Option<RobotCommand>,
    /// The participant's arm measured live, if the lab measures it.
    arm: Option<JointStateSource>,
}

impl App {
    /// The setup screen for a new session.
    pub fn new(config: AppConfig) -> Self {
        let mut app = Self::empty(config);
        app.plan = Some(app.make_plan());
        app
    }

    /// Continues an interrupted session in a new log beside the old one (never at a path
    /// taken from the log's content), at the screen where it stopped.
    pub fn resume(config: AppConfig, old: &LogContents) -> Result<Self, ConsoleError> {
        let mut app = Self::empty(config);
        app.lock = Some(ParticipantLock::acquire(&log_folder(&old.path), &old.start.participant, "console")?);
        let path = continuation_path(old, chrono::Utc::now());
        let mut rec = RecordedSession::resume(old, &path, now_ns())?;
        if let Some(tap) = &app.config.tap {
            rec.set_tap(tap.clone().0);
        }
        let path = rec.path().to_path_buf();
        let status = format!(
            "Resumed {} after {} events; continuing in {}",
            old.path.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
            old.events.len(),
            path.display()
        );
        if app.config.simulate
            && let Some(truth) = old.start.simulated_truth.clone()
        {
            let person = SimulatedPerson { truth, alpha: rec.session().study().population().alpha };
            app.plan = Some(Plan {
                start: old.start.clone(),
                new_record: None,
                simulated: Some(ScriptedParticipant { person }),
                log_path: path,
                error: None,
                study: Arc::clone(&app.config.study),
                protocol_text: app.config.protocol_text.clone(),
                folders: app.config.dirs.describe(),
                new_folders: false,
                balance: None,
            });
        }
        app.shown = Some(rec.session().clone());
        app.worker = Some(Worker::spawn(rec));
        app.screen = Screen::Session;
        // The session's clock runs from its logged start, across the interruption.
        app.session_started_ns = chrono::DateTime::parse_from_rfc3339(&old.start.started_at)
            .ok()
            .and_then(|t| t.timestamp_nanos_opt())
            .and_then(|ns| u64::try_from(ns).ok());
        app.sync_cursor();
        app.after_event();
        app.status = status;
        Ok(app)
    }

    /// A finished session's log, read-only on its summary screen.
    pub fn summary_of(config: AppConfig, log: &LogContents) -> Self {
        let mut app = Self::empty(config);
        let (analysis, error) = match analyse(log) {
            Ok(a) => (Some(a), None),
            Err(e) => (None, Some(e.to_string())),
        };
        let completed = log.events.iter().any(|e| e.event == Event::Ended);
        app.screen = Screen::Summary(Box::new(SummaryView { log_path: log.path.clone(), completed, analysis, error }));
        app.status = "Read-only: this session is over; nothing is written".into();
        app
    }

    fn empty(config: AppConfig) -> Self {
        Self {
            lock: None,
            config,
            screen: Screen::Setup,
            overlay: None,
            plan: None,
            worker: None,
            shown: None,
            pending: VecDeque::new(),
            unwritten: None,
            visible: true,
            status: String::new(),
            joint_pair: 0,
            cursor: 0,
            skip_asked: None,
            participant_mode: false,
            help_scroll: 0,
            say_after: None,
            now_ns: now_ns(),
            session_started_ns: None,
            last_simulated_ns: 0,
            quit: false,
            closed: None,
            exit_message: None,
            robot: None,
            arm: None,
            robot_outbox: None,
        }
    }

    /// The console drives `robot` (none: the operator commands the robot by hand).
    pub fn with_robot(mut self, robot: Option<Robot>) -> Self {
        self.robot = robot;
        self
    }

    pub fn with_arm(mut self, arm: Option<JointStateSource>) -> Self {
        self.arm = arm;
        self
    }

    /// The live arm measurement, if one is subscribed.
    pub fn arm(&self) -> Option<&JointStateSource> {
        self.arm.as_ref()
    }

    /// A grasp keyed now, measured by the live source when there is one: the latest sample at
    /// or before now within the protocol's window (none: the trial learns from the handle).
    pub(super) fn grasp(&mut self, region: String, simulated: Option<ArmMeasurement>) {
        let now = now_ns();
        let window = self.config.study.protocol.learning.measurement.as_ref().map(|m| m.window_s);
        let measured = match (&self.arm, window) {
            (Some(arm), Some(w)) => arm.at(now, w),
            _ => simulated,
        };
        self.submit_stamped(Stamped { time_ns: now, event: Event::GraspRecorded { region, measured } });
    }

    /// The robot, if one is connected.
    pub fn robot(&self) -> Option<&Robot> {
        self.robot.as_ref()
    }

    pub(super) fn make_plan(&self) -> Plan {
        let c = &self.config;
        plan_session(&SetupConfig {
            study: &c.study,
            protocol_text: &c.protocol_text,
            dirs: &c.dirs,
            participant: &c.participant,
            simulate: c.simulate,
            pilot: c.pilot,
            seed: c.seed,
        })
    }

    /// The session as currently shown.
    pub fn session(&self) -> Option<&Session> {
        self.shown.as_ref()
    }

    /// The log being written.
    pub fn log_path(&self) -> Option<PathBuf> {
        match &self.screen {
            Screen::Summary(s) => Some(s.log_path.clone()),
            _ => self
                .worker
                .as_ref()
                .map(|w| w.path().clone())
                .or_else(|| self.plan.as_ref().map(|p| p.log_path.clone())),
        }
    }

    /// Whether work is under way (the screen shows "computing").
    pub fn busy(&self) -> bool {
        self.worker.as_ref().is_some_and(Worker::busy)
    }

    /// What the keyboard drives now.
    pub fn mode(&self) -> Mode {
        self.overlay_mode().unwrap_or_else(|| self.screen_mode())
    }

    /// What a dialog over the screen takes the keys for, if one is open.
    fn overlay_mode(&self) -> Option<Mode> {
        Some(match self.overlay.as_ref()? {
            Overlay::Help => Mode::Help,
            Overlay::ConfirmQuit => Mode::ConfirmQuit,
            Overlay::VoidReason => Mode::VoidReason,
            Overlay::Note(_) | Overlay::ParticipantId(_) | Overlay::AbortReason(_) | Overlay::VoidDetail(_) => {
                Mode::LineEdit
            }
            Overlay::WriteFailed { .. } => Mode::WriteFailed,
        })
    }

    /// What the screen under any dialog takes the keys for.
    pub fn screen_mode(&self) -> Mode {
        match &self.screen {
            Screen::Setup => Mode::Setup,
            Screen::Summary(_) => Mode::Summary,
            Screen::Session if self.transition().is_some() => Mode::Transition,
            Screen::Session => match self.session().map(|s| s.prompt()) {
                Some(Prompt::Present(_)) => Mode::Present,
                Some(Prompt::Grasp(_)) => Mode::Grasp,
                Some(Prompt::Paused) => Mode::Paused,
                Some(Prompt::Done { .. }) | None => Mode::Summary,
                Some(_) if self.participant_mode => Mode::Participant,
                Some(_) => Mode::Questionnaire,
            },
        }
    }

    /// The transition waiting for the experimenter's confirmation (`Session::transition`);
    /// the questionnaire's only while its cursor is still on the first statement.
    pub fn transition(&self) -> Option<Transition> {
        match self.session()?.transition()? {
            Transition::Questionnaire if self.cursor != 0 => None,
            t => Some(t),
        }
    }

    /// What the experimenter tells the participant at a transition: the protocol's text
    /// with the programs' labels.
    pub fn transition_text(&self, stage: Transition) -> String {
        let Some(s) = self.session() else { return String::new() };
        let t = s.study().protocol.session.transitions();
        let labels = &s.start().program_labels;
        match stage {
            Transition::Program(k) => t
                .between_programs
                .replace("{done}", &labels[k.saturating_sub(1)])
                .replace("{next}", &labels[k.min(labels.len() - 1)]),
            Transition::Test => t.before_test,
            Transition::Questionnaire => t.before_questionnaire,
        }
    }

    /// In a practice rehearsal, what the simulated participant did and the key that records
    /// it; `None` when the operator's next step is not the participant's.
    pub fn practice_hint(&self) -> Option<String> {
        if !self.config.practice || self.transition().is_some() || self.overlay.is_some() {
            return None;
        }
        let s = self.session()?;
        let sim = self.plan.as_ref()?.simulated.as_ref()?;
        let scale = &s.study().protocol.questionnaire.scale;
        match (s.prompt(), sim.respond(s)?) {
            (Prompt::Grasp(v), Event::GraspRecorded { region, .. }) => {
                let q = s.query(v.query);
                let object = s.study().object(q);
                let k = q.regions.iter().position(|&r| object.regions[r].id == region)?;
                let label = super::screens::trial::grip_label(s, &object.regions[q.regions[k]].label);
                Some(format!("Practice: the participant took the {label}: press {}", k + 1))
            }
            (Prompt::Likert { index, .. }, Event::LikertAnswered { value, .. }) if self.cursor == index => {
                let k = scale.iter().position(|p| p.value == value)?;
                Some(format!("Practice: the participant answers “{}”: press {}, then Enter", scale[k].label, k + 1))
            }
            (Prompt::ForcedChoice, Event::ForcedChoice { program }) => {
                let key = char::from(b'a' + program as u8);
                Some(format!(
                    "Practice: the participant prefers {}: press {key}, then Enter",
                    s.start().program_labels[program]
                ))
            }
            _ => None,
        }
    }

    /// What `u` would undo now, as the operator names it ("the grasp of Program A, trial
    /// 5"); `None` when there is nothing to undo.
    pub fn undoable(&self) -> Option<String> {
        let s = self.session().filter(|s| s.can_undo())?;
        Some(match s.trials().last() {
            Some(t) => match t.run {
                Some(run) => format!("the grasp of {}, trial {}", s.start().program_labels[run], t.trial),
                None => format!("the grasp of test trial {}", t.trial),
            },
            None => "the last grasp".into(),
        })
    }

    /// The experimenter confirms the transition shown: logged, so that the robot operator's
    /// screen shows the next pose only now, and a resumed console does not ask again.
    pub(super) fn acknowledge(&mut self) {
        let Some(transition) = self.transition() else { return };
        let message = match transition {
            Transition::Program(k) => format!(
                "{} begins: present its first query",
                self.session().map_or(String::new(), |s| s.start().program_labels[k].clone())
            ),
            Transition::Test => "The test phase begins: present its first query".into(),
            Transition::Questionnaire => {
                "The questionnaire begins: h hands it to the participant, or read the statements out".into()
            }
        };
        self.submit_saying(Event::TransitionConfirmed { transition }, message);
    }

    /// How many grip regions are offered now, scale points and void reasons there are: the
    /// digits that act.
    pub fn counts(&self) -> Counts {
        let regions = match self.session().map(|s| (s.prompt(), s)) {
            Some((Prompt::Grasp(v) | Prompt::Present(v), s)) => s.query(v.query).regions.len(),
            _ => 0,
        };
        Counts {
            regions,
            scale_points: self.config.study.protocol.questionnaire.scale.len(),
            void_reasons: crate::session::VoidReason::ALL.len(),
            robot: self.robot.is_some(),
            can_undo: self.session().is_some_and(|s| s.can_undo()),
            joints: matches!(
                self.session().map(|s| s.prompt()),
                Some(Prompt::Present(v) | Prompt::Grasp(v)) if v.phase == crate::session::Phase::Training
            ),
        }
    }

    /// A key press: applied now, or queued while work is under way; ignored while the
    /// terminal is too small to show what it would do.
    pub fn key(&mut self, key: KeyEvent) {
        if !self.visible {
            return;
        }
        if self.busy() {
            self.pending.push_back(key);
            return;
        }
        match action_for(self.mode(), key, self.counts()) {
            Some(action) => self.update(action),
            None => {
                if let Some(why) = why_not(self.mode(), key) {
                    self.status = why;
                }
            }
        }
    }

    /// Advances the clock, collects finished work, replays queued keys, and lets a
    /// simulated participant act.
    pub fn tick(&mut self, now_ns: u64) {
        self.now_ns = now_ns;
        self.collect();
        while !self.busy() {
            let Some(k) = self.pending.pop_front() else { break };
            self.key(k);
        }
        if !self.busy() && matches!(self.screen, Screen::Session) {
            self.hear_robot();
        }
        if self.busy() || self.overlay.is_some() || !matches!(self.screen, Screen::Session) {
            return;
        }
        let Some(sim) = self.plan.as_ref().and_then(|p| p.simulated.clone()) else { return };
        // In practice the operator acts; the participant's choices are only said.
        if self.config.practice {
            return;
        }
        if now_ns.saturating_sub(self.last_simulated_ns) < self.config.pace.as_nanos() as u64 {
            return;
        }
        // A rehearsal goes on by itself; the transition's text is left on the status line.
        if let Some(transition) = self.transition() {
            self.last_simulated_ns = now_ns;
            let text = self.transition_text(transition);
            self.submit_saying(Event::TransitionConfirmed { transition }, text);
            return;
        }
        if let Some(event) = self.session().and_then(|s| sim.respond(s)) {
            self.last_simulated_ns = now_ns;
            // With a robot, a rehearsal's query is presented when the robot is at the pose.
            match (&event, self.robot.is_some(), self.session().and_then(Session::robot)) {
                (Event::QueryPresented { .. }, true, None) => self.send_robot(),
                (Event::QueryPresented { .. }, true, Some(_)) => {}
                (Event::GraspRecorded { .. }, _, _) if self.arm.is_some() => {
                    let Event::GraspRecorded { region, measured } = event else { unreachable!() };
                    self.grasp(region, measured)
                }
                _ => self.submit(event),
            }
        }
    }

    /// Logs what the robot reported; on `at_pose`, presents the query when the lab says so
    /// (and in a rehearsal).
    fn hear_robot(&mut self) {
        let Some(robot) = self.robot.as_mut() else { return };
        let present_on_at_pose = robot.settings.present_on == PresentOn::AtPose || self.config.simulate;
        let Some(report) = robot.next_report(Duration::ZERO) else { return };
        self.submit(report.event());
        match report.state {
            RobotState::AtPose if present_on_at_pose => {
                if let Some(Prompt::Present(v)) = self.session().map(Session::prompt) {
                    let id = self.session().map(|s| s.query(v.query).query.id.clone());
                    if id.as_deref() == Some(report.query.as_str()) {
                        self.submit(Event::QueryPresented { query: report.query });
                    }
                }
            }
            _ => {}
        }
    }

    /// Sends the waiting query's pose to the robot: its command is logged first and sent
    /// once on disk.
    pub(super) fn send_robot(&mut self) {
        let Some(robot) = self.robot.as_ref() else { return };
        let Some(command) = self.session().and_then(|s| command_for(s, &robot.settings)) else { return };
        let event = command.event(robot.kind());
        self.robot_outbox = Some(command);
        self.submit(event);
    }

    /// A logged robot command goes to the robot.
    fn dispatch_robot(&mut self) {
        let (Some(robot), Some(command)) = (self.robot.as_mut(), self.robot_outbox.take()) else { return };
        if let Err(why) = robot.send(&command) {
            let report = Report { query: command.query.clone(), state: RobotState::Failed, detail: why };
            self.status = format!("The robot could not be sent the pose: {}", report.detail);
            self.submit(report.event());
        }
    }

    /// Blocks until the worker is done (headless drivers and tests).
    pub fn wait_idle(&mut self) {
        loop {
            self.wait_worker();
            let Some(k) = self.pending.pop_front() else { break };
            self.key(k);
        }
    }

    /// Takes every report of the worker, waiting for them when `block`.
    fn poll_worker(&mut self, block: bool) {
        loop {
            let Some(worker) = self.worker.as_mut() else { return };
            match worker.poll(block) {
                Ok(Some(done)) => self.finish_work(done),
                Ok(None) => return,
                Err(e) => {
                    self.status = e.to_string();
                    return;
                }
            }
        }
    }

    /// Takes the worker's reports that are ready; whether there was one (the screen changed).
    pub fn collect_reports(&mut self) -> bool {
        let before = self.worker.as_ref().map_or(0, Worker::outstanding);
        self.collect();
        self.worker.as_ref().map_or(0, Worker::outstanding) < before
    }

    fn wait_worker(&mut self) {
        self.poll_worker(true);
    }

    fn collect(&mut self) {
        self.poll_worker(false);
    }

    fn finish_work(&mut self, done: Done) {
        match done {
            Done::Submitted(session, result) => {
                self.shown = Some(*session);
                match result {
                    Ok(event) => {
                        self.unwritten = None;
                        if matches!(self.overlay, Some(Overlay::WriteFailed { .. })) {
                            self.overlay = None;
                        }
                        self.after_event();
                        self.say_measurement(&event);
                        match event {
                            Event::RobotCommanded { .. } => self.dispatch_robot(),
                            Event::RobotReported {
                                state: state @ (RobotState::Failed | RobotState::Timeout),
                                detail,
                                ..
                            } => {
                                let detail = if detail.is_empty() { String::new() } else { format!(" ({detail})") };
                                self.status = format!(
                                    "The robot reported {}{detail}: s sends again, x voids the trial, Enter continues by hand",
                                    state.name()
                                );
                            }
                            _ => {}
                        }
                    }
                    Err(Failure::Rejected(e)) => self.status = e,
                    Err(Failure::Log { message, last_event, event }) => {
                        self.unwritten = Some(*event);
                        // Keys typed after the failed event must not act on a state that
                        // does not have it.
                        self.pending.clear();
                        self.overlay = Some(Overlay::WriteFailed { message, last_event });
                    }
                }
            }
            Done::Finished(view) => {
                self.worker = None;
                self.screen = Screen::Summary(view);
            }
            Done::Closed { path, error } => {
                self.worker = None;
                self.closed = Some((path, error));
            }
        }
    }

    /// Sends an event to the session through the recorder, off the drawing loop.
    pub(super) fn submit(&mut self, event: Event) {
        self.submit_stamped(Stamped { time_ns: now_ns(), event });
    }

    /// [`App::submit`], and once the event has taken effect (it is on disk) say `message`.
    pub(super) fn submit_saying(&mut self, event: Event, message: String) {
        self.say_after = Some(message);
        self.submit(event);
    }

    pub(super) fn submit_stamped(&mut self, stamped: Stamped) {
        if let Some(w) = self.worker.as_mut() {
            w.submit(stamped);
        }
    }

    /// After a grasp of a measured protocol: a measurement that implies another grip than the
    /// key, or none in time, is said (and logged in `/trial/response`).
    fn say_measurement(&mut self, event: &Event) {
        let Event::GraspRecorded { region, measured } = event else { return };
        let Some(session) = self.session() else { return };
        let Some(m) = session.study().protocol.learning.measurement.as_ref() else { return };
        let Some(t) = session.trials().last() else { return };
        self.status = match (&t.measured, measured) {
            (Some(g), _) if !g.agrees(t.region) => {
                let q = session.query(t.query);
                let object = session.study().object(q);
                let implied = &object.regions[q.regions[g.implied_region]];
                let shown = |label: &str| super::screens::trial::grip_label(session, label);
                let keyed = object.regions.iter().find(|r| r.id == *region).map_or(region.clone(), |r| shown(&r.label));
                format!(
                    "The measured arm is nearest a {} ({}) configuration, the key said {keyed} ({region}): the belief learned from the measurement; u undoes the key if it was wrong",
                    shown(&implied.label),
                    implied.id
                )
            }
            (None, _) => {
                let why = self.arm.as_ref().and_then(|a| a.diagnose()).map_or_else(String::new, |w| format!(" ({w})"));
                format!(
                    "No arm sample in the {} s before the grasp{why}: this trial learned from the handle",
                    m.window_s
                )
            }
            _ => return,
        };
    }

    /// After an event took effect: keep the questionnaire cursor in step, and finish the
    /// log when the session is over.
    fn after_event(&mut self) {
        self.status = self.say_after.take().unwrap_or_default();
        let Some(session) = self.session() else { return };
        if let Prompt::Done { completed } = session.prompt() {
            self.finish_log(completed);
        }
    }

    fn sync_cursor(&mut self) {
        if let Some(Prompt::Likert { index, .. }) = self.session().map(|s| s.prompt()) {
            self.cursor = index;
        } else if let Some(Prompt::ForcedChoice) = self.session().map(|s| s.prompt()) {
            self.cursor = self.likert_count();
        }
    }

    /// The questionnaire in the participant's hands is answered: the screen asks them to hand
    /// the keyboard back.
    pub fn participant_done(&self) -> bool {
        self.participant_mode
            && self.cursor > self.likert_count()
            && self.session().is_some_and(|s| s.prompt() == Prompt::Finish)
    }

    /// Number of Likert questions.
    pub fn likert_count(&self) -> usize {
        self.session().map_or(0, |s| s.likert_order().len())
    }

    fn finish_log(&mut self, completed: bool) {
        if let Some(w) = self.worker.as_mut() {
            w.finish(completed);
        }
    }

    pub(super) fn start(&mut self) {
        let Some(mut plan) = self.plan.take() else { return };
        let started = self.lock_and_start(&mut plan);
        self.plan = Some(plan);
        match started {
            Ok(mut rec) => {
                if let Some(tap) = &self.config.tap {
                    rec.set_tap(tap.clone().0);
                }
                self.status = format!("Session started; logging to {}", rec.path().display());
                self.shown = Some(rec.session().clone());
                self.worker = Some(Worker::spawn(rec));
                self.screen = Screen::Session;
                self.session_started_ns = Some(self.now_ns);
            }
            Err(e) => self.status = e.to_string(),
        }
    }

    fn lock_and_start(&mut self, plan: &mut Plan) -> Result<RecordedSession, SetupError> {
        if let Some(e) = &plan.error {
            return Err(SetupError::Plan(e.clone()));
        }
        if self.lock.is_none() {
            self.lock = Some(lock_for(plan)?);
        }
        start_session(plan, &self.config.dirs)
    }

    /// The whole command that continues this session: by participant in a study (the one
    /// unfinished session `run` lets them have), by log for a rehearsal.
    pub fn resume_command(&self, log: &Path) -> String {
        match self.session().map(|s| s.start()) {
            Some(start) if !start.pilot => self.config.dirs.resume_command(&start.participant),
            _ => format!("handover resume {}", crate::study_dir::shell_word(&log.display().to_string())),
        }
    }

    pub(super) fn quit_now(&mut self) {
        // Whatever is under way is written first; then the log is finished.
        self.wait_worker();
        if let Some(w) = self.worker.as_mut() {
            let done = self.shown.as_ref().is_some_and(|s| matches!(s.prompt(), Prompt::Done { .. }));
            w.close();
            self.wait_worker();
            let lost = self.unwritten.as_ref().map_or(String::new(), |_| {
                " (the last event could not be written and is not in it: record it again after resuming)".to_string()
            });
            match self.closed.take() {
                Some((path, None)) if !done => {
                    self.exit_message =
                        Some(format!("Session left unfinished; continue it with: {}{lost}", self.resume_command(&path)))
                }
                // The events on disk are whole: the log replays without its summary.
                Some((path, Some(e))) => {
                    self.exit_message = Some(format!(
                        "could not finish the log ({e}); everything acknowledged is in it: continue it with: \
                         {}{lost}",
                        self.resume_command(&path)
                    ))
                }
                _ => {}
            }
        }
        self.quit = true;
    }

    /// A termination signal: let the worker finish the event it is writing, then leave as
    /// `q` then `y` does (the session stays resumable).
    pub fn interrupt(&mut self) {
        self.wait_worker();
        self.pending.clear();
        self.quit_now();
    }
}
