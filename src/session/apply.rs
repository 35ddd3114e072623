//! Folding one event into a session: one method per event; each checks that the event fits
//! the state before it changes anything, so that on error the state is unchanged.

use super::{
    Applied, ArmMeasurement, BeliefSummary, Event, MeasuredGrasp, Prompt, QueryRef, RobotTrack, Session, SessionError,
    Stage, Transition, TrialCursor, TrialRecord, TrialSlot, UndoPoint, VoidReason, VoidRecord,
};
use crate::ergo::{FeasibleSet, Observation, most_likely_in_region};

impl Event {
    /// The event as the operator would name it (in errors).
    pub fn name(&self) -> &'static str {
        match self {
            Event::QueryPresented { .. } => "query presented",
            Event::GraspRecorded { .. } => "grasp recorded",
            Event::TrialVoided { .. } => "trial voided",
            Event::GraspUndone => "undo",
            Event::Note { .. } => "note",
            Event::Paused => "pause",
            Event::Resumed => "resume",
            Event::LikertAnswered { .. } => "Likert answer",
            Event::ForcedChoice { .. } => "forced choice",
            Event::Ended => "end",
            Event::Aborted { .. } => "abort",
            Event::RobotCommanded { .. } => "robot command",
            Event::RobotReported { .. } => "robot report",
            Event::TransitionConfirmed { .. } => "transition confirmed",
        }
    }
}

impl Session {
    /// Folds one event into the state; on error the state is unchanged.
    pub fn apply(&mut self, event: &Event) -> Result<Applied, SessionError> {
        let name = event.name();
        if let Stage::Done { .. } = self.stage {
            return Err(not_now(name, "the session is over"));
        }
        // What the robot says is logged whenever it says it.
        if self.paused
            && !matches!(
                event,
                Event::Resumed | Event::Note { .. } | Event::Aborted { .. } | Event::RobotReported { .. }
            )
        {
            return Err(not_now(name, "the session is paused"));
        }
        let applied = match event {
            Event::QueryPresented { query } => self.present(name, query)?,
            Event::GraspRecorded { region, measured } => self.record_grasp(name, region, measured.as_ref())?,
            Event::GraspUndone => self.undo_grasp(name)?,
            Event::TrialVoided { reason, detail } => self.void(name, *reason, detail)?,
            Event::Note { text } => {
                self.notes.push(text.clone());
                Applied::Other
            }
            Event::Paused => {
                self.paused = true;
                Applied::Other
            }
            Event::Resumed => {
                if !self.paused {
                    return Err(not_now(name, "the session is not paused"));
                }
                self.paused = false;
                Applied::Other
            }
            Event::TransitionConfirmed { transition } => self.confirm(name, *transition)?,
            Event::LikertAnswered { program, item, value } => self.answer(name, *program, item, *value)?,
            Event::ForcedChoice { program } => self.choose(name, *program)?,
            Event::Ended => {
                if self.prompt() != Prompt::Finish {
                    return Err(not_now(name, "the questionnaire is not complete"));
                }
                self.stage = Stage::Done { completed: true };
                Applied::Ended { completed: true }
            }
            Event::Aborted { .. } => {
                self.stage = Stage::Done { completed: false };
                self.paused = false;
                Applied::Ended { completed: false }
            }
            Event::RobotCommanded { query, command, .. } => self.command_robot(name, query, command)?,
            Event::RobotReported { query, state, detail, command, stale } => {
                let attempt = match &mut self.robot {
                    // A report of format 4 on answers the command it names; an older one, the
                    // last command for its query.
                    Some(track)
                        if !stale && track.query == *query && (command.is_none() || *command == track.command) =>
                    {
                        track.last = Some((*state, detail.clone()));
                        Some(track.attempts)
                    }
                    _ => None,
                };
                Applied::RobotReported { attempt }
            }
        };
        self.events += 1;
        if matches!(
            event,
            Event::RobotCommanded { .. } | Event::RobotReported { .. } | Event::TransitionConfirmed { .. }
        ) {
            self.side_events += 1;
        }
        Ok(applied)
    }

    /// The trial under way, if any.
    pub(super) fn cursor(&self) -> Option<TrialCursor> {
        match self.stage {
            Stage::Trial(c) => Some(c),
            _ => None,
        }
    }

