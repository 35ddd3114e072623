//! The 7-DoF human arm of sections VI–VII, right or left: forward kinematics and the
//! analytic inverse kinematics by the swivel angle (Tolani, Goswami, Badler 2000).
//!
//! # Frames and joint conventions
//! The shoulder frame has its origin at the shoulder joint of the arm modelled, x forward,
//! y to the person's left, z up. Every segment frame has its segment along its own −z, so at q = 0
//! the arm hangs straight down with the palm facing the body (thumb forward).
//!
//! | # | joint | rotation | positive |
//! |---|---|---|---|
//! | 0 | shoulder flexion | about −y of the torso | arm raised forward |
//! | 1 | shoulder abduction | about −x | arm raised sideways, away from the body |
//! | 2 | shoulder internal rotation | about the upper arm's own axis (+z) | forearm turned toward the body |
//! | 3 | elbow flexion | about the upper arm's −y | forearm raised forward |
//! | 4 | forearm pronation | about the forearm's own axis (+z) | palm turned down (from thumb-up) |
//! | 5 | wrist flexion | about the forearm's −y | hand bent toward the palm side |
//! | 6 | wrist deviation | about the hand's −x | hand bent toward the thumb (radial) |
//!
//! R_shoulder = Ry(−q0) Rx(−q1) Rz(q2); R_elbow = R_shoulder Ry(−q3);
//! R_hand = R_elbow Rz(q4) Ry(−q5) Rx(−q6). The hand's grasp point is `hand` metres along
//! the hand frame's −z from the wrist; the grasp frame is the hand frame there, with the
//! grip axis along its x and the palm normal along its y.

use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// Number of joints.
pub const JOINTS: usize = 7;

/// Joint names in order.
pub const JOINT_NAMES: [&str; JOINTS] = [
    "shoulder_flexion",
    "shoulder_abduction",
    "shoulder_internal_rotation",
    "elbow_flexion",
    "forearm_pronation",
    "wrist_flexion",
    "wrist_radial_deviation",
];

/// A configuration of the 7 joints (rad).
pub type ArmConfig = [f64; JOINTS];

/// Which arm: the participant's dominant hand.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Hand {
    #[default]
    Right,
    Left,
}

impl Hand {
    pub fn name(self) -> &'static str {
        match self {
            Hand::Right => "right",
            Hand::Left => "left",
        }
    }

    /// The other hand.
    pub fn other(self) -> Hand {
        match self {
            Hand::Right => Hand::Left,
            Hand::Left => Hand::Right,
        }
    }

    /// A protocol label (a pose, a grip) as a participant with this hand experiences it: for
    /// a left hand, whose poses are mirrored (docs/kinematics.md), its whole words "left" and
    /// "right" swapped (case kept); unchanged for a right hand. Every screen and the 3D scene
    /// name poses and grips this way; the logs' data and the tables keep the protocol's words.
    pub fn experienced(self, label: &str) -> String {
        if self == Hand::Right {
            return label.to_string();
        }
        fn swap(word: &str) -> &str {
            match word {
                "left" => "right",
                "right" => "left",
                "Left" => "Right",
                "Right" => "Left",
                "LEFT" => "RIGHT",
                "RIGHT" => "LEFT",
                w => w,
            }
        }
        let mut out = String::with_capacity(label.len());
        let mut start = 0;
        for (i, c) in label.char_indices() {
            if !c.is_alphanumeric() {
                out.push_str(swap(&label[start..i]));
                out.push(c);
                start = i + c.len_utf8();
            }
        }
        out.push_str(swap(&label[start..]));
        out
    }

    /// A pose in this arm's shoulder frame as the right arm's model sees it: itself for the
    /// right arm, its mirror image M T M for the left (M = diag(1, −1, 1)).
    pub fn as_right(self, t: &Isometry3<f64>) -> Isometry3<f64> {
        match self {
            Hand::Right => *t,
            Hand::Left => mirror(t),
        }
    }
}

