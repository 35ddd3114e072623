//! What Foxglove's 3D panel shows: the frames (world → shoulder → object), the participant's
//! body and arm, and the object offered with its grips.
//!
//! Frames: `world` is on the floor below the modelled shoulder (x forward, y to the person's
//! left, z up); `shoulder` is the arm's frame (`docs/kinematics.md`), at the body's shoulder
//! height above `world`; `object` is the object's frame as commanded for the current query;
//! `view` is where the layout's 3D camera looks: the middle of the body from hip to head and
//! of the arm's reach, so that one camera distance frames every body from 1.50 to 1.95 m.
//!
//! What the scene names it names as the console does: a left hand's grips and poses with
//! "left" and "right" swapped ([`Hand::experienced`]), where the mirrored poses put them.

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3 as NVector3};

use super::foxglove::{
    ArrowPrimitive, Color, CubePrimitive, FrameTransform, FrameTransforms, LinePrimitive, Pose, Quaternion,
    SceneEntity, SceneUpdate, TextPrimitive, Time, Vector3,
};
use crate::kinematics::{ArmConfig, Hand, HumanArm, Object};
use crate::protocol::ResolvedQuery;

pub const WORLD: &str = "world";
pub const SHOULDER: &str = "shoulder";
pub(crate) const OBJECT: &str = "object";
pub const VIEW: &str = "view";

/// Fractions of body height (Winter; `HUMAN-ARM.md`).
const SHOULDER_HEIGHT: f64 = 0.818;
const HALF_SHOULDER_WIDTH: f64 = 0.129;
const HIP_HEIGHT: f64 = 0.530;
const CHIN_HEIGHT: f64 = 0.870;
const HEAD_TOP: f64 = 1.0;
/// The `view` frame's origin in `world`, in body heights: ahead of the chest towards the
/// objects (which are offered within about 0.3 body heights ahead), between the shoulders
/// (towards the other one) and halfway from the hip to the top of the head.
const VIEW_AHEAD: f64 = 0.10;
const VIEW_ACROSS: f64 = 0.065;
const VIEW_UP: f64 = (HIP_HEIGHT + HEAD_TOP) / 2.0;

const ARM: Color = Color { r: 0.9, g: 0.6, b: 0.2, a: 1.0 };
/// The measured arm: cyan, against the mapped configuration's orange.
const MEASURED: Color = Color { r: 0.1, g: 0.75, b: 0.85, a: 1.0 };
const BODY: Color = Color { r: 0.55, g: 0.55, b: 0.6, a: 1.0 };
const NOT_OFFERED: Color = Color { r: 0.6, g: 0.6, b: 0.6, a: 0.35 };
const OBJECT_BODY: Color = Color { r: 0.2, g: 0.2, b: 0.2, a: 1.0 };
/// A grip's label where its grip is not offered: mid grey, read on a light and a dark theme.
const NOT_OFFERED_TEXT: Color = Color { r: 0.45, g: 0.45, b: 0.5, a: 1.0 };
/// The smallest side of a grip's box, so that a grip reads at the layout's camera distance.
const MIN_GRIP_SIDE: f64 = 0.05;
/// The length of the object's axes (m).
const AXES_LENGTH: f64 = 0.12;
/// The gap between the highest of the object's boxes and axes and the lowest label (m). The
/// layout's camera looks down on the object at 25°: the z axis rises on the screen by 0.9 of
/// its length, and a label over a grip nearer the camera (up to a handlebar's 24 cm) sits
/// lower by 0.4 of that, so 16 cm keeps every label above every axis at that view
/// (tests/readers/scene_view.py measures it on the logs).
const LABEL_GAP: f64 = 0.16;
/// The height between two grips' labels (m): a line of text at the layout's camera distance.
const LABEL_STEP: f64 = 0.08;

