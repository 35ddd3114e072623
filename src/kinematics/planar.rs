//! The planar 2-DoF arm of the paper's section V, and random planar objects.

use nalgebra::{Point2, Rotation2, Vector2};
use rand::{Rng, RngExt};
use serde::{Deserialize, Serialize};

/// A planar two-link arm with its base at the origin.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlanarArm {
    /// Link lengths (m).
    pub l1: f64,
    pub l2: f64,
    /// [min, max] (rad) of the shoulder and the elbow.
    pub limits: [[f64; 2]; 2],
}

impl Default for PlanarArm {
    /// Two equal links of 0.3 m (upper arm and forearm scale), shoulder in (−π, π], elbow in (−π, π).
    fn default() -> Self {
        let pi = std::f64::consts::PI;
        Self { l1: 0.3, l2: 0.3, limits: [[-pi, pi], [-pi, pi]] }
    }
}

impl PlanarArm {
    /// The elbow and the end point for joint angles q.
    pub fn forward(&self, q: [f64; 2]) -> (Point2<f64>, Point2<f64>) {
        let elbow = Point2::new(self.l1 * q[0].cos(), self.l1 * q[0].sin());
        let a = q[0] + q[1];
        (elbow, elbow + Vector2::new(self.l2 * a.cos(), self.l2 * a.sin()))
    }

    /// Every joint solution reaching `p` inside the limits: both elbow branches,
    /// q2 = ±acos(c2), q1 = atan2(y, x) − atan2(l2 sin q2, l1 + l2 cos q2).
    /// An unreachable point gives no solution.
    pub fn inverse(&self, p: Point2<f64>) -> Vec<[f64; 2]> {
        let c2 = (p.x * p.x + p.y * p.y - self.l1 * self.l1 - self.l2 * self.l2) / (2.0 * self.l1 * self.l2);
        if !(-1.0..=1.0).contains(&c2) {
            return Vec::new();
        }
        let q2 = c2.acos();
        let mut out = Vec::with_capacity(2);
        for q2 in if q2 == 0.0 { vec![0.0] } else { vec![q2, -q2] } {
            let q1 = wrap(p.y.atan2(p.x) - (self.l2 * q2.sin()).atan2(self.l1 + self.l2 * q2.cos()));
            let q = [q1, q2];
            if self.within_limits(q) {
                out.push(q);
            }
        }
        out
    }

    pub fn within_limits(&self, q: [f64; 2]) -> bool {
        (0..2).all(|d| q[d] >= self.limits[d][0] && q[d] <= self.limits[d][1])
    }
}

/// Wraps an angle into (−π, π].
pub fn wrap(a: f64) -> f64 {
    let pi = std::f64::consts::PI;
    if a > -pi && a <= pi {
        // Already there (and `a % 2π` would return it unchanged): no division.
        return a;
    }
    let mut a = a % (2.0 * pi);
    if a <= -pi {
        a += 2.0 * pi;
    } else if a > pi {
        a -= 2.0 * pi;
    }
    a
}

/// A planar object: points along its closed outline, in order.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanarObject {
    pub points: Vec<Point2<f64>>,
}

/// One configuration of a planar feasible set and what it reaches.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanarConfig {
    pub q: [f64; 2],
    /// Index of the object point it reaches.
    pub point: usize,
    /// The connected piece of the feasible set (in configuration space) it belongs to:
    /// solutions of neighbouring outline points on the same elbow branch are connected.
    pub piece: usize,
}

/// Neighbouring solutions farther apart than this (rad, in either joint) are not connected.
const PIECE_GAP: f64 = 0.5;

impl PlanarObject {
    /// A closed random outline around `centre` (Fig. 5: same centre, random shape and size):
    /// `n` points at equally spaced angles, radius varying smoothly between `r_min` and `r_max`.
    pub fn random_shape<R: Rng + ?Sized>(centre: Point2<f64>, r_min: f64, r_max: f64, n: usize, rng: &mut R) -> Self {
        let base = rng.random_range(r_min..r_max);
        let harmonics: Vec<(f64, f64)> = (1..=3)
            .map(|k| (rng.random_range(0.0..0.4) / k as f64, rng.random_range(0.0..std::f64::consts::TAU)))
            .collect();
        let aspect = rng.random_range(0.3..1.0);
        let turn = rng.random_range(0.0..std::f64::consts::TAU);
        let points = (0..n)
            .map(|i| {
                let t = std::f64::consts::TAU * i as f64 / n as f64;
                let r = base * (1.0 + harmonics.iter().map(|(a, ph)| a * (t * 3.0 + ph).sin()).sum::<f64>());
                let local = Vector2::new(r * t.cos(), aspect * r * t.sin());
                centre + Rotation2::new(turn) * local
            })
            .collect();
        Self { points }
    }

    /// The same object moved by a rotation `angle` about its origin and a translation.
    pub fn placed(&self, angle: f64, at: Vector2<f64>) -> Self {
        let r = Rotation2::new(angle);
        Self { points: self.points.iter().map(|p| Point2::from(r * p.coords + at)).collect() }
    }

