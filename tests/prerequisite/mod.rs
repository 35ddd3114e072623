//! A test's prerequisite that this machine lacks (a tool, a privilege, a reference reader):
//! under CI (`CI=true`, which `.ci/run` sets after installing every prerequisite) a failure;
//! elsewhere a skip that says what is missing and where it runs.

pub fn missing(what: &str) {
    assert!(std::env::var("CI").as_deref() != Ok("true"), "a prerequisite is missing under CI: {what}");
    eprintln!("skipped: {what} (runs in CI, .ci/run)");
}
