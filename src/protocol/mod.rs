//! Protocol files: the study as data (arm, objects, handover poses), parsed into typed
//! values and validated with precise errors; the default protocol is embedded.

mod population;
mod validate;

use serde::{Deserialize, Serialize};

use crate::belief::{ComponentPrior, Prior, PriorError, ResamplePolicy};
use crate::ergo::{Lambda, LearnMask};
use nalgebra::{Isometry3, UnitQuaternion};

use crate::kinematics::{ArmFeasibleSet, Discretisation, Hand, HumanArm, JOINTS, Object, Pose, mirror};
use crate::select::SelectorKind;

pub use population::{Population, PopulationSpec, Spread, truncated_normal};
pub use validate::{Problem, ProtocolError, limits};

/// The default study, embedded so that a bare `handover` runs.
pub const DEFAULT_PROTOCOL: &str = include_str!("../../protocols/bike-handover.json");
/// The name under which the embedded protocol is reported.
pub const DEFAULT_PROTOCOL_NAME: &str = "protocols/bike-handover.json (embedded)";

/// A protocol file as written.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Protocol {
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub arm: ArmSpec,
    /// How the queries' positions fit the participant's body; absent: used as written.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pose_scaling: Option<PoseScaling>,
    #[serde(default)]
    pub discretisation: Discretisation,
    pub objects: Vec<Object>,
    /// How the robot learns: particles, α, what is learned, the prior.
    pub learning: LearningSpec,
    /// The queries the robot may choose from during training.
    pub training_menu: Vec<Query>,
    /// The held-out queries of the test phase.
    pub test_set: Vec<Query>,
    /// Phases, counterbalancing and blinding.
    pub session: SessionSpec,
    /// The post-study questionnaire (the paper's Table I).
    pub questionnaire: QuestionnaireSpec,
    /// Who simulated participants are (dry runs, `plan`); absent: the default population
    /// (`population.rs`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub population: Option<PopulationSpec>,
}

/// The phases of a session.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SessionSpec {
    /// The training conditions (query selectors), in the first counterbalancing order; the
    /// second order reverses them.
    pub conditions: Vec<SelectorKind>,
    /// Training trials per condition, each over the whole training menu.
    pub trials_per_condition: usize,
    /// What the participant is told each training run is called, in the order run.
    pub program_labels: Vec<String>,
    /// Whether the test set is presented in an order shuffled per participant.
    pub shuffle_test: bool,
    /// What the experimenter tells the participant between phases; absent: the defaults of
    /// [`Transitions`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transitions: Option<Transitions>,
}

/// What the console's transition screens say, each confirmed by the experimenter before the
/// next phase: `{done}` and `{next}` are replaced by the programs' labels.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Transitions {
    /// After one training program, before the next.
    pub between_programs: String,
    /// After the last training program, before the test phase.
    pub before_test: String,
    /// After the test phase, before the questionnaire.
    pub before_questionnaire: String,
}

impl Default for Transitions {
    fn default() -> Self {
        Self {
            between_programs: "{done} is done. Tell the participant: the robot will now use {next}; \
                               take each object as you like."
                .into(),
            before_test: "Training is done. Tell the participant: the robot will now hand over each object \
                          in a few more poses; take each as you like."
                .into(),
            before_questionnaire: "The handovers are done. Tell the participant: a few statements about \
                                   each program follow; answer each on the scale shown."
                .into(),
        }
    }
}

impl SessionSpec {
    /// The transitions' texts: the protocol's, or the defaults.
    pub fn transitions(&self) -> Transitions {
        self.transitions.clone().unwrap_or_default()
    }
}

/// A Likert questionnaire asked about each program, then a forced choice.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuestionnaireSpec {
    /// The scale's points, in increasing order of value.
    pub scale: Vec<ScalePoint>,
    /// Statements; `{program}` is replaced by the program's label.
    pub items: Vec<LikertItem>,
    /// The forced-choice question.
    pub forced_choice: String,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScalePoint {
    pub value: i64,
    pub label: String,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LikertItem {
    pub id: String,
    pub statement: String,
}

/// Queries' positions are written for a reference body and scale with the participant's
/// reach: a position p (m, in the shoulder frame) is commanded as p · R / R_ref, where R is
/// the reach of the arm modelled (upper arm + forearm + hand to the grasp centre) and R_ref
/// that of a body of `reference_body_height_m` by Winter's fractions. Orientations and the
/// objects are not scaled.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseScaling {
    pub reference_body_height_m: f64,
}

