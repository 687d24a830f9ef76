//! Libraries hold no process-wide options and set no allocator policy (issue 26): options travel
//! in structs (`splatseg_pipeline::RunOptions`), and only the binary tunes glibc's allocator
//! (`src/memory.rs`); a kernel choice comes from the environment (`SPLATSEG_DISABLE_AVX512`, read
//! where it is checked). A scan of every library crate's sources, so a new `static` flag fails here.

use std::path::{Path, PathBuf};

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("list a source folder") {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn library_crates_hold_no_static_options_and_call_no_mallopt() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for krate in std::fs::read_dir(root.join("crates")).expect("crates/") {
        let src = krate.expect("entry").path().join("src");
        if src.is_dir() {
            rust_files(&src, &mut files);
        }
    }
    files.sort();
    assert!(files.len() > 50, "found only {} library sources", files.len());
    let mut found = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).expect("read a source");
        let rel = file.strip_prefix(root).expect("under the root").to_string_lossy().replace('\\', "/");
        for line in text.lines().map(str::trim) {
            if line.starts_with("//") {
                continue;
            }
            let is_static = line.starts_with("static ") || line.starts_with("pub static ");
            let mutable = ["Atomic", "Mutex", "RwLock", "OnceLock", "OnceCell", "Cell<", "Once "]
                .iter()
                .any(|t| line.contains(t));
            if (is_static && mutable) || line.contains("static mut ") {
                let name = line.split(':').next().unwrap_or(line).replace("pub ", "");
                found.push(format!("{rel}: {name}"));
            }
            if line.contains("mallopt(") {
                found.push(format!("{rel}: mallopt"));
            }
        }
    }
    assert!(found.is_empty(), "process-wide state in libraries: {found:#?}");
}