    fn present(&mut self, name: &'static str, query: &str) -> Result<Applied, SessionError> {
        let Some(cursor) = self.cursor() else {
            return Err(not_now(name, "no trial is waiting for a query"));
        };
        if cursor.presented {
            return Err(not_now(name, "the query is already presented; record the grasp or void the trial"));
        }
        let view = self.view(cursor);
        let expected = &self.query(view.query).query.id;
        if query != expected {
            return Err(SessionError::WrongQuery { found: query.to_string(), expected: expected.clone() });
        }
        self.stage = Stage::Trial(TrialCursor { presented: true, ..cursor });
        self.undo = None;
        let scores = view.program.map_or_else(Vec::new, |run| self.learners[run].scores.clone());
        Ok(Applied::Presented { view, scores })
    }

    fn command_robot(
        &mut self,
        name: &'static str,
        query: &str,
        command: &Option<String>,
    ) -> Result<Applied, SessionError> {
        let Some(cursor) = self.cursor().filter(|c| !c.presented) else {
            return Err(not_now(name, "no trial is waiting for its query to be presented"));
        };
        let view = self.view(cursor);
        let expected = &self.query(view.query).query.id;
        if query != expected {
            return Err(SessionError::WrongQuery { found: query.to_string(), expected: expected.clone() });
        }
        let attempts = self.robot.as_ref().filter(|t| t.query == query).map_or(0, |t| t.attempts) + 1;
        self.robot = Some(RobotTrack { query: query.to_string(), attempts, command: command.clone(), last: None });
        // The robot moves on: the last grasp is final.
        self.undo = None;
        Ok(Applied::RobotCommanded { view, attempt: attempts })
    }

    fn record_grasp(
        &mut self,
        name: &'static str,
        region: &str,
        measured: Option<&ArmMeasurement>,
    ) -> Result<Applied, SessionError> {
        let Some(cursor) = self.cursor().filter(|c| c.presented) else {
            return Err(not_now(name, "no query is presented"));
        };
        let view = self.view(cursor);
        let q = self.query(view.query);
        let object = self.study.object(q);
        let Some(r) = q.regions.iter().position(|&ri| object.regions[ri].id == region) else {
            let offered: Vec<_> = q.regions.iter().map(|&ri| object.regions[ri].id.clone()).collect();
            return Err(SessionError::UnknownRegion {
                region: region.to_string(),
                query: q.query.id.clone(),
                offered: offered.join(", "),
            });
        };
        // Field by field, so that the set and the settings are borrowed while a learner is
        // updated.
        let set: &FeasibleSet = match view.query {
            QueryRef::Training(i) => &self.menu[i],
            QueryRef::Test(i) => &self.tests[i],
        };
        let degenerate = |why: String| SessionError::Degenerate { query: q.query.id.clone(), why };
        let config = most_likely_in_region(set, r, &self.ctx.label_model)
            .ok_or_else(|| degenerate(format!("region '{region}' has no feasible configuration")))?;
        let measured = match measured {
            None => None,
            Some(m) => {
                let refuse = |why: String| SessionError::BadMeasurement { query: q.query.id.clone(), why };
                let Some(spec) = self.study.protocol.learning.measurement.as_ref() else {
                    return Err(refuse(format!(
                        "the protocol's observation is '{}', expected no measurement",
                        self.ctx.observation.name()
                    )));
                };
                if !(m.offset_s.is_finite() && m.offset_s.abs() <= spec.window_s) {
                    return Err(refuse(format!(
                        "offset_s is {}, expected a sample within the protocol's window of ±{} s of the grasp",
                        m.offset_s, spec.window_s
                    )));
                }
                let obs = Observation::measured(set.configs(), &m.q_rad, &self.ctx.sigma)
                    .map_err(|e| refuse(format!("q_rad: {e}")))?;
                let nearest = obs.nearest().expect("a measured observation of a non-empty set");
                Some(MeasuredGrasp { measurement: m.clone(), nearest, implied_region: set.region_of(nearest) })
            }
        };
        let record = TrialRecord {
            phase: view.phase,
            run: view.program,
            trial: view.trial,
            query: view.query,
            region: r,
            config,
            measured,
        };
        let mut undo = UndoPoint { cursor, learner: None, confirmed: self.confirmed.len() };
        let belief = match cursor.slot {
            TrialSlot::Training { run, .. } => {
                let obs = self.ctx.observation_of(set, &record);
                let ahead = self.ahead.as_ref().and_then(|a| a.learned(run, &self.learners[run], &obs));
                let adopted = ahead.is_some();
                let learner = match ahead {
                    Some(learner) => learner,
                    None => {
                        // Learn on a copy: a degenerate update leaves the session unchanged.
                        let mut learner = self.learners[run].clone();
                        let menu_index = learner.suggestion;
                        learner
                            .learn(menu_index, &obs, &self.menu, &self.ctx)
                            .map_err(|e| degenerate(e.to_string()))?;
                        learner
                    }
                };
                undo.learner = Some((run, std::mem::replace(&mut self.learners[run], learner)));
                self.adopted_ahead += usize::from(adopted);
                self.ahead = None;
                Some(self.learners[run].summary.clone())
            }
            TrialSlot::Test { .. } => None,
        };
        self.trials.push(record.clone());
        self.stage = self.next_stage(cursor.slot);
        self.robot = None;
        self.undo = Some(Box::new(undo));
        Ok(Applied::Responded { view, record, belief })
    }

