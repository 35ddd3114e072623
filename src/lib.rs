//! handover: learning a person's ergonomic preferences for robot-to-human handovers, after
//! "Learning Human Ergonomic Preferences for Handovers" (see `docs/` and the README).
//!
//! The math (`ergo`, `belief`, `select`) does no I/O; the command-line tool lives in the
//! binary.

pub mod belief;
pub mod ergo;
pub mod experiment;
pub mod kinematics;
pub mod participant;
pub mod plot;
pub mod protocol;
pub mod select;

/// The one seeded generator type used for every random draw: reproducible across
/// platforms and versions of this crate's dependencies (pinned in `Cargo.lock`).
pub type SeededRng = rand_chacha::ChaCha8Rng;
