//! An output folder and what made it. `manifest.json` names the command that wrote the
//! folder, the program's version, every file it wrote and the sessions (pseudonymous
//! participants) whose data those files hold. From it:
//!
//! - a command writing into a folder first removes the files the same command wrote there
//!   before, so that no file of an earlier run is left beside a new one, and refuses a folder
//!   that holds anything else (another command's outputs, someone's own files);
//! - `participant withdraw` and `status` name every output folder in the study that still
//!   holds a participant who withdrew.
//!
//! The manifest is untrusted input when read: bounded, validated, and its file names are
//! only ever compared with the names found in the folder (no path is built from them).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// The manifest's file name in an output folder.
pub const MANIFEST: &str = "manifest.json";

/// The largest manifest read.
const MAX_MANIFEST_BYTES: u64 = 64 << 20;

/// How deep below a study folder output folders are looked for, and how many entries at most.
const SEARCH_DEPTH: usize = 4;
const SEARCH_ENTRIES: usize = 100_000;

/// One session whose data an output folder holds.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeldSession {
    pub session_id: String,
    pub participant: String,
    pub pilot: bool,
}

/// `manifest.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// The command that wrote the folder (`analyze`, `protocol with`, `plan`, `simulate`).
    pub command: String,
    /// Which run of the command (`plan` and `simulate`: its options, seeds and shard); a run
    /// of other options is refused the folder.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub run: Option<String>,
    pub software_version: String,
    /// When it was written (RFC 3339 UTC).
    pub written_at: String,
    /// False while the command is writing (a folder left so was cut short: its tables,
    /// figures, reports and JSON files are that run's, and the next run of the command
    /// removes them).
    pub complete: bool,
    /// Every file written, relative to the folder, `/`-separated, sorted.
    pub files: Vec<String>,
    /// The sessions whose data the files hold.
    pub sessions: Vec<HeldSession>,
}

/// Why a folder cannot be written into, or its manifest read.
#[derive(Debug, thiserror::Error)]
pub enum OutputDirError {
    #[error(
        "{dir}: holds files that no earlier run of `handover {command}` with these options wrote there ({listed}); give another --out or remove them"
    )]
    Foreign { dir: PathBuf, command: String, listed: String },
    #[error("{path}: {why}")]
    BadManifest { path: PathBuf, why: String },
    /// A search for output folders that stopped before it had looked everywhere.
    #[error("{root}: {why}")]
    SearchCut { root: PathBuf, why: String },
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
}

impl OutputDirError {
    fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Self + '_ {
        move |source| OutputDirError::Io { path: path.to_path_buf(), source }
    }
}

impl Manifest {
    /// Reads and validates `dir`'s manifest (None: the folder has none).
    pub fn read(dir: &Path) -> Result<Option<Self>, OutputDirError> {
        let path = dir.join(MANIFEST);
        if std::fs::symlink_metadata(&path).is_err() {
            return Ok(None);
        }
        let bad = |why: String| OutputDirError::BadManifest { path: path.clone(), why };
        let bytes = crate::input_file::read_regular(&path, MAX_MANIFEST_BYTES).map_err(OutputDirError::io(&path))?;
        let m: Manifest = crate::input_file::parse_json_bytes(&bytes).map_err(|e| bad(e.to_string()))?;
        for f in &m.files {
            if f.is_empty() || f.starts_with('/') || f.split('/').any(|c| c.is_empty() || c == "." || c == "..") {
                return Err(bad(format!("files: '{}' is not a path inside the folder", crate::text::printable(f))));
            }
        }
        for s in &m.sessions {
            crate::participant::validate_id(&s.participant).map_err(|e| bad(format!("sessions: participant: {e}")))?;
        }
        Ok(Some(m))
    }

    /// Whether the folder holds `participant`'s data.
    pub fn holds(&self, participant: &str) -> bool {
        self.sessions.iter().any(|s| s.participant == participant)
    }
}

