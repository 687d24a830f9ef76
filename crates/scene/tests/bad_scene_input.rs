//! Bad scene input: every case is a clear error naming the file and the problem, never a panic.

use crate::colmap_fixture::{write_png, write_scene, write_text_model};
use splatseg_scene::colmap::{read_model_binary, read_model_text, write_model_binary};
use splatseg_scene::load::{load_image_rgb, LoadOptions};
use splatseg_scene::npy::{read_npy, read_npz};
use splatseg_scene::transforms::read_transforms;
use splatseg_scene::{load_scene, SceneError};
use std::path::Path;

/// The fixture model written as binary into `dir`.
fn binary_model(dir: &Path) {
    let text = tempfile::tempdir().expect("tempdir");
    write_text_model(text.path());
    write_model_binary(dir, &read_model_text(text.path()).expect("fixture")).expect("write bin");
}

fn assert_message(err: &SceneError, needles: &[&str]) {
    let msg = err.to_string();
    for needle in needles {
        assert!(msg.contains(needle), "message lacks \"{needle}\": {msg}");
    }
}

#[test]
fn every_truncation_of_every_binary_file_is_an_error() {
    let dir = tempfile::tempdir().expect("tempdir");
    binary_model(dir.path());
    let mut cuts = 0;
    for name in ["cameras.bin", "images.bin", "points3D.bin"] {
        let path = dir.path().join(name);
        let full = std::fs::read(&path).expect("read");
        for len in 0..full.len() {
            std::fs::write(&path, &full[..len]).expect("write cut");
            let err = read_model_binary(dir.path()).expect_err("a truncated file must not load");
            assert_message(&err, &[name]);
            cuts += 1;
        }
        std::fs::write(&path, &full).expect("restore");
        read_model_binary(dir.path()).expect("restored model loads");
    }
    assert!(cuts > 700, "only {cuts} cuts tried");
    let err = {
        let path = dir.path().join("images.bin");
        let mut bytes = std::fs::read(&path).expect("read");
        bytes.extend_from_slice(&[1, 2, 3]);
        std::fs::write(&path, bytes).expect("write");
        read_model_binary(dir.path()).expect_err("trailing bytes")
    };
    assert_message(&err, &["3 unexpected bytes", "images.bin"]);
}

#[test]
fn lying_counts_are_errors_not_huge_allocations() {
    let dir = tempfile::tempdir().expect("tempdir");
    binary_model(dir.path());
    let path = dir.path().join("images.bin");
    let mut bytes = std::fs::read(&path).expect("read");
    // First image: 4 (id) + 56 (pose) + 4 (camera) + "b_side.png\0" → num_points2D at 8 + 75.
    bytes[83..91].copy_from_slice(&(1u64 << 60).to_le_bytes());
    std::fs::write(&path, &bytes).expect("write");
    let err = read_model_binary(dir.path()).expect_err("lying count");
    assert_message(&err, &["num_points2D", "b_side.png", "images.bin"]);

    binary_model(dir.path());
    let path = dir.path().join("points3D.bin");
    let mut bytes = std::fs::read(&path).expect("read");
    bytes[0..8].copy_from_slice(&u64::MAX.to_le_bytes());
    std::fs::write(&path, &bytes).expect("write");
    assert_message(
        &read_model_binary(dir.path()).expect_err("lying count"),
        &["number of points", "points3D.bin"],
    );
}

#[test]
fn unknown_camera_models_are_unsupported_in_text_and_binary() {
    let dir = tempfile::tempdir().expect("tempdir");
    write_text_model(dir.path());
    std::fs::write(dir.path().join("cameras.txt"), "# comment\n1 OPENCV_FISHEYE 64 48 60 60 32 24 0 0 0 0\n")
        .expect("write");
    let err = read_model_text(dir.path()).expect_err("fisheye");
    assert!(matches!(err, SceneError::Unsupported { .. }), "{err}");
    assert_message(&err, &["OPENCV_FISHEYE", "cameras.txt", "supported: SIMPLE_PINHOLE"]);

    let bin = tempfile::tempdir().expect("tempdir");
    binary_model(bin.path());
    let path = bin.path().join("cameras.bin");
    let mut bytes = std::fs::read(&path).expect("read");
    bytes[12..16].copy_from_slice(&6i32.to_le_bytes()); // first camera's model id → FULL_OPENCV
    std::fs::write(&path, &bytes).expect("write");
    let err = read_model_binary(bin.path()).expect_err("full opencv");
    assert!(matches!(err, SceneError::Unsupported { .. }), "{err}");
    assert_message(&err, &["FULL_OPENCV", "model id 6", "cameras.bin"]);
    bytes[12..16].copy_from_slice(&99i32.to_le_bytes());
    std::fs::write(&path, &bytes).expect("write");
    assert_message(&read_model_binary(bin.path()).expect_err("id 99"), &["unknown", "model id 99"]);
}

