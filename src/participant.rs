//! Simulated participants: a person with ground-truth cost parameters λ* who chooses among
//! feasible configurations with Boltzmann probability (eq. 1, 3).

use rand::RngExt;

use crate::SeededRng;
use crate::ergo::{FeasibleSet, Lambda, SetPass};

/// A Boltzmann chooser with ground truth λ* and rationality α.
#[derive(Clone, Debug, PartialEq)]
pub struct SimulatedPerson {
    pub truth: Lambda,
    pub alpha: f64,
}

impl SimulatedPerson {
    /// Draws a configuration index from P(q | Q, λ*) ∝ exp(−α C(q; λ*)).
    pub fn choose(&self, set: &FeasibleSet, rng: &mut SeededRng) -> usize {
        let mut scratch = SetPass::scratch(set.len());
        let pass = SetPass::run(set.configs(), &self.truth.q_star, &self.truth.w, self.alpha, &mut scratch);
        let target = rng.random::<f64>() * pass.sum;
        let mut acc = 0.0;
        for (j, e) in scratch.exps().iter().enumerate() {
            acc += e;
            if acc > target {
                return j;
            }
        }
        pass.argmin(&scratch)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ergo::ConfigSet;
    use rand::SeedableRng;

    #[test]
    fn choices_follow_the_boltzmann_distribution() {
        let set = FeasibleSet::new(ConfigSet::from_rows(&[[0.0], [1.0], [2.0]]).unwrap());
        let p = SimulatedPerson { truth: Lambda { q_star: vec![0.0], w: vec![1.0] }, alpha: 1.0 };
        let mut rng = SeededRng::seed_from_u64(1);
        let n = 200_000;
        let mut counts = [0usize; 3];
        for _ in 0..n {
            counts[p.choose(&set, &mut rng)] += 1;
        }
        let z = 1.0 + (-1.0f64).exp() + (-4.0f64).exp();
        for (j, c) in [0.0f64, 1.0, 4.0].iter().enumerate() {
            let want = (-c).exp() / z;
            let got = counts[j] as f64 / n as f64;
            assert!((got - want).abs() < 0.005, "config {j}: {got} vs {want}");
        }
    }
}

/// Why a participant id was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("participant id '{id}' is invalid: expected 1 to 32 characters from A–Z, a–z, 0–9 and '-'")]
pub struct BadId {
    pub id: String,
}

/// Checks an id against `[A-Za-z0-9-]{1,32}` (no paths, dots or spaces).
pub fn validate_id(id: &str) -> Result<(), BadId> {
    let ok = (1..=32).contains(&id.len()) && id.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-');
    if ok { Ok(()) } else { Err(BadId { id: id.to_string() }) }
}

/// Letters and digits that cannot be mistaken for one another when read aloud or written.
const ID_ALPHABET: &[u8] = b"abcdefghjkmnpqrstuvwxyz23456789";

/// A random, uninformative pseudonymous id such as `p-k3m9x2qa` (8 characters, ≈ 40 bits).
pub fn new_id<R: rand::Rng + ?Sized>(rng: &mut R) -> String {
    let tail: String = (0..8).map(|_| ID_ALPHABET[rng.random_range(0..ID_ALPHABET.len())] as char).collect();
    format!("p-{tail}")
}

/// `participants/<id>.json`: only what the study needs; never a name.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParticipantRecord {
    pub id: String,
    /// Counterbalancing slot: 0 runs the protocol's conditions in order, 1 reversed.
    pub slot: usize,
    /// Creation time, RFC 3339 UTC.
    pub created_at: String,
    /// Body height (m), for the arm model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub body_height_m: Option<f64>,
    /// The dominant hand, with which the participant takes the objects (the right when
    /// not recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub handedness: Option<crate::kinematics::Hand>,
    /// When the participant withdrew (RFC 3339 UTC): no new session is started for them,
    /// `analyze` leaves their sessions out and their counterbalancing slot is free again.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub withdrawn_at: Option<String>,
}

/// Why a participant record could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum RecordFileError {
    #[error(transparent)]
    BadId(#[from] BadId),
    #[error("{path}: {source}")]
    Io { path: std::path::PathBuf, source: std::io::Error },
    #[error("{path}: {message}")]
    Invalid { path: std::path::PathBuf, message: String },
}

impl ParticipantRecord {
    /// The body the participant's sessions are run for.
    pub fn body(&self) -> crate::protocol::Body {
        crate::protocol::Body { height_m: self.body_height_m, hand: self.handedness.unwrap_or_default() }
    }