/// The mirror image M T M of a pose in the sagittal plane (M = diag(1, −1, 1)): the
/// position's y negated, the rotation conjugated (roll and yaw negated).
pub fn mirror(t: &Isometry3<f64>) -> Isometry3<f64> {
    let m = Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, 1.0));
    let r = m * t.rotation.to_rotation_matrix().matrix() * m;
    let p = t.translation.vector;
    Isometry3::from_parts(
        Translation3::new(p.x, -p.y, p.z),
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r)),
    )
}

/// Segment lengths and joint limits of one person's arm.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HumanArm {
    /// Shoulder–elbow (m).
    pub upper_arm: f64,
    /// Elbow–wrist (m).
    pub forearm: f64,
    /// Wrist–grasp centre (m).
    pub hand: f64,
    /// [min, max] per joint (rad).
    pub limits: [[f64; 2]; JOINTS],
    /// Which arm (the right unless stated).
    #[serde(default)]
    pub side: Hand,
}

/// Why an arm description was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ArmError {
    #[error("{segment} length is {value} m, expected a positive number below 2 m")]
    BadLength { segment: &'static str, value: f64 },
    #[error("limits of {joint}: min {min} must be below max {max}")]
    BadLimits { joint: &'static str, min: f64, max: f64 },
    #[error("body height {value} m is outside 0.5–2.5 m")]
    BadHeight { value: f64 },
}

/// Winter's segment fractions of body height (after Drillis & Contini).
pub const UPPER_ARM_FRACTION: f64 = 0.186;
pub(crate) const FOREARM_FRACTION: f64 = 0.146;
pub(crate) const HAND_FRACTION: f64 = 0.108;
/// The grasp centre lies this fraction of the hand's length from the wrist.
pub(crate) const GRASP_CENTRE_FRACTION: f64 = 0.4;

/// AAOS ranges of motion (Norkin & White) in this model's convention, degrees.
pub(crate) const AAOS_LIMITS_DEG: [[f64; 2]; JOINTS] = [
    [-60.0, 180.0], // flexion 180 / extension 60
    [-30.0, 180.0], // abduction 180 / adduction ~30
    [-90.0, 70.0],  // internal 70 / external 90
    [0.0, 150.0],   // elbow flexion 150 / extension 0
    [-80.0, 80.0],  // pronation 80 / supination 80
    [-70.0, 80.0],  // wrist flexion 80 / extension 70
    [-30.0, 20.0],  // radial 20 / ulnar 30
];

impl HumanArm {
    /// Segment lengths from body height by Winter's fractions, AAOS limits.
    pub fn from_height(height: f64) -> Result<Self, ArmError> {
        if !(0.5..=2.5).contains(&height) {
            return Err(ArmError::BadHeight { value: height });
        }
        Ok(Self::with_lengths(
            UPPER_ARM_FRACTION * height,
            FOREARM_FRACTION * height,
            GRASP_CENTRE_FRACTION * HAND_FRACTION * height,
        ))
    }

    /// Given segment lengths (m), AAOS limits.
    pub fn with_lengths(upper_arm: f64, forearm: f64, hand: f64) -> Self {
        Self {
            upper_arm,
            forearm,
            hand,
            limits: AAOS_LIMITS_DEG.map(|[a, b]| [a.to_radians(), b.to_radians()]),
            side: Hand::Right,
        }
    }

    /// The same arm on the other side of the body (mirrored).
    pub fn on_side(self, side: Hand) -> Self {
        Self { side, ..self }
    }

    /// Reach from the shoulder to the grasp centre with the arm straight (m).
    pub fn reach(&self) -> f64 {
        self.upper_arm + self.forearm + self.hand
    }

    /// Checks lengths and limits.
    pub fn validate(&self) -> Result<(), ArmError> {
        for (segment, value) in [("upper_arm", self.upper_arm), ("forearm", self.forearm), ("hand", self.hand)] {
            if !(value.is_finite() && value > 0.0 && value < 2.0) {
                return Err(ArmError::BadLength { segment, value });
            }
        }
        for (d, [min, max]) in self.limits.iter().copied().enumerate() {
            if !(min.is_finite() && max.is_finite() && min < max) {
                return Err(ArmError::BadLimits { joint: JOINT_NAMES[d], min, max });
            }
        }
        Ok(())
    }

    pub fn within_limits(&self, q: &ArmConfig) -> bool {
        self.within_limits_from(0, q)
    }

    /// Whether joints `first`, `first + 1`, … of a configuration, given as `q`, are inside
    /// their limits.
    pub(crate) fn within_limits_from(&self, first: usize, q: &[f64]) -> bool {
        q.iter().zip(&self.limits[first..]).all(|(v, [lo, hi])| *v >= *lo && *v <= *hi)
    }

    /// Forward kinematics: the frames of the shoulder, elbow, wrist and hand (grasp point),
    /// all in the shoulder frame (mirrored for a left arm).
    pub fn forward(&self, q: &ArmConfig) -> ArmFrames {
        let f = self.forward_right(q);
        match self.side {
            Hand::Right => f,
            Hand::Left => ArmFrames {
                shoulder: mirror(&f.shoulder),
                elbow: mirror(&f.elbow),
                wrist: mirror(&f.wrist),
                hand: mirror(&f.hand),
            },
        }
    }

    /// Forward kinematics of the right arm with these lengths.
    pub(crate) fn forward_right(&self, q: &ArmConfig) -> ArmFrames {
        let r_shoulder = ry(-q[0]) * rx(-q[1]) * rz(q[2]);
        let r_elbow = r_shoulder * ry(-q[3]);
        let r_hand = r_elbow * rz(q[4]) * ry(-q[5]) * rx(-q[6]);
        let down = Vector3::new(0.0, 0.0, -1.0);
        let elbow = r_shoulder * down * self.upper_arm;
        let wrist = elbow + r_elbow * down * self.forearm;
        let hand = wrist + r_hand * down * self.hand;
        let frame = |r: Matrix3<f64>, p: Vector3<f64>| {
            Isometry3::from_parts(
                Translation3::from(p),
                UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r)),
            )
        };
        ArmFrames {
            shoulder: frame(r_shoulder, Vector3::zeros()),
            elbow: frame(r_elbow, elbow),
            wrist: frame(r_hand, wrist),
            hand: frame(r_hand, hand),
        }
    }

    /// The points of the arm for a configuration (shoulder, elbow, wrist, hand).
    pub fn points(&self, q: &ArmConfig) -> [Point3<f64>; 4] {
        let f = self.forward(q);
        [f.shoulder, f.elbow, f.wrist, f.hand].map(|i| Point3::from(i.translation.vector))
    }
}

/// The frames of one arm configuration, in the shoulder frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ArmFrames {
    pub shoulder: Isometry3<f64>,
    pub elbow: Isometry3<f64>,
    pub wrist: Isometry3<f64>,
    /// The grasp frame: origin at the grasp centre, orientation of the hand.
    pub hand: Isometry3<f64>,
}

pub(crate) fn rx(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

pub(crate) fn ry(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

pub(crate) fn rz(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::Hand;

    #[test]
    fn a_left_hand_has_left_and_right_swapped_in_whole_words() {
        let l = |s: &str| Hand::Left.experienced(s);
        assert_eq!(l("Handlebars at chest height, turned left"), "Handlebars at chest height, turned right");
        assert_eq!(l("Left grip (blue)"), "Right grip (blue)");
        assert_eq!(l("RIGHT shackle"), "LEFT shackle");
        assert_eq!(l("leftover, upright, bright"), "leftover, upright, bright");
        assert_eq!(l("Über-left → right"), "Über-right → left");
        assert_eq!(Hand::Right.experienced("Left grip (blue)"), "Left grip (blue)");
    }
}