/// The person's arm: from body height (Winter's fractions) or given directly.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArmSpec {
    /// Which arm is modelled, `right` (default) or `left` (mirrored: the queries' poses are
    /// mirrored too, see [`commanded_pose`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub side: Option<Hand>,
    #[serde(default)]
    pub body_height_m: Option<f64>,
    #[serde(default)]
    pub upper_arm_m: Option<f64>,
    #[serde(default)]
    pub forearm_m: Option<f64>,
    /// Wrist to grasp centre.
    #[serde(default)]
    pub hand_m: Option<f64>,
    /// [min, max] per joint in degrees, in the documented joint order; default AAOS.
    #[serde(default)]
    pub limits_deg: Option<[[f64; 2]; JOINTS]>,
}

/// The learning settings of a study. Angles of q* are in degrees here (radians inside).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LearningSpec {
    /// Number of particles N.
    pub particles: usize,
    /// Rationality α of the Boltzmann choice model.
    pub alpha: f64,
    /// Which parts of λ are learned.
    pub learn: LearnMask,
    /// Prior per joint of q* (degrees) and of w; only the learned parts are used.
    pub prior: PriorSpec,
    /// The values of the parts that are not learned.
    pub known: LambdaSpec,
    /// When to resample after an update.
    pub resampling: ResamplePolicy,
    /// Standard deviation of the jitter after resampling: degrees for q*, units of w for w.
    /// With `moves`, the smallest standard deviation of the moves' random walk instead.
    pub jitter: JitterSpec,
    /// Metropolis–Hastings steps per particle after each resampling (resample-move: the
    /// duplicates spread out again under the exact posterior), in place of the jitter; 0,
    /// the default, keeps the paper's jitter.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub moves: usize,
    /// The arithmetic of the selectors' information gain and expected cost: `float64` (the
    /// default) or `float32` (about twice as fast; its tolerance in docs/engine.md). Belief
    /// updates and every logged estimate are float64 either way.
    #[serde(default, skip_serializing_if = "crate::select::Precision::is_default")]
    pub precision: crate::select::Precision,
    /// Cells per prior range for the gridded entropy and the mode.
    pub grid_boxes: usize,
    /// What the robot learns from: `configuration` (the handle mapped to its most likely
    /// configuration by the label model, as in the paper), `region` (the handle itself) or
    /// `measured` (the arm's joint angles as a measuring system reports them; see
    /// `measurement`).
    pub observation: ObservationModel,
    /// The measuring system of `measured` observations (required with it, refused without).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measurement: Option<MeasurementSpec>,
    /// The stated cost model that maps a grabbed handle to a configuration.
    pub label_model: LambdaSpec,
    /// β of the `hybrid` selector (I − β·E[cost]).
    #[serde(default = "default_beta")]
    pub hybrid_beta: f64,
    /// ε of the `budgeted` selector (the most informative query with E[cost] ≤ (1 + ε) ×
    /// the passive query's).
    #[serde(default = "default_epsilon")]
    pub budget_epsilon: f64,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// What a session learns from when the participant takes the object.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ObservationModel {
    /// The label model's most likely configuration of the grip taken (the paper's user study
    /// as published).
    Configuration,
    /// The grip region taken.
    Region,
    /// The arm's joint angles measured at the grasp, with Gaussian noise per joint; a trial
    /// without a measurement in time learns from the grip region taken.
    Measured,
}

impl ObservationModel {
    /// The protocol's name for it.
    pub fn name(self) -> &'static str {
        match self {
            ObservationModel::Configuration => "configuration",
            ObservationModel::Region => "region",
            ObservationModel::Measured => "measured",
        }
    }
}

