//! Where logs live and what they are called: one folder per participant, one file per
//! session (or continuation), named by the participant and the UTC time it was created.

use std::fs::File;
use std::path::{Path, PathBuf};

use super::LogContents;

/// `logs/<participant>/<participant>_<UTC time>.mcap` (the id must be valid: it becomes a
/// file name). The recorder adds a suffix if that name is taken when it creates the file.
pub fn new_log_path(logs: &Path, participant: &str, time: chrono::DateTime<chrono::Utc>) -> PathBuf {
    log_path_in(&logs.join(participant), participant, time)
}

/// `<dir>/<participant>_<UTC time>.mcap`.
pub fn log_path_in(dir: &Path, participant: &str, time: chrono::DateTime<chrono::Utc>) -> PathBuf {
    dir.join(format!("{participant}_{}.mcap", time.format("%Y%m%dT%H%M%SZ")))
}

/// The folder a log is in ("." for a bare file name): where its continuation and its
/// participant's lock live.
pub fn log_folder(log: &Path) -> PathBuf {
    log.parent().filter(|d| !d.as_os_str().is_empty()).map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// Where the continuation of `old` is written: beside it, named after its participant id
/// (validated when the log was read) — never a path taken from the log's content.
pub fn continuation_path(old: &LogContents, time: chrono::DateTime<chrono::Utc>) -> PathBuf {
    log_path_in(&log_folder(&old.path), &old.start.participant, time)
}

/// When a log file was created, from the name [`log_path_in`] and [`create_unique`] give it:
/// (`YYYYMMDDTHHMMSSZ`, the `-k` suffix of a name taken in the same second, 1 without).
pub(super) fn created_key(path: &Path) -> Option<(String, u32)> {
    let stem = path.file_stem()?.to_str()?;
    let (_, stamp) = stem.rsplit_once('_')?;
    let (time, k) = match stamp.split_once('-') {
        Some((t, k)) => (t, k.parse().ok()?),
        None => (stamp, 1),
    };
    let digits = |s: &str| s.bytes().all(|b| b.is_ascii_digit());
    (time.len() == 16 && digits(&time[..8]) && &time[8..9] == "T" && digits(&time[9..15]) && time.ends_with('Z'))
        .then(|| (time.to_string(), k))
}

/// Creates `path` owner-only, or, if that name is taken, `<stem>-2.mcap`, `-3`, … (two
/// consoles started in the same second each get their own file; nothing is overwritten).
pub(super) fn create_unique(path: &Path) -> std::io::Result<(PathBuf, File)> {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let mut candidate = path.to_path_buf();
    for k in 2..=1000 {
        match crate::private_files::create_file(&candidate) {
            Ok(f) => return Ok((candidate, f)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                candidate = path.with_file_name(format!("{stem}-{k}.mcap"));
            }
            Err(e) => return Err(e),
        }
    }
    Err(std::io::Error::new(std::io::ErrorKind::AlreadyExists, "1000 logs of that name exist"))
}

/// Whether `name` is a plain log file name (no directory, no leading dot).
pub fn is_log_file_name(name: &str) -> bool {
    name.len() <= 128
        && name.ends_with(".mcap")
        && !name.starts_with('.')
        && name.bytes().all(|b| b.is_ascii_alphanumeric() || matches!(b, b'-' | b'_' | b'.'))
}

/// Every `.mcap` file under `root` (recursively), sorted; `root` itself if it is there but
/// not a folder (named on the command line, so read, and refused there if it is not a log);
/// nothing if there is no `root`. Below
/// `root` nothing is followed or opened on the way: a link (to a folder or a file), a FIFO or
/// a device is skipped, so a link loop or a named pipe cannot hang or multiply the walk.
pub fn mcap_files(root: &Path) -> Vec<PathBuf> {
    mcap_files_reporting(root).0
}

/// [`mcap_files`], and the folders under `root` that could not be listed, with why: their
/// logs are not counted, and a command that counts says so.
pub fn mcap_files_reporting(root: &Path) -> (Vec<PathBuf>, Vec<(PathBuf, String)>) {
    let mut out = Vec::new();
    let mut unlistable = Vec::new();
    match std::fs::metadata(root) {
        Err(_) => return (out, unlistable),
        Ok(m) if !m.is_dir() => {
            out.push(root.to_path_buf());
            return (out, unlistable);
        }
        Ok(_) => {}
    }
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let entries = match std::fs::read_dir(&dir) {
            Ok(entries) => entries,
            Err(e) => {
                unlistable.push((dir, format!("the folder cannot be listed ({e}): its logs are not counted")));
                continue;
            }
        };
        for e in entries {
            let e = match e {
                Ok(e) => e,
                Err(err) => {
                    unlistable.push((dir.clone(), format!("the folder cannot be listed whole ({err})")));
                    continue;
                }
            };
            let Ok(kind) = e.file_type() else { continue };
            let p = e.path();
            if kind.is_dir() {
                stack.push(p);
            } else if kind.is_file() && p.extension().is_some_and(|x| x == "mcap") {
                out.push(p);
            }
        }
    }
    out.sort();
    unlistable.sort();
    (out, unlistable)
}
