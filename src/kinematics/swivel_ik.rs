//! Analytic inverse kinematics of the 7-DoF arm by the swivel angle (Tolani et al. 2000).
//!
//! For a grasp frame: the wrist centre follows from the hand offset; the elbow flexion from
//! the law of cosines; the elbow then lies on a circle about the shoulder–wrist axis,
//! parameterised by the swivel angle φ (φ = 0: the elbow at its lowest, measured from the
//! reference axis −z; if the shoulder–wrist axis is within 0.06° of −z the reference
//! switches to +x). For each φ, the shoulder angles follow from the elbow and wrist
//! positions and the wrist angles from the remaining orientation, each Euler decomposition
//! with two branches: up to four solutions per φ, of which those inside the limits are kept.

use nalgebra::{Isometry3, Matrix3, Vector3};

use super::human_arm::{ArmConfig, HumanArm, ry};
use super::planar::wrap;

/// One IK solution and the swivel angle it was found at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IkSolution {
    pub q: ArmConfig,
    pub swivel: f64,
}

/// Below this, a sine or cosine is treated as zero (a singular decomposition).
const SINGULAR: f64 = 1e-12;

/// The elbow circle for a wrist position.
struct ElbowCircle {
    centre: Vector3<f64>,
    radius: f64,
    u: Vector3<f64>,
    v: Vector3<f64>,
}

impl ElbowCircle {
    fn new(arm: &HumanArm, wrist: &Vector3<f64>) -> Option<Self> {
        let (l1, l2) = (arm.upper_arm, arm.forearm);
        let dist = wrist.norm();
        if dist > l1 + l2 || dist < (l1 - l2).abs() || dist < 1e-9 {
            return None;
        }
        let n = wrist / dist;
        let cos_beta = ((l1 * l1 + dist * dist - l2 * l2) / (2.0 * l1 * dist)).clamp(-1.0, 1.0);
        let sin_beta = (1.0 - cos_beta * cos_beta).max(0.0).sqrt();
        let mut reference = Vector3::new(0.0, 0.0, -1.0);
        let mut u = reference - reference.dot(&n) * n;
        if u.norm() < 1e-3 {
            reference = Vector3::new(1.0, 0.0, 0.0);
            u = reference - reference.dot(&n) * n;
        }
        let u = u.normalize();
        let v = n.cross(&u);
        Some(Self { centre: n * (l1 * cos_beta), radius: l1 * sin_beta, u, v })
    }
}

/// How far (rad) a cheap arctangent must put an angle outside its limits before it is
/// dropped without the exact one: far more than [`approx_atan2`]'s error (below 2e-6, tested).
const APPROX_MARGIN: f64 = 1e-4;

/// atan2(y, x) to within 2e-6 rad, without a call into libm: the arctangent of the smaller
/// over the larger magnitude by a degree-11 odd polynomial (least squares on [0, 1]), then
/// the octant. NaN when both are zero or either is not finite.
#[inline(always)]
fn approx_atan2(y: f64, x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, PI};
    const C: [f64; 6] = [
        0.999_979_833_527_109_4,
        -0.332_655_470_054_945_9,
        0.193_670_230_425_013_16,
        -0.116_650_888_432_088_75,
        0.052_823_228_824_713_43,
        -0.011_770_394_558_749_574,
    ];
    let (ax, ay) = (x.abs(), y.abs());
    let steep = ay > ax;
    let t = if steep { ax / ay } else { ay / ax };
    let t2 = t * t;
    let p = C[0] + t2 * (C[1] + t2 * (C[2] + t2 * (C[3] + t2 * (C[4] + t2 * C[5]))));
    let a = t * p;
    let a = if steep { FRAC_PI_2 - a } else { a };
    let a = if x < 0.0 { PI - a } else { a };
    if y < 0.0 { -a } else { a }
}

/// Whether wrap(sign · atan2(y, x)) is certainly outside `[lo, hi]`, given `approx`,
/// [`approx_atan2`] or an exact transformation of it: decided only when it is outside by
/// [`APPROX_MARGIN`] and away from ±π (where wrapping could move it), otherwise `false` and
/// the exact arctangent decides. So dropping a branch on it drops exactly what the exact
/// test drops, no more. A NaN is never certain.
#[inline(always)]
fn certainly_outside(approx: f64, sign: f64, [lo, hi]: [f64; 2]) -> bool {
    use std::f64::consts::PI;
    let a = sign * approx;
    a.abs() < PI - APPROX_MARGIN && (a < lo - APPROX_MARGIN || a > hi + APPROX_MARGIN)
}

