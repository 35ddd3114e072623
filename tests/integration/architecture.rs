//! The import rules of `docs/architecture.md` are the code's: every `crate::` path a module's
//! non-test code names is a module its row allows, and only `tui` names ratatui or crossterm.
//! The code is parsed, not cut at its first test module: items compiled only for tests are
//! left out wherever they stand, and the rest is read to its last token.

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

/// Whether an item is compiled only for tests (`#[cfg(test)]`).
fn is_test_only(attrs: &[syn::Attribute]) -> bool {
    attrs
        .iter()
        .any(|a| a.path().is_ident("cfg") && a.parse_args::<syn::Meta>().is_ok_and(|m| m.path().is_ident("test")))
}

/// A file's items without those compiled only for tests, at any depth of inline modules.
fn strip_tests(items: &mut Vec<syn::Item>) {
    items.retain(|item| {
        let attrs = match item {
            syn::Item::Mod(m) => &m.attrs,
            syn::Item::Fn(f) => &f.attrs,
            syn::Item::Use(u) => &u.attrs,
            syn::Item::Impl(i) => &i.attrs,
            syn::Item::Struct(s) => &s.attrs,
            syn::Item::Enum(e) => &e.attrs,
            syn::Item::Const(c) => &c.attrs,
            syn::Item::Static(s) => &s.attrs,
            syn::Item::Trait(t) => &t.attrs,
            syn::Item::Type(t) => &t.attrs,
            syn::Item::Macro(m) => &m.attrs,
            _ => return true,
        };
        !is_test_only(attrs)
    });
    for item in items.iter_mut() {
        if let syn::Item::Mod(syn::ItemMod { content: Some((_, inner)), .. }) = item {
            strip_tests(inner);
        }
    }
}

/// The words of a file's non-test code, as the compiler reads them: parsed (syn), the items
/// compiled only for tests removed wherever they are, and the rest flattened to its tokens'
/// texts (macro bodies included; comments, doc comments and strings are not words).
fn non_test_words(path: &Path) -> Vec<String> {
    fn flatten(tokens: proc_macro2::TokenStream, out: &mut Vec<String>) {
        for t in tokens {
            match t {
                proc_macro2::TokenTree::Group(g) => flatten(g.stream(), out),
                proc_macro2::TokenTree::Ident(i) => out.push(i.to_string()),
                proc_macro2::TokenTree::Punct(p) => out.push(p.as_char().to_string()),
                proc_macro2::TokenTree::Literal(_) => out.push(String::new()),
            }
        }
    }
    let text = std::fs::read_to_string(path).unwrap();
    let mut file = syn::parse_file(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    strip_tests(&mut file.items);
    let mut words = Vec::new();
    flatten(quote::ToTokens::to_token_stream(&file), &mut words);
    words
}

/// The crate modules `words` name (`crate :: name`), and whether they name ratatui or crossterm.
fn named_modules(words: &[String]) -> (BTreeSet<String>, bool) {
    let modules =
        words.windows(4).filter(|w| w[0] == "crate" && w[1] == ":" && w[2] == ":").map(|w| w[3].clone()).collect();
    (modules, words.iter().any(|w| w == "ratatui" || w == "crossterm"))
}

/// A test of the test: a forbidden import is found wherever it stands in non-test code
/// (before a test module, after one, inside a nested module, in a macro's body), and not in
/// test code, comments or strings.
#[test]
fn the_import_reader_sees_all_non_test_code_and_only_it() {
    let dir = crate::support::tmpdir("architecture");
    let cases = [
        ("use crate::tui::App;\n#[cfg(test)]\nmod tests {}\n", true),
        ("#[cfg(test)]\nmod tests { use crate::record::x; }\nuse crate::tui::App;\n", true),
        ("mod inner { fn f() { let _ = crate::tui::run(); } }\n", true),
        ("fn f() { println!(\"{}\", crate::tui::NAME); }\n", true),
        ("#[cfg(test)]\nmod tests { use crate::tui::App; }\n", false),
        ("#[cfg(test)]\nfn helper() { crate::tui::run(); }\n", false),
        ("/// See crate::tui::App.\nfn f() {}\n// crate::tui\nconst S: &str = \"crate::tui\";\n", false),
    ];
    for (k, (code, found)) in cases.iter().enumerate() {
        let file = dir.join(format!("case{k}.rs"));
        std::fs::write(&file, code).unwrap();
        let (modules, _) = named_modules(&non_test_words(&file));
        assert_eq!(modules.contains("tui"), *found, "case {k}: {code}");
    }
    let file = dir.join("ratatui.rs");
    std::fs::write(&file, "fn f() { let _ = ratatui::style::Color::Red; }\n").unwrap();
    assert!(named_modules(&non_test_words(&file)).1);
    let _ = std::fs::remove_dir_all(&dir);
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
            let (named, terminal) = named_modules(&non_test_words(&file));
            for name in named {
                // Items of the crate root (`crate::SeededRng`, `crate::derive_seed`) are shared.
                if modules.contains(&name) && name != *module && !allowed.contains(&name) {
                    problems.push(format!("{}: imports {name}", file.strip_prefix(root()).unwrap().display()));
                }
            }
            if module != "tui" && terminal {
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
