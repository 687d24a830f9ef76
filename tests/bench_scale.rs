//! `splatseg bench scale` on a tiny capture: it writes the capture (repeating views beyond
//! `--distinct-views`), runs `run` in a child and prints every stage with its time and peak memory.

use std::process::Command;

#[test]
fn bench_scale_prints_every_stage_of_a_run_on_the_capture_it_wrote() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let dir = tmp.path().to_str().expect("utf-8");
    let output = Command::new(env!("CARGO_BIN_EXE_splatseg"))
        .args(["bench", "scale", "--views", "3", "--distinct-views", "2", "--size", "160x120"])
        .args(["--gaussians", "7000", "--dir", dir])
        .env("RAYON_NUM_THREADS", "2")
        .output()
        .expect("spawn");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&output.stderr));
    let stages = [
        "load inputs",
        "prepare Gaussians",
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
