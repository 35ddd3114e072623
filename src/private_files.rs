//! Files that hold participant data: readable by the owner only, never overwritten, and
//! never left empty or half-written when a write fails.

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

/// Creates or truncates an output file (a table, a figure, a report) with mode 0600, also
/// when it existed with a wider mode: what a command writes is owner-only whatever the umask.
pub fn create_output(path: &Path) -> std::io::Result<File> {
    let mut o = std::fs::OpenOptions::new();
    o.write(true).create(true).truncate(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::{OpenOptionsExt, PermissionsExt};
        o.mode(0o600);
        let f = o.open(path)?;
        f.set_permissions(std::fs::Permissions::from_mode(0o600))?;
        Ok(f)
    }
    #[cfg(not(unix))]
    o.open(path)
}

/// Writes a whole output file with [`create_output`].
pub fn write_output(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    create_output(path)?.write_all(bytes)
}

/// Writes a tidy table with [`create_output`]: one row per `Serialize` value under its field
/// names, and the header even when there are no rows (serde's CSV writer writes it with the
/// first row, so the header of an empty table comes from a default row). Every table a
/// command writes goes through here.
pub fn write_csv<T: serde::Serialize + Default>(path: &Path, rows: impl IntoIterator<Item = T>) -> std::io::Result<()> {
    let write = || -> Result<(), csv::Error> {
        let mut w = csv::Writer::from_writer(create_output(path)?);
        let mut any = false;
        for r in rows {
            w.serialize(r)?;
            any = true;
        }
        if !any {
            let mut header = csv::Writer::from_writer(Vec::new());
            header.serialize(T::default())?;
            let bytes = header.into_inner().map_err(|e| csv::Error::from(e.into_error()))?;
            let text = String::from_utf8_lossy(&bytes);
            w.write_record(text.lines().next().unwrap_or_default().split(','))?;
        }
        w.flush()?;
        Ok(())
    };
    write().map_err(|e| {
        let e = std::io::Error::from(e);
        std::io::Error::new(e.kind(), format!("cannot write {}: {e}", path.display()))
    })
}

/// Creates `dir` and every missing parent with mode 0700, and gives `dir` itself mode 0700
/// (an existing parent is left as it is).
pub fn create_dir(dir: &Path) -> std::io::Result<()> {
    let mut b = std::fs::DirBuilder::new();
    b.recursive(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::{DirBuilderExt, PermissionsExt};
        b.mode(0o700);
        b.create(dir)?;
        std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o700))?;
    }
    #[cfg(not(unix))]
    b.create(dir)?;
    Ok(())
}

/// Writes a whole new owner-only file and syncs it; on any failure the file is removed, so
/// that no empty or partial file is left to be read later as corrupt.
pub fn write_new(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = create_file(path)?;
    let written = f.write_all(bytes).and_then(|()| f.sync_all());
    if let Err(e) = written {
        drop(f);
        let _ = std::fs::remove_file(path);
        return Err(e);
    }
    sync_parent(path);
    Ok(())
}

/// Replaces `path` with new contents atomically: a new owner-only file beside it (its name
/// with `.new` appended, which must not exist) is written and synced, then renamed over
/// `path`. A crash leaves either the old or the new file whole.
pub fn replace(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".new");
    let tmp = std::path::PathBuf::from(tmp);
    write_new(&tmp, bytes)?;
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
