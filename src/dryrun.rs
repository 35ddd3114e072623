//! Dry runs: whole sessions answered by simulated participants, logged as `pilot`.

use std::time::Duration;

use rand::SeedableRng;

use crate::ergo::Lambda;
use crate::participant::{ScriptedParticipant, SimulatedPerson};
use crate::protocol::Study;
use crate::record::{RecordedSession, SubmitError};
use crate::session::{SessionStart, Stamped, condition_order};
use crate::{SeededRng, derive_seed};

mod purpose {
    pub const ID: u64 = 301;
    pub const SESSION: u64 = 302;
    pub const TRUTH: u64 = 303;
}

/// One simulated participant's session, fully determined by the dry run's seed.
#[derive(Clone, Debug)]
pub struct DryRunPlan {
    pub start: SessionStart,
    pub participant: ScriptedParticipant,
}

/// The plan of simulated participant `index` (0-based): id, counterbalancing slot
/// (alternating), session seed, and ground truth (drawn from the prior unless given).
pub fn plan(study: &Study, seed: u64, index: usize, truth: Option<&Lambda>, started_at: String) -> DryRunPlan {
    let i = index as u64;
    let id = format!("pilot-{:06x}-{:02}", derive_seed(seed, 0, purpose::ID) & 0xff_ffff, index + 1);
    let slot = index % 2;
    let truth = truth.cloned().unwrap_or_else(|| {
        let prior = study.protocol.learning.prior().expect("a validated protocol's prior");
        Lambda::from_slice(&prior.sample(&mut SeededRng::seed_from_u64(derive_seed(seed, i, purpose::TRUTH))))
    });
    let session_seed = derive_seed(seed, i, purpose::SESSION);
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
    };
    let person = SimulatedPerson { truth, alpha: study.protocol.learning.alpha };
    DryRunPlan { start, participant: ScriptedParticipant { person } }
}

/// Nanoseconds since the Unix epoch.
pub fn now_ns() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64)
}

/// Lets the participant answer every prompt until the session is over, waiting `pace`
/// between actions.
pub fn drive(rec: &mut RecordedSession, participant: &ScriptedParticipant, pace: Duration) -> Result<(), SubmitError> {
    while let Some(event) = participant.respond(rec.session()) {
        if !pace.is_zero() {
            std::thread::sleep(pace);
        }
        rec.submit(Stamped { time_ns: now_ns(), event })?;
    }
    Ok(())
}