/// A measuring system of the arm (motion capture, a body tracker).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasurementSpec {
    /// The standard deviation of its error per joint, degrees, in the arm model's joint order:
    /// the system's documented joint-angle accuracy (there is no default: it is the
    /// system's).
    pub sigma_deg: Vec<f64>,
    /// Its names of the model's joints, in the model's order (the `name`s of a ROS 2
    /// `sensor_msgs/msg/JointState`, the columns of a measurements CSV) [default: the model's
    /// own joint names].
    #[serde(default = "default_joint_names")]
    pub joint_names: Vec<String>,
    /// A sample counts for a grasp when it lies at most this many seconds before it (the
    /// latest such one is taken) [default: 0.5].
    #[serde(default = "default_window_s")]
    pub window_s: f64,
}

fn default_joint_names() -> Vec<String> {
    crate::kinematics::JOINT_NAMES.iter().map(|n| n.to_string()).collect()
}

fn default_window_s() -> f64 {
    0.5
}

impl MeasurementSpec {
    /// σ per joint in radians.
    pub fn sigma_rad(&self) -> Vec<f64> {
        self.sigma_deg.iter().map(|d| d.to_radians()).collect()
    }
}

fn default_beta() -> f64 {
    crate::select::DEFAULT_HYBRID_BETA
}

fn default_epsilon() -> f64 {
    crate::select::DEFAULT_BUDGET_EPSILON
}

/// Per-joint priors: q* in degrees, w as is.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PriorSpec {
    pub q_star_deg: Vec<ComponentPrior>,
    pub w: Vec<ComponentPrior>,
}

/// A λ written by hand: q* in degrees, w as is.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LambdaSpec {
    pub q_star_deg: Vec<f64>,
    pub w: Vec<f64>,
}

impl LambdaSpec {
    pub fn to_lambda(&self) -> Lambda {
        Lambda { q_star: self.q_star_deg.iter().map(|d| d.to_radians()).collect(), w: self.w.clone() }
    }
}

/// Jitter after resampling: q* in degrees, w as is.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JitterSpec {
    pub q_star_deg: f64,
    pub w: f64,
}

fn prior_to_radians(p: &ComponentPrior) -> ComponentPrior {
    match *p {
        ComponentPrior::Fixed { value } => ComponentPrior::Fixed { value: value.to_radians() },
        ComponentPrior::Uniform { min, max } => {
            ComponentPrior::Uniform { min: min.to_radians(), max: max.to_radians() }
        }
        ComponentPrior::Gaussian { mean, sd, min, max } => ComponentPrior::Gaussian {
            mean: mean.to_radians(),
            sd: sd.to_radians(),
            min: min.to_radians(),
            max: max.to_radians(),
        },
    }
}

impl LearningSpec {
    /// The prior over λ = [q*, w] in radians, with the unlearned parts fixed to `known`.
    pub fn prior(&self) -> Result<Prior, PriorError> {
        let q = self.prior.q_star_deg.iter().map(prior_to_radians).collect();
        Prior::with_mask(self.learn, q, self.prior.w.clone(), &self.known.to_lambda())
    }

    /// Jitter standard deviations per component of [q*, w].
    pub fn jitter(&self, dim: usize) -> Vec<f64> {
        let mut j = vec![self.jitter.q_star_deg.to_radians(); dim];
        j.extend(std::iter::repeat_n(self.jitter.w, dim));
        j
    }
}

/// A robot query: an object at a handover pose in the person's shoulder frame, with the
/// grip regions offered.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Query {
    pub id: String,
    pub object: String,
    /// The pose's name, as the operator reads it.
    #[serde(default)]
    pub label: String,
    /// The object's frame in the person's right-shoulder frame (x forward, y left, z up).
    pub pose: Pose,
    /// Offered grip regions by id; all of the object's when absent.
    #[serde(default)]
    pub regions: Option<Vec<String>>,
}

/// A validated protocol with everything derived from it.
#[derive(Clone, Debug)]
pub struct Study {
    pub protocol: Protocol,
    /// Where it was read from (for messages).
    pub source_name: String,
    /// SHA-256 (hex) of the protocol text.
    pub sha256: String,
    pub arm: HumanArm,
    /// The learners' prior over λ (`learning.prior()`, checked when the study is built).
    pub prior: Prior,
    pub training: Vec<ResolvedQuery>,
    pub test: Vec<ResolvedQuery>,
}