/// The colour a grip's label names (`"Left grip (blue)"`), else one of a fixed palette.
pub(crate) fn grip_colour(label: &str, index: usize) -> Color {
    let lower = label.to_ascii_lowercase();
    let named = [
        ("blue", (0.15, 0.35, 0.9)),
        ("red", (0.85, 0.15, 0.15)),
        ("green", (0.1, 0.65, 0.25)),
        ("yellow", (0.95, 0.8, 0.1)),
        ("orange", (0.95, 0.5, 0.1)),
        ("purple", (0.55, 0.25, 0.75)),
        ("black", (0.05, 0.05, 0.05)),
        ("white", (0.95, 0.95, 0.95)),
    ];
    let palette = [(0.0, 0.45, 0.7), (0.8, 0.4, 0.0), (0.0, 0.6, 0.5), (0.8, 0.6, 0.7), (0.35, 0.7, 0.9)];
    let words: Vec<&str> = lower.split(|c: char| !c.is_ascii_alphabetic()).collect();
    let (r, g, b) =
        named.iter().find(|(name, _)| words.contains(name)).map(|(_, c)| *c).unwrap_or(palette[index % palette.len()]);
    Color { r, g, b, a: 1.0 }
}

/// The body height the arm implies (its upper arm by Winter's fraction).
fn body_height(arm: &HumanArm) -> f64 {
    arm.upper_arm / crate::kinematics::UPPER_ARM_FRACTION
}

fn transform(time_ns: u64, parent: &str, child: &str, t: &Isometry3<f64>) -> FrameTransform {
    let p = Pose::from_isometry(t);
    FrameTransform {
        timestamp: Time::from_ns(time_ns),
        parent_frame_id: parent.into(),
        child_frame_id: child.into(),
        translation: p.position,
        rotation: p.orientation,
    }
}

fn world_to_shoulder(arm: &HumanArm) -> Isometry3<f64> {
    Isometry3::translation(0.0, 0.0, SHOULDER_HEIGHT * body_height(arm))
}

/// The other shoulder's side: +y for a right arm, −y for a left one.
fn across(arm: &HumanArm) -> f64 {
    match arm.side {
        Hand::Right => 1.0,
        Hand::Left => -1.0,
    }
}

fn world_to_view(arm: &HumanArm) -> Isometry3<f64> {
    let h = body_height(arm);
    Isometry3::translation(VIEW_AHEAD * h, across(arm) * VIEW_ACROSS * h, VIEW_UP * h)
}

/// `/tf` at the start: world → shoulder and world → view.
pub fn start_transforms(time_ns: u64, arm: &HumanArm) -> FrameTransforms {
    FrameTransforms {
        transforms: vec![
            transform(time_ns, WORLD, SHOULDER, &world_to_shoulder(arm)),
            transform(time_ns, WORLD, VIEW, &world_to_view(arm)),
        ],
    }
}

/// `/tf` of a presented query: the start's frames again and shoulder → object (the
/// commanded pose).
pub fn query_transforms(time_ns: u64, arm: &HumanArm, q: &ResolvedQuery) -> FrameTransforms {
    let mut tf = start_transforms(time_ns, arm);
    tf.transforms.push(transform(time_ns, SHOULDER, OBJECT, &q.pose.to_isometry()));
    tf
}

fn point(p: Point3<f64>) -> Vector3 {
    Vector3 { x: p.x, y: p.y, z: p.z }
}

fn strip(points: Vec<Vector3>, thickness: f64, color: Color) -> LinePrimitive {
    LinePrimitive {
        kind: 0,
        pose: Pose::IDENTITY,
        thickness,
        scale_invariant: false,
        points,
        color,
        colors: Vec::new(),
        indices: Vec::new(),
    }
}

/// The participant's trunk and head in `world`: shoulders, spine and a head box, so that the
/// arm and the object are seen against the person.
pub fn body(time_ns: u64, arm: &HumanArm) -> SceneEntity {
    let h = body_height(arm);
    // The modelled shoulder is at y = 0; the other is across the chest.
    let other = across(arm) * 2.0 * HALF_SHOULDER_WIDTH * h;
    let mid = other / 2.0;
    let mut e = SceneEntity::new(time_ns, WORLD, "body");
    let v = |x: f64, y: f64, z: f64| Vector3 { x, y, z };
    e.lines.push(strip(vec![v(0.0, 0.0, SHOULDER_HEIGHT * h), v(0.0, other, SHOULDER_HEIGHT * h)], 0.04, BODY));
    e.lines.push(strip(vec![v(0.0, mid, SHOULDER_HEIGHT * h), v(0.0, mid, HIP_HEIGHT * h)], 0.05, BODY));
    let head = (HEAD_TOP - CHIN_HEIGHT) * h;
    e.cubes.push(CubePrimitive {
        pose: Pose { position: v(0.0, mid, (CHIN_HEIGHT * h) + head / 2.0), orientation: Quaternion::IDENTITY },
        size: v(0.2, 0.16, head),
        color: BODY,
    });
    e
}

