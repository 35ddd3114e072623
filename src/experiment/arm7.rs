//! Section VI: the 7-DoF human arm with the handlebars and the U-lock at random handover
//! poses.

use rand::RngExt;

use super::Scenario;
use crate::SeededRng;
use crate::belief::Prior;
use crate::ergo::{FeasibleSet, LearnMask};
use crate::kinematics::{Pose, feasible_set};
use crate::protocol::{LearningSpec, Study};
use crate::session::choice_set;

/// The 7-DoF scenario on a protocol's arm, objects, discretisation and prior (by default the
/// embedded bike-handover protocol). Random poses: 0.28–0.46 m forward, 0.15 m right to
/// 0.05 m left, 0.40–0.00 m below the shoulder, roll ±30°, pitch ±20°, yaw ±40°; re-drawn
/// until every grip is reachable.
pub struct Arm7 {
    pub study: Study,
}

impl Default for Arm7 {
    fn default() -> Self {
        Self { study: Study::default_study() }
    }
}

impl Arm7 {
    fn learning(&self, learn: LearnMask) -> LearningSpec {
        LearningSpec { learn, ..self.study.protocol.learning.clone() }
    }
}

impl Scenario for Arm7 {
    fn name(&self) -> &'static str {
        "arm7"
    }

    fn prior(&self, learn: LearnMask) -> Prior {
        self.learning(learn).prior().expect("a validated protocol's prior")
    }

    /// The original simulation code's values (docs/HUMAN-ARM facts): α = 40 for learning
    /// q*, 10 for learning w.
    fn default_alpha(&self, learn: LearnMask) -> f64 {
        match learn {
            LearnMask::QStar => 40.0,
            _ => 10.0,
        }
    }

    fn default_iterations(&self) -> usize {
        10
    }

    fn random_query(&self, rng: &mut SeededRng, _regions: bool) -> FeasibleSet {
        let objects = &self.study.protocol.objects;
        loop {
            let object = &objects[rng.random_range(0..objects.len())];
            let pose = Pose {
                position: [rng.random_range(0.28..0.46), rng.random_range(-0.15..0.05), rng.random_range(-0.40..0.0)],
                rpy_deg: [rng.random_range(-30.0..30.0), rng.random_range(-20.0..20.0), rng.random_range(-40.0..40.0)],
            };
            let regions: Vec<usize> = (0..object.regions.len()).collect();
            let set = feasible_set(
                &self.study.arm,
                object,
                &pose.to_isometry(),
                &regions,
                &self.study.protocol.discretisation,
            );
            if set.per_region.iter().all(|&n| n > 0) {
                return choice_set(&set);
            }
        }
    }
}
