//! Reading user-supplied files, and the error that marks bad input (exit status 2).

use std::io::Read;
use std::path::Path;

/// Bad input or usage: the message names the file, the field and what was expected.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct BadInput(pub String);

/// An output folder that cannot be written into: bad input (exit 2) when it holds other
/// files or a manifest that breaks the rules, else the I/O error.
pub fn output_dir_error(e: handover::output_dir::OutputDirError) -> anyhow::Error {
    use handover::output_dir::OutputDirError;
    match e {
        OutputDirError::Foreign { .. } | OutputDirError::BadManifest { .. } => bad(e.to_string()),
        OutputDirError::Io { .. } | OutputDirError::SearchCut { .. } => anyhow::Error::new(e),
    }
}

/// Shorthand for a bad-input error.
/// `--study-dir` as given, else `$HANDOVER_STUDY_DIR`: the study of a command that starts from
/// the study rather than from a log (`analyze` with no log or folder, `resume --participant`).
/// A command that starts from a log takes the log's own study, never the variable, so that a
/// log of another study is never judged by this one's withdrawals.
pub fn study_dir_or_env(given: Option<&Path>) -> Option<std::path::PathBuf> {
    given.map(Path::to_path_buf).or_else(|| std::env::var_os("HANDOVER_STUDY_DIR").map(std::path::PathBuf::from))
}

pub fn bad(msg: impl Into<String>) -> anyhow::Error {
    BadInput(msg.into()).into()
}

/// The most bytes read from any input file (or standard input): a budget, so that
/// `/dev/zero` or a runaway file is refused instead of exhausting memory.
pub const MAX_INPUT_BYTES: u64 = 64 << 20;

/// The text of `path`, or of standard input for `-`, up to [`MAX_INPUT_BYTES`].
pub fn read_text(path: &Path) -> anyhow::Result<String> {
    let name = if path == Path::new("-") { "<stdin>".to_string() } else { path.display().to_string() };
    let mut bytes = Vec::new();
    let read = if path == Path::new("-") {
        std::io::stdin().lock().take(MAX_INPUT_BYTES + 1).read_to_end(&mut bytes)
    } else {
        handover::input_file::open_regular(path).and_then(|f| f.take(MAX_INPUT_BYTES + 1).read_to_end(&mut bytes))
    };
    read.map_err(|e| bad(format!("{name}: cannot read: {e}")))?;
    if bytes.len() as u64 > MAX_INPUT_BYTES {
        return Err(bad(format!("{name}: over the input budget of {MAX_INPUT_BYTES} bytes")));
    }
    String::from_utf8(bytes).map_err(|e| bad(format!("{name}: not UTF-8 text ({e})")))
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
    warn_narrow(&study);
    Ok((text, study))
}

/// Says on standard error what in a study's prior or population is narrow enough to stop it
/// learning a joint or to simulate people nearly alike ([`Study::narrow_warnings`]).
///
/// [`Study::narrow_warnings`]: handover::protocol::Study::narrow_warnings
fn warn_narrow(study: &handover::protocol::Study) {
    for w in study.narrow_warnings() {
        errln!("warning: {}: {w}", study.source_name);
    }
}

/// Whom simulated participants' λ are drawn from (`--population`): `protocol` (its
/// `population` section, or its default), `prior` (the robot's own prior), or a population
/// file (a protocol's `population` section, as `analyze --fit-population` writes it).
#[derive(Debug, Clone, PartialEq)]
pub enum PopulationArg {
    Protocol,
    Prior,
    File(std::path::PathBuf),
}

impl std::str::FromStr for PopulationArg {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "protocol" => Ok(Self::Protocol),
            "prior" => Ok(Self::Prior),
            "" => Err("expected protocol, prior or a population file".to_string()),
            path => Ok(Self::File(std::path::PathBuf::from(path))),
        }
    }
}

/// A population file, read once: its name and its section.
pub struct PopulationFile(String, handover::protocol::PopulationSpec);

impl PopulationArg {
    /// The population file, read and parsed (none for `protocol` and `prior`).
    pub fn read(&self) -> anyhow::Result<Option<PopulationFile>> {
        let Self::File(path) = self else { return Ok(None) };
        let name = path.display().to_string();
        let spec = parse_json(&read_text(path)?, &name)?;
        Ok(Some(PopulationFile(name, spec)))
    }

    /// [`PopulationFile::apply`] of the file, read now.
    pub fn apply(
        &self,
        text: String,
        study: handover::protocol::Study,
    ) -> anyhow::Result<(String, handover::protocol::Study)> {
        PopulationFile::apply(self.read()?.as_ref(), text, study)
    }
}

impl PopulationFile {
    /// The protocol with a population file's section in place of its own, checked as the
    /// protocol's own section is (the text changes with it: logs embed the population their
    /// participants came from); the protocol as it was without a file.
    pub fn apply(
        file: Option<&Self>,
        text: String,
        study: handover::protocol::Study,
    ) -> anyhow::Result<(String, handover::protocol::Study)> {
        let Some(Self(name, spec)) = file else { return Ok((text, study)) };
        with_sections(&text, &study, &[Section::population(spec, name)?])
    }
}

/// A section put into a protocol in place of its own: where, what, and whence (for the
/// protocol's name in messages, e.g. "the population of FILE").
pub struct Section {
    path: &'static [&'static str],
    value: serde_json::Value,
    from: String,
}