    fn undo_grasp(&mut self, name: &'static str) -> Result<Applied, SessionError> {
        let Some(undo) = self.undo.take() else {
            return Err(not_now(name, "there is no grasp to undo since the last query was presented"));
        };
        let (cursor, belief) = self.restore(*undo);
        self.robot = None;
        Ok(Applied::Undone { view: self.view(cursor), belief })
    }

    fn void(&mut self, name: &'static str, reason: VoidReason, detail: &str) -> Result<Applied, SessionError> {
        let (cursor, retracted) = match (self.undo.take(), self.cursor()) {
            (Some(undo), _) => (self.restore(*undo).0, true),
            // Before its query is presented, a trial the robot was sent to can be voided (the
            // robot did not reach the pose).
            (None, Some(c)) if c.presented || self.robot.is_some() => (c, false),
            _ => return Err(not_now(name, "no trial is in progress")),
        };
        let view = self.view(cursor);
        self.voids.push(VoidRecord {
            phase: view.phase,
            run: view.program,
            trial: view.trial,
            query: view.query,
            reason,
            detail: detail.to_string(),
        });
        self.stage = Stage::Trial(TrialCursor { presented: false, ..cursor });
        self.robot = None;
        Ok(Applied::Voided { view, retracted })
    }

    fn answer(&mut self, name: &'static str, program: usize, item: &str, value: i64) -> Result<Applied, SessionError> {
        if self.stage != Stage::Questionnaire {
            return Err(not_now(name, "the questionnaire has not started"));
        }
        let items = &self.study.protocol.questionnaire.items;
        let Some(i) = items.iter().position(|it| it.id == item) else {
            return Err(SessionError::UnknownItem { item: item.to_string(), program });
        };
        if program >= self.learners.len() {
            return Err(SessionError::UnknownProgram(program));
        }
        let scale = &self.study.protocol.questionnaire.scale;
        if !scale.iter().any(|p| p.value == value) {
            return Err(SessionError::OffScale {
                value,
                min: scale.first().map_or(0, |p| p.value),
                max: scale.last().map_or(0, |p| p.value),
            });
        }
        self.likert.insert((program, i), value);
        Ok(Applied::Other)
    }

    fn choose(&mut self, name: &'static str, program: usize) -> Result<Applied, SessionError> {
        if self.stage != Stage::Questionnaire {
            return Err(not_now(name, "the questionnaire has not started"));
        }
        if program >= self.learners.len() {
            return Err(SessionError::UnknownProgram(program));
        }
        self.choice = Some(program);
        Ok(Applied::Other)
    }

    /// Takes back the last grasp: its record, its learning step, and the trial again awaits
    /// its grasp.
    fn confirm(&mut self, name: &'static str, transition: Transition) -> Result<Applied, SessionError> {
        if self.transition() != Some(transition) {
            return Err(not_now(name, format!("{transition:?} is not the transition waiting to be confirmed")));
        }
        self.confirmed.push(transition);
        Ok(Applied::Other)
    }

    fn restore(&mut self, undo: UndoPoint) -> (TrialCursor, Option<BeliefSummary>) {
        self.trials.pop();
        self.confirmed.truncate(undo.confirmed);
        let cursor = TrialCursor { presented: true, ..undo.cursor };
        self.stage = Stage::Trial(cursor);
        let belief = undo.learner.map(|(run, l)| {
            self.learners[run] = l;
            self.learners[run].summary.clone()
        });
        (cursor, belief)
    }
}

fn not_now(event: &'static str, why: impl Into<String>) -> SessionError {
    SessionError::NotNow { event, why: why.into() }
}