#[test]
fn malformed_text_models_name_the_line() {
    let dir = tempfile::tempdir().expect("tempdir");
    write_text_model(dir.path());
    std::fs::write(dir.path().join("cameras.txt"), "\n1 PINHOLE 64 48 60 60 32\n").expect("write");
    let err = read_model_text(dir.path()).expect_err("3 params for PINHOLE");
    assert_message(&err, &["line 2", "3 parameters", "needs 4", "cameras.txt"]);

    write_text_model(dir.path());
    std::fs::write(dir.path().join("images.txt"), "1 1 0 0 0 0 0 5 1 a.png\n70 50\n").expect("write");
    assert_message(&read_model_text(dir.path()).expect_err("pair, not triple"), &["line 2", "images.txt"]);
    std::fs::write(dir.path().join("images.txt"), "1 1 0 0 zero 0 0 5 1 a.png\n\n").expect("write");
    assert_message(
        &read_model_text(dir.path()).expect_err("word for a number"),
        &["QZ", "\"zero\"", "line 1"],
    );

    write_text_model(dir.path());
    std::fs::write(dir.path().join("points3D.txt"), "1 0 0 0 255 255 255 0.5 1\n").expect("write");
    assert_message(&read_model_text(dir.path()).expect_err("odd track"), &["TRACK", "points3D.txt"]);
}

#[test]
fn inconsistent_models_are_rejected_when_building_the_scene() {
    let root = tempfile::tempdir().expect("tempdir");
    write_scene(root.path());
    let images_txt = root.path().join("sparse/0/images.txt");
    std::fs::write(&images_txt, "1 1 0 0 0 0 0 5 9 a_front.png\n\n").expect("write");
    let err = load_scene(root.path(), &LoadOptions::default()).expect_err("camera 9 does not exist");
    assert_message(&err, &["camera 9", "a_front.png", "images.txt"]);
    std::fs::write(&images_txt, "1 0 0 0 0 0 0 5 1 a_front.png\n\n").expect("write");
    let err = load_scene(root.path(), &LoadOptions::default()).expect_err("zero quaternion");
    assert_message(&err, &["zero rotation quaternion", "images.txt"]);
    std::fs::write(&images_txt, "1 1 0 0 0 0 0 5 1 nowhere.png\n\n").expect("write");
    let err = load_scene(root.path(), &LoadOptions::default()).expect_err("no image exists");
    assert!(matches!(err, SceneError::Missing { .. }), "{err}");
    assert_message(&err, &["none of the 1 images", "nowhere.png"]);
    write_scene(root.path());
    let cameras_txt = root.path().join("sparse/0/cameras.txt");
    let cameras = std::fs::read_to_string(&cameras_txt).expect("read");
    for (bad, needles) in [
        ("1 PINHOLE 100 80 0 0 50 40", &["camera 1", "fx 0, fy 0", "cameras.txt"][..]),
        ("1 PINHOLE 100 80 100 nan 50 40", &["camera 1", "non-finite", "cameras.txt"][..]),
        ("1 PINHOLE 0 80 100 100 50 40", &["camera 1", "0x80", "cameras.txt"][..]),
    ] {
        std::fs::write(&cameras_txt, cameras.replace("1 PINHOLE 100 80 100 100 50 40", bad)).expect("write");
        let err = load_scene(root.path(), &LoadOptions::default()).expect_err(bad);
        assert_message(&err, needles);
    }
    std::fs::write(&cameras_txt, &cameras).expect("write");
    std::fs::write(&images_txt, "1 1 0 0 0 0 0 5 1 a_front.png\n\n1 1 0 0 0 0 0 5 1 b_side.png\n\n")
        .expect("write");
    let err = load_scene(root.path(), &LoadOptions::default()).expect_err("image id 1 twice");
    assert_message(&err, &["image id 1 appears twice", "a_front.png", "b_side.png", "images.txt"]);
    std::fs::write(&images_txt, "# no images\n").expect("write");
    let err = load_scene(root.path(), &LoadOptions::default()).expect_err("no images");
    assert_message(&err, &["lists no images", "images.txt"]);
    let zero = LoadOptions { resolution: 0, ..LoadOptions::default() };
    write_scene(root.path());
    assert_message(
        &load_scene(root.path(), &zero).expect_err("resolution 0"),
        &["resolution 0", "1, 2, 4 or 8"],
    );
    for factor in [3, 16, 1600] {
        let odd = LoadOptions { resolution: factor, ..LoadOptions::default() };
        let err = load_scene(root.path(), &odd).expect_err("a factor 3DGS does not take");
        assert_message(&err, &[&format!("resolution {factor}"), "1, 2, 4 or 8", "target width"]);
    }
    let two = LoadOptions { resolution: 2, ..LoadOptions::default() };
    load_scene(root.path(), &two).expect("factor 2 loads");
}

