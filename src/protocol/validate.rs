//! Validation of a parsed protocol: every problem with the field's path and what was expected.

use std::collections::HashSet;
use std::fmt;

use super::{
    ArmSpec, LambdaSpec, LearningSpec, ObservationModel, PopulationSpec, Protocol, Query, QuestionnaireSpec,
    ResolvedQuery, SessionSpec, Study, commanded_pose,
};
use crate::belief::{Prior, ResamplePolicy};
use crate::kinematics::{HumanArm, JOINT_NAMES, JOINTS, Object, Pose, feasible_set};

/// One problem in a protocol: where, and what was expected.
#[derive(Clone, Debug, PartialEq)]
pub struct Problem {
    /// JSON path of the field (e.g. `objects[1].regions[0].id`); empty for the whole file.
    pub path: String,
    pub message: String,
}

/// A protocol that cannot be used, with every problem found.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub struct ProtocolError {
    pub file: String,
    pub problems: Vec<Problem>,
}

impl ProtocolError {
    pub fn new(file: &str, problems: Vec<Problem>) -> Self {
        Self { file: file.to_string(), problems }
    }
}

impl fmt::Display for ProtocolError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = self.problems.len();
        write!(f, "{}: invalid protocol ({n} problem{})", self.file, if n == 1 { "" } else { "s" })?;
        // A message may quote the protocol's text: shown with control characters escaped.
        for p in &self.problems {
            let message = crate::text::printable(&p.message);
            if p.path.is_empty() {
                write!(f, "\n  - {message}")?;
            } else {
                write!(f, "\n  - {}: {message}", crate::text::printable(&p.path))?;
            }
        }
        Ok(())
    }
}

/// The finite range of every number in a protocol and the budgets of the work it implies
/// (documented in docs/protocol-limits.md). A protocol over a budget is refused with the
/// field and the budget named, before any of that work starts.
pub mod limits {
    /// Bytes of protocol text.
    pub const PROTOCOL_BYTES: usize = 4 << 20;
    /// Bytes of a name or label (UTF-8; no control characters). One rule with the log
    /// reader's: `crate::text`.
    pub(crate) const TEXT: usize = crate::text::NAME_BYTES;
    /// Bytes of a description or statement (line breaks allowed, no other control characters).
    pub(crate) const LONG_TEXT: usize = crate::text::LONG_BYTES;
    /// Bytes of a program label (the blinded name of a condition).
    pub(crate) const PROGRAM_LABEL: usize = crate::text::PROGRAM_LABEL_BYTES;
    /// Characters of an id (A–Z, a–z, 0–9, '-', '_'): ids become file names and CSV keys.
    pub const ID: usize = crate::text::ID_BYTES;
    /// Metropolis–Hastings steps per particle after resampling (each a pass over the
    /// session's observations so far).
    pub(crate) const MOVES: usize = 50;
    /// |position| of a pose or TSR frame, m.
    pub(crate) const POSITION_M: f64 = 5.0;
    /// |angle| of any orientation, bound, limit or prior, degrees.
    pub(crate) const ANGLE_DEG: f64 = 360.0;
    /// |translation bound| of a TSR, m.
    pub(crate) const TSR_TRANSLATION_M: f64 = 1.0;
    /// TSR translation sampling step, m.
    pub(crate) const TRANSLATION_STEP_M: (f64, f64) = (0.001, 1.0);
    /// TSR rotation sampling and swivel steps, degrees.
    pub(crate) const ANGLE_STEP_DEG: (f64, f64) = (1.0, 360.0);
    /// Duplicate tolerance of feasible configurations, rad.
    pub(crate) const DUPLICATE_TOLERANCE_RAD: (f64, f64) = (1e-9, 0.1);
    pub const OBJECTS: usize = 32;
    /// Grip regions per object (the console's keys 1–9).
    pub(crate) const REGIONS: usize = 9;
    /// Queries in the training menu, and in the test set.
    pub(crate) const QUERIES: usize = 200;
    /// σ of a measuring system's joint-angle error, degrees.
    pub const SIGMA_DEG: (f64, f64) = crate::ergo::SIGMA_DEG;
    /// How far a measurement may lie from its grasp, s.
    pub const MEASUREMENT_WINDOW_S: (f64, f64) = (0.001, 5.0);
    /// Samples of one region's TSR.
    pub(crate) const GRASPS_PER_REGION: f64 = 20_000.0;
    /// Inverse-kinematics evaluations (grasps × swivel angles) for one query, and for the
    /// whole protocol.
    pub(crate) const IK_PER_QUERY: f64 = 1_000_000.0;
    pub(crate) const IK_PER_PROTOCOL: f64 = 5_000_000.0;
    /// Distinct feasible configurations of one query.
    pub(crate) const CONFIGS_PER_QUERY: usize = 20_000;
    pub const PARTICLES: usize = 100_000;
    /// Particle–configuration pairs of one learning step (particles × every configuration
    /// of the training menu), and likewise for the test set: about 0.2 s of the engine on
    /// two cores, room for 20 000 particles on the default protocol (its test set is the
    /// larger, 5840 configurations: 1.2e8 pairs).
    pub(crate) const PAIRS_PER_STEP: f64 = 2e8;
    pub const ALPHA: f64 = 1000.0;
    /// Largest cost weight w.
    pub(crate) const WEIGHT: f64 = 1000.0;
    pub(crate) const GRID_BOXES: usize = 1000;
    pub(crate) const HYBRID_BETA: f64 = 1e6;
    /// ε of the budgeted selector, at least 0.
    pub(crate) const BUDGET_EPSILON: f64 = 1e6;
    pub const TRIALS_PER_CONDITION: usize = 200;
    /// Points of the Likert scale (keys 1–9), and their |value|.
    pub(crate) const SCALE_POINTS: usize = 9;
    pub(crate) const SCALE_VALUE: i64 = 1000;
    pub(crate) const ITEMS: usize = 50;
}

