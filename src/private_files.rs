//! Files that hold participant data and every output: readable by the owner only, and never
//! left empty or half-written when a write fails or the process is killed (each is written
//! beside its place and renamed or linked into it).

use std::fs::File;
use std::io::Write;
use std::path::Path;

/// Creates a new file with mode 0600; fails if it exists (nothing is ever overwritten).
pub fn create_file(path: &Path) -> std::io::Result<File> {
    let mut o = std::fs::OpenOptions::new();
    o.write(true).create_new(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.mode(0o600);
    }
    o.open(path)
}

/// Writes a whole output file (a table, a figure, a report) through [`replace`]: it appears
/// whole or not at all, also when the command is killed while writing, and is owner-only
/// whatever the umask.
pub fn write_output(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    replace(path, bytes).map_err(|e| std::io::Error::new(e.kind(), format!("cannot write {}: {e}", path.display())))
}

/// A tidy table as CSV text: one row per `Serialize` value under its field names, and the
/// header even when there are no rows (serde's CSV writer writes it with the first row, so
/// the header of an empty table comes from a default row).
pub fn csv_text<T: serde::Serialize + Default>(rows: impl IntoIterator<Item = T>) -> Result<Vec<u8>, csv::Error> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut any = false;
    for r in rows {
        w.serialize(r)?;
        any = true;
    }
    if !any {
        w.serialize(T::default())?;
        let bytes = w.into_inner().map_err(|e| csv::Error::from(e.into_error()))?;
        let header = bytes.iter().position(|&b| b == b'\n').map_or(bytes.len(), |i| i + 1);
        return Ok(bytes[..header].to_vec());
    }
    w.into_inner().map_err(|e| csv::Error::from(e.into_error()))
}

/// A table's boolean as `TRUE` / `FALSE`: the spelling R's `read.csv`, readr and pandas all
/// read as a logical without being told (`#[serde(serialize_with = "csv_bool")]`).
pub fn csv_bool<S: serde::Serializer>(b: &bool, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(bool_text(*b))
}

/// [`csv_bool`] for an optional boolean (empty when absent).
pub fn csv_bool_opt<S: serde::Serializer>(b: &Option<bool>, s: S) -> Result<S::Ok, S::Error> {
    match b {
        Some(b) => s.serialize_str(bool_text(*b)),
        None => s.serialize_none(),
    }
}

/// `TRUE` or `FALSE`.
pub fn bool_text(b: bool) -> &'static str {
    if b { "TRUE" } else { "FALSE" }
}

/// Writes a tidy table ([`csv_text`]) with [`write_output`]. Every table a command writes
/// goes through here, or through [`write_output`] with its own CSV text.
pub fn write_csv<T: serde::Serialize + Default>(path: &Path, rows: impl IntoIterator<Item = T>) -> std::io::Result<()> {
    let text = csv_text(rows).map_err(|e| {
        let e = std::io::Error::from(e);
        std::io::Error::new(e.kind(), format!("cannot write {}: {e}", path.display()))
    })?;
    write_output(path, &text)
}

/// Creates `dir` and every missing parent with mode 0700 whatever the umask. A folder that
/// exists (or a link to one) is left as it is: a group-shared study folder stays shared.
pub fn create_dir(dir: &Path) -> std::io::Result<()> {
    // The folders to create, deepest first, up to the first that exists.
    let mut missing = Vec::new();
    let mut at = Some(dir);
    while let Some(d) = at.filter(|d| !d.as_os_str().is_empty()) {
        match std::fs::metadata(d) {
            Ok(m) if m.is_dir() => break,
            Ok(_) => {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::AlreadyExists,
                    format!("{} exists and is not a folder", d.display()),
                ));
            }
            Err(_) => missing.push(d),
        }
        at = d.parent();
    }
    for d in missing.into_iter().rev() {
        let mut b = std::fs::DirBuilder::new();
        #[cfg(unix)]
        {
            use std::os::unix::fs::DirBuilderExt;
            b.mode(0o700);
        }
        match b.create(d) {
            Ok(()) => {
                #[cfg(unix)]
                {
                    use std::os::unix::fs::PermissionsExt;
                    std::fs::set_permissions(d, std::fs::Permissions::from_mode(0o700))?;
                }
            }
            // Made by another process in the meantime: theirs, left as it is.
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && d.is_dir() => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// Writes a whole new owner-only file and syncs it; fails if `path` exists (nothing is
/// overwritten). The bytes go to a file beside it first, which is then linked to `path`: a
/// crash, a signal or a full disk leaves no file or the whole one, never an empty or cut one
/// to be read later as corrupt. (Where the file system has no hard links, the file is
/// written in place and removed on a failure.)
pub fn write_new(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let tmp = beside(path)?;
    write_synced(&tmp, bytes)?;
    let linked = std::fs::hard_link(&tmp, path);
    let _ = std::fs::remove_file(&tmp);
    match linked {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => return Err(e),
        Err(_) => {
            if let Err(e) = write_synced(path, bytes) {
                if e.kind() != std::io::ErrorKind::AlreadyExists {
                    let _ = std::fs::remove_file(path);
                }
                return Err(e);
            }
        }
    }
    sync_parent(path);
    Ok(())
}

/// Writes `bytes` to a new owner-only file at `path` and syncs it; on a failure the file is
/// removed.
fn write_synced(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = create_file(path)?;
    let written = f.write_all(bytes).and_then(|()| f.sync_all());
    if let Err(e) = written {
        drop(f);
        let _ = std::fs::remove_file(path);
        return Err(e);
    }
    Ok(())
}

/// The temporary file beside `path` that this process writes it through:
/// `.<name>.<pid>.tmp`. A leftover of a killed process that had this process's id is
/// removed first (removing a link removes the link, nothing it points to).
fn beside(path: &Path) -> std::io::Result<std::path::PathBuf> {
    let name = path.file_name().ok_or_else(|| std::io::Error::other(format!("{} names no file", path.display())))?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".{}.tmp", std::process::id()));
    let tmp = path.with_file_name(tmp_name);
    if std::fs::symlink_metadata(&tmp).is_ok() {
        std::fs::remove_file(&tmp)?;
    }
    Ok(tmp)
}

