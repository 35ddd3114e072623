//! What the integration tests share: running the built `handover`, a temporary folder that
//! is removed when the test ends, and a prerequisite this machine lacks.

use std::ops::Deref;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// Runs the built binary with `args` (standard input empty) from a folder that is not the
/// project's: its exit code, standard output and standard error.
pub fn handover(args: &[&str]) -> (i32, String, String) {
    handover_in(&std::env::temp_dir(), args)
}

/// Runs the built binary with `args` from `cwd`.
pub fn handover_in(cwd: &Path, args: &[&str]) -> (i32, String, String) {
    let out =
        Command::new(env!("CARGO_BIN_EXE_handover")).args(args).current_dir(cwd).stdin(Stdio::null()).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8(out.stdout).expect("standard output in UTF-8"),
        String::from_utf8(out.stderr).expect("standard error in UTF-8"),
    )
}

/// A fresh temporary folder (owner-only, as `tempfile` makes them) whose name starts with
/// `handover-<name>`; removed with everything in it when dropped. It reads as a `Path`.
pub struct TestDir(tempfile::TempDir);

pub fn tmpdir(name: &str) -> TestDir {
    TestDir(tempfile::Builder::new().prefix(&format!("handover-{name}-")).tempdir().unwrap())
}

impl Deref for TestDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        self.0.path()
    }
}

impl AsRef<Path> for TestDir {
    fn as_ref(&self) -> &Path {
        self.0.path()
    }
}

/// The default protocol with 300 particles, so that sessions in tests are quick.
pub fn small_protocol_text() -> String {
    small_protocol_value(|_| {}).to_string()
}

fn small_protocol_value(edit: impl FnOnce(&mut serde_json::Value)) -> serde_json::Value {
    let mut v: serde_json::Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 300.into();
    edit(&mut v);
    v
}

/// `small_protocol_text` as `dir/small.json`.
pub fn small_protocol(dir: &Path) -> PathBuf {
    small_protocol_with(dir, |_| {})
}

/// `small_protocol_text` as `edit` changes it, as `dir/small.json`.
pub fn small_protocol_with(dir: &Path, edit: impl FnOnce(&mut serde_json::Value)) -> PathBuf {
    let p = dir.join("small.json");
    std::fs::write(&p, small_protocol_value(edit).to_string()).unwrap();
    p
}

/// A test's prerequisite that this machine lacks (a tool, a privilege, a reference reader):
/// under CI (`CI=true`, which `.ci/run` sets after installing every prerequisite) a failure;
/// elsewhere a skip that says what is missing and where it runs.
pub fn missing(what: &str) {
    assert!(std::env::var("CI").as_deref() != Ok("true"), "a prerequisite is missing under CI: {what}");
    eprintln!("skipped: {what} (runs in CI, .ci/run)");
}