#[derive(Default)]
struct Problems(Vec<Problem>);

impl Problems {
    fn add(&mut self, path: impl Into<String>, message: impl Into<String>) {
        self.0.push(Problem { path: path.into(), message: message.into() });
    }

    /// Every value finite and within ±`bound` (`unit` names it in the message).
    fn within(&mut self, path: &str, v: &[f64], bound: f64, unit: &str) {
        if let Some(i) = v.iter().position(|x| !(x.is_finite() && x.abs() <= bound)) {
            self.add(format!("{path}[{i}]"), format!("is {}, expected a number from -{bound} to {bound} {unit}", v[i]));
        }
    }

    /// A value in [lo, hi].
    fn range(&mut self, path: &str, v: f64, (lo, hi): (f64, f64), what: &str) {
        if !(v.is_finite() && (lo..=hi).contains(&v)) {
            self.add(path, format!("is {v}, expected {what} from {lo} to {hi}"));
        }
    }

    /// A count of at most `max`.
    fn count(&mut self, path: &str, n: usize, max: usize, what: &str) {
        if n > max {
            self.add(path, format!("has {n} {what}, over the budget of {max}"));
        }
    }

    /// A name or label: at most `max` bytes, no control character.
    fn text(&mut self, path: &str, v: &str, max: usize) {
        if let Err(e) = crate::text::check_label(v, max) {
            self.add(path, e.to_string());
        }
    }

    /// A long text: at most `max` bytes, no control character but a line break.
    fn long(&mut self, path: &str, v: &str) {
        if let Err(e) = crate::text::check_long(v, limits::LONG_TEXT) {
            self.add(path, e.to_string());
        }
    }

    /// An id that may become a file name (the id rule of `crate::text`).
    fn id(&mut self, path: &str, v: &str) {
        if let Err(e) = crate::text::check_id(v) {
            self.add(path, e.to_string());
        }
    }
}

fn pose_fields(path: &str, pose: &crate::kinematics::Pose, p: &mut Problems) {
    p.within(&format!("{path}.position"), &pose.position, limits::POSITION_M, "m");
    p.within(&format!("{path}.rpy_deg"), &pose.rpy_deg, limits::ANGLE_DEG, "degrees");
}

fn arm(spec: &ArmSpec, p: &mut Problems) -> Option<HumanArm> {
    let mut arm = match (spec.body_height_m, spec.upper_arm_m, spec.forearm_m, spec.hand_m) {
        (Some(h), ..) => match HumanArm::from_height(h) {
            Ok(a) => a,
            Err(e) => {
                p.add("arm.body_height_m", e.to_string());
                return None;
            }
        },
        (None, Some(u), Some(f), Some(h)) => HumanArm::with_lengths(u, f, h),
        _ => {
            p.add("arm", "expected body_height_m, or all of upper_arm_m, forearm_m and hand_m");
            return None;
        }
    };
    // Lengths given beside a body height override Winter's fractions.
    arm.upper_arm = spec.upper_arm_m.unwrap_or(arm.upper_arm);
    arm.forearm = spec.forearm_m.unwrap_or(arm.forearm);
    arm.hand = spec.hand_m.unwrap_or(arm.hand);
    if let Some(limits) = spec.limits_deg {
        for (d, [lo, hi]) in limits.iter().copied().enumerate() {
            let a = limits::ANGLE_DEG;
            if !(lo.is_finite() && hi.is_finite()) || lo > hi || lo < -a || hi > a {
                p.add(
                    format!("arm.limits_deg[{d}]"),
                    format!("{} limits are [{lo}, {hi}], expected min ≤ max within ±{a} degrees", JOINT_NAMES[d]),
                );
            }
        }
        arm.limits = limits.map(|[a, b]| [a.to_radians(), b.to_radians()]);
    }
    arm.side = spec.side.unwrap_or_default();
    match arm.validate() {
        Ok(()) => Some(arm),
        Err(e) => {
            p.add("arm", e.to_string());
            None
        }
    }
}

