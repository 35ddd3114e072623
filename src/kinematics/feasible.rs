//! The feasible set a robot query induces (section III-A): every IK solution of every
//! discretised grasp of the offered grip regions, labelled by region.

use std::collections::HashSet;

use nalgebra::Isometry3;
use serde::{Deserialize, Serialize};

use super::human_arm::{ArmConfig, HumanArm};
use super::object::Object;
use super::tsr::Resolution;

/// How a feasible set is enumerated.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Discretisation {
    /// TSR sampling.
    pub resolution: Resolution,
    /// Swivel-angle grid step (degrees).
    pub swivel_step_deg: f64,
    /// Configurations closer than this in every joint (rad) count as one.
    pub duplicate_tolerance_rad: f64,
}

impl Default for Discretisation {
    fn default() -> Self {
        Self { resolution: Resolution::default(), swivel_step_deg: 5.0, duplicate_tolerance_rad: 1e-4 }
    }
}

/// One feasible configuration and the region (index into the offered regions) it grasps.
#[derive(Clone, Debug, PartialEq)]
pub struct FeasibleConfig {
    pub region: usize,
    pub q: ArmConfig,
}

/// A query's feasible set, grouped by offered region (in the order offered).
#[derive(Clone, Debug, PartialEq)]
pub struct ArmFeasibleSet {
    pub configs: Vec<FeasibleConfig>,
    /// How many configurations each offered region has.
    pub per_region: Vec<usize>,
}

impl ArmFeasibleSet {
    /// Region labels, one per configuration.
    pub fn labels(&self) -> Vec<usize> {
        self.configs.iter().map(|c| c.region).collect()
    }

    /// Configurations as rows.
    pub fn rows(&self) -> Vec<Vec<f64>> {
        self.configs.iter().map(|c| c.q.to_vec()).collect()
    }
}

/// The feasible set of `object` at `object_pose` (object frame in the shoulder frame) with
/// the grip regions `offered` (indices into the object's regions).
pub fn feasible_set(
    arm: &HumanArm,
    object: &Object,
    object_pose: &Isometry3<f64>,
    offered: &[usize],
    disc: &Discretisation,
) -> ArmFeasibleSet {
    let swivels = super::swivel_ik::swivel_grid(disc.swivel_step_deg.to_radians());
    let mut configs = Vec::new();
    let mut per_region = Vec::with_capacity(offered.len());
    let tol = disc.duplicate_tolerance_rad;
    for (label, &r) in offered.iter().enumerate() {
        let mut seen = HashSet::new();
        let before = configs.len();
        for grasp in object.regions[r].tsr.discretise(&disc.resolution) {
            for s in arm.inverse(&(object_pose * grasp), &swivels) {
                let key: [i64; 7] = s.q.map(|v| (v / tol).round() as i64);
                if seen.insert(key) {
                    configs.push(FeasibleConfig { region: label, q: s.q });
                }
            }
        }
        per_region.push(configs.len() - before);
    }
    ArmFeasibleSet { configs, per_region }
}