/// The angle of (−y, −x) from that of (y, x): turned by π, into [−π, π].
#[inline(always)]
fn half_turn(a: f64) -> f64 {
    use std::f64::consts::PI;
    if a > 0.0 { a - PI } else { a + PI }
}

/// A decomposition before its `hypot`, for the cheap test: the middle angle's sine `s` and
/// the square root standing for its cosine `c` (within an ulp of `hypot`, far inside the
/// margin), and the outer angles' (y, x) undivided — the first branch divides them by +c,
/// which leaves their angle, the second by −c, which turns it by π.
struct Cheap {
    s: f64,
    c: f64,
    outer: [(f64, f64); 2],
}

impl Cheap {
    /// As [`decompose_yxz`] reads its matrix.
    fn yxz(r: &Matrix3<f64>) -> Self {
        let c = (r[(1, 0)] * r[(1, 0)] + r[(1, 1)] * r[(1, 1)]).sqrt();
        Self { s: -r[(1, 2)], c, outer: [(r[(0, 2)], r[(2, 2)]), (r[(1, 0)], r[(1, 1)])] }
    }

    /// As [`decompose_zyx`] reads its matrix.
    fn zyx(r: &Matrix3<f64>) -> Self {
        let c = (r[(2, 1)] * r[(2, 1)] + r[(2, 2)] * r[(2, 2)]).sqrt();
        Self { s: -r[(2, 0)], c, outer: [(r[(1, 0)], r[(0, 0)]), (r[(2, 1)], r[(2, 2)])] }
    }
}

/// One branch of an Euler decomposition: each of its three angles as the (y, x) whose
/// atan2 it is, so that an angle is computed only when the ones before it are in limits.
type Branch = [(f64, f64); 3];

/// R = Ry(a) Rx(b) Rz(c): both branches of (a, b, c).
fn decompose_yxz(r: &Matrix3<f64>) -> (Branch, Option<Branch>) {
    let sb = -r[(1, 2)];
    let cb = r[(1, 0)].hypot(r[(1, 1)]);
    if cb < SINGULAR {
        return ([(-r[(2, 0)], r[(0, 0)]), (sb, 0.0), (0.0, 1.0)], None);
    }
    let branch = |cb: f64| [(r[(0, 2)] / cb, r[(2, 2)] / cb), (sb, cb), (r[(1, 0)] / cb, r[(1, 1)] / cb)];
    (branch(cb), Some(branch(-cb)))
}

/// R = Rz(c) Ry(a) Rx(b): both branches of (c, a, b).
fn decompose_zyx(r: &Matrix3<f64>) -> (Branch, Option<Branch>) {
    let sa = -r[(2, 0)];
    let ca = r[(2, 1)].hypot(r[(2, 2)]);
    if ca < SINGULAR {
        return ([(-r[(0, 1)], r[(1, 1)]), (sa, 0.0), (0.0, 1.0)], None);
    }
    let branch = |ca: f64| [(r[(1, 0)] / ca, r[(0, 0)] / ca), (sa, ca), (r[(2, 1)] / ca, r[(2, 2)] / ca)];
    (branch(ca), Some(branch(-ca)))
}

/// Up to two branches' joint angles, without allocating.
struct Branches {
    angles: [[f64; 3]; 2],
    len: usize,
}

impl Branches {
    fn is_empty(&self) -> bool {
        self.len == 0
    }

    fn iter(&self) -> impl Iterator<Item = &[f64; 3]> {
        self.angles[..self.len].iter()
    }
}

impl HumanArm {
    /// The wrist centre for a grasp frame.
    fn wrist_for(&self, grasp: &Isometry3<f64>) -> Vector3<f64> {
        grasp.translation.vector + grasp.rotation * Vector3::new(0.0, 0.0, self.hand)
    }

