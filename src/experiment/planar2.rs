//! Section V: the planar 2-DoF arm with random planar objects.

use nalgebra::{Point2, Vector2};
use rand::RngExt;

use super::Scenario;
use crate::SeededRng;
use crate::belief::{ComponentPrior, Prior};
use crate::ergo::{ConfigSet, FeasibleSet, Lambda, LearnMask};
use crate::kinematics::{PlanarArm, PlanarObject};

/// The planar scenario: two 0.3 m links; objects are random outlines (24 points) of radius
/// 4–15 cm, centred at a random reachable point, half of them shapes about a common centre
/// (Fig. 5) and half one shape at a random pose (Fig. 6).
#[derive(Default)]
pub struct Planar2 {
    pub arm: PlanarArm,
}

/// The known part of λ when it is not learned.
const KNOWN_Q_STAR: [f64; 2] = [0.3, 1.2];
const KNOWN_W: [f64; 2] = [1.0, 1.0];
const POINTS: usize = 24;

impl Scenario for Planar2 {
    fn name(&self) -> &'static str {
        "planar2"
    }

    fn prior(&self, learn: LearnMask) -> Prior {
        let u = |min, max| ComponentPrior::Uniform { min, max };
        let known = Lambda { q_star: KNOWN_Q_STAR.to_vec(), w: KNOWN_W.to_vec() };
        Prior::with_mask(learn, vec![u(-1.5, 1.5), u(-2.5, 2.5)], vec![u(0.05, 1.0), u(0.05, 1.0)], &known)
            .expect("a valid built-in prior")
    }

    fn default_alpha(&self, _: LearnMask) -> f64 {
        10.0
    }

    fn default_iterations(&self) -> usize {
        5
    }

    fn random_query(&self, rng: &mut SeededRng, regions: bool) -> FeasibleSet {
        loop {
            let object = if rng.random::<bool>() {
                let r: f64 = rng.random_range(0.2..0.45);
                let a: f64 = rng.random_range(-1.2..1.6);
                PlanarObject::random_shape(Point2::new(r * a.cos(), r * a.sin()), 0.04, 0.15, POINTS, rng)
            } else {
                let shape = PlanarObject::random_shape(Point2::origin(), 0.06, 0.12, POINTS, rng);
                let r: f64 = rng.random_range(0.2..0.45);
                let a: f64 = rng.random_range(-1.2..1.6);
                shape.placed(rng.random_range(0.0..std::f64::consts::TAU), Vector2::new(r * a.cos(), r * a.sin()))
            };
            let mut configs = object.feasible_set(&self.arm);
            if configs.len() < 2 {
                continue;
            }
            if !regions {
                let rows: Vec<[f64; 2]> = configs.iter().map(|c| c.q).collect();
                return FeasibleSet::new(ConfigSet::from_rows(&rows).expect("finite IK solutions"));
            }
            // The region taken is the connected piece: grouped contiguously, outline order kept
            // within a piece.
            configs.sort_by_key(|c| c.piece);
            let rows: Vec<[f64; 2]> = configs.iter().map(|c| c.q).collect();
            let labels: Vec<usize> = configs.iter().map(|c| c.piece).collect();
            return FeasibleSet::with_regions(ConfigSet::from_rows(&rows).expect("finite IK solutions"), &labels)
                .expect("pieces numbered 0.. and grouped by the sort");
        }
    }
}
