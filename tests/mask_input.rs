//! SAM masks as `splatseg merge` and `splatseg run` read them: a SAM PNG folder gives the same
//! result as the same masks in SAM JSON, and a mask of the wrong size is refused with an error
//! naming the mask's own file.

use splatseg_scene::image_io::write_png_luma8;
use splatseg_scene::sam::{read_sam_json, write_sam_png_folder};
use splatseg_scene::Plane;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn splatseg(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_splatseg")).args(args).output().expect("the splatseg binary runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn utf8(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// A tiny synthetic capture (2 views of 64×48, SAM JSON masks in `sam/`).
fn tiny_scene(dir: &Path) {
    let out = splatseg(&["synth", "--out", utf8(dir), "--views", "2", "--size", "64x48"]);
    assert!(out.status.success(), "synth failed: {}", stderr(&out));
}

/// A copy of the scene's masks where `view_000` is a SAM PNG folder instead of JSON.
fn png_folder_masks(scene: &Path, dir: &Path) -> PathBuf {
    std::fs::create_dir_all(dir).expect("mkdir");
    std::fs::copy(scene.join("sam/view_001.json"), dir.join("view_001.json")).expect("copy json");
    let masks = read_sam_json(&scene.join("sam/view_000.json")).expect("synthetic masks").masks;
    assert!(masks.len() > 3, "the comparison needs several masks");
    write_sam_png_folder(&dir.join("view_000"), &masks).expect("png folder");
    dir.join("view_000")
}

fn merge(scene: &Path, masks: &Path, out: &Path) -> Output {
    splatseg(&["merge", utf8(scene), "--masks", utf8(masks), "--out", utf8(out)])
}

#[test]
fn merge_reads_a_sam_png_folder_as_the_same_masks_in_json() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    let pngs = tmp.path().join("png_masks");
    png_folder_masks(&scene, &pngs);
    let (out_json, out_png) = (tmp.path().join("out_json"), tmp.path().join("out_png"));
    for (masks, out) in [(scene.join("sam"), &out_json), (pngs, &out_png)] {
        let run = merge(&scene, &masks, out);
        assert!(run.status.success(), "merge with {}: {}", masks.display(), stderr(&run));
    }
    for file in ["masks/view_000.png", "masks/view_001.png", "merge/view_000.json"] {
        let a = std::fs::read(out_json.join(file)).expect("json output");
        let b = std::fs::read(out_png.join(file)).expect("png output");
        assert!(a == b, "{file} differs between the JSON and the PNG-folder masks");
    }
}

/// Runs `merge` and `run` on `masks` and checks that both fail naming `bad` (and no JSON file).
fn assert_both_name(scene: &Path, masks: &Path, bad: &Path, out: &Path) {
    let runs = [
        ("merge", merge(scene, masks, &out.join("merge"))),
        ("run", splatseg(&["run", utf8(scene), "--masks", utf8(masks), "--out", utf8(&out.join("run"))])),
    ];
    for (command, out) in runs {
        let err = stderr(&out);
        assert!(!out.status.success(), "{command} accepted a 32×24 mask for a 64×48 image");
        assert!(err.contains(utf8(bad)), "{command} does not name {}: {err}", bad.display());
        assert!(err.contains("[24, 32]") && err.contains("[48, 64]"), "{command}, both sizes: {err}");
        assert!(!err.contains("view_000.json"), "{command} names a JSON file that does not exist: {err}");
        assert!(!err.contains("panicked"), "{command}: {err}");
    }
}

#[test]
fn a_wrong_size_mask_png_is_named_by_merge_and_run() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    let pngs = tmp.path().join("png_masks");
    let folder = png_folder_masks(&scene, &pngs);
    // One mask of the wrong size among right ones: named, not only the folder's metadata.csv.
    let bad = folder.join("1.png");
    write_png_luma8(&bad, &Plane::filled(32, 24, 0)).expect("write a 32×24 mask");
    assert_both_name(&scene, &pngs, &bad, &tmp.path().join("one_bad"));
    // Every mask of the same wrong size: the first PNG is named, not `view_000.json`.
    let count = std::fs::read_dir(&folder).expect("folder").count() - 1;
    for i in 0..count {
        write_png_luma8(&folder.join(format!("{i}.png")), &Plane::filled(32, 24, 0))
            .expect("write a 32×24 mask");
    }
    assert_both_name(&scene, &pngs, &folder.join("0.png"), &tmp.path().join("all_bad"));
}