    /// The record's file in a participants directory.
    pub fn path(dir: &std::path::Path, id: &str) -> Result<std::path::PathBuf, BadId> {
        validate_id(id)?;
        Ok(dir.join(format!("{id}.json")))
    }

    /// Writes a new record (owner-readable only, synced); fails if one exists, and leaves no
    /// file behind if the write fails (a full disk, say).
    pub fn create(&self, dir: &std::path::Path) -> Result<std::path::PathBuf, RecordFileError> {
        self.validate().map_err(|message| RecordFileError::Invalid { path: dir.to_path_buf(), message })?;
        let path = Self::path(dir, &self.id)?;
        let err = |source| RecordFileError::Io { path: path.clone(), source };
        crate::private_files::create_dir(dir).map_err(err)?;
        let mut text = serde_json::to_string_pretty(self).map_err(|e| err(std::io::Error::other(e)))?;
        text.push('\n');
        crate::private_files::write_new(&path, text.as_bytes()).map_err(err)?;
        Ok(path)
    }

    /// Checks every field with the rules used on creation.
    pub fn validate(&self) -> Result<(), String> {
        validate_id(&self.id).map_err(|e| format!("id: {e}"))?;
        if self.slot >= 2 {
            return Err(format!("slot is {}, expected 0 or 1 (the orders AB and BA)", self.slot));
        }
        if chrono::DateTime::parse_from_rfc3339(&self.created_at).is_err() {
            return Err(format!("created_at '{}' is not an RFC 3339 time", self.created_at.escape_debug()));
        }
        if let Some(w) = &self.withdrawn_at
            && chrono::DateTime::parse_from_rfc3339(w).is_err()
        {
            return Err(format!("withdrawn_at '{}' is not an RFC 3339 time", w.escape_debug()));
        }
        if let Some(h) = self.body_height_m
            && !(BODY_HEIGHT_M.0..=BODY_HEIGHT_M.1).contains(&h)
        {
            return Err(format!(
                "body_height_m is {h}, expected metres from {} to {}",
                BODY_HEIGHT_M.0, BODY_HEIGHT_M.1
            ));
        }
        Ok(())
    }

    /// Marks the record withdrawn (now), replacing the file atomically (a new owner-only file
    /// renamed over the old one, so a crash leaves the old or the new record, never a part).
    /// Withdrawing twice keeps the first time.
    pub fn withdraw(dir: &std::path::Path, id: &str, now: &str) -> Result<Self, RecordFileError> {
        let mut rec = Self::load(dir, id)?;
        if rec.withdrawn_at.is_some() {
            return Ok(rec);
        }
        rec.withdrawn_at = Some(now.to_string());
        rec.validate().map_err(|message| RecordFileError::Invalid { path: dir.to_path_buf(), message })?;
        let path = Self::path(dir, id)?;
        let err = |source| RecordFileError::Io { path: path.clone(), source };
        let mut text = serde_json::to_string_pretty(&rec).map_err(|e| err(std::io::Error::other(e)))?;
        text.push('\n');
        crate::private_files::replace(&path, text.as_bytes()).map_err(err)?;
        Ok(rec)
    }

    /// Whether the participant has withdrawn.
    pub fn is_withdrawn(&self) -> bool {
        self.withdrawn_at.is_some()
    }

    /// Reads and validates a participant's record (at most 64 KiB).
    pub fn load(dir: &std::path::Path, id: &str) -> Result<Self, RecordFileError> {
        let path = Self::path(dir, id)?;
        let io = |source| RecordFileError::Io { path: path.clone(), source };
        let invalid = |message: String| RecordFileError::Invalid { path: path.clone(), message };
        let bytes = crate::input_file::read_regular(&path, MAX_RECORD_BYTES).map_err(io)?;
        let rec: Self = crate::input_file::parse_json_bytes(&bytes).map_err(|e| invalid(e.to_string()))?;
        rec.validate().map_err(invalid)?;
        if rec.id != id {
            return Err(invalid(format!("id is '{}', expected '{id}'", crate::text::printable(&rec.id))));
        }
        Ok(rec)
    }
}

/// `participants/<id>.deleted.json`: all that is kept of a participant whose data was deleted
/// on withdrawal — the id and the dates, no data — so that a copy of one of their logs (a
/// backup, say) is still left out by `analyze` and never continued by `resume`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tombstone {
    pub id: String,
    /// When the participant withdrew (RFC 3339 UTC).
    pub withdrawn_at: String,
    /// When their logs and record were deleted (RFC 3339 UTC).
    pub data_deleted_at: String,
}