fn objects(objects: &[Object], res: &crate::kinematics::Resolution, p: &mut Problems) {
    if objects.is_empty() {
        p.add("objects", "is empty, expected at least one object");
    }
    p.count("objects", objects.len(), limits::OBJECTS, "objects");
    let mut ids = HashSet::new();
    for (i, o) in objects.iter().enumerate() {
        let path = format!("objects[{i}]");
        if !ids.insert(o.id.as_str()) {
            p.add(format!("{path}.id"), format!("duplicate id '{}', expected unique object ids", o.id));
        }
        if o.regions.is_empty() {
            p.add(format!("{path}.regions"), "is empty, expected at least one grip region");
        }
        p.count(&format!("{path}.regions"), o.regions.len(), limits::REGIONS, "grip regions");
        p.id(&format!("{path}.id"), &o.id);
        p.text(&format!("{path}.label"), &o.label, limits::TEXT);
        let mut rids = HashSet::new();
        for (k, r) in o.regions.iter().enumerate() {
            let rpath = format!("{path}.regions[{k}]");
            if !rids.insert(r.id.as_str()) {
                p.add(format!("{rpath}.id"), format!("duplicate id '{}', expected unique region ids", r.id));
            }
            p.id(&format!("{rpath}.id"), &r.id);
            p.text(&format!("{rpath}.label"), &r.label, limits::TEXT);
            let mut bounds_ok = true;
            for (row, [lo, hi]) in r.tsr.bw.iter().copied().enumerate() {
                let (bound, unit) =
                    if row < 3 { (limits::TSR_TRANSLATION_M, "m") } else { (limits::ANGLE_DEG, "degrees") };
                if !(lo.is_finite() && hi.is_finite()) || lo > hi || lo.abs() > bound || hi.abs() > bound {
                    bounds_ok = false;
                    p.add(
                        format!("{rpath}.tsr.Bw[{row}]"),
                        format!("is [{lo}, {hi}], expected min ≤ max within ±{bound} {unit}"),
                    );
                }
            }
            pose_fields(&format!("{rpath}.tsr.T0_w"), &r.tsr.t0_w, p);
            pose_fields(&format!("{rpath}.tsr.Tw_e"), &r.tsr.tw_e, p);
            let samples = r.tsr.sample_count(res);
            if bounds_ok && samples > limits::GRASPS_PER_REGION {
                p.add(
                    format!("{rpath}.tsr"),
                    format!(
                        "discretises into {samples} grasps at this resolution, over the budget of {} per region",
                        limits::GRASPS_PER_REGION
                    ),
                );
            }
        }
    }
}

fn lambda_spec(path: &str, l: &LambdaSpec, p: &mut Problems) {
    for (field, v) in [("q_star_deg", &l.q_star_deg), ("w", &l.w)] {
        if v.len() != JOINTS {
            p.add(format!("{path}.{field}"), format!("has {} values, expected {JOINTS} (one per joint)", v.len()));
        }
    }
    p.within(&format!("{path}.q_star_deg"), &l.q_star_deg, limits::ANGLE_DEG, "degrees");
    if let Some(i) = l.w.iter().position(|w| !(w.is_finite() && (0.0..=limits::WEIGHT).contains(w))) {
        p.add(format!("{path}.w[{i}]"), format!("is {}, expected a weight from 0 to {}", l.w[i], limits::WEIGHT));
    }
}

