//! The demo's outputs are pinned byte for byte: every file `splatseg demo` writes (the scene, the
//! run's masks, overlays, labelled PLY, report and metrics, the train stage's outputs) and what
//! it prints, against `tests/golden/demo.digests`. A change meant to change no result (issue 26's
//! redesign) passes this unchanged; a change meant to change results reruns it with
//! `SPLATSEG_UPDATE_GOLDEN=1` and says so in its commit. The reduced stress suite's outputs are
//! pinned the same way (`tests/golden/reduced_suite.digests`, by the suite's own test).

use splatseg_pipeline::digest::{compare_with_golden, folder_digests, text_digest};
use std::path::Path;
use std::process::Command;

#[test]
fn the_demo_writes_the_golden_bytes() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let out = tmp.path().join("demo");
    let run = Command::new(env!("CARGO_BIN_EXE_splatseg"))
        .args(["demo", "-q", "--out"])
        .arg(&out)
        .output()
        .expect("splatseg runs");
    assert!(run.status.success(), "demo failed: {}", String::from_utf8_lossy(&run.stderr));
    // The caches hold timings and keys, the lock a process id: not outputs.
    let skip = |rel: &str| rel.ends_with(".splatseg.lock") || rel.starts_with("run/cache/");
    let mut digests = folder_digests(&out, skip).expect("digests");
    let stdout = String::from_utf8_lossy(&run.stdout).replace(&*out.to_string_lossy(), "OUT");
    digests.push(("<stdout>".to_string(), text_digest(&stdout)));
    let golden = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/demo.digests");
    let update = std::env::var_os("SPLATSEG_UPDATE_GOLDEN").is_some();
    if let Err(e) = compare_with_golden(&digests, &golden, update) {
        panic!("{e}\n--- stdout ---\n{stdout}");
    }
}