/// `/human/arm` at the start: the body alone.
pub fn body_only(time_ns: u64, arm: &HumanArm) -> SceneUpdate {
    SceneUpdate { deletions: Vec::new(), entities: vec![body(time_ns, arm)] }
}

/// `/human/arm` when no grasp is shown (a new query presented, a grasp undone or voided):
/// the body, and the last grasp's arms deleted, so that the scene never shows an arm that
/// did not take the object offered.
pub fn arm_cleared(time_ns: u64, arm: &HumanArm) -> SceneUpdate {
    SceneUpdate {
        deletions: vec![deletion(time_ns, "human_arm"), deletion(time_ns, "measured_arm")],
        entities: vec![body(time_ns, arm)],
    }
}

/// The deletion of the entity `id` (kind 0: by id).
fn deletion(time_ns: u64, id: &str) -> super::foxglove::SceneEntityDeletion {
    super::foxglove::SceneEntityDeletion { timestamp: Time::from_ns(time_ns), kind: 0, id: id.into() }
}

/// `/human/arm` of a grasp: the body again (a viewer that seeks, or joins a live session late,
/// shows only a topic's latest message) and the arm of a configuration in `shoulder`
/// (shoulder, elbow, wrist, grasp).
pub fn arm(time_ns: u64, arm: &HumanArm, q: &ArmConfig) -> SceneUpdate {
    let mut e = SceneEntity::new(time_ns, SHOULDER, "human_arm");
    e.lines.push(strip(arm.points(q).into_iter().map(point).collect(), 0.03, ARM));
    SceneUpdate { deletions: Vec::new(), entities: vec![body(time_ns, arm), e] }
}

/// The arm as a measuring system saw it, beside [`arm`]'s: entity `measured_arm`, thinner, in
/// [`MEASURED`]; `None` deletes the last one (a grasp without a measurement).
pub fn measured_arm(update: &mut SceneUpdate, time_ns: u64, arm: &HumanArm, q: Option<&ArmConfig>) {
    match q {
        Some(q) => {
            let mut e = SceneEntity::new(time_ns, SHOULDER, "measured_arm");
            e.lines.push(strip(arm.points(q).into_iter().map(point).collect(), 0.015, MEASURED));
            update.entities.push(e);
        }
        None => update.deletions.push(deletion(time_ns, "measured_arm")),
    }
}

fn axes(length: f64) -> Vec<ArrowPrimitive> {
    let arrow = |rotation: UnitQuaternion<f64>, color: Color| ArrowPrimitive {
        pose: Pose { position: Vector3 { x: 0.0, y: 0.0, z: 0.0 }, orientation: rotation.into() },
        shaft_length: length * 0.8,
        shaft_diameter: 0.008,
        head_length: length * 0.2,
        head_diameter: 0.02,
        color,
    };
    // An arrow points along its pose's x axis.
    vec![
        arrow(UnitQuaternion::identity(), Color { r: 0.9, g: 0.1, b: 0.1, a: 1.0 }),
        arrow(
            UnitQuaternion::from_euler_angles(0.0, 0.0, std::f64::consts::FRAC_PI_2),
            Color { r: 0.1, g: 0.8, b: 0.1, a: 1.0 },
        ),
        arrow(
            UnitQuaternion::from_euler_angles(0.0, -std::f64::consts::FRAC_PI_2, 0.0),
            Color { r: 0.1, g: 0.3, b: 0.9, a: 1.0 },
        ),
    ]
}

