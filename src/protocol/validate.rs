//! Validation of a parsed protocol: every problem with the field's path and what was expected.

use std::collections::HashSet;
use std::fmt;

use super::{ArmSpec, LambdaSpec, LearningSpec, Protocol, Query, QuestionnaireSpec, ResolvedQuery, SessionSpec, Study};
use crate::belief::{Prior, ResamplePolicy};
use crate::kinematics::{HumanArm, JOINT_NAMES, JOINTS, Object, feasible_set};

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
        for p in &self.problems {
            if p.path.is_empty() {
                write!(f, "\n  - {}", p.message)?;
            } else {
                write!(f, "\n  - {}: {}", p.path, p.message)?;
            }
        }
        Ok(())
    }
}

#[derive(Default)]
struct Problems(Vec<Problem>);

impl Problems {
    fn add(&mut self, path: impl Into<String>, message: impl Into<String>) {
        self.0.push(Problem { path: path.into(), message: message.into() });
    }

    fn finite(&mut self, path: &str, v: &[f64]) {
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            self.add(format!("{path}[{i}]"), format!("is {}, expected a finite number", v[i]));
        }
    }
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
            if !(lo.is_finite() && hi.is_finite()) || lo > hi {
                p.add(
                    format!("arm.limits_deg[{d}]"),
                    format!("{} limits are [{lo}, {hi}], expected finite min ≤ max", JOINT_NAMES[d]),
                );
            }
        }
        arm.limits = limits.map(|[a, b]| [a.to_radians(), b.to_radians()]);
    }
    match arm.validate() {
        Ok(()) => Some(arm),
        Err(e) => {
            p.add("arm", e.to_string());
            None
        }
    }
}

fn objects(objects: &[Object], p: &mut Problems) {
    if objects.is_empty() {
        p.add("objects", "is empty, expected at least one object");
    }
    let mut ids = HashSet::new();
    for (i, o) in objects.iter().enumerate() {
        let path = format!("objects[{i}]");
        if !ids.insert(o.id.as_str()) {
            p.add(format!("{path}.id"), format!("duplicate id '{}', expected unique object ids", o.id));
        }
        if o.regions.is_empty() {
            p.add(format!("{path}.regions"), "is empty, expected at least one grip region");
        }
        let mut rids = HashSet::new();
        for (k, r) in o.regions.iter().enumerate() {
            let rpath = format!("{path}.regions[{k}]");
            if !rids.insert(r.id.as_str()) {
                p.add(format!("{rpath}.id"), format!("duplicate id '{}', expected unique region ids", r.id));
            }
            for (row, [lo, hi]) in r.tsr.bw.iter().copied().enumerate() {
                if !(lo.is_finite() && hi.is_finite()) || lo > hi {
                    p.add(format!("{rpath}.tsr.Bw[{row}]"), format!("is [{lo}, {hi}], expected finite min ≤ max"));
                }
            }
            p.finite(&format!("{rpath}.tsr.T0_w.position"), &r.tsr.t0_w.position);
            p.finite(&format!("{rpath}.tsr.T0_w.rpy_deg"), &r.tsr.t0_w.rpy_deg);
            p.finite(&format!("{rpath}.tsr.Tw_e.position"), &r.tsr.tw_e.position);
            p.finite(&format!("{rpath}.tsr.Tw_e.rpy_deg"), &r.tsr.tw_e.rpy_deg);
        }
    }
}

fn lambda_spec(path: &str, l: &LambdaSpec, p: &mut Problems) {
    for (field, v) in [("q_star_deg", &l.q_star_deg), ("w", &l.w)] {
        if v.len() != JOINTS {
            p.add(format!("{path}.{field}"), format!("has {} values, expected {JOINTS} (one per joint)", v.len()));
        }
        p.finite(&format!("{path}.{field}"), v);
    }
    if let Some(i) = l.w.iter().position(|w| *w < 0.0) {
        p.add(format!("{path}.w[{i}]"), format!("is {}, expected a non-negative weight", l.w[i]));
    }
}