/// Every number of a component prior within ±`bound` (and a weight's support within
/// [0, `bound`]).
fn prior_ranges(path: &str, priors: &[crate::belief::ComponentPrior], bound: f64, weight: bool, p: &mut Problems) {
    use crate::belief::ComponentPrior as C;
    for (d, c) in priors.iter().enumerate() {
        let values: Vec<f64> = match *c {
            C::Fixed { value } => vec![value],
            C::Uniform { min, max } => vec![min, max],
            C::Gaussian { mean, sd, min, max } => vec![mean, sd, min, max],
        };
        let (lo, _) = c.support();
        if values.iter().any(|v| !(v.is_finite() && v.abs() <= bound)) || (weight && lo < 0.0) {
            let range = if weight { format!("0 to {bound}") } else { format!("-{bound} to {bound}") };
            p.add(format!("{path}[{d}]"), format!("has a number outside {range}: {c:?}"));
        }
    }
}

fn learning(l: &LearningSpec, p: &mut Problems) {
    if l.particles == 0 || l.particles > limits::PARTICLES {
        p.add("learning.particles", format!("is {}, expected a count from 1 to {}", l.particles, limits::PARTICLES));
    }
    if !(l.alpha.is_finite() && l.alpha > 0.0 && l.alpha <= limits::ALPHA) {
        p.add("learning.alpha", format!("is {}, expected a positive number up to {}", l.alpha, limits::ALPHA));
    }
    prior_ranges("learning.prior.q_star_deg", &l.prior.q_star_deg, limits::ANGLE_DEG, false, p);
    prior_ranges("learning.prior.w", &l.prior.w, limits::WEIGHT, true, p);
    for (field, v) in [("q_star_deg", &l.prior.q_star_deg), ("w", &l.prior.w)] {
        if v.len() != JOINTS {
            p.add(
                format!("learning.prior.{field}"),
                format!("has {} entries, expected {JOINTS} (one per joint)", v.len()),
            );
        }
    }
    lambda_spec("learning.known", &l.known, p);
    lambda_spec("learning.label_model", &l.label_model, p);
    let lengths_ok = [l.prior.q_star_deg.len(), l.prior.w.len(), l.known.q_star_deg.len(), l.known.w.len()]
        .iter()
        .all(|&n| n == JOINTS);
    // Checked as written (degrees), so that messages quote the file's numbers.
    if lengths_ok && let Err(e) = Prior::new(l.prior.q_star_deg.clone(), l.prior.w.clone()) {
        // The prior names its component as q_star[d] or w[d].
        let msg = e.to_string();
        let (component, rest) = msg.split_once(": ").unwrap_or(("", &msg));
        let path = match component.strip_prefix("q_star") {
            Some(idx) => format!("learning.prior.q_star_deg{idx}"),
            None => format!("learning.prior.{component}"),
        };
        p.add(path, rest.to_string());
    }
    if let ResamplePolicy::EssBelow { fraction } = l.resampling
        && !(fraction > 0.0 && fraction <= 1.0)
    {
        p.add("learning.resampling.fraction", format!("is {fraction}, expected a fraction in (0, 1]"));
    }
    p.range("learning.jitter.q_star_deg", l.jitter.q_star_deg, (0.0, limits::ANGLE_DEG), "degrees");
    p.range("learning.jitter.w", l.jitter.w, (0.0, limits::WEIGHT), "a weight");
    if l.moves > limits::MOVES {
        p.add("learning.moves", format!("is {}, expected 0 to {} steps per particle", l.moves, limits::MOVES));
    }
    if l.grid_boxes == 0 || l.grid_boxes > limits::GRID_BOXES {
        p.add(
            "learning.grid_boxes",
            format!("is {}, expected 1 to {} cells per prior range", l.grid_boxes, limits::GRID_BOXES),
        );
    }
    measurement(l, p);
    p.range("learning.hybrid_beta", l.hybrid_beta, (0.0, limits::HYBRID_BETA), "a number");
    p.range("learning.budget_epsilon", l.budget_epsilon, (0.0, limits::BUDGET_EPSILON), "a fraction");
}

/// The population: one spread per joint, each mean inside the prior's support of a learned
/// component (draws are truncated to it) and each sd at most the support's width.
fn population(pop: &PopulationSpec, l: &LearningSpec, p: &mut Problems) {
    for (field, spreads, priors, bound, unit) in [
        ("q_star_deg", &pop.q_star_deg, &l.prior.q_star_deg, limits::ANGLE_DEG, "degrees"),
        ("w", &pop.w, &l.prior.w, limits::WEIGHT, "a weight"),
    ] {
        if spreads.len() != JOINTS {
            p.add(
                format!("population.{field}"),
                format!("has {} entries, expected {JOINTS} (one per joint)", spreads.len()),
            );
            continue;
        }
        for (i, (s, prior)) in spreads.iter().zip(priors).enumerate() {
            let path = format!("population.{field}[{i}]");
            let (lo, hi) = prior.support();
            if !(s.mean.is_finite() && s.mean.abs() <= bound) {
                p.add(
                    format!("{path}.mean"),
                    format!("is {}, expected a number from -{bound} to {bound} {unit}", s.mean),
                );
            } else if hi > lo && !(lo..=hi).contains(&s.mean) {
                p.add(
                    format!("{path}.mean"),
                    format!(
                        "is {}, expected a value inside learning.prior.{field}[{i}]'s support [{lo}, {hi}]",
                        s.mean
                    ),
                );
            }
            let width = if hi > lo { hi - lo } else { bound };
            p.range(&format!("{path}.sd"), s.sd, (0.0, width), unit);
        }
    }
    if let Some(alpha) = pop.alpha
        && !(alpha.is_finite() && alpha > 0.0 && alpha <= limits::ALPHA)
    {
        p.add("population.alpha", format!("is {alpha}, expected a positive number up to {}", limits::ALPHA));
    }
}

