//! The console's update: an operator's intent, in the mode the keys are in, becomes an
//! event for the session, a dialog, or a move of the questionnaire's cursor.

use super::app::{App, Overlay};
use super::keys::{Action, Mode};
use super::theme;
use crate::participant::validate_id;
use crate::session::{Event, Prompt, VoidReason};

impl App {
    /// Applies an operator's intent.
    pub fn update(&mut self, action: Action) {
        let mode = self.mode();
        match (mode, action) {
            (_, Action::Help) => {
                self.help_scroll = 0;
                self.overlay = Some(Overlay::Help)
            }
            (Mode::Help, Action::Cancel) => self.overlay = None,
            (Mode::Help, Action::ScrollUp) => self.help_scroll = self.help_scroll.saturating_sub(1),
            (Mode::Help, Action::ScrollDown) => self.help_scroll = self.help_scroll.saturating_add(1),
            (Mode::Transition, Action::Confirm) => self.acknowledge(),
            (Mode::Questionnaire, Action::HandOver) => {
                self.participant_mode = true;
                self.status = "Please answer each statement with a number; Enter goes to the next one.".into();
            }
            (Mode::Participant, Action::HandBack) => {
                self.participant_mode = false;
                self.status = "The experimenter has the keyboard again (h hands it back to the participant)".into();
            }
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
                self.overlay = if self.driver.running() { Some(Overlay::AbortReason(String::new())) } else { None };
            }
            (Mode::WriteFailed, Action::Retry) => {
                self.driver.retry();
            }
            (Mode::WriteFailed, Action::Quit) => self.quit_now(),
            (Mode::Setup, Action::Confirm) => self.start(),
            (Mode::Setup, Action::EditParticipant) if !self.config.simulate => {
                self.overlay = Some(Overlay::ParticipantId(String::new()))
            }
            (Mode::LineEdit, Action::Char(c)) => {
                if let Some(
                    Overlay::Note(t) | Overlay::ParticipantId(t) | Overlay::AbortReason(t) | Overlay::VoidDetail(t),
                ) = &mut self.overlay
                {
                    t.push(c);
                }
            }
            (Mode::LineEdit, Action::Backspace) => {
                if let Some(
                    Overlay::Note(t) | Overlay::ParticipantId(t) | Overlay::AbortReason(t) | Overlay::VoidDetail(t),
                ) = &mut self.overlay
                {
                    t.pop();
                }
            }
            (Mode::LineEdit | Mode::VoidReason, Action::Cancel) => self.overlay = None,
            (Mode::LineEdit, Action::Confirm) => match self.overlay.take() {
                Some(Overlay::Note(text)) if !text.trim().is_empty() => {
                    self.submit_saying(Event::Note { text }, "Note logged".into())
                }
                Some(Overlay::AbortReason(text)) if !text.trim().is_empty() => {
                    self.submit(Event::Aborted { reason: text.trim().to_string() })
                }
                Some(Overlay::AbortReason(text)) => {
                    self.status = "A reason is needed to end the session for good (Esc goes back)".into();
                    self.overlay = Some(Overlay::AbortReason(text));
                }
                Some(Overlay::VoidDetail(text)) if !text.trim().is_empty() => {
                    self.void(VoidReason::Other, text.trim().to_string())
                }
                Some(Overlay::VoidDetail(text)) => {
                    self.status = "Say what happened, for the log (Esc goes back)".into();
                    self.overlay = Some(Overlay::VoidDetail(text));
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
            (Mode::Present | Mode::Grasp | Mode::Questionnaire | Mode::Paused | Mode::Transition, Action::Note) => {
                self.overlay = Some(Overlay::Note(String::new()))
            }
            (Mode::Present | Mode::Grasp | Mode::Questionnaire, Action::Pause) => self.submit(Event::Paused),
            (Mode::Paused, Action::Pause) => self.submit(Event::Resumed),
            (Mode::Present | Mode::Grasp, Action::SwitchJoints) => self.joint_pair += 1,
            (Mode::Present | Mode::Grasp, Action::Void) => self.overlay = Some(Overlay::VoidReason),
            (Mode::VoidReason, Action::VoidReason(k)) => match VoidReason::ALL[k] {
                VoidReason::Other => self.overlay = Some(Overlay::VoidDetail(String::new())),
                reason => {
                    self.overlay = None;
                    self.void(reason, String::new());
                }
            },
            (Mode::Present | Mode::Transition, Action::Undo) => {
                if let Some(what) = self.undoable() {
                    // Back across a transition the participant was already told about.
                    let back = self.session().and_then(|s| match (s.prompt(), s.trials().last()) {
                        (Prompt::Present(v), Some(t))
                            if mode == Mode::Present && (v.phase, v.program) != (t.phase, t.run) =>
                        {
                            Some(match t.run {
                                Some(run) => s.start().program_labels[run].clone(),
                                None => "the test phase".into(),
                            })
                        }
                        _ => None,
                    });
                    let undone = match back {
                        Some(phase) => {
                            format!("Undone: {what}; back to {phase}: tell the participant, then record it again")
                        }
                        None => format!("Undone: {what}; record it again"),
                    };
                    self.submit_saying(Event::GraspUndone, undone);
                } else {
                    self.status = super::keys::NOTHING_TO_UNDO.into();
                }
            }
            (Mode::Present, Action::SendRobot) => self.driver.send_robot(),
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
                        let grip = &s.study().object(q).regions[r];
                        let region = grip.id.clone();
                        let phase = match v.program {
                            Some(k) => format!("{}, trial {}", s.start().program_labels[k], v.trial),
                            None => format!("test trial {}", v.trial),
                        };
                        let label = super::screens::trial::grip_label(s, &grip.label);
                        let said = format!("Recorded: {label} ({phase}); u undoes it");
                        // Practising on a measured protocol: the simulated arm, when the key agrees.
                        let simulated =
                            match (self.config.practice, self.plan.as_ref().and_then(|p| p.simulated.as_ref())) {
                                (true, Some(sim)) => match sim.respond(s) {
                                    Some(Event::GraspRecorded { region: r, measured }) if r == region => measured,
                                    _ => None,
                                },
                                _ => None,
                            };
                        self.say_after = Some(said);
                        self.grasp(region, simulated);
                    }
                    None => self.status = format!("Only {} regions are offered", q.regions.len()),
                }
            }
            (Mode::Questionnaire | Mode::Participant, a) => self.questionnaire(a),
            _ => {}
        }
    }

    /// Voids the trial under way, saying so: it stays in the history with its reason and is
    /// repeated.
    fn void(&mut self, reason: VoidReason, detail: String) {
        let trial = match self.session().map(|s| s.prompt()) {
            Some(Prompt::Present(v) | Prompt::Grasp(v)) => Some(v.trial),
            _ => None,
        };
        let message =
            trial.map_or_else(String::new, |t| format!("Trial {t} voided ({}): it is repeated", reason.label()));
        self.submit_saying(Event::TrialVoided { reason, detail }, message);
    }

    /// The questionnaire: a digit answers the statement shown (and another digit changes
    /// the answer) without moving on, so a double press never answers two statements; Enter
    /// moves on, and on a statement or choice not answered asks first (a second Enter skips
    /// it); ← / → move freely.
    fn questionnaire(&mut self, action: Action) {
        let n = self.likert_count();
        let asked = self.skip_asked.take();
        let Some(s) = self.session() else { return };
        let order = s.likert_order();
        match action {
            Action::Prev => {
                self.status.clear();
                self.cursor = self.cursor.saturating_sub(1);
            }
            Action::Next => {
                self.status.clear();
                self.cursor = (self.cursor + 1).min(n + 1);
            }
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
                let message =
                    format!("Answered “{}”: Enter for the next statement, or another number to change it", point.label);
                self.submit_saying(event, message);
            }
            Action::Choice(p) if self.cursor >= n => {
                self.cursor = n;
                let message = "Chosen: Enter to review the answers, or the other letter to change it".to_string();
                self.submit_saying(Event::ForcedChoice { program: p }, message);
            }
            // A key of another questionnaire screen says where it acts.
            Action::Likert(_) => {
                self.status = if self.cursor == n {
                    "This is the forced choice: a or b answers it (← goes back to the statements)".into()
                } else {
                    "This is the review: ← goes back to a statement to change it, Enter finishes".into()
                };
            }
            Action::Choice(_) => {
                let points = s.study().protocol.questionnaire.scale.len();
                self.status = format!(
                    "a and b answer the forced choice, after the statements: 1–{points} answers this statement"
                );
            }
            Action::Confirm => {
                if s.prompt() == Prompt::Finish && self.cursor > n {
                    if self.participant_mode {
                        self.status = theme::HAND_BACK.into();
                    } else {
                        self.submit(Event::Ended);
                    }
                    return;
                }
                let answered = if self.cursor < n {
                    s.likert_answers().contains_key(&order[self.cursor])
                } else {
                    self.cursor > n || s.forced_choice().is_some()
                };
                let points = s.study().protocol.questionnaire.scale.len();
                if answered || asked == Some(self.cursor) || self.cursor > n {
                    self.status.clear();
                    self.cursor = (self.cursor + 1).min(n + 1);
                } else {
                    self.skip_asked = Some(self.cursor);
                    let what = if self.cursor < n {
                        format!(
                            "Statement {} of {n} has no answer: Enter again skips it, 1–{points} answers it",
                            self.cursor + 1
                        )
                    } else {
                        "The forced choice has no answer: Enter again skips it, a or b answers it".to_string()
                    };
                    self.status = what;
                }
            }
            _ => {}
        }
    }
}
