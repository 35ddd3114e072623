//! The operator console (placeholder until the console lands).

use anyhow::Result;
use handover::record::LogContents;

use super::input::bad;

pub fn resume(old: LogContents) -> Result<()> {
    Err(bad(format!(
        "{}: resuming in the console is not available yet; use --dry-run for dry runs",
        old.path.display()
    )))
}
