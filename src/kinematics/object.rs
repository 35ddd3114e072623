//! Objects as data: named grip regions, each a TSR in the object's frame.

use serde::{Deserialize, Serialize};

use super::tsr::Tsr;

/// An object the robot hands over.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Object {
    /// Identifier used by queries.
    pub id: String,
    /// What the operator reads.
    pub label: String,
    pub regions: Vec<GripRegion>,
}

/// One place the person can grasp the object (e.g. a rubber grip).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GripRegion {
    pub id: String,
    pub label: String,
    pub tsr: Tsr,
}

impl Object {
    /// The index of a region by id.
    pub fn region(&self, id: &str) -> Option<usize> {
        self.regions.iter().position(|r| r.id == id)
    }
}