/// Every regular file and link under `dir` (links are listed, never followed), relative and
/// `/`-separated, sorted; folders separately, deepest first. Subfolders that are output
/// folders of their own (with a manifest) are left out.
fn contents(dir: &Path) -> Result<(Vec<String>, Vec<PathBuf>), OutputDirError> {
    let (mut files, mut folders) = (Vec::new(), Vec::new());
    let mut stack = vec![(dir.to_path_buf(), String::new())];
    while let Some((d, rel)) = stack.pop() {
        for e in std::fs::read_dir(&d).map_err(OutputDirError::io(&d))? {
            let e = e.map_err(OutputDirError::io(&d))?;
            let name = e.file_name().to_string_lossy().into_owned();
            let relative = if rel.is_empty() { name } else { format!("{rel}/{name}") };
            let kind = e.file_type().map_err(OutputDirError::io(&e.path()))?;
            if kind.is_dir() {
                // A folder with a manifest of its own is another output (a protocol made from
                // this analysis's prior): not this folder's to list, remove or refuse.
                if std::fs::symlink_metadata(e.path().join(MANIFEST)).is_err() {
                    folders.push(e.path());
                    stack.push((e.path(), relative));
                }
            } else {
                files.push(relative);
            }
        }
    }
    files.sort();
    folders.sort_by_key(|f| std::cmp::Reverse(f.components().count()));
    Ok((files, folders))
}

/// Whether `name` (the last part of a path) is a writer's leftover temporary file
/// (`.<name>.<pid>.tmp`, `private_files`).
fn is_leftover(relative: &str) -> bool {
    let name = relative.rsplit('/').next().unwrap_or(relative);
    name.starts_with('.') && name.ends_with(".tmp")
}

/// Whether a file is of a kind commands write (a table, a figure, a report, JSON).
fn of_a_written_kind(relative: &str) -> bool {
    let ext = Path::new(relative).extension().and_then(|e| e.to_str());
    ext.is_some_and(|e| ["csv", "svg", "pdf", "png", "md", "json"].contains(&e))
}

/// Makes `dir` ready for `command` to write into: the files an earlier run of the same
/// command wrote there (its manifest's, or all of a run cut short) and writers' leftovers are
/// removed, and folders emptied by that; a folder holding anything else is refused. Then an
/// incomplete manifest naming `sessions` is written, which [`finish`] completes. A folder
/// that does not exist is created (owner-only).
pub fn prepare(dir: &Path, command: &str, run: Option<&str>, sessions: &[HeldSession]) -> Result<(), OutputDirError> {
    if std::fs::symlink_metadata(dir).is_ok() {
        let earlier = Manifest::read(dir)?;
        let (files, folders) = contents(dir)?;
        // A run cut short listed nothing yet: what it may have written is a table, a figure,
        // a report or a JSON file of its kinds.
        let ours = |f: &String| match &earlier {
            Some(m) if m.command == command && m.run.as_deref() == run => {
                m.files.contains(f) || (!m.complete && of_a_written_kind(f))
            }
            _ => false,
        };
        let foreign: Vec<&String> =
            files.iter().filter(|f| f.as_str() != MANIFEST && !is_leftover(f) && !ours(f)).collect();
        if !foreign.is_empty() {
            let mut listed: Vec<String> =
                foreign.iter().take(5).map(|f| crate::text::printable(f).into_owned()).collect();
            if foreign.len() > 5 {
                listed.push(format!("{} more", foreign.len() - 5));
            }
            let listed = match &earlier {
                Some(m) if m.command != command => {
                    format!("`handover {}` wrote them: {}", crate::text::printable(&m.command), listed.join(", "))
                }
                Some(m) if m.run.as_deref() != run => {
                    format!("a run of other options, seeds or shard wrote them: {}", listed.join(", "))
                }
                _ => listed.join(", "),
            };
            return Err(OutputDirError::Foreign { dir: dir.to_path_buf(), command: command.to_string(), listed });
        }
        for f in &files {
            // Only names found in the folder are removed; a link is removed, not followed.
            let path = f.split('/').fold(dir.to_path_buf(), |p, c| p.join(c));
            std::fs::remove_file(&path).map_err(OutputDirError::io(&path))?;
        }
        for folder in folders {
            let _ = std::fs::remove_dir(&folder); // only an empty one goes
        }
    } else {
        crate::private_files::create_dir(dir).map_err(OutputDirError::io(dir))?;
    }
    write(dir, command, run, false, sessions)
}