    /// Every solution reaching `grasp` (in this arm's shoulder frame) at the given swivel
    /// angles, inside the joint limits. An unreachable grasp gives no solution. A left arm
    /// solves the mirrored grasp with the right arm's model (the angles are anatomical).
    pub fn inverse(&self, grasp: &Isometry3<f64>, swivels: &Swivels) -> Vec<IkSolution> {
        let grasp = &self.side.as_right(grasp);
        let mut out = Vec::new();
        let wrist = self.wrist_for(grasp);
        let Some(circle) = ElbowCircle::new(self, &wrist) else {
            return out;
        };
        let (l1, l2) = (self.upper_arm, self.forearm);
        let cos_elbow = ((wrist.norm_squared() - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)).clamp(-1.0, 1.0);
        let elbow_flexion = cos_elbow.acos();
        let r_hand: Matrix3<f64> = *grasp.rotation.to_rotation_matrix().matrix();
        let mut elbows = vec![elbow_flexion];
        if elbow_flexion > 0.0 && -elbow_flexion >= self.limits[3][0] {
            elbows.push(-elbow_flexion);
        }
        // What depends on the elbow alone, once: its sine and cosine, its rotation, and
        // whether it is inside its limits at all.
        let elbows: Vec<(f64, (f64, f64), Matrix3<f64>)> = elbows
            .into_iter()
            .filter(|&q3| self.within_limits_from(3, &[wrap(q3)]))
            .map(|q3| (q3, q3.sin_cos(), ry(-q3)))
            .collect();
        for (&phi, &(s, c)) in swivels.angles.iter().zip(&swivels.sin_cos) {
            let radial = circle.u * c + circle.v * s;
            let elbow = circle.centre + radial * circle.radius;
            let d1 = elbow / l1;
            let d2 = (wrist - elbow) / l2;
            for &(q3, (s3, c3), r_flexion) in &elbows {
                // d2 = sin q3 · x_s + cos q3 · d1 (the forearm in the upper arm's x–z plane).
                let x_s = if s3.abs() > 1e-9 { ((d2 - d1 * c3) / s3).normalize() } else { radial };
                let z_s = -d1;
                let y_s = z_s.cross(&x_s);
                let r_shoulder = Matrix3::from_columns(&[x_s, y_s, z_s]);
                // Which branches of the shoulder and the wrist may be inside their limits, by
                // the cheap arctangent: most (φ, elbow) have none and are dropped without a
                // `hypot` or an exact arctangent. The exact test decides the rest.
                const SHOULDER_SIGNS: [f64; 3] = [-1.0, -1.0, 1.0];
                const WRIST_SIGNS: [f64; 3] = [1.0, -1.0, -1.0];
                let shoulder_may = self.may_be_within(0, SHOULDER_SIGNS, &Cheap::yxz(&r_shoulder));
                if shoulder_may == [false; 2] {
                    continue;
                }
                let m = (r_shoulder * r_flexion).transpose() * r_hand;
                let wrist_may = self.may_be_within(4, WRIST_SIGNS, &Cheap::zyx(&m));
                if wrist_may == [false; 2] {
                    continue;
                }
                let (s1, s2) = decompose_yxz(&r_shoulder);
                let shoulders = self.branches_within(0, SHOULDER_SIGNS, s1, s2, shoulder_may);
                if shoulders.is_empty() {
                    continue;
                }
                let (w1, w2) = decompose_zyx(&m);
                let wrists = self.branches_within(4, WRIST_SIGNS, w1, w2, wrist_may);
                let q3_wrapped = wrap(q3);
                for sh in shoulders.iter() {
                    for wr in wrists.iter() {
                        let q = [sh[0], sh[1], sh[2], q3_wrapped, wr[0], wr[1], wr[2]];
                        out.push(IkSolution { q, swivel: phi });
                    }
                }
            }
        }
        out
    }

    /// Which of a decomposition's two branches may have joints `first`, `first + 1`,
    /// `first + 2` (each angle times its sign) inside their limits: `false` only for a branch
    /// with an angle [`certainly_outside`]. Near the singular decomposition (one branch, read
    /// differently) both may.
    fn may_be_within(&self, first: usize, signs: [f64; 3], d: &Cheap) -> [bool; 2] {
        use std::f64::consts::PI;
        if d.c < 1e-6 {
            return [true; 2];
        }
        let [l0, l1, l2] = [self.limits[first], self.limits[first + 1], self.limits[first + 2]];
        let [(y0, x0), (y2, x2)] = d.outer;
        // The first branch's angles; the second's follow exactly: atan2(s, −c) = ±π − atan2(s, c)
        // and its outer angles turned by π.
        let (a0, a1, a2) = (approx_atan2(y0, x0), approx_atan2(d.s, d.c), approx_atan2(y2, x2));
        let b1 = if d.s >= 0.0 { PI - a1 } else { -PI - a1 };
        let (b0, b2) = (half_turn(a0), half_turn(a2));
        let first_may = !(certainly_outside(a1, signs[1], l1)
            || certainly_outside(a0, signs[0], l0)
            || certainly_outside(a2, signs[2], l2));
        let second_may = !(certainly_outside(b1, signs[1], l1)
            || certainly_outside(b0, signs[0], l0)
            || certainly_outside(b2, signs[2], l2));
        [first_may, second_may]
    }

