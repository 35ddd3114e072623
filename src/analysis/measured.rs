//! Post-hoc arm measurements (`analyze --measurements FILE`): a CSV of time-stamped joint
//! angles from a motion-capture system, aligned to a session's grasps by time, and the
//! session re-fitted with the measured observation model beside its logged fit.
//!
//! The file is untrusted: its size, its number of samples and every value are bounded, and
//! a bad field is named with its row and column.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::ergo::{FeasibleSet, Observation};
use crate::kinematics::JOINTS;
use crate::protocol::Study;
use crate::protocol::{MeasurementSpec, ObservationModel};
use crate::record::{LogContents, RecordError, replay_with};
use crate::session::{
    Applied, ArmMeasurement, BeliefSummary, Learner, MeasurementSource, QueryRef, Session, SessionError, TrialRecord,
};

/// The largest measurements file read, bytes.
pub const MAX_MEASUREMENT_BYTES: u64 = 256 << 20;
/// The most samples read from one file (≈ 11 h at 50 Hz).
pub const MAX_MEASUREMENT_SAMPLES: usize = 2_000_000;
/// The most points × frames of a C3D file (what its reader allocates for: 60 markers for
/// 10 minutes at 200 Hz is 7.2 million).
pub(crate) const MAX_C3D_POINT_FRAMES: usize = 8_000_000;

/// Why a measurements file was refused.
#[derive(Debug, thiserror::Error)]
#[error("{}: {why}", path.display())]
pub struct MeasurementFileError {
    pub path: PathBuf,
    pub why: String,
}

/// Time-stamped joint angles (rad) in the arm model's joint order, in increasing time.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasurementSeries {
    pub path: PathBuf,
    /// (ns since the Unix epoch, angles).
    pub samples: Vec<(u64, [f64; JOINTS])>,
}

/// Parses a sample time: seconds since the Unix epoch (a decimal number, read to the
/// nanosecond without going through a float) or RFC 3339.
fn parse_time(text: &str) -> Option<u64> {
    if let Some(ns) = decimal_seconds_ns(text) {
        return Some(ns);
    }
    if let Ok(s) = text.parse::<f64>() {
        return (s.is_finite() && (0.0..=4.0e9).contains(&s)).then(|| (s * 1e9).round() as u64);
    }
    let t = chrono::DateTime::parse_from_rfc3339(text).ok()?;
    u64::try_from(t.timestamp_nanos_opt()?).ok()
}

/// `SECONDS[.FRACTION]` (digits only) as nanoseconds, exactly: a fraction's first nine digits
/// are the nanoseconds, the tenth rounds them. Seconds up to 4e9, as [`parse_time`] accepts.
fn decimal_seconds_ns(text: &str) -> Option<u64> {
    let (whole, fraction) = text.split_once('.').unwrap_or((text, ""));
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    if !digits(whole) || !(fraction.is_empty() || digits(fraction)) || whole.len() > 10 {
        return None;
    }
    let seconds: u64 = whole.parse().ok()?;
    if seconds > 4_000_000_000 {
        return None;
    }
    let mut ns: u64 = 0;
    for k in 0..9 {
        ns = ns * 10 + fraction.as_bytes().get(k).map_or(0, |b| u64::from(b - b'0'));
    }
    if fraction.as_bytes().get(9).is_some_and(|b| *b >= b'5') {
        ns += 1;
    }
    Some(seconds * 1_000_000_000 + ns)
}