fn learning(l: &LearningSpec, p: &mut Problems) {
    if l.particles == 0 || l.particles > 1_000_000 {
        p.add("learning.particles", format!("is {}, expected a count from 1 to 1000000", l.particles));
    }
    if !(l.alpha.is_finite() && l.alpha > 0.0) {
        p.add("learning.alpha", format!("is {}, expected a positive number", l.alpha));
    }
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
    for (field, v) in [("q_star_deg", l.jitter.q_star_deg), ("w", l.jitter.w)] {
        if !(v.is_finite() && v >= 0.0) {
            p.add(format!("learning.jitter.{field}"), format!("is {v}, expected a non-negative number"));
        }
    }
    if l.grid_boxes == 0 {
        p.add("learning.grid_boxes", "is 0, expected at least 1 cell per prior range");
    }
    if !(l.hybrid_beta.is_finite() && l.hybrid_beta >= 0.0) {
        p.add("learning.hybrid_beta", format!("is {}, expected a non-negative number", l.hybrid_beta));
    }
}

fn resolve(
    list: &str,
    queries: &[Query],
    protocol: &Protocol,
    arm: Option<&HumanArm>,
    ids: &mut HashSet<String>,
    p: &mut Problems,
) -> Vec<ResolvedQuery> {
    if queries.is_empty() {
        p.add(list, "is empty, expected at least one query");
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
        p.finite(&format!("{path}.pose.position"), &q.pose.position);
        p.finite(&format!("{path}.pose.rpy_deg"), &q.pose.rpy_deg);
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
        let (Some(arm), true) = (arm, q.pose.position.iter().chain(&q.pose.rpy_deg).all(|v| v.is_finite())) else {
            continue;
        };
        let feasible = feasible_set(arm, object, &q.pose.to_isometry(), &regions, &protocol.discretisation);
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
        out.push(ResolvedQuery { query: q.clone(), object: oi, regions, feasible });
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
    if s.trials_per_condition == 0 {
        p.add("session.trials_per_condition", "is 0, expected a positive count");
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
    let d = &protocol.discretisation;
    if !(d.resolution.translation_m.is_finite() && d.resolution.translation_m > 0.0) {
        p.add(
            "discretisation.resolution.translation_m",
            format!("is {}, expected a positive length", d.resolution.translation_m),
        );
    }
    if !(d.resolution.rotation_deg.is_finite() && d.resolution.rotation_deg > 0.0) {
        p.add(
            "discretisation.resolution.rotation_deg",
            format!("is {}, expected a positive angle", d.resolution.rotation_deg),
        );
    }
    if !(d.swivel_step_deg.is_finite() && d.swivel_step_deg > 0.0 && d.swivel_step_deg <= 360.0) {
        p.add("discretisation.swivel_step_deg", format!("is {}, expected an angle in (0, 360]", d.swivel_step_deg));
    }
    if !(d.duplicate_tolerance_rad.is_finite() && d.duplicate_tolerance_rad > 0.0) {
        p.add(
            "discretisation.duplicate_tolerance_rad",
            format!("is {}, expected a positive angle", d.duplicate_tolerance_rad),
        );
    }
    objects(&protocol.objects, &mut p);
    learning(&protocol.learning, &mut p);
    session(&protocol.session, &protocol.questionnaire, &mut p);
    // Feasible sets are computed only for a discretisation that makes sense.
    let arm = if p.0.is_empty() { arm } else { None };
    let mut ids = HashSet::new();
    let training = resolve("training_menu", &protocol.training_menu, &protocol, arm.as_ref(), &mut ids, &mut p);
    let test = resolve("test_set", &protocol.test_set, &protocol, arm.as_ref(), &mut ids, &mut p);
    match (p.0.is_empty(), arm) {
        (true, Some(arm)) => Ok(Study { protocol, source_name: name.to_string(), sha256, arm, training, test }),
        _ => Err(ProtocolError::new(name, p.0)),
    }
}