fn measurement(l: &LearningSpec, p: &mut Problems) {
    let m = match (l.observation, &l.measurement) {
        (ObservationModel::Measured, Some(m)) => m,
        (ObservationModel::Measured, None) => {
            p.add(
                "learning.measurement",
                "is missing, expected the measuring system (sigma_deg per joint) with observation 'measured'",
            );
            return;
        }
        (other, Some(_)) => {
            p.add(
                "learning.measurement",
                format!("is given but learning.observation is '{}', expected it only with 'measured'", other.name()),
            );
            return;
        }
        (_, None) => return,
    };
    if m.sigma_deg.len() != JOINTS {
        p.add(
            "learning.measurement.sigma_deg",
            format!("has {} entries, expected {JOINTS} (one per joint)", m.sigma_deg.len()),
        );
    }
    for (d, &s) in m.sigma_deg.iter().enumerate() {
        p.range(&format!("learning.measurement.sigma_deg[{d}]"), s, limits::SIGMA_DEG, "degrees");
    }
    if m.joint_names.len() != JOINTS {
        p.add(
            "learning.measurement.joint_names",
            format!("has {} entries, expected {JOINTS} (one per joint, in the model's order)", m.joint_names.len()),
        );
    }
    let mut seen = HashSet::new();
    for (d, name) in m.joint_names.iter().enumerate() {
        let ok = (1..=64).contains(&name.len())
            && name.bytes().all(|b| b.is_ascii_alphanumeric() || matches!(b, b'_' | b'/' | b'.' | b'-'));
        if !ok {
            p.add(
                format!("learning.measurement.joint_names[{d}]"),
                format!(
                    "is '{}', expected 1 to 64 characters from A–Z, a–z, 0–9, '_', '/', '.', '-'",
                    name.escape_debug()
                ),
            );
        } else if !seen.insert(name.as_str()) {
            p.add(format!("learning.measurement.joint_names[{d}]"), format!("'{name}' is named twice"));
        }
    }
    p.range("learning.measurement.window_s", m.window_s, limits::MEASUREMENT_WINDOW_S, "seconds");
}

