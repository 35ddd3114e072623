//! What `simulate` and `plan` share to run as a job array: `--shard K/N` parsed, and the
//! shard directories of a merge checked (the same run, each shard once, none missing).

use std::path::{Path, PathBuf};

use anyhow::Result;
use handover::experiment::{SHARD_MANIFEST, ShardManifest};

use super::input::bad;

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
/// `fingerprint`, each shard once, none missing. In the order given.
pub fn checked_shards<'a>(dirs: &'a [PathBuf], fingerprint: &str) -> Result<Vec<(&'a Path, ShardManifest)>> {
    let mut seen: Vec<Option<&Path>> = Vec::new();
    let mut out = Vec::with_capacity(dirs.len());
    for dir in dirs {
        let path = dir.join(SHARD_MANIFEST);
        let text = super::input::read_text(&path)?;
        let m: ShardManifest = super::input::parse_json(&text, &path.display().to_string())?;
        if m.run != fingerprint {
            return Err(bad(format!("{}: a shard of another run (other options than this command's)", dir.display())));
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
