//! Arms, objects and feasible sets (section III-A): the planar 2-DoF arm of section V, the
//! 7-DoF human arm of sections VI–VII, task space regions, and the feasible set a robot
//! query induces.

pub mod feasible;
pub mod human_arm;
pub mod object;
pub mod planar;
pub mod swivel_ik;
pub mod tsr;

pub use feasible::{ArmFeasibleSet, Discretisation, FeasibleConfig, feasible_set};
pub use human_arm::{ArmConfig, ArmError, ArmFrames, Hand, HumanArm, JOINT_NAMES, JOINTS, UPPER_ARM_FRACTION, mirror};
pub use object::{GripRegion, Object};
pub use planar::{PlanarArm, PlanarConfig, PlanarObject};
pub use swivel_ik::{IkSolution, Swivels, swivel_grid};
pub use tsr::{Pose, Resolution, Tsr};