fn resolve(
    list: &str,
    queries: &[Query],
    protocol: &Protocol,
    arm: Option<&HumanArm>,
    ids: &mut HashSet<String>,
    ik_total: &mut f64,
    p: &mut Problems,
) -> Vec<ResolvedQuery> {
    if queries.is_empty() {
        p.add(list, "is empty, expected at least one query");
    }
    if queries.len() > limits::QUERIES {
        p.count(list, queries.len(), limits::QUERIES, "queries");
        return Vec::new();
    }
    let mut out = Vec::new();
    for (i, q) in queries.iter().enumerate() {
        let path = format!("{list}[{i}]");
        if !ids.insert(q.id.clone()) {
            p.add(
                format!("{path}.id"),
                format!("duplicate id '{}', expected ids unique across training_menu and test_set", q.id),
            );
        }
        pose_fields(&format!("{path}.pose"), &q.pose, p);
        p.id(&format!("{path}.id"), &q.id);
        p.text(&format!("{path}.label"), &q.label, limits::TEXT);
        let Some(oi) = protocol.objects.iter().position(|o| o.id == q.object) else {
            let known: Vec<_> = protocol.objects.iter().map(|o| o.id.as_str()).collect();
            p.add(
                format!("{path}.object"),
                format!("unknown object '{}', expected one of: {}", q.object, known.join(", ")),
            );
            continue;
        };
        let object = &protocol.objects[oi];
        let regions: Vec<usize> = match &q.regions {
            None => (0..object.regions.len()).collect(),
            Some(names) => {
                if names.is_empty() {
                    p.add(format!("{path}.regions"), "is empty, expected at least one offered region");
                }
                let mut seen = HashSet::new();
                let mut v = Vec::new();
                for (k, n) in names.iter().enumerate() {
                    match object.region(n) {
                        Some(r) if seen.insert(r) => v.push(r),
                        Some(_) => p.add(format!("{path}.regions[{k}]"), format!("region '{n}' is offered twice")),
                        None => {
                            let known: Vec<_> = object.regions.iter().map(|r| r.id.as_str()).collect();
                            p.add(
                                format!("{path}.regions[{k}]"),
                                format!(
                                    "unknown region '{n}' of object '{}', expected one of: {}",
                                    object.id,
                                    known.join(", ")
                                ),
                            )
                        }
                    }
                }
                v
            }
        };
        let pose_ok = q.pose.position.iter().all(|v| v.is_finite() && v.abs() <= limits::POSITION_M)
            && q.pose.rpy_deg.iter().all(|v| v.is_finite() && v.abs() <= limits::ANGLE_DEG);
        let (Some(arm), true) = (arm, pose_ok) else {
            continue;
        };
        // The work this query implies, before any of it is done.
        let d = &protocol.discretisation;
        let swivels = (360.0 / d.swivel_step_deg).round().max(1.0);
        let ik: f64 = regions.iter().map(|&r| object.regions[r].tsr.sample_count(&d.resolution) * swivels).sum();
        if ik > limits::IK_PER_QUERY {
            p.add(
                path.clone(),
                format!(
                    "needs {ik} inverse-kinematics evaluations (grasps × swivel angles), over the budget of {} per query",
                    limits::IK_PER_QUERY
                ),
            );
            continue;
        }
        *ik_total += ik;
        if *ik_total > limits::IK_PER_PROTOCOL {
            p.add(
                path.clone(),
                format!(
                    "brings the protocol to {ik_total} inverse-kinematics evaluations, over the budget of {}",
                    limits::IK_PER_PROTOCOL
                ),
            );
            return out;
        }
        let Some(scale) = super::pose_scale(protocol, arm) else { continue };
        let pose = commanded_pose(&q.pose, scale, arm.side);
        let feasible = feasible_set(arm, object, &pose, &regions, d);
        if feasible.configs.len() > limits::CONFIGS_PER_QUERY {
            p.add(
                path.clone(),
                format!(
                    "has {} feasible configurations, over the budget of {} per query (coarsen the discretisation)",
                    feasible.configs.len(),
                    limits::CONFIGS_PER_QUERY
                ),
            );
            continue;
        }
        for (k, &n) in feasible.per_region.iter().enumerate() {
            if n == 0 {
                p.add(
                    format!("{path}.pose"),
                    format!(
                        "region '{}' of '{}' has no feasible arm configuration at this pose, expected at least one",
                        object.regions[regions[k]].id, object.id
                    ),
                );
            }
        }
        out.push(ResolvedQuery { query: q.clone(), pose: Pose::from_isometry(&pose), object: oi, regions, feasible });
    }
    out
}