impl Section {
    /// A `population` section read from `name`.
    pub fn population(spec: &handover::protocol::PopulationSpec, name: &str) -> anyhow::Result<Self> {
        Ok(Self {
            path: &["population"],
            value: serde_json::to_value(spec)?,
            from: format!("the population of {name}"),
        })
    }

    /// A `learning.prior` section read from `name`.
    pub fn prior(spec: &handover::protocol::PriorSpec, name: &str) -> anyhow::Result<Self> {
        Ok(Self {
            path: &["learning", "prior"],
            value: serde_json::to_value(spec)?,
            from: format!("the prior of {name}"),
        })
    }
}

/// The protocol `text` with `sections` in place of its own, checked as a protocol file is
/// (the text changes with them: logs embed what their sessions ran with); an invalid result
/// is bad input.
pub fn with_sections(
    text: &str,
    study: &handover::protocol::Study,
    sections: &[Section],
) -> anyhow::Result<(String, handover::protocol::Study)> {
    let mut v: serde_json::Value = serde_json::from_str(text)?;
    for s in sections {
        let slot = s.path.iter().fold(&mut v, |v, key| &mut v[*key]);
        *slot = s.value.clone();
    }
    let text = serde_json::to_string_pretty(&v)? + "\n";
    let from: Vec<&str> = sections.iter().map(|s| s.from.as_str()).collect();
    let name = format!("{} with {}", study.source_name, from.join(" and "));
    let next = handover::protocol::Study::from_json(&text, &name).map_err(|e| bad(e.to_string()))?;
    // What the protocol had itself was said when it was read: only what the sections bring.
    let before = study.narrow_warnings();
    for w in next.narrow_warnings().into_iter().filter(|w| !before.contains(w)) {
        errln!("warning: {}: {w}", next.source_name);
    }
    Ok((text, next))
}

/// A hand on the command line: `left` or `right`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum HandArg {
    Left,
    Right,
}

impl From<HandArg> for handover::kinematics::Hand {
    fn from(h: HandArg) -> Self {
        match h {
            HandArg::Left => Self::Left,
            HandArg::Right => Self::Right,
        }
    }
}

/// A body height from the command line, inside the range a participant record accepts.
pub fn body_height(flag: &str, h: f64) -> anyhow::Result<f64> {
    let (lo, hi) = handover::participant::BODY_HEIGHT_M;
    if (lo..=hi).contains(&h) { Ok(h) } else { Err(bad(format!("{flag} is {h}, expected metres from {lo} to {hi}"))) }
}

/// The study's folders, as every command that reads or writes them takes them.
#[derive(Debug, Default, clap::Args)]
pub struct StudyFolders {
    #[command(flatten)]
    pub logs: LogFolders,
    /// Where participant records live (default: STUDY_DIR/participants).
    #[arg(long = "participants-dir", value_name = "DIR")]
    pub participants: Option<std::path::PathBuf>,
}

impl StudyFolders {
    pub fn resolve(&self) -> handover::study_dir::StudyDirs {
        handover::study_dir::StudyDirs::resolve(
            self.logs.study_dir.as_deref(),
            self.participants.as_deref(),
            self.logs.logs.as_deref(),
        )
    }
}

/// The study's folder and its logs, for a command that writes logs but no participant
/// records (`dry-run`).
#[derive(Debug, Default, clap::Args)]
pub struct LogFolders {
    /// The study directory: participant records in DIR/participants, logs in DIR/logs
    /// (default: $HANDOVER_STUDY_DIR, else the current directory).
    #[arg(long, value_name = "DIR", env = "HANDOVER_STUDY_DIR")]
    pub study_dir: Option<std::path::PathBuf>,
    /// Where session logs live (default: STUDY_DIR/logs).
    #[arg(long, value_name = "DIR")]
    pub logs: Option<std::path::PathBuf>,
}

impl LogFolders {
    pub fn resolve(&self) -> handover::study_dir::StudyDirs {
        handover::study_dir::StudyDirs::resolve(self.study_dir.as_deref(), None, self.logs.as_deref())
    }
}

/// How fast a simulated participant acts: slow enough to follow where a console shows it,
/// at once where nothing does.
#[derive(Debug, Default, clap::Args)]
pub struct Pace {
    /// Milliseconds between the simulated participant's actions [default: 800 in the
    /// console, to follow them; 0 without one].
    #[arg(long = "pace", value_name = "MS")]
    ms: Option<u64>,
}

impl Pace {
    /// The pace where the console shows the session.
    pub fn in_console(&self) -> std::time::Duration {
        std::time::Duration::from_millis(self.ms.unwrap_or(800))
    }

    /// The pace where nothing shows it (a dry run).
    pub fn headless(&self) -> std::time::Duration {
        std::time::Duration::from_millis(self.ms.unwrap_or(0))
    }
}

/// clap's parser of a count of at least `min`: `--trials 0` is refused naming the flag, before
/// anything runs (exit 2).
pub fn count(min: u64) -> clap::builder::RangedU64ValueParser<usize> {
    clap::builder::RangedU64ValueParser::new().range(min..)
}

/// A list with each value kept at its first place only (`a,b,a` is `a,b`): a value given twice
/// is run once.
pub fn first_occurrences<T: PartialEq + Clone>(values: &[T]) -> Vec<T> {
    let mut out: Vec<T> = Vec::with_capacity(values.len());
    for v in values {
        if !out.contains(v) {
            out.push(v.clone());
        }
    }
    out
}