impl Tombstone {
    /// The tombstone's file in a participants directory.
    pub fn path(dir: &std::path::Path, id: &str) -> Result<std::path::PathBuf, BadId> {
        validate_id(id)?;
        Ok(dir.join(format!("{id}.deleted.json")))
    }

    /// Writes the tombstone (owner-only, synced, atomically replacing an earlier one).
    pub fn write(&self, dir: &std::path::Path) -> Result<std::path::PathBuf, RecordFileError> {
        let path = Self::path(dir, &self.id)?;
        let err = |source| RecordFileError::Io { path: path.clone(), source };
        for t in [&self.withdrawn_at, &self.data_deleted_at] {
            if chrono::DateTime::parse_from_rfc3339(t).is_err() {
                let message = format!("'{}' is not an RFC 3339 time", t.escape_debug());
                return Err(RecordFileError::Invalid { path: path.clone(), message });
            }
        }
        let mut text = serde_json::to_string_pretty(self).map_err(|e| err(std::io::Error::other(e)))?;
        text.push('\n');
        crate::private_files::replace(&path, text.as_bytes()).map_err(err)?;
        Ok(path)
    }

    /// Reads a participant's tombstone, if there is one (a regular file of at most 64 KiB).
    pub fn load(dir: &std::path::Path, id: &str) -> Result<Self, RecordFileError> {
        let path = Self::path(dir, id)?;
        let invalid = |message: String| RecordFileError::Invalid { path: path.clone(), message };
        let bytes = crate::input_file::read_regular(&path, MAX_RECORD_BYTES)
            .map_err(|e| RecordFileError::Io { path: path.clone(), source: e })?;
        let t: Self = crate::input_file::parse_json_bytes(&bytes).map_err(|e| invalid(e.to_string()))?;
        if t.id != id {
            return Err(invalid(format!("id is '{}', expected '{id}'", crate::text::printable(&t.id))));
        }
        Ok(t)
    }
}

/// The ids of the regular files `<id><suffix>` in a folder, in id order.
fn ids_with_suffix(dir: &std::path::Path, suffix: &str) -> Vec<String> {
    ids_with_suffix_reporting(dir, suffix).0
}

/// [`ids_with_suffix`], and why the folder could not be listed (a missing folder is no
/// problem: nobody is registered yet).
fn ids_with_suffix_reporting(dir: &std::path::Path, suffix: &str) -> (Vec<String>, Option<String>) {
    let entries = match std::fs::read_dir(dir) {
        Ok(entries) => entries,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return (Vec::new(), None),
        Err(e) => return (Vec::new(), Some(format!("the folder cannot be listed ({e})"))),
    };
    let mut ids: Vec<String> = entries
        .flatten()
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
        .filter_map(|e| e.file_name().to_str()?.strip_suffix(suffix).map(str::to_string))
        .filter(|id| !id.ends_with(".deleted") && validate_id(id).is_ok())
        .collect();
    ids.sort();
    (ids, None)
}

/// The participant records in a folder (`<id>.json`, in id order), and the files (or the
/// folder) that could not be read, with why: never passed over in silence.
pub fn registered(participants: &std::path::Path) -> (Vec<ParticipantRecord>, Vec<(std::path::PathBuf, String)>) {
    let (ids, unlistable) = ids_with_suffix_reporting(participants, ".json");
    let mut problems: Vec<(std::path::PathBuf, String)> =
        unlistable.into_iter().map(|why| (participants.to_path_buf(), why)).collect();
    let mut records = Vec::new();
    for id in ids {
        match ParticipantRecord::load(participants, &id) {
            Ok(r) => records.push(r),
            Err(e) => problems.push((participants.join(format!("{id}.json")), e.to_string())),
        }
    }
    (records, problems)
}

/// The ids whose data was deleted on withdrawal (`<id>.deleted.json`), in id order.
pub fn deleted(participants: &std::path::Path) -> Vec<String> {
    ids_with_suffix(participants, ".deleted.json")
        .into_iter()
        .filter(|id| Tombstone::load(participants, id).is_ok())
        .collect()
}

/// Whether the participant withdrew: `participants/<id>.json` says so, or their data was
/// deleted and `participants/<id>.deleted.json` is all that is left (a missing or unreadable
/// record says nothing).
pub fn has_withdrawn(participants: &std::path::Path, id: &str) -> bool {
    ParticipantRecord::load(participants, id).is_ok_and(|r| r.is_withdrawn())
        || Tombstone::load(participants, id).is_ok()
}