/// Validates a parsed protocol and derives the study from it.
fn session(s: &SessionSpec, q: &QuestionnaireSpec, p: &mut Problems) {
    if s.conditions.len() != 2 {
        p.add(
            "session.conditions",
            format!("has {} conditions, expected 2 (counterbalanced AB / BA)", s.conditions.len()),
        );
    } else if s.conditions[0] == s.conditions[1] {
        p.add("session.conditions", "names the same condition twice, expected two different selectors");
    }
    if s.trials_per_condition == 0 || s.trials_per_condition > limits::TRIALS_PER_CONDITION {
        p.add(
            "session.trials_per_condition",
            format!("is {}, expected a count from 1 to {}", s.trials_per_condition, limits::TRIALS_PER_CONDITION),
        );
    }
    if s.program_labels.len() != s.conditions.len() {
        p.add(
            "session.program_labels",
            format!("has {} labels, expected {} (one per condition)", s.program_labels.len(), s.conditions.len()),
        );
    }
    let mut seen = HashSet::new();
    for (i, l) in s.program_labels.iter().enumerate() {
        if l.trim().is_empty() || !seen.insert(l.as_str()) {
            p.add(format!("session.program_labels[{i}]"), format!("'{l}' must be non-empty and unique"));
        }
        p.text(&format!("session.program_labels[{i}]"), l, limits::PROGRAM_LABEL);
    }
    if let Some(t) = &s.transitions {
        for (field, text, placeholders) in [
            ("between_programs", &t.between_programs, &["{done}", "{next}"][..]),
            ("before_test", &t.before_test, &[][..]),
            ("before_questionnaire", &t.before_questionnaire, &[][..]),
        ] {
            let path = format!("session.transitions.{field}");
            p.long(&path, text);
            if text.trim().is_empty() {
                p.add(path.clone(), "is empty, expected what the experimenter tells the participant");
            }
            let mut rest = text.as_str();
            while let Some(i) = rest.find('{') {
                let tail = &rest[i..];
                match placeholders.iter().find(|ph| tail.starts_with(**ph)) {
                    Some(ph) => rest = &tail[ph.len()..],
                    None => {
                        let expected = if placeholders.is_empty() {
                            "no placeholder".to_string()
                        } else {
                            placeholders.join(" or ")
                        };
                        p.add(path.clone(), format!("has '{{' not starting a known placeholder, expected {expected}"));
                        break;
                    }
                }
            }
        }
    }
    p.count("questionnaire.scale", q.scale.len(), limits::SCALE_POINTS, "points");
    p.count("questionnaire.items", q.items.len(), limits::ITEMS, "statements");
    p.long("questionnaire.forced_choice", &q.forced_choice);
    for (i, pt) in q.scale.iter().enumerate() {
        if pt.value.abs() > limits::SCALE_VALUE {
            p.add(
                format!("questionnaire.scale[{i}].value"),
                format!("is {}, expected a value within ±{}", pt.value, limits::SCALE_VALUE),
            );
        }
        p.text(&format!("questionnaire.scale[{i}].label"), &pt.label, limits::TEXT);
    }
    for (i, it) in q.items.iter().enumerate() {
        p.id(&format!("questionnaire.items[{i}].id"), &it.id);
        p.long(&format!("questionnaire.items[{i}].statement"), &it.statement);
    }
    if q.scale.len() < 2 {
        p.add("questionnaire.scale", format!("has {} points, expected at least 2", q.scale.len()));
    }
    for (i, w) in q.scale.windows(2).enumerate() {
        if w[1].value <= w[0].value {
            p.add(
                format!("questionnaire.scale[{}].value", i + 1),
                format!("is {} after {}, expected strictly increasing values", w[1].value, w[0].value),
            );
        }
    }
    for (i, pt) in q.scale.iter().enumerate() {
        if pt.label.trim().is_empty() {
            p.add(format!("questionnaire.scale[{i}].label"), "is empty, expected a label on every point");
        }
    }
    if q.items.is_empty() {
        p.add("questionnaire.items", "is empty, expected at least one statement");
    }
    let mut ids = HashSet::new();
    for (i, it) in q.items.iter().enumerate() {
        if !ids.insert(it.id.as_str()) {
            p.add(format!("questionnaire.items[{i}].id"), format!("duplicate id '{}'", it.id));
        }
        if it.statement.trim().is_empty() {
            p.add(format!("questionnaire.items[{i}].statement"), "is empty, expected a statement");
        }
    }
    if q.forced_choice.trim().is_empty() {
        p.add("questionnaire.forced_choice", "is empty, expected the question");
    }
}

