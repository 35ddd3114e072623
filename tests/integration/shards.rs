//! Helpers shared by the integration tests that merge shards.

use std::path::Path;

/// Sets a shard's manifest's hash of `file` to the file's: a shard edited along with its
/// manifest, as a hostile one would be, so that a merge reads its rows.
pub fn rehash(dir: &Path, file: &str) {
    use sha2::Digest as _;
    if file == "shard.json" {
        return;
    }
    let hash: String =
        sha2::Sha256::digest(std::fs::read(dir.join(file)).unwrap()).iter().map(|b| format!("{b:02x}")).collect();
    let mut m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("shard.json")).unwrap()).unwrap();
    m["files"][file] = hash.into();
    std::fs::write(dir.join("shard.json"), m.to_string()).unwrap();
}
