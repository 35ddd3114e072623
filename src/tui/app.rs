//! The console's state and its update: intents in, events to the session out. Every event
//! goes through the recorder (durable on disk) before its consequence is shown; that work
//! runs on a worker thread, and keys pressed meanwhile wait in order.

use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::mpsc::{Receiver, TryRecvError, channel};
use std::time::Duration;

use rand::RngExt;
use ratatui::crossterm::event::KeyEvent;

use super::keys::{Action, Counts, Mode, action_for};
use crate::analysis::{SessionAnalysis, analyse};
use crate::dryrun::{now_ns, plan};
use crate::participant::{ParticipantRecord, ScriptedParticipant, SimulatedPerson, new_id, validate_id};
use crate::protocol::{Study, for_body};
use crate::record::{
    LogContents, RecordError, RecordedSession, SubmitError, continuation_path, log_folder, new_log_path, read_log,
};
use crate::session::{Event, Prompt, Session, SessionStart, Stamped, VoidReason, condition_order};
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
    /// Wait between simulated actions.
    pub pace: Duration,
    /// The session seed (random when absent).
    pub seed: Option<u64>,
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
    /// The log could not be written: nothing moves on until the event is retried (`r`).
    WriteFailed {
        message: String,
        last_event: usize,
    },
}

/// What a new session will be (shown on the setup screen).
#[derive(Clone, Debug)]
pub struct Plan {
    pub start: SessionStart,
    /// A participant record to create when the session starts ("new").
    pub new_record: Option<ParticipantRecord>,
    pub simulated: Option<ScriptedParticipant>,
    pub log_path: PathBuf,
    pub error: Option<String>,
    /// The protocol as this session runs it: the participant's body height scales the arm.
    pub study: Arc<Study>,
    pub protocol_text: String,
    /// The study's folders, and which of them are new (read once, when planned).
    pub folders: String,
    pub new_folders: bool,
}

/// Why a submitted event did not take effect.
enum Failure {
    /// The session refused it (nothing was logged).
    Rejected(String),
    /// The log could not be written; the event is kept to be retried.
    Log { message: String, last_event: usize, event: Stamped },
}

enum WorkDone {
    Submitted(Box<RecordedSession>, Result<(), Failure>),
    Finished(Box<SummaryView>),
}