#[test]
fn missing_folders_say_what_was_looked_for() {
    let root = tempfile::tempdir().expect("tempdir");
    let err = load_scene(&root.path().join("nope"), &LoadOptions::default()).expect_err("absent path");
    assert!(matches!(err, SceneError::Missing { .. }), "{err}");
    assert_message(&err, &["nope"]);

    let err = load_scene(root.path(), &LoadOptions::default()).expect_err("empty folder");
    assert_message(&err, &["COLMAP", "transforms_train.json", "transforms.json"]);

    write_scene(root.path());
    std::fs::rename(root.path().join("images"), root.path().join("pictures")).expect("rename");
    let err = load_scene(root.path(), &LoadOptions::default()).expect_err("no images/");
    assert!(matches!(err, SceneError::Missing { .. }), "{err}");
    assert_message(&err, &["images folder", "images"]);

    std::fs::rename(root.path().join("pictures"), root.path().join("images")).expect("rename");
    std::fs::remove_dir_all(root.path().join("sparse")).expect("remove sparse");
    let err = load_scene(root.path(), &LoadOptions::default()).expect_err("no sparse/");
    assert!(matches!(err, SceneError::Missing { .. }), "{err}");
    assert_message(&err, &["COLMAP model", "sparse"]);

    let model = root.path().join("model");
    write_text_model(&model);
    std::fs::remove_file(model.join("points3D.txt")).expect("remove");
    assert_message(&read_model_text(&model).expect_err("missing points3D.txt"), &["points3D.txt"]);
}

#[test]
fn images_whose_size_disagrees_with_the_camera_are_rejected() {
    let root = tempfile::tempdir().expect("tempdir");
    write_scene(root.path());
    write_png(&root.path().join("images").join("a_front.png"), 90, 80);
    let scene = load_scene(root.path(), &LoadOptions::default()).expect("scene loads");
    let err = load_image_rgb(&scene, &scene.views[0], &LoadOptions::default()).expect_err("wrong size");
    assert_message(&err, &["90x80", "100x80", "a_front.png"]);
    let half = LoadOptions { resolution: 2, ..LoadOptions::default() };
    let scene = load_scene(root.path(), &half).expect("scene loads");
    let err = load_image_rgb(&scene, &scene.views[0], &half).expect_err("wrong size at resolution 2");
    assert_message(&err, &["90x80", "50x40", "a_front.png"]);

    std::fs::write(root.path().join("images").join("b_side.png"), b"not a png").expect("write");
    let scene = load_scene(root.path(), &LoadOptions::default()).expect("scene loads");
    assert_message(
        &load_image_rgb(&scene, &scene.views[1], &LoadOptions::default()).expect_err("garbage"),
        &["b_side.png"],
    );
}

