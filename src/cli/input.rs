//! Reading user-supplied files, and the error that marks bad input (exit status 2).

use std::io::Read;
use std::path::Path;

/// Bad input or usage: the message names the file, the field and what was expected.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct BadInput(pub String);

/// Shorthand for a bad-input error.
pub fn bad(msg: impl Into<String>) -> anyhow::Error {
    BadInput(msg.into()).into()
}

/// The text of `path`, or of standard input for `-`.
pub fn read_text(path: &Path) -> anyhow::Result<String> {
    let mut text = String::new();
    if path == Path::new("-") {
        std::io::stdin().read_to_string(&mut text).map_err(|e| bad(format!("<stdin>: cannot read: {e}")))?;
    } else {
        text = std::fs::read_to_string(path).map_err(|e| bad(format!("{}: cannot read: {e}", path.display())))?;
    }
    Ok(text)
}

/// Parses JSON into `T`, naming the file on error.
pub fn parse_json<T: serde::de::DeserializeOwned>(text: &str, name: &str) -> anyhow::Result<T> {
    serde_json::from_str(text).map_err(|e| bad(format!("{name}: {e}")))
}

/// The protocol at `path`, or the embedded default; an invalid one is bad input.
pub fn load_study(path: Option<&Path>) -> anyhow::Result<handover::protocol::Study> {
    load_protocol(path).map(|(_, study)| study)
}

/// The protocol's text (logged with every session) and its study, from `path` or the
/// embedded default; an invalid one is bad input.
pub fn load_protocol(path: Option<&Path>) -> anyhow::Result<(String, handover::protocol::Study)> {
    use handover::protocol::{DEFAULT_PROTOCOL, DEFAULT_PROTOCOL_NAME, Study};
    let (text, name) = match path {
        Some(p) => (read_text(p)?, p.display().to_string()),
        None => (DEFAULT_PROTOCOL.to_string(), DEFAULT_PROTOCOL_NAME.to_string()),
    };
    let study = Study::from_json(&text, &name).map_err(|e| bad(e.to_string()))?;
    Ok((text, study))
}
