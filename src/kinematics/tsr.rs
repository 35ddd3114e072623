//! Task Space Regions (Berenson, Srinivasa, Kuffner 2011) and their discretisation.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// A rigid pose: a translation (m) and roll–pitch–yaw (degrees), rotation Rz(yaw) Ry(pitch) Rx(roll).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct Pose {
    pub position: [f64; 3],
    #[serde(default)]
    pub rpy_deg: [f64; 3],
}

impl Pose {
    /// The pose of an isometry (roll, pitch, yaw in (−180°, 180°]).
    pub fn from_isometry(t: &Isometry3<f64>) -> Self {
        // Rounding noise of the rotation (below 1e-9 m or degrees) is cleared, so that a pose
        // reads as written (no "−0.0").
        let clean = |v: f64| if v.abs() < 1e-9 { 0.0 } else { v };
        let (r, p, y) = t.rotation.euler_angles();
        let v = t.translation.vector;
        Self { position: [v.x, v.y, v.z].map(clean), rpy_deg: [r, p, y].map(|a| clean(a.to_degrees())) }
    }

    pub fn to_isometry(&self) -> Isometry3<f64> {
        let [r, p, y] = self.rpy_deg.map(f64::to_radians);
        Isometry3::from_parts(
            Translation3::from(Vector3::from(self.position)),
            UnitQuaternion::from_euler_angles(r, p, y),
        )
    }
}

/// How finely a TSR is discretised.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Resolution {
    /// Spacing of translation samples (m).
    pub translation_m: f64,
    /// Spacing of rotation samples (degrees).
    pub rotation_deg: f64,
}

impl Default for Resolution {
    fn default() -> Self {
        Self { translation_m: 0.02, rotation_deg: 30.0 }
    }
}

/// A TSR: the region's frame T0_w (in the object's frame), the end-effector offset Tw_e in
/// that frame, and bounds Bw on [x, y, z, roll, pitch, yaw] in frame w (m and degrees).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tsr {
    #[serde(rename = "T0_w")]
    pub t0_w: Pose,
    #[serde(rename = "Tw_e", default)]
    pub tw_e: Pose,
    #[serde(rename = "Bw")]
    pub bw: [[f64; 2]; 6],
}

impl Tsr {
    /// One sample: T0_w · Trans(x, y, z) · Rz(yaw) Ry(pitch) Rx(roll) · Tw_e.
    pub fn sample(&self, x: [f64; 6]) -> Isometry3<f64> {
        let offset = Isometry3::from_parts(
            Translation3::new(x[0], x[1], x[2]),
            UnitQuaternion::from_euler_angles(x[3].to_radians(), x[4].to_radians(), x[5].to_radians()),
        );
        self.t0_w.to_isometry() * offset * self.tw_e.to_isometry()
    }

    /// The grid of samples: only rows whose bounds differ are discretised; a full-turn
    /// rotation row does not repeat its endpoint.
    pub fn discretise(&self, res: &Resolution) -> Vec<Isometry3<f64>> {
        let rows: Vec<Vec<f64>> = self
            .bw
            .iter()
            .enumerate()
            .map(|(i, &[lo, hi])| {
                let step = if i < 3 { res.translation_m } else { res.rotation_deg };
                row_values(lo, hi, step, i >= 3)
            })
            .collect();
        let mut out = Vec::new();
        let mut idx = [0usize; 6];
        loop {
            let x: [f64; 6] = std::array::from_fn(|i| rows[i][idx[i]]);
            out.push(self.sample(x));
            let mut i = 0;
            loop {
                idx[i] += 1;
                if idx[i] < rows[i].len() {
                    break;
                }
                idx[i] = 0;
                i += 1;
                if i == 6 {
                    return out;
                }
            }
        }
    }

    /// How many samples [`Tsr::discretise`] makes, computed without making them (a
    /// protocol's budget is checked before any work); infinite for bounds that are not
    /// finite.
    pub fn sample_count(&self, res: &Resolution) -> f64 {
        self.bw
            .iter()
            .enumerate()
            .map(|(i, &[lo, hi])| {
                let step = if i < 3 { res.translation_m } else { res.rotation_deg };
                row_count(lo, hi, step, i >= 3)
            })
            .product()
    }
}

/// Samples of one row: 1 for a fixed row, a full turn without its repeated endpoint,
/// otherwise both ends and every `step` between (at least 2). Not finite for bounds or
/// steps that are not.
fn row_count(lo: f64, hi: f64, step: f64, rotation: bool) -> f64 {
    if !(lo.is_finite() && hi.is_finite() && step.is_finite() && step > 0.0) {
        return f64::INFINITY;
    }
    if hi <= lo {
        return 1.0;
    }
    if rotation && hi - lo >= 360.0 - 1e-9 {
        return (360.0 / step).ceil().max(1.0);
    }
    ((hi - lo) / step).ceil().max(1.0) + 1.0
}

fn row_values(lo: f64, hi: f64, step: f64, rotation: bool) -> Vec<f64> {
    let n = row_count(lo, hi, step, rotation);
    if !n.is_finite() || n <= 1.0 {
        return vec![lo];
    }
    let n = n as usize;
    if rotation && hi - lo >= 360.0 - 1e-9 {
        return (0..n).map(|k| lo + 360.0 * k as f64 / n as f64).collect();
    }
    (0..n).map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_differing_rows_are_discretised_and_full_turns_do_not_repeat() {
        let tsr = Tsr {
            t0_w: Pose::default(),
            tw_e: Pose::default(),
            bw: [[0.0, 0.0], [0.0, 0.0], [-0.02, 0.02], [0.0, 0.0], [0.0, 0.0], [-180.0, 180.0]],
        };
        let samples = tsr.discretise(&Resolution { translation_m: 0.02, rotation_deg: 30.0 });
        assert_eq!(samples.len(), 3 * 12);
        assert!((samples[0].translation.z + 0.02).abs() < 1e-12);
        assert_eq!(row_values(-180.0, 180.0, 30.0, true).last().copied(), Some(150.0));
    }

    #[test]
    fn sample_composes_frame_offset_and_end_effector() {
        let tsr = Tsr {
            t0_w: Pose { position: [1.0, 0.0, 0.0], rpy_deg: [0.0, 0.0, 90.0] },
            tw_e: Pose { position: [0.0, 0.0, 0.1], rpy_deg: [0.0, 0.0, 0.0] },
            bw: [[0.0; 2]; 6],
        };
        let t = tsr.sample([0.2, 0.0, 0.0, 0.0, 0.0, 0.0]);
        // w is rotated 90° about z: its x is the world's y.
        assert!((t.translation.vector - Vector3::new(1.0, 0.2, 0.1)).norm() < 1e-12);
    }
}