    /// The branches whose joints `first`, `first + 1`, `first + 2` (each angle times its
    /// sign, wrapped) are inside their limits, in order, of those that `may` be; a branch's
    /// angles are computed one by one and it is dropped at its first angle out of limits,
    /// the middle angle first.
    fn branches_within(&self, first: usize, signs: [f64; 3], a: Branch, b: Option<Branch>, may: [bool; 2]) -> Branches {
        let mut out = Branches { angles: [[0.0; 3]; 2], len: 0 };
        'branch: for (branch, _) in std::iter::once(a).chain(b).zip(may).filter(|(_, may)| *may) {
            for k in [1, 0, 2] {
                let (y, x) = branch[k];
                let angle = wrap(signs[k] * y.atan2(x));
                let [lo, hi] = self.limits[first + k];
                if !(angle >= lo && angle <= hi) {
                    continue 'branch;
                }
                out.angles[out.len][k] = angle;
            }
            out.len += 1;
        }
        out
    }

    /// Every solution over a swivel grid φ = 0, step, 2·step, … (one full turn, no repeated
    /// endpoint).
    #[cfg(test)]
    pub(crate) fn inverse_grid(&self, grasp: &Isometry3<f64>, step: f64) -> Vec<IkSolution> {
        self.inverse(grasp, &swivel_grid(step))
    }

    /// The swivel angle of a configuration (as [`HumanArm::inverse`] measures it).
    #[cfg(test)]
    pub(crate) fn swivel_angle(&self, q: &ArmConfig) -> Option<f64> {
        let frames = self.forward_right(q);
        let wrist = frames.wrist.translation.vector;
        let elbow = frames.elbow.translation.vector;
        let circle = ElbowCircle::new(self, &wrist)?;
        let off = elbow - circle.centre;
        Some(off.dot(&circle.v).atan2(off.dot(&circle.u)))
    }
}

/// Swivel angles to search, with their sines and cosines computed once (every grasp of a
/// feasible set searches the same angles).
#[derive(Clone, Debug, PartialEq)]
pub struct Swivels {
    angles: Vec<f64>,
    sin_cos: Vec<(f64, f64)>,
}

impl Swivels {
    /// The given angles (rad), in order.
    pub fn new(angles: &[f64]) -> Self {
        Self { angles: angles.to_vec(), sin_cos: angles.iter().map(|a| a.sin_cos()).collect() }
    }

    pub fn angles(&self) -> &[f64] {
        &self.angles
    }
}