    /// Every IK solution of every point, labelled with its point and its connected piece
    /// (pieces numbered in order of first appearance).
    pub fn feasible_set(&self, arm: &PlanarArm) -> Vec<PlanarConfig> {
        let mut out = Vec::new();
        for (i, p) in self.points.iter().enumerate() {
            for q in arm.inverse(*p) {
                out.push(PlanarConfig { q, point: i, piece: 0 });
            }
        }
        // Union-find over solutions: connect the same elbow branch at consecutive points of
        // the closed outline when the joints move little.
        let mut parent: Vec<usize> = (0..out.len()).collect();
        fn find(p: &mut [usize], i: usize) -> usize {
            if p[i] != i {
                let r = find(p, p[i]);
                p[i] = r;
            }
            p[i]
        }
        let n = self.points.len();
        for a in 0..out.len() {
            for b in 0..out.len() {
                let next = (out[a].point + 1) % n;
                let same_branch = (out[a].q[1] >= 0.0) == (out[b].q[1] >= 0.0);
                let close = (0..2).all(|d| wrap(out[a].q[d] - out[b].q[d]).abs() < PIECE_GAP);
                if out[b].point == next && a != b && same_branch && close {
                    let (x, y) = (find(&mut parent, a), find(&mut parent, b));
                    parent[x] = y;
                }
            }
        }
        let mut ids = std::collections::HashMap::new();
        for (i, c) in out.iter_mut().enumerate() {
            let root = find(&mut parent, i);
            let next_id = ids.len();
            c.piece = *ids.entry(root).or_insert(next_id);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn inverse_returns_both_branches_that_reach_the_point(q1 in -3.0..3.0f64, q2 in 0.05..3.0f64) {
            let arm = PlanarArm { l1: 0.3, l2: 0.25, ..PlanarArm::default() };
            let (_, p) = arm.forward([q1, q2]);
            let sols = arm.inverse(p);
            prop_assert_eq!(sols.len(), 2);
            prop_assert!(sols[0][1] > 0.0 && sols[1][1] < 0.0, "one elbow-up, one elbow-down: {:?}", sols);
            for q in &sols {
                let (_, r) = arm.forward(*q);
                prop_assert!((r - p).norm() < 1e-9);
            }
            prop_assert!(sols.iter().any(|q| (q[0] - q1).abs() < 1e-9 && (q[1] - q2).abs() < 1e-9));
        }
    }

    #[test]
    fn unreachable_points_have_no_solution() {
        let arm = PlanarArm::default();
        assert!(arm.inverse(Point2::new(0.7, 0.0)).is_empty());
        assert!(PlanarArm { l1: 0.3, l2: 0.1, ..PlanarArm::default() }.inverse(Point2::new(0.1, 0.0)).is_empty());
    }

    #[test]
    fn limits_prune_solutions() {
        let arm = PlanarArm { limits: [[-3.2, 3.2], [0.0, 3.2]], ..PlanarArm::default() };
        let sols = arm.inverse(Point2::new(0.3, 0.2));
        assert_eq!(sols.len(), 1);
        assert!(sols[0][1] >= 0.0);
    }

    #[test]
    fn random_objects_are_reproducible_and_labelled() {
        use rand::SeedableRng;
        let mut a = crate::SeededRng::seed_from_u64(4);
        let mut b = crate::SeededRng::seed_from_u64(4);
        let o = PlanarObject::random_shape(Point2::new(0.3, 0.2), 0.05, 0.15, 24, &mut a);
        assert_eq!(o, PlanarObject::random_shape(Point2::new(0.3, 0.2), 0.05, 0.15, 24, &mut b));
        let set = o.feasible_set(&PlanarArm::default());
        assert!(!set.is_empty());
        assert!(set.iter().all(|c| c.point < 24));
    }

    #[test]
    fn the_two_elbow_branches_of_a_reachable_outline_are_two_pieces() {
        // A small circle well inside the workspace: every point has both branches, and each
        // branch traces one closed curve in configuration space.
        let points = (0..24)
            .map(|i| {
                let t = std::f64::consts::TAU * i as f64 / 24.0;
                Point2::new(0.35 + 0.05 * t.cos(), 0.1 + 0.05 * t.sin())
            })
            .collect();
        let set = PlanarObject { points }.feasible_set(&PlanarArm::default());
        assert_eq!(set.len(), 48);
        let pieces: std::collections::BTreeSet<usize> = set.iter().map(|c| c.piece).collect();
        assert_eq!(pieces.len(), 2);
        assert!(set.iter().all(|c| (c.piece == set[0].piece) == ((c.q[1] >= 0.0) == (set[0].q[1] >= 0.0))));
        // Cut by a joint limit, the elbow-down branch disappears and one piece is left.
        let limited = PlanarArm { limits: [[-3.2, 3.2], [0.0, 3.2]], ..PlanarArm::default() };
        let points = (0..24)
            .map(|i| {
                let t = std::f64::consts::TAU * i as f64 / 24.0;
                Point2::new(0.35 + 0.05 * t.cos(), 0.1 + 0.05 * t.sin())
            })
            .collect();
        let set = PlanarObject { points }.feasible_set(&limited);
        assert!(set.iter().all(|c| c.piece == 0));
    }
}