impl MeasurementSeries {
    /// Reads a CSV with a `time` column (seconds since the Unix epoch, or RFC 3339) and, for
    /// each of `joint_names` (the protocol's measuring-system names, in the model's order), a
    /// column `<name>_deg` or `<name>_rad`; other columns are ignored. Rows in increasing time.
    pub fn read_csv(path: &Path, joint_names: &[String]) -> Result<Self, MeasurementFileError> {
        let fail = |why: String| MeasurementFileError { path: path.to_path_buf(), why };
        let file = crate::input_file::open_bounded(path, MAX_MEASUREMENT_BYTES).map_err(|e| fail(e.to_string()))?;
        let mut reader = csv::ReaderBuilder::new().from_reader(file);
        let header = reader.headers().map_err(|e| fail(format!("header: {e}")))?.clone();
        let column = |name: &str| header.iter().position(|h| h.trim() == name);
        let time = column("time").ok_or_else(|| fail("header: no 'time' column".into()))?;
        let mut joints = Vec::with_capacity(JOINTS);
        for name in joint_names {
            let (deg, rad) = (format!("{name}_deg"), format!("{name}_rad"));
            match (column(&deg), column(&rad)) {
                (Some(c), None) => joints.push((c, true, deg)),
                (None, Some(c)) => joints.push((c, false, rad)),
                (Some(_), Some(_)) => return Err(fail(format!("header: both '{deg}' and '{rad}', expected one"))),
                (None, None) => return Err(fail(format!("header: no '{deg}' or '{rad}' column for joint '{name}'"))),
            }
        }
        if joints.len() != JOINTS {
            return Err(fail(format!("{} joint names, expected {JOINTS}", joints.len())));
        }
        let mut samples: Vec<(u64, [f64; JOINTS])> = Vec::new();
        for (i, record) in reader.records().enumerate() {
            let row = i + 2;
            let record = record.map_err(|e| fail(format!("row {row}: {e}")))?;
            if samples.len() == MAX_MEASUREMENT_SAMPLES {
                return Err(fail(format!("has more than {MAX_MEASUREMENT_SAMPLES} samples (the sample budget)")));
            }
            let field = |c: usize| record.get(c).unwrap_or("").trim();
            let t = parse_time(field(time)).ok_or_else(|| {
                fail(format!(
                    "row {row}, column 'time': '{}' is not seconds since the Unix epoch or an RFC 3339 time",
                    field(time).escape_debug()
                ))
            })?;
            if samples.last().is_some_and(|(last, _)| t <= *last) {
                return Err(fail(format!(
                    "row {row}, column 'time': not after the previous row's (rows in time order)"
                )));
            }
            let mut q = [0.0; JOINTS];
            for (d, (c, degrees, name)) in joints.iter().enumerate() {
                let v: f64 = field(*c).parse().map_err(|_| {
                    fail(format!("row {row}, column '{name}': '{}' is not a number", field(*c).escape_debug()))
                })?;
                let rad = if *degrees { v.to_radians() } else { v };
                if !(rad.is_finite() && rad.abs() <= 10.0) {
                    return Err(fail(format!("row {row}, column '{name}': {v} is not an angle within ±10 rad")));
                }
                q[d] = rad;
            }
            samples.push((t, q));
        }
        if samples.is_empty() {
            return Err(fail("has no samples".into()));
        }
        Ok(Self { path: path.to_path_buf(), samples })
    }

    /// Reads the joint angles of a C3D file (a maintained pure-Rust reader, `c3dio`): each joint
    /// name is `<point label>.<x|y|z>`, the component of a point that holds angles in degrees
    /// (as Vicon's Plug-in Gait writes `RShoulderAngles`, `RElbowAngles`, …). C3D has no
    /// wall-clock time: frame k (from 0) is at `start_ns` + k / rate. A frame whose point is
    /// invalid (a negative residual) gives no sample.
    pub fn read_c3d(path: &Path, joint_names: &[String], start_ns: u64) -> Result<Self, MeasurementFileError> {
        let fail = |why: String| MeasurementFileError { path: path.to_path_buf(), why };
        let bytes = crate::input_file::read_regular(path, MAX_MEASUREMENT_BYTES).map_err(|e| fail(e.to_string()))?;
        check_c3d_header(&bytes).map_err(|why| fail(format!("not a C3D file the reader can take: {why}")))?;
        // The reader is not hardened against every malformed file: a panic is a refusal.
        let c3d = quietly(|| c3dio::C3d::from_bytes(&bytes).map_err(|e| format!("{e:?}")))
            .ok_or_else(|| fail("the C3D reader could not parse it".into()))?
            .map_err(|e| fail(format!("not a C3D file: {e}")))?;
        let points = &c3d.points;
        let rate = f64::from(points.frame_rate);
        if !(rate.is_finite() && (1.0..=10_000.0).contains(&rate)) {
            return Err(fail(format!("POINT:RATE is {rate}, expected 1 to 10000 frames a second")));
        }
        let mut columns = Vec::with_capacity(JOINTS);
        for name in joint_names {
            let (label, axis) = name
                .rsplit_once('.')
                .and_then(|(l, a)| Some((l, ["x", "y", "z"].iter().position(|c| *c == a)?)))
                .ok_or_else(|| fail(format!("joint name '{name}' is not '<point label>.<x|y|z>'")))?;
            let column = points
                .labels
                .iter()
                .position(|l| l.trim() == label)
                .ok_or_else(|| fail(format!("no point labelled '{label}' (for joint '{name}')")))?;
            columns.push((column, axis));
        }
        let frames = points.points.rows();
        if frames > MAX_MEASUREMENT_SAMPLES {
            return Err(fail(format!(
                "has {frames} frames, expected at most {MAX_MEASUREMENT_SAMPLES} (the sample budget)"
            )));
        }
        let mut samples = Vec::with_capacity(frames);
        'frames: for k in 0..frames {
            let mut q = [0.0; JOINTS];
            for (d, &(column, axis)) in columns.iter().enumerate() {
                let Some(p) = points.points.get(k, column) else { continue 'frames };
                let v = f64::from(p.point[axis]).to_radians();
                if p.residual < 0.0 || !(v.is_finite() && v.abs() <= 10.0) {
                    continue 'frames;
                }
                q[d] = v;
            }
            samples.push((start_ns + (k as f64 / rate * 1e9).round() as u64, q));
        }
        if samples.is_empty() {
            return Err(fail("has no frame with every joint's angle".into()));
        }
        Ok(Self { path: path.to_path_buf(), samples })
    }