/// Completes `dir`'s manifest: every file now in it, and `sessions`.
pub fn finish(dir: &Path, command: &str, run: Option<&str>, sessions: &[HeldSession]) -> Result<(), OutputDirError> {
    write(dir, command, run, true, sessions)
}

fn write(
    dir: &Path,
    command: &str,
    run: Option<&str>,
    complete: bool,
    sessions: &[HeldSession],
) -> Result<(), OutputDirError> {
    let files: Vec<String> = if complete {
        contents(dir)?.0.into_iter().filter(|f| f != MANIFEST && !is_leftover(f)).collect()
    } else {
        Vec::new()
    };
    let m = Manifest {
        command: command.to_string(),
        run: run.map(String::from),
        software_version: env!("CARGO_PKG_VERSION").to_string(),
        written_at: chrono::Utc::now().to_rfc3339_opts(chrono::SecondsFormat::Secs, true),
        complete,
        files,
        sessions: sessions.to_vec(),
    };
    let path = dir.join(MANIFEST);
    let mut text = serde_json::to_string_pretty(&m).map_err(|e| OutputDirError::io(&path)(std::io::Error::other(e)))?;
    text.push('\n');
    crate::private_files::replace(&path, text.as_bytes()).map_err(OutputDirError::io(&path))
}

