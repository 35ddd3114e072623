//! The console's view: the screen, its dialogs, the questionnaire's cursor and the status
//! line; keys in, events to the session out through the session driver (`driver.rs`), which
//! owns the log's worker thread, the robot and the live arm. Every event goes through the
//! recorder (durable on disk) before its consequence is shown; keys pressed meanwhile wait
//! in order.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use ratatui::crossterm::event::KeyEvent;

use super::driver::{Driver, Heard};
use super::keys::{Counts, Mode, QuestionnaireAt, action_for, why_not};
use crate::analysis::{SessionAnalysis, analyse};
use crate::dryrun::now_ns;
use crate::participant::{ScriptedParticipant, SimulatedPerson};
use crate::protocol::Study;
use crate::record::{LogContents, RecordError, RecordedSession, SharedTap, continuation_path, log_folder};
use crate::robot::Robot;
use crate::robot::joint_states::JointStateSource;
use crate::session::{ArmMeasurement, Event, Prompt, RobotState, Session, Transition};
use crate::setup::{Plan, SetupConfig, plan_session};
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
    /// A pilot's body (a participant's is in their record): the protocol is fitted to it.
    pub pilot_body: crate::protocol::Body,
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
    /// The session, its log and the lab's devices.
    pub(super) driver: Driver,
    pending: VecDeque<KeyEvent>,
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
    /// Printed after the terminal is restored.
    pub exit_message: Option<String>,
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
        app.driver.hold(ParticipantLock::acquire(&log_folder(&old.path), &old.start.participant, "console")?);
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
        app.driver.run(rec);
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
            config,
            screen: Screen::Setup,
            overlay: None,
            plan: None,
            driver: Driver::default(),
            pending: VecDeque::new(),
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
            exit_message: None,
        }
    }

    /// The console drives `robot` (none: the operator commands the robot by hand).
    pub fn with_robot(mut self, robot: Option<Robot>) -> Self {
        self.driver.set_robot(robot);
        self
    }

    pub fn with_arm(mut self, arm: Option<JointStateSource>) -> Self {
        self.driver.set_arm(arm);
        self
    }

    /// The live arm measurement, if one is subscribed.
    pub fn arm(&self) -> Option<&JointStateSource> {
        self.driver.arm()
    }

    /// A grasp keyed now, measured by the live source when there is one.
    pub(super) fn grasp(&mut self, region: String, simulated: Option<ArmMeasurement>) {
        let window = self.config.study.protocol.learning.measurement.as_ref().map(|m| m.window_s);
        self.driver.grasp(region, simulated, window);
    }

    /// The robot, if one is connected.
    pub fn robot(&self) -> Option<&Robot> {
        self.driver.robot()
    }

    pub(super) fn make_plan(&self) -> Plan {
        let c = &self.config;
        plan_session(&SetupConfig {
            study: &c.study,
            protocol_text: &c.protocol_text,
            dirs: &c.dirs,
            participant: &c.participant,
            simulate: c.simulate,
            pilot: c.pilot.then_some(c.pilot_body),
            seed: c.seed,
        })
    }

    /// The session as currently shown.
    pub fn session(&self) -> Option<&Session> {
        self.driver.session()
    }

    /// The log being written.
    pub fn log_path(&self) -> Option<PathBuf> {
        match &self.screen {
            Screen::Summary(s) => Some(s.log_path.clone()),
            _ => self.driver.log_path().or_else(|| self.plan.as_ref().map(|p| p.log_path.clone())),
        }
    }

    /// Whether work is under way (the screen shows "computing").
    pub fn busy(&self) -> bool {
        self.driver.busy()
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
            robot: self.driver.robot().is_some(),
            can_undo: self.session().is_some_and(|s| s.can_undo()),
            joints: matches!(
                self.session().map(|s| s.prompt()),
                Some(Prompt::Present(v) | Prompt::Grasp(v)) if v.phase == crate::session::Phase::Training
            ),
            questionnaire: match self.cursor.cmp(&self.likert_count()) {
                std::cmp::Ordering::Less => QuestionnaireAt::Statement,
                std::cmp::Ordering::Equal => QuestionnaireAt::ForcedChoice,
                std::cmp::Ordering::Greater => QuestionnaireAt::Review,
            },
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
        self.collect_reports();
        while !self.busy() {
            let Some(k) = self.pending.pop_front() else { break };
            self.key(k);
        }
        if !self.busy() && matches!(self.screen, Screen::Session) {
            self.driver.hear_robot(self.config.simulate);
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
            match (&event, self.driver.robot().is_some(), self.session().and_then(Session::robot)) {
                (Event::QueryPresented { .. }, true, None) => self.driver.send_robot(),
                (Event::QueryPresented { .. }, true, Some(_)) => {}
                (Event::GraspRecorded { .. }, _, _) if self.driver.arm().is_some() => {
                    let Event::GraspRecorded { region, measured } = event else { unreachable!() };
                    self.grasp(region, measured)
                }
                _ => self.submit(event),
            }
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

    /// Takes every report of the worker that comes by `deadline` (`None`: waits for all).
    fn poll_worker(&mut self, deadline: Option<Instant>) {
        loop {
            let wait = deadline.map_or(Duration::MAX, |d| d.saturating_duration_since(Instant::now()));
            let Some(heard) = self.driver.poll(wait) else { break };
            match heard {
                Ok(heard) => self.react(heard),
                Err(e) => {
                    self.status = e.to_string();
                    return;
                }
            }
        }
    }

    /// Takes the worker's reports that are ready; whether there was one (the screen changed).
    pub fn collect_reports(&mut self) -> bool {
        self.await_reports(Duration::ZERO)
    }

    /// Takes the worker's reports that come `within` from now; whether there was one.
    pub fn await_reports(&mut self, within: Duration) -> bool {
        let before = self.driver.outstanding();
        self.poll_worker(Some(Instant::now() + within));
        self.driver.outstanding() < before
    }

    fn wait_worker(&mut self) {
        self.poll_worker(None);
    }

    /// What the screens show of what the session did.
    fn react(&mut self, heard: Heard) {
        match heard {
            Heard::Written { event, robot_failed } => {
                if matches!(self.overlay, Some(Overlay::WriteFailed { .. })) {
                    self.overlay = None;
                }
                self.after_event();
                self.say_measurement(&event);
                if let Some(why) = robot_failed {
                    self.status = format!("The robot could not be sent the pose: {why}");
                }
                if let Event::RobotReported { state, detail, command, stale: true, .. } = &event {
                    let which = command.as_deref().map_or(String::new(), |c| format!(" for command {c}"));
                    let detail = if detail.is_empty() { String::new() } else { format!(" ({detail})") };
                    self.status = format!(
                        "A stale robot status was logged and ignored: {}{which}, not the command under way{detail}",
                        state.name()
                    );
                } else if let Event::RobotReported {
                    state: state @ (RobotState::Failed | RobotState::Timeout),
                    detail,
                    ..
                } = event
                {
                    let detail = if detail.is_empty() { String::new() } else { format!(" ({detail})") };
                    self.status = format!(
                        "The robot reported {}{detail}: s sends again, x voids the trial, Enter continues by hand",
                        state.name()
                    );
                }
            }
            Heard::Rejected(why) => self.status = why,
            Heard::WriteFailed { message, last_event } => {
                // Keys typed after the failed event must not act on a state that does not
                // have it.
                self.pending.clear();
                self.overlay = Some(Overlay::WriteFailed { message, last_event });
            }
            Heard::Finished(view) => self.screen = Screen::Summary(view),
            Heard::Closed => {}
        }
    }

    /// Sends an event to the session through the recorder, off the drawing loop.
    pub(super) fn submit(&mut self, event: Event) {
        self.driver.submit(event);
    }

    /// [`App::submit`], and once the event has taken effect (it is on disk) say `message`.
    pub(super) fn submit_saying(&mut self, event: Event, message: String) {
        self.say_after = Some(message);
        self.submit(event);
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
                let why = self.driver.arm().and_then(|a| a.diagnose()).map_or_else(String::new, |w| format!(" ({w})"));
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
        self.session().map_or(0, Session::likert_count)
    }

    fn finish_log(&mut self, completed: bool) {
        self.driver.finish_log(completed);
    }

    pub(super) fn start(&mut self) {
        let Some(mut plan) = self.plan.take() else { return };
        let started = self.driver.lock_and_start(&mut plan, &self.config.dirs);
        self.plan = Some(plan);
        match started {
            Ok(mut rec) => {
                if let Some(tap) = &self.config.tap {
                    rec.set_tap(tap.clone().0);
                }
                self.status = format!("Session started; logging to {}", rec.path().display());
                self.driver.run(rec);
                self.screen = Screen::Session;
                self.session_started_ns = Some(self.now_ns);
            }
            Err(e) => self.status = e.to_string(),
        }
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
        if self.driver.running() {
            let done = self.session().is_some_and(|s| matches!(s.prompt(), Prompt::Done { .. }));
            self.driver.close();
            self.wait_worker();
            let lost = if self.driver.has_unwritten() {
                " (the last event could not be written and is not in it: record it again after resuming)".to_string()
            } else {
                String::new()
            };
            match self.driver.take_closed() {
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
