//! `bench scale` on a tiny capture (the library `splatseg bench scale` calls, with 2 distinct views
//! where the command renders at most `DISTINCT_VIEWS`, so that the repeated views are exercised): it
//! writes the capture (repeating views beyond the distinct ones), runs the binary's `run` in a child
//! and prints every stage with its time and peak memory.

use splatseg_bench::scale::{scale, ScaleRequest};
use std::path::Path;

#[test]
fn bench_scale_prints_every_stage_of_a_run_on_the_capture_it_wrote() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let request = ScaleRequest {
        views: 3,
        size: (160, 120),
        gaussians: 7000,
        seed: 0,
        distinct_views: 2,
        dir: tmp.path().to_path_buf(),
    };
    let stdout = scale(&request, Path::new(env!("CARGO_BIN_EXE_splatseg"))).expect("bench scale runs");
    let stages = [
        "load inputs",
        "prepare Gaussians",
        "per view: visibility, SAM masks",
        "per view: depth, merge, visibility",
        "match",
        "lift and render back",
        "outputs and eval",
        "**whole run** (child process)",
    ];
    for stage in stages {
        let line = stdout.lines().find(|l| l.starts_with(&format!("| {stage} |"))).unwrap_or_else(|| {
            panic!("no row for `{stage}`:\n{stdout}");
        });
        let cells: Vec<&str> = line.split('|').map(|c| c.trim().trim_matches('*')).collect();
        let seconds: f64 = cells[2].parse().unwrap_or_else(|_| panic!("seconds in `{line}`"));
        assert!(seconds >= 0.0, "{line}");
        if cfg!(target_os = "linux") {
            let mb: f64 = cells[3].parse().unwrap_or_else(|_| panic!("peak MB in `{line}`"));
            assert!(mb > 1.0, "{line}");
        }
    }
    let scene = tmp.path().join("scene-3v-160x120-7000g-s0");
    let images = std::fs::read_to_string(scene.join("sparse/0/images.txt")).expect("COLMAP images");
    assert!(images.contains("view_002.png"), "the repeated view is in the capture");
    for file in ["sam/view_002.json", "features/view_002.npy", "depth/view_002.npy", "images/view_002.png"] {
        assert!(scene.join(file).is_file(), "{file}");
    }
    let out = tmp.path().join("out-scene-3v-160x120-7000g-s0");
    assert!(out.join("masks/view_002.png").is_file(), "run labelled the repeated view too");
}