/// Replaces `path` (or creates it) with new contents atomically: a new owner-only file
/// beside it is written and synced, then renamed over `path`, and the folder synced. A crash
/// or a signal leaves either the old or the new file whole, never a cut one.
pub fn replace(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let tmp = beside(path)?;
    write_synced(&tmp, bytes)?;
    if let Err(e) = std::fs::rename(&tmp, path) {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    sync_parent(path);
    Ok(())
}

/// Syncs the directory that holds `path`, so that a new file's name is durable too (best
/// effort: not every file system supports it).
pub fn sync_parent(path: &Path) {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty())
        && let Ok(d) = File::open(dir)
    {
        let _ = d.sync_all();
    }
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    fn mode(p: &Path) -> u32 {
        std::fs::metadata(p).unwrap().permissions().mode() & 0o777
    }

    #[test]
    fn every_created_directory_is_owner_only() {
        let tmp = std::env::temp_dir().join(format!("handover-dirs-{}", std::process::id()));
        let deep = tmp.join("logs").join("p-1");
        create_dir(&deep).unwrap();
        assert_eq!(mode(&tmp), 0o700);
        assert_eq!(mode(&tmp.join("logs")), 0o700);
        assert_eq!(mode(&deep), 0o700);
        std::fs::remove_dir_all(&tmp).unwrap();
    }

    #[test]
    fn an_existing_folder_keeps_its_mode() {
        let tmp = std::env::temp_dir().join(format!("handover-shared-{}", std::process::id()));
        std::fs::create_dir(&tmp).unwrap();
        std::fs::set_permissions(&tmp, std::fs::Permissions::from_mode(0o2775)).unwrap();
        create_dir(&tmp).unwrap();
        assert_eq!(std::fs::metadata(&tmp).unwrap().permissions().mode() & 0o7777, 0o2775);
        let link = tmp.with_extension("link");
        std::os::unix::fs::symlink(&tmp, &link).unwrap();
        create_dir(&link).unwrap();
        create_dir(&link.join("new")).unwrap();
        assert_eq!(std::fs::metadata(&tmp).unwrap().permissions().mode() & 0o7777, 0o2775);
        assert_eq!(mode(&tmp.join("new")), 0o700, "what it creates is owner-only");
        std::fs::remove_file(&link).unwrap();
        std::fs::remove_dir_all(&tmp).unwrap();
    }

    #[test]
    fn an_output_replaces_the_old_whole_and_owner_only() {
        let tmp = std::env::temp_dir().join(format!("handover-out-{}", std::process::id()));
        create_dir(&tmp).unwrap();
        let p = tmp.join("t.csv");
        std::fs::write(&p, "old").unwrap();
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o644)).unwrap();
        // A leftover of a killed writer with this process's id is no obstacle.
        std::fs::write(tmp.join(format!(".t.csv.{}.tmp", std::process::id())), "cut").unwrap();
        write_csv(&p, [(1, "a")]).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "1,a\n");
        assert_eq!(mode(&p), 0o600);
        let names: Vec<_> = std::fs::read_dir(&tmp).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, ["t.csv"], "no temporary file is left");
        std::fs::remove_dir_all(&tmp).unwrap();
    }

    #[test]
    fn existing_files_are_never_overwritten() {
        let tmp = std::env::temp_dir().join(format!("handover-new-{}", std::process::id()));
        create_dir(&tmp).unwrap();
        let p = tmp.join("a.json");
        write_new(&p, b"{}").unwrap();
        assert_eq!(mode(&p), 0o600);
        let e = write_new(&p, b"other").unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::AlreadyExists);
        assert_eq!(std::fs::read(&p).unwrap(), b"{}");
        std::fs::remove_dir_all(&tmp).unwrap();
    }
}