/// The console.
pub struct App {
    pub config: AppConfig,
    pub screen: Screen,
    pub overlay: Option<Overlay>,
    pub plan: Option<Plan>,
    live: Option<RecordedSession>,
    /// This console's hold on the participant (one live session per participant).
    lock: Option<ParticipantLock>,
    /// A copy of the session as last shown (kept while the worker has the live one).
    shown: Option<Session>,
    worker: Option<Receiver<WorkDone>>,
    pending: VecDeque<KeyEvent>,
    /// The event whose log write failed, waiting for a retry.
    unwritten: Option<Stamped>,
    /// Whether the terminal is large enough to show the screen (keys are ignored otherwise).
    pub visible: bool,
    /// The last message for the operator.
    pub status: String,
    /// Which pair of joints the particle view shows.
    pub joint_pair: usize,
    /// Position in the questionnaire: items, then the forced choice, then finish.
    pub cursor: usize,
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
    pub fn resume(config: AppConfig, old: &LogContents) -> Result<Self, String> {
        let mut app = Self::empty(config);
        let lock = ParticipantLock::acquire(&log_folder(&old.path), &old.start.participant, "console");
        app.lock = Some(lock.map_err(|e| e.to_string())?);
        let path = continuation_path(old, chrono::Utc::now());
        let rec = RecordedSession::resume(old, &path, now_ns()).map_err(|e| e.to_string())?;
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
            let person = SimulatedPerson { truth, alpha: rec.session().study().protocol.learning.alpha };
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
            });
        }
        app.shown = Some(rec.session().clone());
        app.live = Some(rec);
        app.screen = Screen::Session;
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
            live: None,
            shown: None,
            worker: None,
            pending: VecDeque::new(),
            unwritten: None,
            visible: true,
            status: String::new(),
            joint_pair: 0,
            cursor: 0,
            now_ns: now_ns(),
            session_started_ns: None,
            last_simulated_ns: 0,
            quit: false,
            exit_message: None,
        }
    }

    fn make_plan(&self) -> Plan {
        let c = &self.config;
        let study = &c.study;
        let seed = c.seed.unwrap_or_else(|| rand::rng().random());
        let now = chrono::Utc::now();
        let started_at = now.to_rfc3339_opts(chrono::SecondsFormat::Millis, true);
        if c.simulate {
            let p = plan(study, seed, 0, None, started_at);
            let log_path = new_log_path(&c.dirs.logs, &p.start.participant, now);
            return Plan {
                start: p.start,
                new_record: None,
                simulated: Some(p.participant),
                log_path,
                error: None,
                study: Arc::clone(study),
                protocol_text: c.protocol_text.clone(),
                folders: c.dirs.describe(),
                new_folders: !c.dirs.missing().is_empty(),
            };
        }
        let (mut study, mut protocol_text) = (Arc::clone(study), c.protocol_text.clone());
        let (id, slot, new_record, error) = if c.participant == "new" {
            let id = new_id(&mut rand::rng());
            let counts = crate::counterbalance::completed_per_slot(&c.dirs.logs, &c.dirs.participants, 2);
            let slot = counts.least_filled();
            let rec = ParticipantRecord {
                id: id.clone(),
                slot,
                created_at: now.to_rfc3339_opts(chrono::SecondsFormat::Secs, true),
                body_height_m: None,
                handedness: None,
                withdrawn_at: None,
            };
            (id, slot, Some(rec), None)
        } else {
            match ParticipantRecord::load(&c.dirs.participants, &c.participant) {
                Ok(r) if r.is_withdrawn() => {
                    let why = format!(
                        "participant {} withdrew from the study ({}): no new session can be started for them",
                        r.id,
                        r.withdrawn_at.as_deref().unwrap_or_default()
                    );
                    (r.id, r.slot, None, Some(why))
                }
                Ok(r) => match for_body(&c.protocol_text, &study.source_name, r.body()) {
                    Ok((text, fitted)) => {
                        (study, protocol_text) = (Arc::new(fitted), text);
                        (r.id, r.slot, None, None)
                    }
                    Err(e) => (r.id, r.slot, None, Some(e.to_string())),
                },
                Err(e) => (c.participant.clone(), 0, None, Some(e.to_string())),
            }
        };
        let start = SessionStart {
            session_id: format!("{:016x}", rand::rng().random::<u64>()),
            participant: id.clone(),
            protocol_name: study.protocol.name.clone(),
            protocol_sha256: study.sha256.clone(),
            seed,
            condition_order: condition_order(&study, slot),
            program_labels: study.protocol.session.program_labels.clone(),
            software_version: env!("CARGO_PKG_VERSION").to_string(),
            pilot: false,
            slot,
            started_at,
            simulated_truth: None,
            resumed_from: None,
        };
        let log_path = if validate_id(&id).is_ok() { new_log_path(&c.dirs.logs, &id, now) } else { PathBuf::new() };
        Plan {
            start,
            new_record,
            simulated: None,
            log_path,
            error,
            study,
            protocol_text,
            folders: c.dirs.describe(),
            new_folders: !c.dirs.missing().is_empty(),
        }
    }

    /// The session as currently shown.
    pub fn session(&self) -> Option<&Session> {
        self.live.as_ref().map(|l| l.session()).or(self.shown.as_ref())
    }

    /// The log being written.
    pub fn log_path(&self) -> Option<PathBuf> {
        match &self.screen {
            Screen::Summary(s) => Some(s.log_path.clone()),
            _ => self
                .live
                .as_ref()
                .map(|l| l.path().to_path_buf())
                .or_else(|| self.plan.as_ref().map(|p| p.log_path.clone())),
        }
    }

    /// Whether work is under way (the screen shows "computing").
    pub fn busy(&self) -> bool {
        self.worker.is_some()
    }

    /// What the keyboard drives now.
    pub fn mode(&self) -> Mode {
        match &self.overlay {
            Some(Overlay::Help) => return Mode::Help,
            Some(Overlay::ConfirmQuit) => return Mode::ConfirmQuit,
            Some(Overlay::VoidReason) => return Mode::VoidReason,
            Some(Overlay::Note(_) | Overlay::ParticipantId(_) | Overlay::AbortReason(_)) => return Mode::LineEdit,
            Some(Overlay::WriteFailed { .. }) => return Mode::WriteFailed,
            None => {}
        }
        match &self.screen {
            Screen::Setup => Mode::Setup,
            Screen::Summary(_) => Mode::Summary,
            Screen::Session => match self.session().map(|s| s.prompt()) {
                Some(Prompt::Present(_)) => Mode::Present,
                Some(Prompt::Grasp(_)) => Mode::Grasp,
                Some(Prompt::Paused) => Mode::Paused,
                Some(Prompt::Done { .. }) | None => Mode::Summary,
                Some(_) => Mode::Questionnaire,
            },
        }
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
        if let Some(action) = action_for(self.mode(), key, self.counts()) {
            self.update(action);
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
        if self.busy() || self.overlay.is_some() || !matches!(self.screen, Screen::Session) {
            return;
        }
        let Some(sim) = self.plan.as_ref().and_then(|p| p.simulated.clone()) else { return };
        if now_ns.saturating_sub(self.last_simulated_ns) < self.config.pace.as_nanos() as u64 {
            return;
        }
        if let Some(event) = self.session().and_then(|s| sim.respond(s)) {
            self.last_simulated_ns = now_ns;
            self.submit(event);
        }
    }

    /// Blocks until the worker is done (headless drivers and tests).
    pub fn wait_idle(&mut self) {
        while let Some(rx) = &self.worker {
            match rx.recv() {
                Ok(done) => {
                    self.worker = None;
                    self.finish_work(done);
                }
                Err(_) => self.worker = None,
            }
        }
        while !self.busy() {
            let Some(k) = self.pending.pop_front() else { break };
            self.key(k);
            if let Some(rx) = self.worker.take()
                && let Ok(done) = rx.recv()
            {
                self.finish_work(done);
            }
        }
    }

    fn collect(&mut self) {
        let Some(rx) = &self.worker else { return };
        match rx.try_recv() {
            Ok(done) => {
                self.worker = None;
                self.finish_work(done);
            }
            Err(TryRecvError::Empty) => {}
            Err(TryRecvError::Disconnected) => {
                self.worker = None;
                self.status = "internal error: the worker stopped".into();
            }
        }
    }

    fn finish_work(&mut self, done: WorkDone) {
        match done {
            WorkDone::Submitted(rec, result) => {
                self.shown = Some(rec.session().clone());
                self.live = Some(*rec);
                match result {
                    Ok(()) => {
                        self.unwritten = None;
                        if matches!(self.overlay, Some(Overlay::WriteFailed { .. })) {
                            self.overlay = None;
                        }
                        self.after_event();
                    }
                    Err(Failure::Rejected(e)) => self.status = e,
                    Err(Failure::Log { message, last_event, event }) => {
                        self.unwritten = Some(event);
                        // Keys typed after the failed event must not act on a state that
                        // does not have it.
                        self.pending.clear();
                        self.overlay = Some(Overlay::WriteFailed { message, last_event });
                    }
                }
            }
            WorkDone::Finished(view) => self.screen = Screen::Summary(view),
        }
    }

    /// Sends an event to the session through the recorder, off the drawing loop.
    fn submit(&mut self, event: Event) {
        self.submit_stamped(Stamped { time_ns: now_ns(), event });
    }

    fn submit_stamped(&mut self, stamped: Stamped) {
        let Some(mut live) = self.live.take() else { return };
        let (tx, rx) = channel();
        std::thread::spawn(move || {
            let result = live.submit(stamped.clone()).map(|_| ()).map_err(|e| match e {
                SubmitError::Rejected(e) => Failure::Rejected(e.to_string()),
                SubmitError::Log(e) => {
                    let last_event = match &e {
                        RecordError::Write { last_event, .. } => *last_event,
                        _ => live.session().event_count(),
                    };
                    Failure::Log { message: e.to_string(), last_event, event: stamped }
                }
            });
            let _ = tx.send(WorkDone::Submitted(Box::new(live), result));
        });
        self.worker = Some(rx);
    }

    /// After an event took effect: keep the questionnaire cursor in step, and finish the
    /// log when the session is over.
    fn after_event(&mut self) {
        self.status.clear();
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

    /// Number of Likert questions.
    pub fn likert_count(&self) -> usize {
        self.session().map_or(0, |s| s.likert_order().len())
    }

    fn finish_log(&mut self, completed: bool) {
        let Some(live) = self.live.take() else { return };
        let (tx, rx) = channel();
        std::thread::spawn(move || {
            let view = match live.finish() {
                Ok(path) => {
                    let analysis =
                        read_log(&path).map_err(|e| e.to_string()).and_then(|l| analyse(&l).map_err(|e| e.to_string()));
                    let (analysis, error) = match analysis {
                        Ok(a) => (Some(a), None),
                        Err(e) => (None, Some(e)),
                    };
                    SummaryView { log_path: path, completed, analysis, error }
                }
                Err(e) => {
                    SummaryView { log_path: PathBuf::new(), completed, analysis: None, error: Some(e.to_string()) }
                }
            };
            let _ = tx.send(WorkDone::Finished(Box::new(view)));
        });
        self.worker = Some(rx);
    }

    fn start(&mut self) {
        let Some(plan) = self.plan.clone() else { return };
        if let Some(e) = &plan.error {
            self.status = format!("cannot start: {e}");
            return;
        }
        if self.lock.is_none() {
            let dir = plan.log_path.parent().unwrap_or(std::path::Path::new("."));
            match ParticipantLock::acquire(dir, &plan.start.participant, "console") {
                Ok(lock) => self.lock = Some(lock),
                Err(e) => {
                    self.status = format!("cannot start: {e}");
                    return;
                }
            }
        }
        if let Some(rec) = &plan.new_record {
            if let Err(e) = rec.create(&self.config.dirs.participants) {
                self.status = format!("cannot create the participant record: {e}");
                return;
            }
            // Made once: a retry after a failed log does not make it again.
            if let Some(p) = self.plan.as_mut() {
                p.new_record = None;
            }
        }
        let session = match Session::new(Arc::clone(&plan.study), plan.start.clone()) {
            Ok(s) => s,
            Err(e) => {
                self.status = e.to_string();
                return;
            }
        };
        match RecordedSession::create(&plan.log_path, &plan.protocol_text, session, now_ns()) {
            Ok(rec) => {
                self.status = format!("Session started; logging to {}", rec.path().display());
                self.shown = Some(rec.session().clone());
                self.live = Some(rec);
                self.screen = Screen::Session;
                self.session_started_ns = Some(self.now_ns);
            }
            Err(e) => self.status = format!("cannot create the log: {e}"),
        }
    }

    fn quit_now(&mut self) {
        if let Some(live) = self.live.take() {
            let done = matches!(live.session().prompt(), Prompt::Done { .. });
            let path = live.path().to_path_buf();
            let lost = self.unwritten.as_ref().map_or(String::new(), |_| {
                " (the last event could not be written and is not in it: record it again after resuming)".to_string()
            });
            match live.finish() {
                Ok(path) if !done => {
                    self.exit_message = Some(format!(
                        "Session left unfinished; continue it with: handover resume {}{lost}",
                        path.display()
                    ))
                }
                Ok(_) => {}
                // The events on disk are whole: the log replays without its summary.
                Err(e) => {
                    self.exit_message = Some(format!(
                        "could not finish the log ({e}); everything acknowledged is in it: continue it with: \
                         handover resume {}{lost}",
                        path.display()
                    ))
                }
            }
        }
        self.quit = true;
    }

    /// A termination signal: let the worker finish the event it is writing, then leave as
    /// `q` then `y` does (the session stays resumable).
    pub fn interrupt(&mut self) {
        self.wait_idle_worker();
        self.pending.clear();
        self.quit_now();
    }

    fn wait_idle_worker(&mut self) {
        while let Some(rx) = self.worker.take() {
            if let Ok(done) = rx.recv() {
                self.finish_work(done);
            }
        }
    }

    /// Applies an operator's intent.
    pub fn update(&mut self, action: Action) {
        let mode = self.mode();
        match (mode, action) {
            (_, Action::Help) => self.overlay = Some(Overlay::Help),
            (Mode::Help, Action::Cancel) => self.overlay = None,
            (Mode::Setup, Action::Quit) | (Mode::Summary, Action::Quit) => self.quit_now(),
            (_, Action::Quit) if !matches!(mode, Mode::LineEdit | Mode::WriteFailed) => {
                self.overlay = Some(Overlay::ConfirmQuit)
            }
            (Mode::ConfirmQuit, Action::Yes) => {
                self.overlay = None;
                self.quit_now();
            }
            (Mode::ConfirmQuit, Action::No) => self.overlay = None,
            (Mode::ConfirmQuit, Action::Abort) => {
                self.overlay = if self.live.is_some() { Some(Overlay::AbortReason(String::new())) } else { None };
            }
            (Mode::WriteFailed, Action::Retry) => {
                if let Some(event) = self.unwritten.clone() {
                    self.submit_stamped(event);
                }
            }
            (Mode::WriteFailed, Action::Quit) => self.quit_now(),
            (Mode::Setup, Action::Confirm) => self.start(),
            (Mode::Setup, Action::EditParticipant) if !self.config.simulate => {
                self.overlay = Some(Overlay::ParticipantId(String::new()))
            }
            (Mode::LineEdit, Action::Char(c)) => {
                if let Some(Overlay::Note(t) | Overlay::ParticipantId(t) | Overlay::AbortReason(t)) = &mut self.overlay
                {
                    t.push(c);
                }
            }
            (Mode::LineEdit, Action::Backspace) => {
                if let Some(Overlay::Note(t) | Overlay::ParticipantId(t) | Overlay::AbortReason(t)) = &mut self.overlay
                {
                    t.pop();
                }
            }
            (Mode::LineEdit | Mode::VoidReason, Action::Cancel) => self.overlay = None,
            (Mode::LineEdit, Action::Confirm) => match self.overlay.take() {
                Some(Overlay::Note(text)) if !text.trim().is_empty() => self.submit(Event::Note { text }),
                Some(Overlay::AbortReason(text)) if !text.trim().is_empty() => {
                    self.submit(Event::Aborted { reason: text.trim().to_string() })
                }
                Some(Overlay::AbortReason(text)) => {
                    self.status = "A reason is needed to end the session for good (Esc goes back)".into();
                    self.overlay = Some(Overlay::AbortReason(text));
                }
                Some(Overlay::ParticipantId(id)) => {
                    let id = id.trim().to_string();
                    if id == "new" || validate_id(&id).is_ok() {
                        self.config.participant = id;
                        self.plan = Some(self.make_plan());
                    } else {
                        self.status = format!("'{id}' is not a participant id (A–Z, a–z, 0–9, '-', at most 32)");
                    }
                }
                _ => {}
            },
            (Mode::Present | Mode::Grasp | Mode::Questionnaire | Mode::Paused, Action::Note) => {
                self.overlay = Some(Overlay::Note(String::new()))
            }
            (Mode::Present | Mode::Grasp | Mode::Questionnaire, Action::Pause) => self.submit(Event::Paused),
            (Mode::Paused, Action::Pause) => self.submit(Event::Resumed),
            (Mode::Present | Mode::Grasp, Action::SwitchJoints) => self.joint_pair += 1,
            (Mode::Present | Mode::Grasp, Action::Void) => self.overlay = Some(Overlay::VoidReason),
            (Mode::VoidReason, Action::VoidReason(k)) => {
                self.overlay = None;
                self.submit(Event::TrialVoided { reason: VoidReason::ALL[k], detail: String::new() });
            }
            (Mode::Present, Action::Undo) => {
                if self.session().is_some_and(|s| s.can_undo()) {
                    self.submit(Event::GraspUndone);
                } else {
                    self.status = "Nothing to undo: a grasp can be undone until the next query is presented".into();
                }
            }
            (Mode::Present, Action::Confirm) => {
                if let Some(Prompt::Present(v)) = self.session().map(|s| s.prompt()) {
                    let id = self.session().expect("a session").query(v.query).query.id.clone();
                    self.submit(Event::QueryPresented { query: id });
                }
            }
            (Mode::Grasp, Action::Region(k)) => {
                let Some(s) = self.session() else { return };
                let Prompt::Grasp(v) = s.prompt() else { return };
                let q = s.query(v.query);
                match q.regions.get(k) {
                    Some(&r) => {
                        let region = s.study().object(q).regions[r].id.clone();
                        self.submit(Event::GraspRecorded { region });
                    }
                    None => self.status = format!("Only {} regions are offered", q.regions.len()),
                }
            }
            (Mode::Questionnaire, a) => self.questionnaire(a),
            _ => {}
        }
    }

    fn questionnaire(&mut self, action: Action) {
        let n = self.likert_count();
        let Some(s) = self.session() else { return };
        let order = s.likert_order();
        match action {
            Action::Prev => self.cursor = self.cursor.saturating_sub(1),
            Action::Next => self.cursor = (self.cursor + 1).min(n + 1),
            Action::Likert(k) if self.cursor < n => {
                let scale = &s.study().protocol.questionnaire.scale;
                let Some(point) = scale.get(k) else {
                    self.status = format!("The scale has {} points", scale.len());
                    return;
                };
                let (program, item) = order[self.cursor];
                let event = Event::LikertAnswered {
                    program,
                    item: s.study().protocol.questionnaire.items[item].id.clone(),
                    value: point.value,
                };
                self.cursor += 1;
                self.submit(event);
            }
            Action::Choice(p) if self.cursor >= n => {
                self.cursor = n + 1;
                self.submit(Event::ForcedChoice { program: p });
            }
            Action::Confirm => {
                if s.prompt() == Prompt::Finish && self.cursor >= n {
                    self.submit(Event::Ended);
                } else {
                    self.cursor = (self.cursor + 1).min(n + 1);
                }
            }
            _ => {}
        }
    }
}
