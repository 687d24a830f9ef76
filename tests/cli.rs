//! The binary as users meet it: exit codes and messages on bad input, and the settings file.

use std::path::Path;
use std::process::{Command, Output};

fn splatseg(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_splatseg")).args(args).output().expect("the splatseg binary runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A tiny synthetic capture written by `splatseg synth`.
fn tiny_scene(dir: &Path) {
    let out =
        splatseg(&["synth", "--out", dir.to_str().expect("utf-8 path"), "--views", "2", "--size", "64x48"]);
    assert!(out.status.success(), "synth failed: {}", stderr(&out));
}

#[test]
fn info_on_a_missing_folder_fails_and_names_it() {
    let out = splatseg(&["info", "/definitely/not/here/scene_xyz"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("scene_xyz"), "{}", stderr(&out));
    assert!(!stderr(&out).contains("panicked"), "{}", stderr(&out));
}

#[test]
fn run_with_a_missing_masks_folder_fails_and_names_it() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    let masks = tmp.path().join("no_masks_here");
    let out = splatseg(&[
        "run",
        scene.to_str().expect("utf-8"),
        "--masks",
        masks.to_str().expect("utf-8"),
        "--out",
        tmp.path().join("out").to_str().expect("utf-8"),
    ]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("no_masks_here"), "{}", stderr(&out));
    assert!(!stderr(&out).contains("panicked"), "{}", stderr(&out));
}

#[test]
fn extract_from_an_unlabelled_ply_says_to_run_the_pipeline_first() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    let out_ply = tmp.path().join("object.ply");
    let out = splatseg(&[
        "extract",
        scene.join("gaussians.ply").to_str().expect("utf-8"),
        "--ids",
        "3",
        "--out",
        out_ply.to_str().expect("utf-8"),
    ]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("object_id"), "{}", stderr(&out));
    assert!(!out_ply.exists(), "nothing may be written on error");
}

#[test]
fn a_truncated_ply_is_rejected_with_its_path() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    let ply = scene.join("gaussians.ply");
    let bytes = std::fs::read(&ply).expect("ply");
    let cut = tmp.path().join("cut.ply");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).expect("write");
    let out = splatseg(&["objects", cut.to_str().expect("utf-8")]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("cut.ply"), "{}", stderr(&out));
}

