//! handover: learning a person's ergonomic preferences for robot-to-human handovers, after
//! "Learning Human Ergonomic Preferences for Handovers" (see `docs/` and the README).
//!
//! The math (`ergo`, `belief`, `select`) does no I/O; the command-line tool lives in the
//! binary.

pub mod analysis;
pub mod belief;
pub mod counterbalance;
pub mod dryrun;
pub mod ergo;
pub mod experiment;
pub mod input_file;
pub mod kinematics;
pub mod live;
pub mod output_dir;
pub mod participant;
pub mod plan;
pub mod plot;
pub mod private_files;
pub mod protocol;
pub mod record;
pub mod robot;
pub mod select;
pub mod session;
pub mod setup;
pub mod stats;
pub mod study_dir;
pub mod study_status;
pub mod text;
pub mod tui;

/// The one seeded generator type used for every random draw: reproducible across
/// platforms and versions of this crate's dependencies (pinned in `Cargo.lock`).
pub type SeededRng = rand_chacha::ChaCha8Rng;

/// A seed for one purpose of one unit of work (a trial, a run), mixed from a run's seed by
/// splitmix64, so that every random stream is independent and reproducible.
pub fn derive_seed(seed: u64, unit: u64, purpose: u64) -> u64 {
    let mut z = seed ^ unit.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ purpose.wrapping_mul(0xD1B5_4A32_D192_ED69);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The largest session seed: 2^53 − 1, the largest integer every JSON and CSV reader
/// (JavaScript, R, pandas' float columns) reads exactly, so a log or a table carries its seed
/// in one number.
pub const MAX_SESSION_SEED: u64 = (1 << 53) - 1;

/// A session seed from 64 random bits: their top 53, below [`MAX_SESSION_SEED`].
pub fn session_seed(bits: u64) -> u64 {
    bits >> 11
}

/// Nanoseconds since the Unix epoch: the one clock events, samples and logs are stamped with.
pub fn now_ns() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64)
}
