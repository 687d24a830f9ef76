//! One integration-test binary per crate. Each test binary links the crate and all its
//! dependencies once, and `cargo test` runs the binaries one after another, so every file of a
//! crate's `tests/` is a module of its `tests/main.rs` (with `autotests = false` and one `[[test]]`
//! in the manifest) rather than a binary of its own. This test fails naming every file of `tests/`
//! that `main.rs` leaves out (it would silently never run), every module it declares that has no
//! file, and every crate with several test files but no `main.rs`.

use crate::architecture_doc::{parse_toml, read};
use std::collections::BTreeSet;
use std::path::Path;

#[test]
fn every_test_file_is_a_module_of_its_crates_one_test_binary() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let manifest = parse_toml(&root.join("Cargo.toml"));
    let members = manifest
        .get("workspace")
        .and_then(|w| w.get("members"))
        .and_then(|m| m.as_array())
        .expect("the root Cargo.toml has [workspace] members");
    let mut dirs = vec![root.to_path_buf()];
    for member in members.iter().map(|m| m.as_str().expect("a member is a path string")) {
        if member != "." {
            dirs.push(root.join(member));
        }
    }
    let problems: Vec<String> = dirs.iter().flat_map(|dir| layout_problems(dir)).collect();
    assert!(problems.is_empty(), "test layout:\n- {}", problems.join("\n- "));
}

#[test]
fn a_left_out_file_and_a_module_without_file_are_named() {
    let dir = tempfile::tempdir().expect("temp dir");
    let tests = dir.path().join("tests");
    std::fs::create_dir_all(tests.join("common")).expect("mkdir");
    std::fs::write(dir.path().join("Cargo.toml"), "[package]\nname = \"x\"\nautotests = false\n")
        .expect("write");
    for (file, text) in [
        ("main.rs", "mod common;\nmod kept;\nmod gone;\n"),
        ("kept.rs", ""),
        ("left_out.rs", ""),
        ("common/mod.rs", ""),
    ] {
        std::fs::write(tests.join(file), text).expect("write");
    }
    let found = layout_problems(dir.path());
    assert_eq!(found.len(), 2, "{found:?}");
    assert!(found[0].contains("gone") && found[0].contains("no file"), "{found:?}");
    assert!(found[1].contains("left_out.rs") && found[1].contains("never"), "{found:?}");

    std::fs::remove_file(tests.join("main.rs")).expect("rm");
    let found = layout_problems(dir.path());
    assert!(found.len() == 1 && found[0].contains("several test files"), "{found:?}");
}

/// What is wrong with the test layout of the crate in `dir`, one sentence each.
fn layout_problems(dir: &Path) -> Vec<String> {
    let tests = dir.join("tests");
    let name = dir.display();
    let Ok(entries) = std::fs::read_dir(&tests) else { return Vec::new() };
    let mut files = BTreeSet::new();
    for entry in entries.flatten() {
        let path = entry.path();
        let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or_default().to_string();
        let module_file = path.extension().is_some_and(|e| e == "rs") && stem != "main";
        if module_file || path.join("mod.rs").is_file() {
            files.insert(stem);
        }
    }
    let main = tests.join("main.rs");
    if !main.is_file() {
        return if files.len() > 1 {
            vec![format!("{name}: several test files and no tests/main.rs (one binary each)")]
        } else {
            Vec::new()
        };
    }
    let autotests = parse_toml(&dir.join("Cargo.toml"))
        .get("package")
        .and_then(|p| p.get("autotests"))
        .and_then(|a| a.as_bool());
    let mut problems = Vec::new();
    if autotests != Some(false) {
        problems.push(format!("{name}: tests/main.rs without `autotests = false` (each file builds twice)"));
    }
    let declared: BTreeSet<String> = read(&main)
        .lines()
        .filter_map(|l| l.trim().strip_prefix("mod ")?.strip_suffix(';').map(str::to_string))
        .collect();
    for module in declared.difference(&files) {
        problems.push(format!("{name}: tests/main.rs declares `mod {module};`, which has no file"));
    }
    for file in files.difference(&declared) {
        problems.push(format!("{name}: tests/{file}.rs is not a module of tests/main.rs: it never runs"));
    }
    problems
}