/// Every output folder with a manifest under `root` (at most [`SEARCH_DEPTH`] levels down,
/// links not followed); what could not be looked at — a folder that cannot be listed, a
/// manifest that cannot be read, a search cut at [`SEARCH_ENTRIES`] — goes into `errors`,
/// never passed over in silence.
pub fn manifests(root: &Path, errors: &mut Vec<OutputDirError>) -> Vec<(PathBuf, Manifest)> {
    let mut out = Vec::new();
    let mut stack = vec![(root.to_path_buf(), 0)];
    let mut seen = 0;
    while let Some((d, depth)) = stack.pop() {
        let entries = match std::fs::read_dir(&d) {
            Ok(entries) => entries,
            Err(e) => {
                errors.push(OutputDirError::Io { path: d, source: e });
                continue;
            }
        };
        for e in entries {
            let e = match e {
                Ok(e) => e,
                Err(err) => {
                    errors.push(OutputDirError::Io { path: d.clone(), source: err });
                    continue;
                }
            };
            seen += 1;
            if seen > SEARCH_ENTRIES {
                errors.push(OutputDirError::SearchCut {
                    root: root.to_path_buf(),
                    why: format!("more than {SEARCH_ENTRIES} entries: the search for output folders stopped there"),
                });
                return out;
            }
            let Ok(kind) = e.file_type() else { continue };
            if kind.is_dir() && depth < SEARCH_DEPTH {
                stack.push((e.path(), depth + 1));
            } else if kind.is_file() && e.file_name() == MANIFEST {
                match Manifest::read(&d) {
                    Ok(Some(m)) => out.push((d.clone(), m)),
                    Ok(None) => {}
                    Err(e) => errors.push(e),
                }
            }
        }
    }
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

/// The manifest of the output folder that wrote `file`: its own folder's or the one above
/// (`analyze` writes a pilot's fit into `DIR/pilot/`, its manifest into `DIR`), whichever
/// lists it. None when neither does (a file made by hand, or by an earlier version).
pub fn manifest_of(file: &Path) -> Result<Option<Manifest>, OutputDirError> {
    let Some(name) = file.file_name().and_then(|n| n.to_str()) else { return Ok(None) };
    let folder = file.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if let Some(m) = Manifest::read(folder)?.filter(|m| m.files.iter().any(|f| f == name)) {
        return Ok(Some(m));
    }
    let (Some(up), Some(sub)) = (folder.parent(), folder.file_name().and_then(|n| n.to_str())) else { return Ok(None) };
    let up = if up.as_os_str().is_empty() { Path::new(".") } else { up };
    let relative = format!("{sub}/{name}");
    Ok(Manifest::read(up)?.filter(|m| m.files.contains(&relative)))
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    fn session(p: &str) -> HeldSession {
        HeldSession { session_id: "s".into(), participant: p.into(), pilot: false }
    }

    #[test]
    fn a_rerun_removes_its_earlier_files_and_refuses_anything_else() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("out");
        prepare(&dir, "analyze", None, &[session("p-1")]).unwrap();
        std::fs::create_dir(dir.join("pilot")).unwrap();
        std::fs::write(dir.join("pilot/old.csv"), "x").unwrap();
        std::fs::write(dir.join("prior.json"), "{}").unwrap();
        finish(&dir, "analyze", None, &[session("p-1")]).unwrap();
        let m = Manifest::read(&dir).unwrap().unwrap();
        assert_eq!(m.files, ["pilot/old.csv", "prior.json"]);
        // The manifest that wrote a file, from its folder or the one above; none for another.
        assert_eq!(manifest_of(&dir.join("pilot/old.csv")).unwrap().as_ref(), Some(&m));
        assert_eq!(manifest_of(&dir.join("prior.json")).unwrap().as_ref(), Some(&m));
        assert_eq!(manifest_of(&dir.join("pilot/other.csv")).unwrap(), None);
        assert!(m.complete && m.holds("p-1") && !m.holds("p-2"));
        // The same command again: the earlier files go.
        prepare(&dir, "analyze", None, &[session("p-2")]).unwrap();
        assert!(!dir.join("prior.json").exists() && !dir.join("pilot").exists());
        // Someone's own file, or another command's folder, is refused and left alone.
        std::fs::write(dir.join("mine.txt"), "keep").unwrap();
        let e = prepare(&dir, "analyze", None, &[]).unwrap_err().to_string();
        assert!(e.contains("mine.txt"), "{e}");
        assert_eq!(std::fs::read_to_string(dir.join("mine.txt")).unwrap(), "keep");
        std::fs::remove_file(dir.join("mine.txt")).unwrap();
        finish(&dir, "analyze", None, &[]).unwrap();
        std::fs::write(dir.join("t.csv"), "x").unwrap();
        let e = prepare(&dir, "protocol with", None, &[]).unwrap_err().to_string();
        assert!(e.contains("`handover analyze` wrote them"), "{e}");
        // Another run of the same command (other options) is refused; the same run replaces.
        let plan = tmp.path().join("plan");
        prepare(&plan, "plan", Some("seed 1"), &[]).unwrap();
        std::fs::write(plan.join("power.csv"), "x").unwrap();
        finish(&plan, "plan", Some("seed 1"), &[]).unwrap();
        let e = prepare(&plan, "plan", Some("seed 2"), &[]).unwrap_err().to_string();
        assert!(e.contains("a run of other options, seeds or shard wrote them: power.csv"), "{e}");
        prepare(&plan, "plan", Some("seed 1"), &[]).unwrap();
        assert!(!plan.join("power.csv").exists());
    }

    #[test]
    fn a_manifest_naming_a_path_outside_its_folder_is_refused() {
        let tmp = tempfile::tempdir().unwrap();
        prepare(tmp.path(), "analyze", None, &[]).unwrap();
        let text = std::fs::read_to_string(tmp.path().join(MANIFEST))
            .unwrap()
            .replace("\"files\": []", "\"files\": [\"../x\"]");
        std::fs::write(tmp.path().join(MANIFEST), text).unwrap();
        let e = Manifest::read(tmp.path()).unwrap_err().to_string();
        assert!(e.contains("files: '../x' is not a path inside the folder"), "{e}");
    }
}