    /// The grasp's sample by [`ArmMeasurement::pick`]'s rule (the latest at or before
    /// `time_ns`, within `window_s`), as a measurement at that time.
    pub fn at(&self, time_ns: u64, window_s: f64) -> Option<ArmMeasurement> {
        let i = self.samples.partition_point(|(t, _)| *t <= time_ns);
        ArmMeasurement::pick(self.samples[..i].iter().rev().take(1), time_ns, window_s, MeasurementSource::File)
    }
}

/// The most points a C3D file may have.
const MAX_C3D_POINTS: usize = 10_000;

/// Checks what the C3D reader trusts before it reads: the parameter block's place, the
/// processor type, and the frames × points the data section implies (a budget).
fn check_c3d_header(bytes: &[u8]) -> Result<(), String> {
    if bytes.len() < 1024 {
        return Err(format!("{} bytes, shorter than a header and a parameter block", bytes.len()));
    }
    let block = usize::from(bytes[0]);
    if block < 2 || bytes.len() < 512 * block {
        return Err(format!(
            "the parameter block is said to start at block {block}, expected 2 or more within the file"
        ));
    }
    let processor = bytes[512 * (block - 1) + 3];
    // 84 Intel, 85 DEC, 86 MIPS: the byte order, and where the scale factor's sign bit is
    // (a negative scale factor says the data are floats).
    let (big_endian, sign_byte) = match processor {
        84 => (false, 15),
        85 => (false, 13),
        86 => (true, 12),
        other => return Err(format!("processor type {other}, expected 84, 85 or 86")),
    };
    let word = |i: usize| {
        let b = [bytes[i], bytes[i + 1]];
        usize::from(if big_endian { u16::from_be_bytes(b) } else { u16::from_le_bytes(b) })
    };
    let (points, analog, first, last, data_block) = (word(2), word(4), word(6), word(8), word(16));
    if first == 0 || last < first {
        return Err(format!("frames {first} to {last}, expected 1 ≤ first ≤ last"));
    }
    let frames = last - first + 1;
    if points > MAX_C3D_POINTS || frames > MAX_MEASUREMENT_SAMPLES || points * frames > MAX_C3D_POINT_FRAMES {
        return Err(format!(
            "{points} points × {frames} frames, over the budget of {MAX_C3D_POINTS} points, \
             {MAX_MEASUREMENT_SAMPLES} frames and {MAX_C3D_POINT_FRAMES} points × frames"
        ));
    }
    if data_block <= block {
        return Err(format!(
            "the data are said to start at block {data_block}, expected after the parameters (block {block})"
        ));
    }
    // Every frame holds x, y, z and a residual word per point and the analog samples, as
    // 2-byte integers or 4-byte floats: the file must be as long as its header says.
    let value_bytes = if bytes[sign_byte] & 0x80 != 0 { 4 } else { 2 };
    let needed = 512 * (data_block - 1) + frames * (4 * points + analog) * value_bytes;
    if bytes.len() < needed {
        return Err(format!(
            "{} bytes, but its header implies at least {needed} ({points} points and {analog} analog values × {frames} frames \
             from block {data_block}): the file is cut short",
            bytes.len()
        ));
    }
    Ok(())
}

/// Runs `f`, turning a panic into `None` without printing the panic message (a third-party
/// parser's panic on a malformed file is a refusal, reported as such, not a crash report).
fn quietly<T>(f: impl FnOnce() -> T) -> Option<T> {
    use std::cell::Cell;
    thread_local!(static QUIET: Cell<bool> = const { Cell::new(false) });
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !QUIET.with(Cell::get) {
                previous(info);
            }
        }));
    });
    QUIET.with(|q| q.set(true));
    let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).ok();
    QUIET.with(|q| q.set(false));
    out
}

/// One program's belief after its last update, by the logged model and by the measured one.
#[derive(Clone, Debug, PartialEq)]
pub struct RefitRun {
    pub program: usize,
    pub condition: &'static str,
    pub logged: BeliefSummary,
    pub measured: BeliefSummary,
}

