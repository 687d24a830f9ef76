//! `splatseg-lift` exports no function that only tests or benches call (issue 26): every `pub fn`
//! of the crate is named somewhere in the production sources (the crates' `src/` outside their test
//! modules, and the binary's `src/`), so the tests exercise the path `run` takes, not a twin of it.
//! A textual scan: a name used in production for something else would hide a test-only function,
//! so lift's public names are kept distinct.

use std::path::{Path, PathBuf};

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("list a source folder").flatten() {
        let path = entry.path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The text before a file's first `#[cfg(test)]` (test modules sit at the end of a file), or
/// nothing for a file that is itself a test module (`*tests.rs`).
fn production_part(path: &Path) -> String {
    let text = std::fs::read_to_string(path).expect("read a source");
    if path.file_stem().is_some_and(|s| s.to_string_lossy().ends_with("tests")) {
        return String::new();
    }
    match text.find("#[cfg(test)]") {
        Some(at) => text[..at].to_string(),
        None => text,
    }
}

/// Names of the `pub fn`s in `text` (not `pub(crate)` or narrower).
fn public_functions(text: &str) -> Vec<String> {
    let mut names = Vec::new();
    for line in text.lines().map(str::trim_start) {
        let rest = line
            .strip_prefix("pub fn ")
            .or_else(|| line.strip_prefix("pub const fn "))
            .or_else(|| line.strip_prefix("pub unsafe fn "));
        if let Some(rest) = rest {
            let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            names.push(name);
        }
    }
    names
}

/// Whether `name` occurs in `text` as a word other than right after `fn ` (its definition).
fn used(text: &str, name: &str) -> bool {
    let is_word = |c: char| c.is_alphanumeric() || c == '_';
    text.match_indices(name).any(|(at, _)| {
        let before = text[..at].chars().next_back();
        let after = text[at + name.len()..].chars().next();
        let whole = !before.is_some_and(is_word) && !after.is_some_and(is_word);
        whole && !text[..at].ends_with("fn ")
    })
}

#[test]
fn every_public_function_of_lift_has_a_production_caller() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut lift_files = Vec::new();
    rust_files(&root.join("crates/lift/src"), &mut lift_files);
    let mut production = Vec::new();
    rust_files(&root.join("src"), &mut production);
    for krate in std::fs::read_dir(root.join("crates")).expect("crates/").flatten() {
        if krate.path().join("src").is_dir() {
            rust_files(&krate.path().join("src"), &mut production);
        }
    }
    let corpus: String = production.iter().map(|f| production_part(f)).collect::<Vec<_>>().join("\n");
    let mut names: Vec<String> =
        lift_files.iter().flat_map(|f| public_functions(&production_part(f))).collect();
    names.sort();
    names.dedup();
    assert!(names.len() >= 20, "found only {} public functions in lift: is the scan broken?", names.len());
    assert!(names.iter().any(|n| n == "render_label_map"), "the scan misses lift's id renderer");
    let test_only: Vec<&String> = names.iter().filter(|n| !used(&corpus, n)).collect();
    assert!(
        test_only.is_empty(),
        "lift exports functions that no production code calls (only tests or benches, or nobody): \
         {test_only:?}; make them private, move them into the test, or call them on the production path"
    );
}

#[test]
fn the_scan_tells_a_call_from_a_definition() {
    assert!(used("let x = foo(1);", "foo"));
    assert!(!used("pub fn foo() {}", "foo"));
    assert!(!used("let x = foobar(1);", "foo"));
    assert_eq!(public_functions("pub fn a() {}\n    pub fn b_2(x: u8)\npub(crate) fn c()"), ["a", "b_2"]);
}