pub(super) fn study(protocol: Protocol, name: &str, sha256: String) -> Result<Study, ProtocolError> {
    let mut p = Problems::default();
    if protocol.name.trim().is_empty() {
        p.add("name", "is empty, expected the protocol's name");
    }
    let arm = arm(&protocol.arm, &mut p);
    if let Some(s) = protocol.pose_scaling
        && let Err(e) = HumanArm::from_height(s.reference_body_height_m)
    {
        p.add("pose_scaling.reference_body_height_m", e.to_string());
    }
    p.text("name", &protocol.name, limits::TEXT);
    p.long("description", &protocol.description);
    let d = &protocol.discretisation;
    p.range("discretisation.resolution.translation_m", d.resolution.translation_m, limits::TRANSLATION_STEP_M, "m");
    p.range("discretisation.resolution.rotation_deg", d.resolution.rotation_deg, limits::ANGLE_STEP_DEG, "degrees");
    p.range("discretisation.swivel_step_deg", d.swivel_step_deg, limits::ANGLE_STEP_DEG, "degrees");
    p.range(
        "discretisation.duplicate_tolerance_rad",
        d.duplicate_tolerance_rad,
        limits::DUPLICATE_TOLERANCE_RAD,
        "rad",
    );
    objects(&protocol.objects, &d.resolution, &mut p);
    learning(&protocol.learning, &mut p);
    if let Some(pop) = &protocol.population {
        population(pop, &protocol.learning, &mut p);
    }
    session(&protocol.session, &protocol.questionnaire, &mut p);
    // Feasible sets are computed only for a discretisation that makes sense.
    let arm = if p.0.is_empty() { arm } else { None };
    let mut ids = HashSet::new();
    let mut ik = 0.0;
    let training =
        resolve("training_menu", &protocol.training_menu, &protocol, arm.as_ref(), &mut ids, &mut ik, &mut p);
    let test = resolve("test_set", &protocol.test_set, &protocol, arm.as_ref(), &mut ids, &mut ik, &mut p);
    let particles = protocol.learning.particles as f64;
    for (list, queries) in [("training_menu", &training), ("test_set", &test)] {
        let pairs = particles * queries.iter().map(|q| q.feasible.configs.len() as f64).sum::<f64>();
        if pairs > limits::PAIRS_PER_STEP {
            p.add(
                list,
                format!(
                    "learning.particles × its feasible configurations = {pairs} pairs per learning step, over the budget of {}",
                    limits::PAIRS_PER_STEP
                ),
            );
        }
    }
    // The prior as learners use it (its ranges, the learn-mask and the known values), built
    // once: every later use takes the study's.
    let prior = match protocol.learning.prior() {
        Ok(prior) => Some(prior),
        // What the checks above found already, in the file's degrees.
        Err(_) if !p.0.is_empty() => None,
        Err(e) => {
            p.add("learning.prior", e.to_string());
            None
        }
    };
    match (p.0.is_empty(), arm, prior) {
        (true, Some(arm), Some(prior)) => {
            Ok(Study { protocol, source_name: name.to_string(), sha256, arm, prior, training, test })
        }
        _ => Err(ProtocolError::new(name, p.0)),
    }
}

#[cfg(test)]
mod tests {
    use super::limits;

    /// docs/protocol-limits.md states every limit with the value the code uses.
    #[test]
    fn the_documented_limits_are_the_enforced_ones() {
        let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/protocol-limits.md")).unwrap();
        let row = |name: &str, value: String| {
            let line =
                doc.lines().find(|l| l.starts_with(&format!("| `{name}` |"))).unwrap_or_else(|| panic!("{name}"));
            assert!(line.contains(&format!("| {value} |")), "{name}: the doc says {line}, the code {value}");
        };
        let range = |(a, b): (f64, f64)| format!("{a} to {b}");
        row("PROTOCOL_BYTES", limits::PROTOCOL_BYTES.to_string());
        row("TEXT", limits::TEXT.to_string());
        row("LONG_TEXT", limits::LONG_TEXT.to_string());
        row("PROGRAM_LABEL", limits::PROGRAM_LABEL.to_string());
        row("ID", limits::ID.to_string());
        row("POSITION_M", limits::POSITION_M.to_string());
        row("ANGLE_DEG", limits::ANGLE_DEG.to_string());
        row("TSR_TRANSLATION_M", limits::TSR_TRANSLATION_M.to_string());
        row("TRANSLATION_STEP_M", range(limits::TRANSLATION_STEP_M));
        row("ANGLE_STEP_DEG", range(limits::ANGLE_STEP_DEG));
        row("DUPLICATE_TOLERANCE_RAD", range(limits::DUPLICATE_TOLERANCE_RAD));
        row("OBJECTS", limits::OBJECTS.to_string());
        row("REGIONS", limits::REGIONS.to_string());
        row("QUERIES", limits::QUERIES.to_string());
        row("GRASPS_PER_REGION", limits::GRASPS_PER_REGION.to_string());
        row("IK_PER_QUERY", limits::IK_PER_QUERY.to_string());
        row("IK_PER_PROTOCOL", limits::IK_PER_PROTOCOL.to_string());
        row("CONFIGS_PER_QUERY", limits::CONFIGS_PER_QUERY.to_string());
        row("PARTICLES", limits::PARTICLES.to_string());
        row("PAIRS_PER_STEP", limits::PAIRS_PER_STEP.to_string());
        row("ALPHA", limits::ALPHA.to_string());
        row("WEIGHT", limits::WEIGHT.to_string());
        row("GRID_BOXES", limits::GRID_BOXES.to_string());
        row("HYBRID_BETA", limits::HYBRID_BETA.to_string());
        row("BUDGET_EPSILON", limits::BUDGET_EPSILON.to_string());
        row("TRIALS_PER_CONDITION", limits::TRIALS_PER_CONDITION.to_string());
        row("SCALE_POINTS", limits::SCALE_POINTS.to_string());
        row("SCALE_VALUE", limits::SCALE_VALUE.to_string());
        row("ITEMS", limits::ITEMS.to_string());
    }
}
