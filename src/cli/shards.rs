//! What `simulate` and `plan` share to run as a job array: `--shard K/N` parsed, a shard's
//! manifest written, and the shard directories of a merge checked (the same run and version,
//! each shard once, none missing, every file as the shard wrote it).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::Result;
use handover::experiment::{SHARD_MANIFEST, ShardManifest};

use super::input::bad;

/// The largest shard file hashed.
const MAX_SHARD_FILE_BYTES: u64 = 16 << 30;

/// The most shards a run is split into.
const MAX_SHARDS: usize = 100_000;

/// `K/N` with N from 1 to [`MAX_SHARDS`] shards and K below N.
pub fn parse_shard(text: &str) -> Result<(usize, usize)> {
    let parsed = text.split_once('/').and_then(|(k, n)| Some((k.trim().parse().ok()?, n.trim().parse().ok()?)));
    match parsed {
        Some((k, n)) if (1..=MAX_SHARDS).contains(&n) && k < n => Ok((k, n)),
        _ => Err(bad(format!("--shard is '{text}', expected K/N with 1 ≤ N ≤ 100000 and 0 ≤ K < N"))),
    }
}

/// The SHA-256 (hex) of a shard's file.
fn file_sha256(path: &Path) -> Result<String> {
    use sha2::Digest as _;
    let mut file = handover::input_file::open_bounded(path, MAX_SHARD_FILE_BYTES)
        .map_err(|e| bad(format!("{}: {e}", path.display())))?;
    let mut hasher = sha2::Sha256::new();
    let mut buffer = vec![0u8; 1 << 16];
    loop {
        let n = std::io::Read::read(&mut file, &mut buffer).map_err(|e| bad(format!("{}: {e}", path.display())))?;
        if n == 0 {
            break;
        }
        hasher.update(&buffer[..n]);
    }
    Ok(hasher.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

/// A finished shard's manifest: its run, this version, the shard, the rows, a hash of each
/// of `files` (already written in `dir`) and its computing time.
pub fn manifest(
    dir: &Path,
    run: String,
    (shard, of): (usize, usize),
    rows: usize,
    files: &[&str],
    seconds: f64,
    threads: usize,
) -> Result<ShardManifest> {
    let mut hashes = BTreeMap::new();
    for name in files {
        hashes.insert(name.to_string(), file_sha256(&dir.join(name))?);
    }
    let version = env!("CARGO_PKG_VERSION").to_string();
    Ok(ShardManifest { run, version, shard, of, rows, files: hashes, seconds, threads })
}

/// How long a merged run computed: its shards' own times, summed.
pub fn merged_timing(manifests: &[ShardManifest], merge_seconds: f64) -> String {
    let computing: f64 = manifests.iter().map(|m| m.seconds).sum();
    format!("{computing:.1} s of computing in {} shards, merged in {merge_seconds:.1} s", manifests.len())
}

/// Writes a shard's manifest into its directory.
pub fn write_manifest(dir: &Path, manifest: &ShardManifest) -> Result<()> {
    use anyhow::Context as _;
    let path = dir.join(SHARD_MANIFEST);
    handover::private_files::write_output(&path, (serde_json::to_string_pretty(manifest)? + "\n").as_bytes())
        .with_context(|| format!("cannot write {}", path.display()))
}

/// A shard's `file` holds the rows its manifest says.
pub fn check_rows(dir: &Path, file: &str, rows: usize, manifest: &ShardManifest) -> Result<()> {
    if rows == manifest.rows {
        return Ok(());
    }
    Err(bad(format!("{}: {file} has {rows} rows, its manifest says {}", dir.display(), manifest.rows)))
}

/// The shard directories of a merge with their manifests, checked: every one of the run
/// `fingerprint` and of this version, each shard once, none missing (the number of shards is
/// the manifests'), its manifest hashing exactly `files` (what the merge reads), each as the
/// shard wrote it. In the order given.
pub fn checked_shards<'a>(
    dirs: &'a [PathBuf],
    fingerprint: &str,
    files: &[&str],
) -> Result<Vec<(&'a Path, ShardManifest)>> {
    let mut seen: Vec<Option<&Path>> = Vec::new();
    let mut out = Vec::with_capacity(dirs.len());
    for dir in dirs {
        let path = dir.join(SHARD_MANIFEST);
        if !handover::input_file::is_plain_file(&path) {
            return Err(bad(format!(
                "{}: no {SHARD_MANIFEST}: the shard did not finish (run it again) or this is not a shard's folder",
                dir.display()
            )));
        }
        let text = super::input::read_text(&path)?;
        let m: ShardManifest = super::input::parse_json(&text, &path.display().to_string())?;
        if m.run != fingerprint {
            return Err(bad(format!("{}: a shard of another run (other options than this command's)", dir.display())));
        }
        if m.version != env!("CARGO_PKG_VERSION") {
            return Err(bad(format!(
                "{}: computed by handover {}, this is {}: run the shard again with this version",
                dir.display(),
                crate_text(&m.version),
                env!("CARGO_PKG_VERSION")
            )));
        }
        let named: Vec<&str> = m.files.keys().map(String::as_str).collect();
        let mut wanted = files.to_vec();
        wanted.sort_unstable();
        if named != wanted {
            return Err(bad(format!(
                "{}: \"files\" names {}, expected {}: every file the merge reads is checked by its hash",
                path.display(),
                crate_text(&named.join(", ")),
                wanted.join(", ")
            )));
        }
        for (name, hash) in &m.files {
            if name.contains(['/', '\\']) || name.starts_with('.') {
                return Err(bad(format!(
                    "{}: \"files\" names '{}', expected a file name",
                    path.display(),
                    crate_text(name)
                )));
            }
            if file_sha256(&dir.join(name))? != *hash {
                return Err(bad(format!(
                    "{}: {name} is not the file the shard wrote (its SHA-256 differs from {SHARD_MANIFEST}'s)",
                    dir.display()
                )));
            }
        }
        // The number of shards is what `--shard` accepts, checked before it sizes anything.
        if !(1..=MAX_SHARDS).contains(&m.of) {
            return Err(bad(format!("{}: \"of\" is {}, expected 1 to {MAX_SHARDS} shards", path.display(), m.of)));
        }
        if seen.is_empty() {
            seen = vec![None; m.of];
        }
        if m.of != seen.len() || m.shard >= m.of {
            return Err(bad(format!(
                "{}: shard {}/{}, expected one of {} shards",
                dir.display(),
                m.shard,
                m.of,
                seen.len()
            )));
        }
        if let Some(first) = seen[m.shard].replace(dir.as_path()) {
            return Err(bad(format!(
                "shard {}/{} is given twice: {} and {}",
                m.shard,
                m.of,
                first.display(),
                dir.display()
            )));
        }
        out.push((dir.as_path(), m));
    }
    let missing: Vec<String> =
        seen.iter().enumerate().filter(|(_, d)| d.is_none()).map(|(k, _)| k.to_string()).collect();
    if !missing.is_empty() {
        return Err(bad(format!("shards {} of {} are missing", missing.join(", "), seen.len())));
    }
    Ok(out)
}

/// A manifest's text as it may be printed (at most 80 characters, no control characters).
fn crate_text(text: &str) -> String {
    handover::text::printable(&text.chars().take(80).collect::<String>()).into_owned()
}