/// φ = 0, step, … below one full turn.
pub fn swivel_grid(step: f64) -> Swivels {
    let n = (std::f64::consts::TAU / step).round().max(1.0) as usize;
    let angles: Vec<f64> = (0..n).map(|k| k as f64 * std::f64::consts::TAU / n as f64).collect();
    Swivels::new(&angles)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::human_arm::JOINTS;
    use proptest::prelude::*;

    fn arm() -> HumanArm {
        HumanArm::from_height(1.75).unwrap()
    }

    fn in_limits() -> impl Strategy<Value = ArmConfig> {
        let a = arm();
        let ranges: Vec<_> = a.limits.iter().map(|[lo, hi]| (lo + 1e-3)..(hi - 1e-3)).collect();
        ranges.prop_map(|v| {
            let mut q = [0.0; JOINTS];
            q.copy_from_slice(&v);
            q
        })
    }

    fn pose_error(a: &Isometry3<f64>, b: &Isometry3<f64>) -> f64 {
        let dp = (a.translation.vector - b.translation.vector).norm();
        let dr = (a.rotation.to_rotation_matrix().matrix() - b.rotation.to_rotation_matrix().matrix()).abs().max();
        dp.max(dr)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        #[test]
        fn every_solution_reproduces_the_grasp_and_respects_the_arm(q in in_limits()) {
            let a = arm();
            let grasp = a.forward(&q).hand;
            let sols = a.inverse_grid(&grasp, 5f64.to_radians());
            for s in &sols {
                prop_assert!(pose_error(&a.forward(&s.q).hand, &grasp) < 1e-9, "{:?}", s);
                prop_assert!(a.within_limits(&s.q));
                let [sh, el, wr, _] = a.points(&s.q);
                prop_assert!(((el - sh).norm() - a.upper_arm).abs() < 1e-12);
                prop_assert!(((wr - el).norm() - a.forearm).abs() < 1e-12);
            }
        }

        #[test]
        fn a_configuration_is_found_again_at_its_own_swivel_angle(q in in_limits()) {
            let a = arm();
            prop_assume!(q[3] > 0.05); // a straight elbow leaves the swivel angle undefined
            let phi = a.swivel_angle(&q).unwrap();
            let sols = a.inverse(&a.forward(&q).hand, &Swivels::new(&[phi]));
            let found = sols.iter().any(|s| s.q.iter().zip(&q).all(|(x, y)| (x - y).abs() < 1e-9));
            prop_assert!(found, "{:?} not among {:?}", q, sols);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(100))]

        /// The left arm is the right arm's mirror image with the same anatomical angles, and
        /// its inverse kinematics reproduces its own grasps.
        #[test]
        fn the_left_arm_mirrors_the_right_and_solves_its_own_grasps(q in in_limits()) {
            let right = arm();
            let left = arm().on_side(crate::kinematics::Hand::Left);
            let (fr, fl) = (right.forward(&q), left.forward(&q));
            prop_assert!(pose_error(&fl.hand, &crate::kinematics::human_arm::mirror(&fr.hand)) < 1e-12);
            prop_assert!(fl.hand.translation.y == -fr.hand.translation.y);
            let sols = left.inverse_grid(&fl.hand, 5f64.to_radians());
            for s in &sols {
                prop_assert!(pose_error(&left.forward(&s.q).hand, &fl.hand) < 1e-9, "{:?}", s);
            }
            prop_assume!(q[3] > 0.05);
            let phi = left.swivel_angle(&q).unwrap();
            let found = left.inverse(&fl.hand, &Swivels::new(&[phi])).iter().any(|s| s.q.iter().zip(&q).all(|(x, y)| (x - y).abs() < 1e-9));
            prop_assert!(found);
        }
    }

    /// Abduction takes a right arm's hand to the right (−y) and a left arm's to the left.
    #[test]
    fn abduction_raises_either_arm_away_from_the_body() {
        let q = [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert!(arm().forward(&q).hand.translation.y < -0.3);
        assert!(arm().on_side(crate::kinematics::Hand::Left).forward(&q).hand.translation.y > 0.3);
    }

    #[test]
    fn unreachable_grasps_have_no_solution() {
        let a = arm();
        let far = Isometry3::translation(0.9, 0.0, 0.0);
        assert!(a.inverse_grid(&far, 0.1).is_empty());
    }

    #[test]
    fn no_nan_at_the_reference_singularity() {
        // Wrist straight below the shoulder: the shoulder–wrist axis lies on the reference axis.
        let a = arm();
        let q = [0.0, 0.0, 0.0, 0.4, 0.0, 0.0, 0.0];
        let grasp = a.forward(&q).hand;
        let sols = a.inverse_grid(&grasp, 5f64.to_radians());
        assert!(!sols.is_empty());
        for s in &sols {
            assert!(s.q.iter().all(|v| v.is_finite()));
            assert!(pose_error(&a.forward(&s.q).hand, &grasp) < 1e-9);
        }
        // Fully stretched arm: the elbow circle has radius zero.
        let straight = a.forward(&[0.3, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0]).hand;
        for s in a.inverse_grid(&straight, 5f64.to_radians()) {
            assert!(s.q.iter().all(|v| v.is_finite()));
        }
    }

    /// The search as first written, every branch's angles computed and the limits checked
    /// on the whole configuration: the oracle of the pruned search.
    fn inverse_unpruned(a: &HumanArm, grasp: &Isometry3<f64>, swivels: &Swivels) -> Vec<IkSolution> {
        let grasp = &a.side.as_right(grasp);
        let wrist = a.wrist_for(grasp);
        let Some(circle) = ElbowCircle::new(a, &wrist) else {
            return vec![];
        };
        let (l1, l2) = (a.upper_arm, a.forearm);
        let cos_elbow = ((wrist.norm_squared() - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)).clamp(-1.0, 1.0);
        let flexion = cos_elbow.acos();
        let r_hand: Matrix3<f64> = *grasp.rotation.to_rotation_matrix().matrix();
        let mut elbows = vec![flexion];
        if flexion > 0.0 && -flexion >= a.limits[3][0] {
            elbows.push(-flexion);
        }
        let angles = |b: Branch| b.map(|(y, x)| y.atan2(x));
        let mut out = vec![];
        for &phi in swivels.angles() {
            let (s, c) = phi.sin_cos();
            let radial = circle.u * c + circle.v * s;
            let elbow = circle.centre + radial * circle.radius;
            let (d1, d2) = (elbow / l1, (wrist - elbow) / l2);
            for &q3 in &elbows {
                let (s3, c3) = q3.sin_cos();
                let x_s = if s3.abs() > 1e-9 { ((d2 - d1 * c3) / s3).normalize() } else { radial };
                let z_s = -d1;
                let r_shoulder = Matrix3::from_columns(&[x_s, z_s.cross(&x_s), z_s]);
                let m = (r_shoulder * ry(-q3)).transpose() * r_hand;
                let (s1, s2) = decompose_yxz(&r_shoulder);
                let (w1, w2) = decompose_zyx(&m);
                for sh in std::iter::once(s1).chain(s2).map(angles) {
                    for wr in std::iter::once(w1).chain(w2).map(angles) {
                        let q = [-sh[0], -sh[1], sh[2], q3, wr[0], -wr[1], -wr[2]].map(wrap);
                        if a.within_limits(&q) {
                            out.push(IkSolution { q, swivel: phi });
                        }
                    }
                }
            }
        }
        out
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]

        /// Dropping a branch at its first angle out of limits (by the cheap arctangent
        /// when it is certainly out, by the exact one otherwise), and an elbow out of limits
        /// before any swivel angle, finds exactly the solutions of the full search, bit for
        /// bit and in the same order, for either arm.
        #[test]
        fn the_pruned_search_finds_exactly_the_solutions_of_the_full_search(
            q in in_limits(),
            offset in prop::array::uniform3(-0.08f64..0.08),
            tilt in prop::array::uniform3(-0.4f64..0.4),
            left in any::<bool>(),
        ) {
            let a = if left { arm().on_side(crate::kinematics::Hand::Left) } else { arm() };
            // Reachable grasps, and grasps near them whose solutions cross the limits.
            let mut grasp = a.forward(&q).hand;
            grasp.translation.vector += Vector3::from(offset);
            grasp.rotation *= nalgebra::UnitQuaternion::from_euler_angles(tilt[0], tilt[1], tilt[2]);
            let swivels = swivel_grid(5f64.to_radians());
            prop_assert_eq!(a.inverse(&grasp, &swivels), inverse_unpruned(&a, &grasp, &swivels));
        }
    }

    /// The cheap arctangent is within 2e-6 rad of atan2 everywhere (every octant, tiny and
    /// huge magnitudes), and NaN where it cannot say.
    #[test]
    fn the_cheap_arctangent_is_within_its_bound() {
        let mut worst: f64 = 0.0;
        for i in 0..200_000 {
            let t = i as f64 / 200_000.0 * std::f64::consts::TAU - std::f64::consts::PI;
            for r in [1e-300, 1e-9, 1.0, 1e9, 1e300] {
                let (y, x) = (r * t.sin(), r * t.cos());
                let d = (approx_atan2(y, x) - y.atan2(x)).abs();
                // ±π are one angle: at x < 0, y = ±0 the two may sit on either side.
                worst = worst.max(d.min((d - std::f64::consts::TAU).abs()));
            }
        }
        assert!(worst < 2e-6, "{worst}");
        assert!(worst * 10.0 < APPROX_MARGIN);
        assert!(approx_atan2(0.0, 0.0).is_nan());
        assert!(approx_atan2(f64::NAN, 1.0).is_nan());
        assert!(!certainly_outside(approx_atan2(0.0, 0.0), 1.0, [0.5, 1.0]));
        // Near ±π the exact test decides: the two sides of the cut are one angle.
        assert!(!certainly_outside(approx_atan2(1e-9, -1.0), 1.0, [-0.5, 0.5]));
        assert!(certainly_outside(approx_atan2(1.0, 0.0), 1.0, [-0.5, 0.5]));
        assert!(!certainly_outside(
            approx_atan2(1.0, 0.0),
            1.0,
            [-0.5, std::f64::consts::FRAC_PI_2 - 0.5 * APPROX_MARGIN]
        ));
    }

    #[test]
    fn swivel_grid_has_no_repeated_endpoint() {
        let g = swivel_grid(5f64.to_radians());
        let g = g.angles();
        assert_eq!(g.len(), 72);
        assert!(g[71] < std::f64::consts::TAU - 1e-9);
    }
}