/// The body heights the arm model serves (m), as checked on a record and on the command line.
pub const BODY_HEIGHT_M: (f64, f64) = (0.5, 2.5);
/// The largest participant record read.
pub(crate) const MAX_RECORD_BYTES: u64 = 64 << 10;

#[cfg(test)]
mod id_tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn ids_are_checked() {
        for ok in ["p-k3m9x2qa", "P01", "a", &"x".repeat(32)] {
            assert!(validate_id(ok).is_ok(), "{ok}");
        }
        for bad in ["", "../etc", "a b", "p.1", "p/1", "é", &"x".repeat(33)] {
            assert!(validate_id(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn new_ids_are_valid_and_differ() {
        let mut rng = SeededRng::seed_from_u64(1);
        let a = new_id(&mut rng);
        let b = new_id(&mut rng);
        assert!(validate_id(&a).is_ok() && a != b && a.len() == 10);
    }
}

/// A simulated participant for dry runs and rehearsals: answers every prompt of a session,
/// reproducibly from the session seed and the number of events so far (so a resumed dry
/// run answers exactly as an uninterrupted one).
#[derive(Clone, Debug, PartialEq)]
pub struct ScriptedParticipant {
    pub person: SimulatedPerson,
}

/// Purpose tag of the per-event RNG.
const RESPOND: u64 = 201;

impl ScriptedParticipant {
    /// The event that answers the session's prompt (the robot operator's part included);
    /// `None` when the session is over.
    pub fn respond(&self, session: &crate::session::Session) -> Option<crate::session::Event> {
        use crate::session::{Event, Prompt};
        use rand::SeedableRng;
        let mut rng = SeededRng::seed_from_u64(crate::derive_seed(
            session.start().seed,
            session.participant_events() as u64,
            RESPOND,
        ));
        // In a dry run the simulated experimenter tells the participant what comes next.
        if let Some(transition) = session.transition() {
            return Some(Event::TransitionConfirmed { transition });
        }
        Some(match session.prompt() {
            Prompt::Present(view) => Event::QueryPresented { query: session.query(view.query).query.id.clone() },
            Prompt::Grasp(view) => {
                let set = session.set(view.query);
                let chosen = self.person.choose(set, &mut rng);
                let q = session.query(view.query);
                let region = session.study().object(q).regions[q.regions[set.region_of(chosen)]].id.clone();
                // A measuring system sees the configuration taken with the protocol's noise.
                let measured = session.study().protocol.learning.measurement.as_ref().map(|m| {
                    let q_rad = set
                        .configs()
                        .config(chosen)
                        .iter()
                        .zip(m.sigma_rad())
                        .map(|(q, sigma)| {
                            let noise = rand_distr::Normal::new(0.0, sigma).expect("a validated, positive σ");
                            q + rand_distr::Distribution::sample(&noise, &mut rng)
                        })
                        .collect();
                    crate::session::ArmMeasurement {
                        q_rad,
                        source: crate::session::MeasurementSource::Simulated,
                        offset_s: 0.0,
                    }
                });
                Event::GraspRecorded { region, measured }
            }
            Prompt::Likert { program, item, .. } => {
                let scale = &session.study().protocol.questionnaire.scale;
                let base = if self.preferred(session) == program { scale.len() * 3 / 4 } else { scale.len() / 2 };
                let k = (base as i64 + rng.random_range(-1..=1)).clamp(0, scale.len() as i64 - 1) as usize;
                Event::LikertAnswered {
                    program,
                    item: session.study().protocol.questionnaire.items[item].id.clone(),
                    value: scale[k].value,
                }
            }
            Prompt::ForcedChoice => {
                let p = self.preferred(session);
                let program = if rng.random::<f64>() < 0.8 { p } else { 1 - p.min(1) };
                Event::ForcedChoice { program }
            }
            Prompt::Finish => Event::Ended,
            Prompt::Paused => Event::Resumed,
            Prompt::Done { .. } => return None,
        })
    }

    /// The program whose training handovers cost this person less on average.
    fn preferred(&self, session: &crate::session::Session) -> usize {
        let mut best = (0, f64::INFINITY);
        for run in 0..session.learners().len() {
            let costs: Vec<f64> = session
                .trials()
                .iter()
                .filter(|t| t.run == Some(run))
                .map(|t| {
                    let q = session.set(t.query).configs().config(t.config);
                    crate::ergo::cost(&q, &self.person.truth.q_star, &self.person.truth.w)
                })
                .collect();
            let mean = costs.iter().sum::<f64>() / costs.len().max(1) as f64;
            if mean < best.1 {
                best = (run, mean);
            }
        }
        best.0
    }
}