/// Writes `json` as `transforms.json` with one 8×6 image and returns the load error.
fn transforms_error(json: &str) -> SceneError {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("transforms.json"), json).expect("write");
    write_png(&dir.path().join("images").join("a.png"), 8, 6);
    let err = read_transforms(dir.path(), &LoadOptions::default()).expect_err("must fail");
    assert_message(&err, &["transforms.json"]);
    err
}

#[test]
fn malformed_transforms_files_are_rejected() {
    let m = "[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]";
    assert_message(&transforms_error("{\"frames\": [ {\"file_path\": "), &["EOF"]);
    assert_message(&transforms_error("{\"camera_angle_x\": 0.5}"), &["frames"]);
    assert_message(&transforms_error("{\"camera_angle_x\": 0.5, \"frames\": []}"), &["no frames"]);
    let no_focal = format!(r#"{{"frames": [{{"file_path": "images/a.png", "transform_matrix": {m}}}]}}"#);
    assert_message(&transforms_error(&no_focal), &["no focal length", "frame 0"]);
    let bad_matrix = r#"{"camera_angle_x": 0.5, "frames": [{"file_path": "images/a.png",
        "transform_matrix": [[1,0,0],[0,1,0],[0,0,1]]}]}"#;
    assert_message(&transforms_error(bad_matrix), &["4x4", "frame 0"]);
    let scaled = r#"{"camera_angle_x": 0.5, "frames": [{"file_path": "images/a.png",
        "transform_matrix": [[2,0,0,0],[0,2,0,0],[0,0,2,0],[0,0,0,1]]}]}"#;
    assert_message(&transforms_error(scaled), &["not a rotation"]);
    let fisheye = format!(
        r#"{{"camera_model": "OPENCV_FISHEYE", "fl_x": 5, "frames": [{{"file_path": "images/a.png", "transform_matrix": {m}}}]}}"#
    );
    assert!(matches!(transforms_error(&fisheye), SceneError::Unsupported { .. }));
    let bad_width = format!(
        r#"{{"fl_x": 5, "w": -3, "h": 6, "frames": [{{"file_path": "images/a.png", "transform_matrix": {m}}}]}}"#
    );
    assert_message(&transforms_error(&bad_width), &["w = -3"]);
    let all_missing =
        format!(r#"{{"fl_x": 5, "frames": [{{"file_path": "images/zzz.png", "transform_matrix": {m}}}]}}"#);
    let err = transforms_error(&all_missing);
    assert!(matches!(err, SceneError::Missing { .. }), "{err}");
    assert_message(&err, &["none of the 1 frames", "images/zzz.png"]);
}

/// `bytes` with the first occurrence of `from` replaced by `to` (same length).
fn replace_bytes(bytes: &[u8], from: &[u8], to: &[u8]) -> Vec<u8> {
    let at = bytes.windows(from.len()).position(|w| w == from).expect("pattern present");
    [&bytes[..at], to, &bytes[at + from.len()..]].concat()
}

#[test]
fn bad_npy_files_are_rejected() {
    let dir = tempfile::tempdir().expect("tempdir");
    let good = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/npy/f32_2x3.npy"))
        .expect("fixture");
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("magic.npy", b"PK\x03\x04 not numpy".to_vec(), "magic"),
        ("empty.npy", Vec::new(), "magic"),
        ("truncated_data.npy", good[..good.len() - 5].to_vec(), "truncated"),
        ("truncated_header.npy", good[..40].to_vec(), "header"),
        ("long.npy", [good.as_slice(), &[0u8; 4]].concat(), "longer than its header"),
        ("version.npy", [&good[..6], &[9u8, 0], &good[8..]].concat(), "version 9.0"),
        ("dtype.npy", replace_bytes(&good, b"<f4", b"<c8"), "unsupported dtype '<c8'"),
        ("dict.npy", replace_bytes(&good, b"(2, 3)", b"[2, 3]"), "header"),
    ];
    for (name, bytes, needle) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, &bytes).expect("write");
        let err = read_npy(&path).expect_err(name);
        assert_message(&err, &[needle, name]);
    }
    let fake_npz = dir.path().join("fake.npz");
    std::fs::write(&fake_npz, b"not a zip").expect("write");
    assert_message(&read_npz(&fake_npz).expect_err("not a zip"), &["zip", "fake.npz"]);
}
