//! `splatseg cues` end to end with the random-weight checkpoints that
//! tools/fixtures/make_model_fixtures.py wrote (crates/models/tests/fixtures), and its outputs feeding
//! `splatseg merge` and `splatseg run`.

use std::path::{Path, PathBuf};
use std::process::Command;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/models/tests/fixtures")
}

fn splatseg(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_splatseg")).args(args).output().expect("run splatseg");
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "splatseg {args:?} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

fn model_args(f: &Path) -> Vec<String> {
    [
        "--dinov2",
        &f.join("dinov2_tiny").display().to_string(),
        "--depth-model",
        &f.join("depth_anything_tiny").display().to_string(),
        "--sam",
        &f.join("sam_tiny.pth").display().to_string(),
    ]
    .iter()
    .map(|s| s.to_string())
    .collect()
}

#[test]
fn cues_on_lego_writes_every_cue_and_caches() {
    let lego = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/nerf_synthetic_lego");
    if !lego.exists() {
        println!("skipped: {} is absent", lego.display());
        return;
    }
    let out = tempfile::tempdir().unwrap();
    let out_dir = out.path().display().to_string();
    let mut args: Vec<String> =
        ["cues", &lego.display().to_string(), "--out", &out_dir, "--resolution", "8", "--shard", "0/50"]
            .iter()
            .map(|s| s.to_string())
            .collect();
    args.extend(model_args(&fixtures()));
    let argv: Vec<&str> = args.iter().map(String::as_str).collect();
    let first = splatseg(&argv);
    assert!(first.contains("8 computed, 0 cached"), "{first}");
    // 800×800 at resolution 8 → 100×100; DINOv2 at long side 518 → 37×37 patches of the tiny 32-d model
    let features = splatseg_scene::npy::read_npy(&out.path().join("features/r_0.npy")).unwrap();
    assert_eq!(features.shape, vec![37, 37, 32]);
    let norms: Vec<f32> =
        features.data.chunks(32).map(|v| v.iter().map(|x| x * x).sum::<f32>().sqrt()).collect();
    assert!(norms.iter().all(|n| (n - 1.0).abs() < 1e-4), "features are L2-normalised");
    let depth = splatseg_scene::npy::read_npy(&out.path().join("depth/r_50.npy")).unwrap();
    assert_eq!(depth.shape, vec![100, 100]);
    let log = splatseg_scene::npy::read_npy(&out.path().join("log/r_0.npy")).unwrap();
    assert_eq!(log.shape, vec![100, 100]);
    let masks = splatseg_scene::sam::read_sam_json(&out.path().join("sam/r_0.json")).unwrap().masks;
    assert!(masks.iter().all(|m| m.size() == (100, 100)), "masks at full image resolution");
    let second = splatseg(&argv);
    assert!(second.contains("0 computed, 8 cached"), "{second}");

    // The cues feed `splatseg merge` as they are.
    let merged = out.path().join("merged");
    let cue = |name: &str| out.path().join(name).display().to_string();
    let lego_s = lego.display().to_string();
    let merged_s = merged.display().to_string();
    let (sam, features, depth) = (cue("sam"), cue("features"), cue("depth"));
    let said = splatseg(&[
        "merge",
        &lego_s,
        "--masks",
        &sam,
        "--features",
        &features,
        "--depth",
        &depth,
        "--resolution",
        "8",
        "--out",
        &merged_s,
    ]);
    assert!(said.contains("merged 2 views"), "{said}");
    for stem in ["r_0", "r_50"] {
        let labels =
            splatseg_scene::labels::read_label_png(&merged.join(format!("masks/{stem}.png"))).unwrap();
        assert_eq!((labels.width, labels.height), (100, 100));
        assert!(merged.join(format!("merge/{stem}.json")).is_file());
    }
}

#[test]
fn cues_feed_the_pipeline() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene");
    let cues = dir.path().join("cues");
    let (scene_s, cues_s) = (scene.display().to_string(), cues.display().to_string());
    splatseg(&["synth", "--out", &scene_s, "--views", "3", "--size", "96x72"]);
    let mut args: Vec<String> = ["cues", &scene_s, "--out", &cues_s].iter().map(|s| s.to_string()).collect();
    args.extend(model_args(&fixtures()));
    splatseg(&args.iter().map(String::as_str).collect::<Vec<_>>());
    let run_out = dir.path().join("run").display().to_string();
    let summary = splatseg(&[
        "run",
        &scene_s,
        "--masks",
        &cues.join("sam").display().to_string(),
        "--features",
        &cues.join("features").display().to_string(),
        "--depth",
        &cues.join("depth").display().to_string(),
        "--out",
        &run_out,
    ]);
    assert!(summary.contains("3 views"), "{summary}");
    assert!(Path::new(&run_out).join("report.md").is_file());
}

#[test]
fn run_computes_the_cues_itself_when_given_model_checkpoints() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene");
    let out = dir.path().join("run");
    let (scene_s, out_s) = (scene.display().to_string(), out.display().to_string());
    splatseg(&["synth", "--out", &scene_s, "--views", "2", "--size", "70x56"]);
    let f = fixtures();
    let (sam, dinov2, depth) = (
        f.join("sam_tiny.pth").display().to_string(),
        f.join("dinov2_tiny").display().to_string(),
        f.join("depth_anything_tiny").display().to_string(),
    );
    let said = splatseg(&[
        "run",
        &scene_s,
        "--sam",
        &sam,
        "--dinov2",
        &dinov2,
        "--depth-model",
        &depth,
        "--out",
        &out_s,
    ]);
    assert!(said.contains("2 views"), "{said}");
    for stem in ["view_000", "view_001"] {
        assert!(out.join(format!("cues/sam/{stem}.json")).is_file());
        assert!(out.join(format!("cues/features/{stem}.npy")).is_file());
        assert!(out.join(format!("cues/depth/{stem}.npy")).is_file());
        let labels = splatseg_scene::labels::read_label_png(&out.join(format!("masks/{stem}.png"))).unwrap();
        assert_eq!((labels.width, labels.height), (70, 56));
    }
}