#[test]
fn config_prints_the_papers_defaults_as_toml() {
    let out = splatseg(&["config"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8(out.stdout).expect("utf-8");
    assert!(text.contains("tau_merge = 0.85\n"), "{text}");
    assert!(text.contains("tau_depth = 0.15\n"), "{text}");
    assert!(text.contains("[match]") && text.contains("[lift]") && text.contains("[final_maps]"), "{text}");
    assert!(text.contains("[train]") && text.contains("iterations = 100000\n"), "{text}");
    assert!(text.contains("lambda_semantic = 0.1\n") && text.contains("lambda_reg = 0.01\n"), "{text}");
    assert!(text.contains("identity_maps = true\n") && text.contains("readback = \"rendered\"\n"), "{text}");
}

#[test]
fn render_draws_over_black_as_3dgs_with_the_alpha_to_composite() {
    // a few Gaussians of the scene, so that most pixels see none
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    let all = splatseg_scene::ply::read_ply(&scene.join("gaussians.ply")).expect("the scene's PLY");
    let few: Vec<usize> = (0..all.len()).step_by(97).collect();
    let ply = tmp.path().join("few.ply");
    splatseg_scene::ply::write_ply(&ply, &all.select(&few)).expect("writes the PLY");
    let out = tmp.path().join("rendered");
    let rendered = splatseg(&[
        "render",
        scene.to_str().expect("utf-8"),
        "--gaussians",
        ply.to_str().expect("utf-8"),
        "--out",
        out.to_str().expect("utf-8"),
        "--what",
        "rgb,alpha",
    ]);
    assert!(rendered.status.success(), "{}", stderr(&rendered));
    let rgb = splatseg_scene::image_io::read_rgb8(&out.join("view_000_rgb.png")).expect("rgb");
    let alpha = splatseg_scene::image_io::read_grey8(&out.join("view_000_alpha.png"))
        .expect("alpha")
        .expect("a grey alpha map");
    let (mut empty, mut drawn) = (0, 0);
    for (i, &a) in alpha.data.iter().enumerate() {
        if a == 0 {
            empty += 1;
            assert_eq!(&rgb.data[3 * i..3 * i + 3], &[0, 0, 0], "pixel {i}: nothing drawn, not black");
        } else if rgb.data[3 * i..3 * i + 3].iter().any(|&c| c > 0) {
            drawn += 1;
        }
    }
    assert!(empty > 0 && drawn > 0, "{empty} empty and {drawn} drawn pixels");
}

#[test]
fn train_runs_end_to_end_and_scores_held_out_views() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    let out_dir = tmp.path().join("trained");
    let out =
        splatseg(&["synth", "--out", scene.to_str().expect("utf-8"), "--views", "9", "--size", "64x48"]);
    assert!(out.status.success(), "synth failed: {}", stderr(&out));
    let ply = scene.join("gaussians.ply");
    let config = tmp.path().join("save.toml");
    std::fs::write(&config, "[train]\nsave_iterations = [10, 30, 7000]\n").expect("config");
    let out = splatseg(&[
        "train",
        scene.to_str().expect("utf-8"),
        "--gaussians",
        ply.to_str().expect("utf-8"),
        "--out",
        out_dir.to_str().expect("utf-8"),
        "--iterations",
        "30",
        "--config",
        config.to_str().expect("utf-8"),
    ]);
    assert!(out.status.success(), "train failed: {}", stderr(&out));
    // 3DGS's checkpoint layout, for iterations before the last only
    assert!(out_dir.join("point_cloud/iteration_10/point_cloud.ply").is_file());
    assert!(
        !out_dir.join("point_cloud/iteration_30").exists()
            && !out_dir.join("point_cloud/iteration_7000").exists()
    );
    let quality: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("quality.json")).expect("quality.json"))
            .expect("valid JSON");
    // views 0 and 8 are held out (every 8th), the other 7 train
    assert_eq!(quality["test_after"]["views"], 2);
    assert_eq!(quality["train_after"]["views"], 7);
    assert!(quality["test_after"]["psnr"].as_f64().expect("psnr") > 10.0);
    assert!(out_dir.join("gaussians.ply").is_file() && out_dir.join("renders/view_000.png").is_file());
    // no object ids in the synthetic PLY: no joint stage, no features
    assert!(quality["labelled"].is_null() && !out_dir.join("object_features.npy").exists());

    // without --gaussians: one Gaussian per sparse point of the COLMAP model, as 3DGS starts
    let scratch = tmp.path().join("from_points");
    let out = splatseg(&[
        "train",
        scene.to_str().expect("utf-8"),
        "--out",
        scratch.to_str().expect("utf-8"),
        "--iterations",
        "5",
    ]);
    assert!(out.status.success(), "train from points failed: {}", stderr(&out));
    let quality: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(scratch.join("quality.json")).expect("quality.json"))
            .expect("valid JSON");
    let points = std::fs::read_to_string(scene.join("sparse/0/points3D.txt"))
        .map(|t| t.lines().filter(|l| !l.starts_with('#') && !l.trim().is_empty()).count())
        .expect("synth writes a text COLMAP model");
    let start = quality["gaussians"][0].as_u64().expect("count") as usize;
    assert!(points > 0 && start == points, "{start} Gaussians from {points} points");
}

#[test]
fn train_with_a_missing_ply_or_a_bad_setting_fails_clearly() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    let missing = tmp.path().join("nope_gaussians.ply");
    let out_dir = tmp.path().join("out");
    let args = |ply: &Path| {
        vec![
            "train".to_string(),
            scene.display().to_string(),
            "--gaussians".into(),
            ply.display().to_string(),
            "--out".into(),
            out_dir.display().to_string(),
        ]
    };
    let out = Command::new(env!("CARGO_BIN_EXE_splatseg")).args(args(&missing)).output().expect("runs");
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("nope_gaussians.ply") && !stderr(&out).contains("panicked"),
        "{}",
        stderr(&out)
    );
    let config = tmp.path().join("bad.toml");
    std::fs::write(&config, "[train]\nlambda_dssim = 3.0\n").expect("write");
    let mut with_config = args(&scene.join("gaussians.ply"));
    with_config.extend(["--config".to_string(), config.display().to_string()]);
    let out = Command::new(env!("CARGO_BIN_EXE_splatseg")).args(with_config).output().expect("runs");
    assert!(!out.status.success());
    assert!(stderr(&out).contains("lambda_dssim"), "{}", stderr(&out));
    assert!(!out_dir.join("gaussians.ply").exists(), "nothing written on a bad setting");
}

#[test]
fn train_scales_images_wider_than_1600_px_unless_told() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    let out =
        splatseg(&["synth", "--out", scene.to_str().expect("utf-8"), "--views", "2", "--size", "1700x64"]);
    assert!(out.status.success(), "synth failed: {}", stderr(&out));
    let render_width = |extra: &[&str]| {
        let out_dir = tmp.path().join(format!("out{}", extra.len()));
        let mut args =
            vec!["train", scene.to_str().expect("utf-8"), "--out", out_dir.to_str().expect("utf-8")];
        args.extend(["--iterations", "1"]);
        args.extend(extra);
        let out = splatseg(&args);
        assert!(out.status.success(), "train failed: {}", stderr(&out));
        splatseg_scene::image_io::image_size(&out_dir.join("renders/view_000.png"))
            .expect("held-out render")
            .0
    };
    assert_eq!(render_width(&[]), 850, "1700 px → 1/2");
    assert_eq!(render_width(&["--resolution", "1"]), 1700);
}