/// `/scene/object`: the object of a presented query in `object`: each grip a box spanning its
/// TSR's translation bounds (at least [`MIN_GRIP_SIDE`]) in the colour its label names, the
/// offered ones opaque and the others faint; each labelled as the participant with `hand`
/// has it, in that colour (one that reads on a light and a dark theme), above the whole
/// object; a bar through the grips; the object's axes (x red, y green, z blue: the offered
/// pose).
pub fn object(time_ns: u64, object: &Object, q: &ResolvedQuery, hand: Hand) -> SceneUpdate {
    let mut e = SceneEntity::new(time_ns, OBJECT, "object");
    // Up as the participant stands, in the object's frame, whatever the object's turn.
    let up = q.pose.to_isometry().rotation.inverse() * NVector3::z();
    let grips: Vec<_> = object
        .regions
        .iter()
        .map(|region| {
            let b = region.tsr.bw;
            let centre = NVector3::new((b[0][0] + b[0][1]) / 2.0, (b[1][0] + b[1][1]) / 2.0, (b[2][0] + b[2][1]) / 2.0);
            let pose = region.tsr.t0_w.to_isometry() * Translation3::from(centre);
            let extent = NVector3::from_fn(|k, _| (b[k][1] - b[k][0]).max(MIN_GRIP_SIDE));
            (pose, extent)
        })
        .collect();
    // The labels stand in a column above everything the object draws (its boxes, its axes and
    // so the pose arrow at its centre), one line per grip, each over its own grip and joined
    // to it by a thin line in its colour: no label covers a box, an axis, the pose arrow or
    // another label.
    let top = grips
        .iter()
        .map(|(pose, extent)| pose.translation.vector.dot(&up) + extent.norm() / 2.0)
        .fold(AXES_LENGTH, f64::max)
        + LABEL_GAP;
    let mut centres = Vec::new();
    for (i, (region, (pose, extent))) in object.regions.iter().zip(&grips).enumerate() {
        let offered = q.regions.contains(&i);
        let color = if offered { grip_colour(&region.label, i) } else { NOT_OFFERED };
        e.cubes.push(CubePrimitive {
            pose: Pose::from_isometry(pose),
            size: Vector3 { x: extent.x, y: extent.y, z: extent.z },
            color,
        });
        let c = pose.translation.vector;
        let height = top + LABEL_STEP * i as f64;
        let at = c + up * (height - c.dot(&up));
        let label = Isometry3::from_parts(Translation3::from(at), UnitQuaternion::identity());
        let name = hand.experienced(&region.label);
        let leader = [c + up * (extent.norm() / 2.0), at - up * (LABEL_STEP / 3.0)];
        e.lines.push(strip(leader.iter().map(|&p| point(Point3::from(p))).collect(), 0.003, color));
        e.texts.push(TextPrimitive {
            pose: Pose::from_isometry(&label),
            billboard: true,
            font_size: 13.0,
            scale_invariant: true,
            color: if offered { color } else { NOT_OFFERED_TEXT },
            text: if offered { name } else { format!("{name} (not offered)") },
        });
        centres.push(point(Point3::from(c)));
    }
    if centres.len() > 1 {
        e.lines.push(strip(centres, 0.02, OBJECT_BODY));
    }
    e.arrows = axes(AXES_LENGTH);
    e.metadata = vec![
        super::foxglove::KeyValuePair { key: "query".into(), value: q.query.id.clone() },
        super::foxglove::KeyValuePair { key: "pose".into(), value: hand.experienced(&q.query.label) },
        super::foxglove::KeyValuePair { key: "object".into(), value: object.label.clone() },
    ];
    SceneUpdate { deletions: Vec::new(), entities: vec![e] }
}

#[cfg(test)]
mod tests {
    use super::grip_colour;

    #[test]
    fn grips_take_the_colour_their_label_names() {
        assert_eq!(grip_colour("Left grip (blue)", 1).b, 0.9);
        assert_eq!(grip_colour("Right shackle grip (red)", 0).r, 0.85);
        // "Bluetooth" names no colour: the palette.
        assert_eq!(grip_colour("Bluetooth handle", 0), grip_colour("plain", 0));
        assert_ne!(grip_colour("plain", 0), grip_colour("plain", 1));
    }
}