/// `splatseg cues` with `env` set, stderr piped: (stdout, stderr).
fn cues_piped(args: &[&str], env: &[(&str, &str)]) -> (String, String) {
    let mut command = Command::new(env!("CARGO_BIN_EXE_splatseg"));
    command.args(args).env_remove("RUST_LOG");
    for (name, value) in env {
        command.env(name, value);
    }
    let out = command.output().expect("run splatseg");
    let (stdout, stderr) =
        (String::from_utf8_lossy(&out.stdout).to_string(), String::from_utf8_lossy(&out.stderr).to_string());
    assert!(out.status.success(), "splatseg {args:?} failed:\n{stdout}\n{stderr}");
    (stdout, stderr)
}

#[test]
fn cues_recompute_exactly_what_a_changed_image_checkpoint_or_setting_touches() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene");
    let scene_s = scene.display().to_string();
    splatseg(&["synth", "--out", &scene_s, "--views", "3", "--size", "64x48"]);
    // a checkpoint of our own, so that touching it changes nothing in the repository
    let sam = dir.path().join("sam.pth");
    std::fs::copy(fixtures().join("sam_tiny.pth"), &sam).unwrap();
    let (sam_s, out_s) = (sam.display().to_string(), dir.path().join("cues").display().to_string());
    let base = ["cues", scene_s.as_str(), "--out", out_s.as_str(), "--sam", sam_s.as_str()];
    let with =
        |extra: &[&'static str]| -> Vec<&str> { base.iter().copied().chain(extra.iter().copied()).collect() };
    // 3 views × (SAM, LoG)
    assert!(splatseg(&with(&[])).contains("6 computed, 0 cached"));
    assert!(splatseg(&with(&[])).contains("0 computed, 6 cached"));
    let json = dir.path().join("cues/sam/view_001.json");
    let before = std::fs::read(&json).unwrap();

    // another image content under the same name: that view's two cues again, the rest cached
    let images = scene.join("images");
    let (first, second) = (images.join("view_000.png"), images.join("view_001.png"));
    let (a, b) = (std::fs::read(&first).unwrap(), std::fs::read(&second).unwrap());
    assert_ne!(a, b, "the synthetic views differ");
    std::fs::write(&second, &a).unwrap();
    assert!(splatseg(&with(&[])).contains("2 computed, 4 cached"));
    assert_ne!(std::fs::read(&json).unwrap(), before, "view_001's masks are the new image's");
    std::fs::write(&second, &b).unwrap();
    assert!(splatseg(&with(&[])).contains("2 computed, 4 cached"));
    assert_eq!(std::fs::read(&json).unwrap(), before, "the old image gives the old masks again");

    // another setting (the image size): everything
    assert!(splatseg(&with(&["--resolution", "2"])).contains("6 computed, 0 cached"));
    assert!(splatseg(&with(&[])).contains("6 computed, 0 cached"));
    // the checkpoint written again (its modification time): SAM's outputs, not the LoG maps
    let file = std::fs::File::options().write(true).open(&sam).unwrap();
    file.set_modified(std::time::SystemTime::now() + std::time::Duration::from_secs(5)).unwrap();
    drop(file);
    assert!(splatseg(&with(&[])).contains("3 computed, 3 cached"));
    assert_eq!(std::fs::read(&json).unwrap(), before, "the same weights give the same masks");
}

#[test]
fn cues_write_progress_lines_with_an_eta_into_a_piped_log() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene");
    let scene_s = scene.display().to_string();
    splatseg(&["synth", "--out", &scene_s, "--views", "2", "--size", "64x48"]);
    let sam = fixtures().join("sam_tiny.pth").display().to_string();
    let out = |name: &str| dir.path().join(name).display().to_string();
    let (a, b) = (out("a"), out("b"));
    // the default interval (30 s): this short run writes no progress line
    let (_, quiet) = cues_piped(&["cues", &scene_s, "--out", &a, "--sam", &sam], &[]);
    assert!(!quiet.contains("views"), "a progress line before 30 s:\n{quiet}");
    let (stdout, log) =
        cues_piped(&["cues", &scene_s, "--out", &b, "--sam", &sam], &[("SPLATSEG_LOG_EVERY_SECS", "0")]);
    assert!(stdout.contains("4 computed, 0 cached"), "{stdout}");
    let lines: Vec<&str> = log.lines().filter(|l| l.contains("INFO") && l.contains(" views ")).collect();
    assert!(!lines.is_empty(), "no progress line in the piped log:\n{log}");
    assert!(lines.iter().all(|l| l.contains("(eta ")), "{lines:?}");
    assert!(lines.iter().any(|l| l.contains("2/2 views")), "{lines:?}");
    assert!(!log.contains('\r') && !log.contains("\u{1b}["), "terminal control codes in a piped log:\n{log}");
    let help = splatseg(&["cues", "--help"]);
    for said in ["SPLATSEG_LOG_EVERY_SECS", "kill", "OUT/cache/<cue>/<stem>.key"] {
        assert!(help.contains(said), "cues --help does not say {said}:\n{help}");
    }
    let bad = Command::new(env!("CARGO_BIN_EXE_splatseg"))
        .args(["cues", &scene_s, "--out", &out("c")])
        .env("SPLATSEG_LOG_EVERY_SECS", "soon")
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("SPLATSEG_LOG_EVERY_SECS"));
}