/// A session re-fitted with measured observations.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasuredRefit {
    /// The observation model the session was logged with.
    pub logged_observation: ObservationModel,
    /// Standing grasps (not undone or voided) of the session, and how many had a sample
    /// within the window.
    pub grasps: usize,
    pub measured: usize,
    /// Measurements whose nearest configuration lies in another region than the one keyed.
    pub disagreements: usize,
    pub runs: Vec<RefitRun>,
}

/// Re-fits a logged session with the measured observation model: every standing grasp takes
/// the sample of `series` nearest its logged time within the window of `spec` (without one,
/// it learns from the region taken, as a live session would). Each program's learner starts
/// from the session's own prior draw and learns from the queries the session asked, in
/// order (an active learner would have asked others had it learned otherwise; the re-fit
/// answers what the same handovers say when the arm is measured).
/// `logged_study` is the log's own (`record::study_of`), built once by the caller.
pub fn refit(
    log: &LogContents,
    logged_study: Arc<Study>,
    series: &MeasurementSeries,
    spec: &MeasurementSpec,
) -> Result<MeasuredRefit, RecordError> {
    let logged_observation = logged_study.protocol.learning.observation;
    // The standing trials with the times of their grasps.
    let mut standing: Vec<(TrialRecord, u64)> = Vec::new();
    let logged = replay_with(Arc::clone(&logged_study), log, |_, step| match step {
        Some((_, s, Applied::Responded { record, .. })) => standing.push((record.clone(), s.time_ns)),
        Some((_, _, Applied::Undone { .. } | Applied::Voided { retracted: true, .. })) => {
            standing.pop();
        }
        _ => {}
    })?;
    let mut study = (*logged_study).clone();
    study.protocol.learning.observation = ObservationModel::Measured;
    study.protocol.learning.measurement = Some(spec.clone());
    let fresh = Session::new(Arc::new(study), log.start.clone()).map_err(|e| RecordError::Replay {
        path: log.path.clone(),
        index: 0,
        topic: "/session/start".into(),
        source: Box::new(e),
    })?;
    let ctx = fresh.context();
    let menu: Vec<FeasibleSet> =
        (0..fresh.study().training.len()).map(|i| fresh.set(QueryRef::Training(i)).clone()).collect();
    let mut learners: Vec<Learner> = fresh.learners().to_vec();
    let (mut measured, mut disagreements) = (0, 0);
    for (t, time_ns) in &standing {
        let set = fresh.set(t.query);
        let m = series.at(*time_ns, spec.window_s);
        let obs = match &m {
            Some(m) => {
                measured += 1;
                let obs =
                    Observation::measured(set.configs(), &m.q_rad, &ctx.sigma).map_err(|e| RecordError::Replay {
                        path: log.path.clone(),
                        index: 0,
                        topic: "/trial/response".into(),
                        source: Box::new(SessionError::BadMeasurement {
                            query: fresh.query(t.query).query.id.clone(),
                            why: e.to_string(),
                        }),
                    })?;
                if obs.nearest().is_some_and(|nearest| set.region_of(nearest) != t.region) {
                    disagreements += 1;
                }
                obs
            }
            None => Observation::Region(set.regions()[t.region].clone().collect()),
        };
        if let (Some(run), QueryRef::Training(i)) = (t.run, t.query) {
            learners[run].learn(i, &obs, &menu, ctx).map_err(|e| RecordError::Replay {
                path: log.path.clone(),
                index: 0,
                topic: "/trial/response".into(),
                source: Box::new(SessionError::Degenerate {
                    query: fresh.query(t.query).query.id.clone(),
                    why: e.to_string(),
                }),
            })?;
        }
    }
    let runs = logged
        .learners()
        .iter()
        .zip(&learners)
        .enumerate()
        .map(|(program, (a, b))| RefitRun {
            program,
            condition: a.condition.name(),
            logged: a.summary.clone(),
            measured: b.summary.clone(),
        })
        .collect();
    Ok(MeasuredRefit { logged_observation, grasps: standing.len(), measured, disagreements, runs })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimal_times_are_read_to_the_nanosecond() {
        assert_eq!(parse_time("1764806400.000000001"), Some(1_764_806_400_000_000_001));
        assert_eq!(parse_time("1764806400.1"), Some(1_764_806_400_100_000_000));
        assert_eq!(parse_time("1764806400"), Some(1_764_806_400_000_000_000));
        assert_eq!(parse_time("1764806400.0000000015"), Some(1_764_806_400_000_000_002));
        // Through a float this time would be off by hundreds of nanoseconds.
        assert_ne!((("1764806400.000000001".parse::<f64>().unwrap()) * 1e9).round() as u64, 1_764_806_400_000_000_001);
        assert_eq!(parse_time("1.7648064e9"), Some(1_764_806_400_000_000_000));
        for bad in ["", "-1", "4000000001", "1e99", "x"] {
            assert_eq!(parse_time(bad), None, "{bad}");
        }
    }
}