/// A query with its object, offered regions and feasible set resolved.
#[derive(Clone, Debug)]
pub struct ResolvedQuery {
    pub query: Query,
    /// The pose the robot commands for this participant (scaled and, for a left arm,
    /// mirrored), in the shoulder frame of the arm modelled.
    pub pose: Pose,
    /// Index into the protocol's objects.
    pub object: usize,
    /// Indices into the object's regions, in the order offered.
    pub regions: Vec<usize>,
    pub feasible: ArmFeasibleSet,
}

impl Study {
    /// Parses and validates protocol text; `name` is used in messages.
    pub fn from_json(text: &str, name: &str) -> Result<Self, ProtocolError> {
        if text.len() > validate::limits::PROTOCOL_BYTES {
            return Err(ProtocolError::new(
                name,
                vec![Problem {
                    path: String::new(),
                    message: format!(
                        "has {} bytes, over the budget of {} bytes for a protocol",
                        text.len(),
                        validate::limits::PROTOCOL_BYTES
                    ),
                }],
            ));
        }
        let whole = |message: String| ProtocolError::new(name, vec![Problem { path: String::new(), message }]);
        crate::input_file::check_no_bom(text).map_err(|e| whole(e.to_string()))?;
        let de = &mut serde_json::Deserializer::from_str(text);
        let protocol: Protocol = serde_path_to_error::deserialize(&mut *de).map_err(|e| {
            let path = e.path().to_string();
            ProtocolError::new(
                name,
                vec![Problem {
                    path: if path == "." { String::new() } else { path },
                    message: e.into_inner().to_string(),
                }],
            )
        })?;
        // One document: anything after it but white space is refused, not ignored.
        de.end().map_err(|e| whole(format!("{e}: expected nothing after the protocol's one JSON document")))?;
        validate::study(protocol, name, sha256_hex(text.as_bytes()))
    }

    /// The embedded default protocol.
    pub fn default_study() -> Self {
        Self::from_json(DEFAULT_PROTOCOL, DEFAULT_PROTOCOL_NAME).expect("the embedded protocol is valid (tested)")
    }

    /// The population simulated participants are drawn from.
    pub fn population(&self) -> Population {
        Population::new(self.protocol.population.as_ref(), &self.prior, self.protocol.learning.alpha)
    }

    /// People drawn from the robot's own prior, with the protocol's α (`dry-run --population
    /// prior`).
    pub fn prior_population(&self) -> Population {
        Population::from_prior(&self.prior, self.protocol.learning.alpha)
    }

    /// What in the prior or the population is so narrow that the study would barely learn a
    /// joint, or would simulate people nearly alike there: each a sentence naming the joints.
    /// A learned component's normal prior with an sd under [`NARROW_PRIOR_SHARE`] of its
    /// range (the robot will barely move from its mean), and a population spread under
    /// [`NARROW_POPULATION_SHARE`] of the prior's range (what a fit gives when the data do
    /// not determine a spread). Valid protocols, said so that nobody runs one unawares.
    pub fn narrow_warnings(&self) -> Vec<String> {
        let l = &self.protocol.learning;
        let dim = l.prior.q_star_deg.len();
        let name = |i: usize| Lambda::component_name(i, dim);
        let unit = |i: usize| if i < dim { "°" } else { "" };
        let written: Vec<&ComponentPrior> = l.prior.q_star_deg.iter().chain(&l.prior.w).collect();
        let learned = |i: usize| !self.prior.components().get(i).is_none_or(ComponentPrior::is_fixed);
        let mut out = Vec::new();
        let narrow_priors: Vec<String> = written
            .iter()
            .enumerate()
            .filter(|(i, _)| learned(*i))
            .filter_map(|(i, c)| match **c {
                ComponentPrior::Gaussian { mean, sd, min, max } if sd < NARROW_PRIOR_SHARE * (max - min) => {
                    Some(format!("{} sd {sd:.1}{u} about {mean:.1}{u} on [{min}, {max}]{u}", name(i), u = unit(i)))
                }
                _ => None,
            })
            .collect();
        if !narrow_priors.is_empty() {
            out.push(format!(
                "the prior's {} under {:.0} % of its range: the robot will barely learn {} from a participant (a pilot's prior.json keeps each sd at least what the data resolve; docs/engine.md)",
                narrow_priors.join(", "),
                100.0 * NARROW_PRIOR_SHARE,
                if narrow_priors.len() == 1 { "that joint" } else { "those joints" }
            ));
        }
        if let Some(pop) = &self.protocol.population {
            let spreads: Vec<&Spread> = pop.q_star_deg.iter().chain(&pop.w).collect();
            let narrow: Vec<String> = spreads
                .iter()
                .zip(&written)
                .enumerate()
                .filter(|(i, _)| learned(*i))
                .filter_map(|(i, (s, c))| {
                    let (min, max) = c.support();
                    (s.sd < NARROW_POPULATION_SHARE * (max - min))
                        .then(|| format!("{} sd {:.2}{}", name(i), s.sd, unit(i)))
                })
                .collect();
            if !narrow.is_empty() {
                out.push(format!(
                    "the population's {} under {:.0} % of the prior's range: the simulated people are nearly alike there (if a fit made it, its data did not determine those spreads: see population.csv's sd_at_floor and intervals)",
                    narrow.join(", "),
                    100.0 * NARROW_POPULATION_SHARE
                ));
            }
        }
        out
    }

