//! Learning ahead: while a participant reaches for the object, the learner after each grip
//! they may take is computed, so that the key that records the grip adopts it instead of
//! waiting for the update and the next suggestion. Learning is deterministic in the learner
//! and the observation, so an adopted learner is the one the update would compute, bit for
//! bit, and the log is the same with or without learning ahead.

use std::sync::Arc;

use super::learner::Learner;
use super::{QueryRef, Session, TrialRecord, TrialSlot};
use crate::ergo::{Observation, most_likely_in_region};

/// The learners computed ahead for one learner state and the query it suggested.
#[derive(Debug)]
pub(super) struct Ahead {
    run: usize,
    /// [`Learner::generation`] of the state they were learned from.
    generation: u64,
    /// Per outcome: the observation and the learner after it.
    outcomes: Vec<(Observation, Arc<Learner>)>,
}

impl Ahead {
    /// The learner computed ahead for `obs` learned by `learner` (run `run`), if any.
    pub(super) fn learned(&self, run: usize, learner: &Learner, obs: &Observation) -> Option<Learner> {
        if self.run != run || self.generation != learner.generation() {
            return None;
        }
        self.outcomes.iter().find(|(o, _)| o == obs).map(|(_, l)| Learner::clone(l))
    }
}

impl Session {
    /// Learns ahead for the presented training query: for each region offered (as the
    /// operator's key records it, without a measurement), the learner after it, the next
    /// suggestion included. `stop` is asked before each outcome (a key waiting ends the
    /// work; what is done is kept and the next call goes on from there). Returns whether
    /// every outcome is ready (also when nothing is presented).
    pub fn speculate(&mut self, stop: &mut dyn FnMut() -> bool) -> bool {
        let Some(cursor) = self.cursor().filter(|c| c.presented) else { return true };
        let TrialSlot::Training { run, .. } = cursor.slot else { return true };
        let view = self.view(cursor);
        let QueryRef::Training(menu_index) = view.query else { return true };
        let learner = &self.learners[run];
        let mut outcomes = match self.ahead.take() {
            Some(a) if a.run == run && a.generation == learner.generation() => a.outcomes.clone(),
            _ => Vec::new(),
        };
        let set = &self.menu[menu_index];
        let regions = self.query(view.query).regions.len();
        let mut complete = true;
        for region in 0..regions {
            let Some(config) = most_likely_in_region(set, region, &self.ctx.label_model) else { continue };
            let record = TrialRecord {
                phase: view.phase,
                run: view.program,
                trial: view.trial,
                query: view.query,
                region,
                config,
                measured: None,
            };
            let obs = self.ctx.observation_of(set, &record);
            if outcomes.iter().any(|(o, _)| *o == obs) {
                continue;
            }
            if stop() {
                complete = false;
                break;
            }
            let mut next = learner.clone();
            // A degenerate update is left to the response, which reports it.
            if next.learn(menu_index, &obs, &self.menu, &self.ctx).is_ok() {
                outcomes.push((obs, Arc::new(next)));
            }
        }
        self.ahead = Some(Arc::new(Ahead { run, generation: learner.generation(), outcomes }));
        complete
    }

    /// How many responses adopted a learner computed ahead (for tests and timing).
    pub fn adopted_ahead(&self) -> usize {
        self.adopted_ahead
    }
}
