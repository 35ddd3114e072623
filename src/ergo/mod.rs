//! The ergonomic cost model of the paper's section III-B.
//!
//! λ = [q*, w] over D joints; the cost of a configuration q is
//! C(q; λ) = Σ_d w_d (q_d − q*_d)² (eq. 2 with W = diag(w)), and a person chooses q from a
//! feasible set with Boltzmann probability ∝ exp(−α C(q; λ)) (eq. 1; eq. 3 normalised over
//! the set, with the α that the paper's eq. 3 drops).

mod config_set;
mod lambda;
mod lanes;
mod lanes_f32;
mod likelihood;
pub(crate) mod numeric;
mod set_pass;
mod set_pass_f32;

pub use config_set::{ConfigSet, ConfigSetError, FeasibleSet};
pub use lambda::{Lambda, LearnMask};
pub use likelihood::{Observation, ObservationError, SIGMA_DEG, cost, log_likelihood, most_likely_in_region};
pub use numeric::{exp_nonpositive, log_sum_exp, xlogx};
pub(crate) use set_pass::PRUNE_LOGIT;
pub use set_pass::{Scratch, SetPass, region_weights};
pub use set_pass_f32::{ScratchF32, cross_min_f32, min_cost_f32, run_f32, weighted_norms_f32};