    /// The factor the queries' positions are scaled by for this study's arm.
    pub fn pose_scale(&self) -> f64 {
        pose_scale(&self.protocol, &self.arm).unwrap_or(1.0)
    }

    /// Every query, training menu first.
    pub fn all_queries(&self) -> impl Iterator<Item = &ResolvedQuery> {
        self.training.iter().chain(&self.test)
    }

    /// A query by id.
    pub fn query(&self, id: &str) -> Option<&ResolvedQuery> {
        self.all_queries().find(|q| q.query.id == id)
    }

    pub fn object(&self, q: &ResolvedQuery) -> &Object {
        &self.protocol.objects[q.object]
    }
}

/// A normal prior narrower than this share of its range is said to be narrow (a pilot whose
/// people fit alike by chance gave 2.1° on a 70° range, 3 %).
pub const NARROW_PRIOR_SHARE: f64 = 0.05;
/// A population spread narrower than this share of the prior's range is said to be narrow
/// (fits put undetermined spreads at 0.2 % of it).
pub const NARROW_POPULATION_SHARE: f64 = 0.01;

/// SHA-256 of bytes as lowercase hex.
pub(crate) fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest;
    sha2::Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}

/// The reach ratio R / R_ref of [`PoseScaling`] for an arm (1 without scaling); `None` for
/// a reference height no body has.
pub(crate) fn pose_scale(protocol: &Protocol, arm: &HumanArm) -> Option<f64> {
    match protocol.pose_scaling {
        None => Some(1.0),
        Some(s) => HumanArm::from_height(s.reference_body_height_m).ok().map(|r| arm.reach() / r.reach()),
    }
}

/// The pose the robot commands for a query written as `written` (in the protocol's
/// right-shoulder convention): positions × `scale` (the reach ratio of [`PoseScaling`]); for
/// a left arm then mirrored in the sagittal plane (M = diag(1, −1, 1): y, roll and yaw
/// negated) and turned half a turn about the object's own z axis, so that every grip keeps
/// its colour and sits where the mirror puts it. For objects whose grips are symmetric
/// under the object's x → −x (both default objects) the left arm's feasible set is then the
/// right arm's, angle for angle; for any object it is computed for the pose commanded.
pub fn commanded_pose(written: &Pose, scale: f64, side: Hand) -> Isometry3<f64> {
    let mut t = Pose { position: written.position.map(|v| v * scale), rpy_deg: written.rpy_deg }.to_isometry();
    if side == Hand::Left {
        t = mirror(&t) * UnitQuaternion::from_euler_angles(0.0, 0.0, std::f64::consts::PI);
    }
    t
}

/// The body a session is run for: a height (the protocol's arm when absent) and the hand.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Body {
    pub height_m: Option<f64>,
    pub hand: Hand,
}

impl std::fmt::Display for Body {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.height_m {
            Some(h) => write!(f, "a {h} m participant's {} arm", self.hand.name()),
            None => write!(f, "the protocol's body, {} arm", self.hand.name()),
        }
    }
}

