//! The import rules of `docs/architecture.md` are the code's: every `crate::` path a module's
//! non-test code names is a module its row allows, and only `tui` names ratatui or crossterm.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// module → the modules it may import, from the table's rows.
fn rules() -> BTreeMap<String, BTreeSet<String>> {
    let text = std::fs::read_to_string(root().join("docs/architecture.md")).unwrap();
    let mut out = BTreeMap::new();
    for line in text.lines().filter(|l| l.starts_with("| `")) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        let module = cells[1].trim_matches('`');
        if module.contains('.') || module.contains('`') {
            continue; // `main.rs`, `cli`: everything
        }
        let allowed: BTreeSet<String> = cells[3].split('`').skip(1).step_by(2).map(String::from).collect();
        out.insert(module.to_string(), allowed);
    }
    out
}

fn rust_files(p: &Path) -> Vec<PathBuf> {
    if p.is_file() {
        return vec![p.to_path_buf()];
    }
    let mut out = Vec::new();
    for e in std::fs::read_dir(p).unwrap().flatten() {
        out.extend(rust_files(&e.path()));
    }
    out.retain(|f| f.extension().is_some_and(|e| e == "rs"));
    out
}

/// The code of a file without its test module (and test files are skipped by the caller).
fn non_test_code(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    match text.find("#[cfg(test)]\nmod tests") {
        Some(i) => text[..i].to_string(),
        None => text,
    }
}

#[test]
fn every_module_imports_only_what_its_row_allows() {
    let rules = rules();
    // Every module of the library has a row.
    let lib = std::fs::read_to_string(root().join("src/lib.rs")).unwrap();
    let declared: BTreeSet<String> =
        lib.lines().filter_map(|l| l.strip_prefix("pub mod ")).map(|m| m.trim_end_matches(';').to_string()).collect();
    let rows: BTreeSet<String> = rules.keys().cloned().collect();
    assert_eq!(declared, rows, "the modules of src/lib.rs and the rows of docs/architecture.md");
    let modules: BTreeSet<&String> = rules.keys().collect();
    let mut problems = Vec::new();
    for (module, allowed) in &rules {
        let dir = root().join("src").join(module);
        let path = if dir.is_dir() { dir } else { root().join("src").join(format!("{module}.rs")) };
        assert!(path.exists(), "{module}: no {}", path.display());
        for file in rust_files(&path).into_iter().filter(|f| !f.ends_with("tests.rs")) {
            let code = non_test_code(&file);
            for (i, _) in code.match_indices("crate::") {
                let name: String = code[i + 7..].chars().take_while(|c| c.is_ascii_lowercase() || *c == '_').collect();
                // Items of the crate root (`crate::SeededRng`, `crate::derive_seed`) are shared.
                let is_module = modules.contains(&name);
                if is_module && name != *module && !allowed.contains(&name) {
                    problems.push(format!("{}: imports {name}", file.strip_prefix(root()).unwrap().display()));
                }
            }
            if module != "tui" && (code.contains("ratatui") || code.contains("crossterm")) {
                problems.push(format!("{}: names ratatui or crossterm", file.display()));
            }
        }
    }
    problems.sort();
    problems.dedup();
    assert!(problems.is_empty(), "imports docs/architecture.md does not allow:\n{}", problems.join("\n"));
}

/// A test that lacks a prerequisite goes through one mechanism, `support::missing` (a failure
/// under CI, a skip elsewhere): no test prints its own "skipped", and every file that reads a
/// prerequisite's variable (`HANDOVER_PYTHON`, `HANDOVER_RSCRIPT`, `HANDOVER_NODE_MODULES`,
/// `HANDOVER_ROS_*`) with `std::env::var` says `missing(` at least as often as it reads one.
#[test]
fn a_missing_prerequisite_is_said_one_way_that_fails_under_ci() {
    let dir = root().join("tests/integration");
    let mut problems = Vec::new();
    let mut files = 0;
    for file in rust_files(&dir) {
        let name = file.file_name().unwrap().to_string_lossy().into_owned();
        let text = std::fs::read_to_string(&file).unwrap();
        files += 1;
        if name == "support.rs" || name == "architecture.rs" {
            continue;
        }
        for (n, line) in text.lines().enumerate() {
            let l = line.to_lowercase();
            if (l.contains("eprintln!(\"skip") || l.contains("println!(\"skip")) && !l.trim_start().starts_with("//") {
                problems.push(format!("{name}:{}: prints its own skip: {}", n + 1, line.trim()));
            }
        }
        let reads = text.matches("env::var(\"HANDOVER_").count();
        let said = text.matches("missing(").count();
        if reads > said {
            problems.push(format!("{name}: reads {reads} prerequisite variable(s), says missing( {said} time(s)"));
        }
    }
    assert!(files > 20, "the suite's files were read: {files}");
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