#[test]
fn negative_numbers_get_the_options_own_message() {
    for (args, expected) in [
        (&["merge", "s", "--masks", "m", "--out", "o", "--shard", "-1/2"][..], "expected K/N with 0 ≤ K < N"),
        (&["train", "s", "--out", "o", "--iterations", "-5"][..], "invalid value '-5' for '--iterations"),
        (&["synth", "--out", "o", "--views", "-3"][..], "invalid value '-3' for '--views"),
    ] {
        let out = splatseg(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: a usage error");
        assert!(stderr(&out).contains(expected), "{args:?}: {}", stderr(&out));
        assert!(!stderr(&out).contains("unexpected argument"), "{args:?}: {}", stderr(&out));
    }
}

#[test]
fn a_ply_without_gaussians_is_refused_by_render_train_and_run() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    let mut header = String::from("ply\nformat binary_little_endian 1.0\nelement vertex 0\n");
    for name in ["x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2"] {
        header += &format!("property float {name}\n");
    }
    header += "property float rot_0\nproperty float rot_1\nproperty float rot_2\nproperty float rot_3\nend_header\n";
    let empty = tmp.path().join("empty.ply");
    std::fs::write(&empty, header).expect("write");
    let (s, e) = (scene.to_str().expect("utf-8"), empty.to_str().expect("utf-8"));
    let out = |name: &str| tmp.path().join(name).to_str().expect("utf-8").to_string();
    let masks = scene.join("sam");
    for args in [
        vec!["render", s, "--gaussians", e, "--out", &out("render")],
        vec!["train", s, "--gaussians", e, "--out", &out("train"), "--iterations", "10"],
        vec!["run", s, "--gaussians", e, "--masks", masks.to_str().expect("utf-8"), "--out", &out("run")],
    ] {
        let result = splatseg(&args);
        assert_eq!(result.status.code(), Some(1), "{args:?}: {}", stderr(&result));
        assert!(
            stderr(&result).contains("holds no Gaussians") && stderr(&result).contains("empty.ply"),
            "{args:?}: {}",
            stderr(&result)
        );
    }
}

#[test]
fn train_says_when_a_labelled_ply_gets_no_joint_stage() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    let path = |p: &Path| p.to_str().expect("utf-8").to_string();
    let run = tmp.path().join("run");
    let masks = scene.join("sam");
    let out = splatseg(&["run", &path(&scene), "--masks", &path(&masks), "--out", &path(&run)]);
    assert!(out.status.success(), "run: {}", stderr(&out));
    let labelled = run.join("gaussians.ply");
    let train = tmp.path().join("train");
    let out = splatseg(&[
        "train",
        &path(&scene),
        "--gaussians",
        &path(&labelled),
        "--out",
        &path(&train),
        "--iterations",
        "20",
    ]);
    assert!(out.status.success(), "train: {}", stderr(&out));
    assert!(
        stderr(&out).contains("no joint optimisation runs and no label maps are written"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn objects_counts_views_in_the_label_maps_beside_the_ply() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    let out = tmp.path().join("out");
    let run = splatseg(&[
        "run",
        scene.to_str().expect("utf-8"),
        "--masks",
        scene.join("sam").to_str().expect("utf-8"),
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    let table = |ply: &Path| -> serde_json::Value {
        let listed = splatseg(&["objects", ply.to_str().expect("utf-8"), "--json"]);
        assert!(listed.status.success(), "{}", stderr(&listed));
        serde_json::from_slice(&listed.stdout).expect("json")
    };
    // run's folder: every object's views counted in OUT/masks/, as the label maps say
    let beside = table(&out.join("gaussians.ply"));
    let objects = beside["objects"].as_array().expect("objects");
    assert!(!objects.is_empty());
    let maps: Vec<Vec<u32>> = ["view_000", "view_001"]
        .iter()
        .map(|v| {
            splatseg_scene::labels::read_label_png(&out.join(format!("masks/{v}.png"))).expect("map").data
        })
        .collect();
    for o in objects {
        let id = o["id"].as_i64().expect("id");
        let seen = maps.iter().filter(|m| id > 0 && m.contains(&(id as u32))).count();
        assert_eq!(o["views_seen"], seen, "{o}");
    }
    // the same PLY elsewhere, without masks/ beside it: no views column
    let alone = tmp.path().join("alone.ply");
    std::fs::copy(out.join("gaussians.ply"), &alone).expect("copy");
    let elsewhere = table(&alone);
    assert!(elsewhere["objects"].as_array().expect("objects").iter().all(|o| o["views_seen"].is_null()));
}