/// The protocol text as run for one participant's body: the arm scaled to their height
/// (Winter's fractions; joint limits kept) and on their dominant side. The session logs
/// this text, so a replay rebuilds the same arm and the same commanded poses.
pub fn for_body(text: &str, name: &str, body: Body) -> Result<(String, Study), ProtocolError> {
    let mut v: serde_json::Value = serde_json::from_str(text)
        .map_err(|e| ProtocolError::new(name, vec![Problem { path: String::new(), message: e.to_string() }]))?;
    if !v.get("arm").is_some_and(serde_json::Value::is_object) {
        // Not a protocol: let the validator name what is missing.
        return Study::from_json(text, name).map(|s| (text.to_string(), s));
    }
    let written_side = v["arm"].get("side").and_then(serde_json::Value::as_str).unwrap_or("right");
    if body.height_m.is_none() && written_side == body.hand.name() {
        // The protocol's own body: run as written.
        return Study::from_json(text, name).map(|s| (text.to_string(), s));
    }
    if let Some(h) = body.height_m {
        let limits = v["arm"].get("limits_deg").cloned();
        v["arm"] = serde_json::json!({ "body_height_m": h });
        if let Some(l) = limits {
            v["arm"]["limits_deg"] = l;
        }
    }
    v["arm"]["side"] = serde_json::json!(body.hand.name());
    // Compact: the text is embedded in every log of the participant.
    let text = serde_json::to_string(&v).expect("serialisable");
    let study = Study::from_json(&text, &format!("{name} ({body})"))?;
    Ok((text, study))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each learned joint's normal prior at sds either side of the narrow share, and each
    /// population spread either side of its share (7 joints × 2 × 2 = 28 protocols): a joint
    /// is named exactly when it is under the share; fixed components are never named.
    #[test]
    fn narrow_priors_and_populations_are_named_joint_by_joint() {
        let base: serde_json::Value = serde_json::from_str(DEFAULT_PROTOCOL).unwrap();
        assert!(Study::default_study().narrow_warnings().is_empty());
        let mut cases = 0;
        for joint in 0..JOINTS {
            let (min, max) = base["learning"]["prior"]["q_star_deg"][joint]
                .as_object()
                .map(|c| (c["min"].as_f64().unwrap(), c["max"].as_f64().unwrap()))
                .unwrap();
            let width = max - min;
            for (share, named) in [(0.9, true), (1.1, false)] {
                let mut v = base.clone();
                v["learning"]["prior"]["q_star_deg"][joint] = serde_json::json!({
                    "kind": "gaussian", "mean": (min + max) / 2.0, "sd": share * NARROW_PRIOR_SHARE * width,
                    "min": min, "max": max,
                });
                let w = Study::from_json(&v.to_string(), "p").unwrap().narrow_warnings();
                let said = w.iter().any(|w| w.contains(&format!("prior's q*{} sd", joint + 1)));
                assert_eq!(said, named, "prior q*{} at {share} × the share: {w:?}", joint + 1);
                let mut v = base.clone();
                let spreads: Vec<serde_json::Value> = (0..JOINTS)
                    .map(|j| {
                        let c = &base["learning"]["prior"]["q_star_deg"][j];
                        let (lo, hi) = (c["min"].as_f64().unwrap(), c["max"].as_f64().unwrap());
                        let sd = if j == joint { share * NARROW_POPULATION_SHARE * (hi - lo) } else { (hi - lo) / 6.0 };
                        serde_json::json!({"mean": (lo + hi) / 2.0, "sd": sd})
                    })
                    .collect();
                let w_spreads = vec![serde_json::json!({"mean": 1.0, "sd": 0.0}); JOINTS];
                v["population"] = serde_json::json!({"q_star_deg": spreads, "w": w_spreads});
                let study = Study::from_json(&v.to_string(), "p").unwrap();
                let w = study.narrow_warnings();
                let said = w.iter().any(|w| w.contains(&format!("population's q*{} sd", joint + 1)));
                assert_eq!(said, named, "population q*{} at {share} × the share: {w:?}", joint + 1);
                // w is not learned by the default protocol: its zero spreads are never named.
                assert!(!w.iter().any(|w| w.contains(" w1 ")), "{w:?}");
                cases += 2;
            }
        }
        assert_eq!(cases, 28);
    }
}
