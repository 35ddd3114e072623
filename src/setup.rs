//! Setting up a console session, outside the console: the plan (who, which slot, the
//! protocol as run for their body, where the log goes) and starting it (the participant's
//! lock, their record, the log). The console shows the plan and asks for the start.

use std::path::PathBuf;
use std::sync::Arc;

use rand::RngExt;

use crate::dryrun::{now_ns, plan};
use crate::participant::{ParticipantRecord, RecordFileError, ScriptedParticipant, new_id, validate_id};
use crate::protocol::{Study, for_body};
use crate::record::{RecordError, RecordedSession, new_log_path};
use crate::session::{Session, SessionError, SessionStart, condition_order};
use crate::study_dir::{LockError, ParticipantLock, StudyDirs};

/// What a console session is set up from.
#[derive(Clone, Debug)]
pub struct SetupConfig<'a> {
    pub study: &'a Arc<Study>,
    pub protocol_text: &'a str,
    pub dirs: &'a StudyDirs,
    /// "new" or an existing participant's id.
    pub participant: &'a str,
    /// A simulated participant answers (a rehearsal; the log is flagged pilot).
    pub simulate: bool,
    /// A pilot with a real person, of this body: a `pilot-` id, no record, the log flagged
    /// pilot, the protocol fitted to the body as to a participant's.
    pub pilot: Option<crate::protocol::Body>,
    /// The session seed (random when absent).
    pub seed: Option<u64>,
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
    /// The study's folders, and whether the study is new: neither its participants' nor its
    /// logs' folder exists yet, so counterbalancing starts afresh (read once, when planned).
    pub folders: String,
    pub new_folders: bool,
    /// The counterbalancing so far, one line (none for a rehearsal).
    pub balance: Option<String>,
}

/// Why a planned session could not start (nothing of it is left behind but what is said).
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// The plan says why it cannot run (an unknown or withdrawn participant, a body the
    /// protocol cannot serve).
    #[error("cannot start: {0}")]
    Plan(String),
    #[error("cannot start: {0}")]
    Lock(#[from] LockError),
    #[error("cannot create the participant record: {0}")]
    Record(#[from] RecordFileError),
    #[error("{0}")]
    Session(#[from] SessionError),
    #[error("cannot create the log: {0}")]
    Log(#[from] RecordError),
}

/// The plan of a new session.
pub fn plan_session(c: &SetupConfig) -> Plan {
    let study = c.study;
    let seed = c.seed.unwrap_or_else(|| crate::session_seed(rand::rng().random()));
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
            protocol_text: c.protocol_text.to_string(),
            folders: c.dirs.describe(),
            new_folders: c.dirs.missing().len() == 2,
            balance: None,
        };
    }
    let (mut study, mut protocol_text) = (Arc::clone(study), c.protocol_text.to_string());
    // Where the study stands (the setup screen's line) and the next slot, from one reading.
    let status = crate::study_status::study_status(c.dirs, &study);
    let balance = format!("{} · {}", status.summary_line(), status.counts.describe());
    let next_slot = status.next_slot;
    let (id, slot, new_record, error) = if let Some(body) = c.pilot {
        // Kept apart as dry runs are: no record, no slot of the study's taken.
        let id = format!("pilot-{}", new_id(&mut rand::rng()).trim_start_matches("p-"));
        match for_body(c.protocol_text, &study.source_name, body) {
            Ok((text, fitted)) => {
                (study, protocol_text) = (Arc::new(fitted), text);
                (id, next_slot, None, None)
            }
            Err(e) => (id, next_slot, None, Some(e.to_string())),
        }
    } else if c.participant == "new" {
        let id = new_id(&mut rand::rng());
        let slot = next_slot;
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
        match ParticipantRecord::load(&c.dirs.participants, c.participant) {
            Ok(r) if r.is_withdrawn() => {
                let why = format!(
                    "participant {} withdrew from the study ({}): no new session can be started for them",
                    r.id,
                    r.withdrawn_at.as_deref().unwrap_or_default()
                );
                (r.id, r.slot, None, Some(why))
            }
            Ok(r) => match crate::record::open_sessions(&c.dirs.logs.join(&r.id)).first() {
                // One session per participant at a time: the unfinished one is continued (one
                // that a console runs now is refused by the participant's lock, which says so).
                Some(open) if crate::study_dir::holder_running(&c.dirs.logs.join(&r.id)) != Some(true) => {
                    let why = format!(
                        "participant {} has an unfinished session ({}, {} events recorded): continue it with: {}",
                        r.id,
                        open.path.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned()),
                        open.events.len(),
                        c.dirs.resume_command(&r.id)
                    );
                    (r.id, r.slot, None, Some(why))
                }
                _ => match for_body(c.protocol_text, &study.source_name, r.body()) {
                    Ok((text, fitted)) => {
                        (study, protocol_text) = (Arc::new(fitted), text);
                        (r.id, r.slot, None, None)
                    }
                    Err(e) => (r.id, r.slot, None, Some(e.to_string())),
                },
            },
            Err(e) => {
                let why = match crate::participant::Tombstone::load(&c.dirs.participants, c.participant) {
                    Ok(t) => format!(
                        "participant {} withdrew from the study ({}) and their data was deleted: no new session can be started for them",
                        t.id, t.withdrawn_at
                    ),
                    Err(_) => e.to_string(),
                };
                (c.participant.to_string(), 0, None, Some(why))
            }
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
        pilot: c.pilot.is_some(),
        slot,
        started_at,
        simulated_truth: None,
        resumed_from: None,
        selection: None,
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
        new_folders: c.dirs.missing().len() == 2,
        balance: Some(balance),
    }
}

/// The participant's lock for a plan (one live session per participant).
pub fn lock_for(plan: &Plan) -> Result<ParticipantLock, SetupError> {
    let dir = plan.log_path.parent().unwrap_or(std::path::Path::new("."));
    Ok(ParticipantLock::acquire(dir, &plan.start.participant, "console")?)
}

/// Starts a planned session: creates the participant's record if the plan has a new one
/// (once: a retry after a later failure does not make it again), then the session and its
/// log. The caller holds the participant's lock ([`lock_for`]).
pub fn start_session(plan: &mut Plan, dirs: &StudyDirs) -> Result<RecordedSession, SetupError> {
    if let Some(e) = &plan.error {
        return Err(SetupError::Plan(e.clone()));
    }
    if let Some(rec) = &plan.new_record {
        rec.create(&dirs.participants)?;
        plan.new_record = None;
    }
    let session = Session::new(Arc::clone(&plan.study), plan.start.clone())?;
    Ok(RecordedSession::create(&plan.log_path, &plan.protocol_text, session, now_ns())?)
}
