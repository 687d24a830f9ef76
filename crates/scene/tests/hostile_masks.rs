//! Untrusted SAM mask input: absurd or mismatched declared sizes are refused before a mask of
//! that size is allocated, `area` / `bbox` are recomputed from the masks (and counted, as
//! data), and COLMAP keypoints follow the cameras to `--resolution N`.

use crate::colmap_fixture;

use glam::DVec2;
use splatseg_scene::image_io::write_png_luma8;
use splatseg_scene::rle::{Rle, MAX_MASK_PIXELS};
use splatseg_scene::sam::{
    read_sam_json, read_sam_json_for_image, read_sam_png_folder, read_sam_png_folder_for_image,
    read_view_masks, read_view_masks_for_image, write_sam_json, SamMask,
};
use splatseg_scene::{load_scene, LoadOptions, Plane};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

fn assert_has(message: &str, parts: &[&str]) {
    for p in parts {
        assert!(message.contains(p), "expected {p:?} in: {message}");
    }
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::create_dir_all(path.parent().expect("parent")).expect("mkdir");
    std::fs::write(&path, text).expect("write");
    path
}

/// A 6×4 (w×h) mask with a 2×3 block at x = 1..3, y = 1..4.
fn block_mask() -> Plane<bool> {
    let mut m = Plane::filled(6, 4, false);
    for y in 1..4 {
        for x in 1..3 {
            *m.get_mut(x, y) = true;
        }
    }
    m
}

/// An RLE of `[100000, 100000]` whose counts do sum to h·w (10^10): only the size cap stops it.
fn huge_rle() -> Rle {
    Rle { height: 100_000, width: 100_000, counts: vec![4_000_000_000, 4_000_000_000, 2_000_000_000] }
}

#[test]
fn absurd_declared_sizes_are_refused_before_decoding() {
    let huge = huge_rle();
    assert_eq!(huge.counts.iter().map(|&c| c as u64).sum::<u64>(), huge.pixel_count());
    // Without the cap this would allocate two 10 GB masks.
    assert_has(&huge.decode().unwrap_err(), &["[100000, 100000]", "10000000000 pixels", "2^28"]);
    assert_has(&huge.check().unwrap_err(), &["2^28"]);
    let s = huge.to_coco_string();
    assert_has(&Rle::from_coco_string(100_000, 100_000, &s).unwrap_err(), &["[100000, 100000]"]);
    // Just at the cap is fine (and not decoded here); one pixel more is not.
    let side = 1u32 << 14;
    assert_eq!(side as u64 * side as u64, MAX_MASK_PIXELS);
    Rle { height: side, width: side, counts: vec![side * side] }.check().unwrap();
    let over = Rle { height: side, width: side + 1, counts: vec![side * (side + 1)] };
    assert_has(&over.check().unwrap_err(), &["more than the 268435456"]);

    let dir = tempfile::tempdir().unwrap();
    let json = format!(r#"[{{"segmentation": {{"size": [100000, 100000], "counts": "{s}"}}}}]"#);
    let path = write(dir.path(), "huge.json", &json);
    assert_has(
        &read_sam_json(&path).unwrap_err().to_string(),
        &["mask 0", "[100000, 100000]", "2^28", "huge.json"],
    );
    // Uncompressed counts, same story.
    let path = write(
        dir.path(),
        "huge_counts.json",
        r#"[{"segmentation": {"size": [100000, 100000], "counts": [4000000000, 4000000000, 2000000000]}}]"#,
    );
    assert_has(&read_sam_json(&path).unwrap_err().to_string(), &["[100000, 100000]", "huge_counts.json"]);
    // A side beyond 32 bits used to be clamped silently to u32::MAX (and pass with 0 pixels).
    let path =
        write(dir.path(), "wide.json", r#"[{"segmentation": {"size": [1099511627776, 0], "counts": [0]}}]"#);
    assert_has(&read_sam_json(&path).unwrap_err().to_string(), &["[1099511627776, 0]", "wide.json"]);
}

#[test]
fn counts_must_sum_to_exactly_h_times_w() {
    let dir = tempfile::tempdir().unwrap();
    for (name, counts) in [("more.json", "[5, 3, 1, 3, 13]"), ("fewer.json", "[5, 3, 1, 3, 11]")] {
        let json = format!(r#"[{{"segmentation": {{"size": [4, 6], "counts": {counts}}}}}]"#);
        let path = write(dir.path(), name, &json);
        let sum = if name == "more.json" { "sum to 25" } else { "sum to 23" };
        assert_has(&read_sam_json(&path).unwrap_err().to_string(), &["mask 0", sum, "24 pixels", name]);
    }
}

#[test]
fn declared_size_must_match_the_image_when_known() {
    let dir = tempfile::tempdir().unwrap();
    let mask = SamMask::from_rle(Rle::encode(&block_mask()));
    let path = dir.path().join("view.json");
    write_sam_json(&path, std::slice::from_ref(&mask)).unwrap();
    assert_eq!(read_sam_json_for_image(&path, 6, 4).unwrap().masks, vec![mask.clone()]);
    let err = read_sam_json_for_image(&path, 8, 4).unwrap_err().to_string();
    assert_has(&err, &["mask 0", "declared size [4, 6]", "the image, which is [4, 8]", "view.json"]);
    // The per-view loader checks too, and names the file the masks came from.
    let err = read_view_masks_for_image(dir.path(), "view", 6, 5).unwrap_err().to_string();
    assert_has(&err, &["[4, 6]", "[5, 6]", "view.json"]);
    assert_eq!(
        read_view_masks_for_image(dir.path(), "view", 6, 4).unwrap().map(|f| f.masks),
        Some(vec![mask])
    );

    // A huge declared size is reported as a mismatch with the image, without being decoded.
    let s = huge_rle().to_coco_string();
    let json = format!(r#"[{{"segmentation": {{"size": [100000, 100000], "counts": "{s}"}}}}]"#);
    let path = write(dir.path(), "huge.json", &json);
    let err = read_sam_json_for_image(&path, 64, 48).unwrap_err().to_string();
    assert_has(&err, &["declared size [100000, 100000]", "[48, 64]", "huge.json"]);

    // Binary-mask segmentations are checked against the image as well.
    let path =
        write(dir.path(), "rows.json", r#"[{"segmentation": [[true, false, true], [false, true, false]]}]"#);
    read_sam_json_for_image(&path, 3, 2).unwrap();
    assert_has(
        &read_sam_json_for_image(&path, 2, 3).unwrap_err().to_string(),
        &["[2, 3]", "[3, 2]", "rows.json"],
    );

    // PNG folders: the PNG's header is checked, and the error names that PNG.
    let folder = dir.path().join("png_view");
    write_png_folder(&folder, &[block_mask()], &["0,6,1,1,1,2,1.5,2.5,0.9,0.95,0,0,6,4"]);
    read_sam_png_folder_for_image(&folder, 6, 4).unwrap();
    let err = read_sam_png_folder_for_image(&folder, 7, 4).unwrap_err().to_string();
    assert_has(&err, &["[4, 6]", "[4, 7]", "0.png"]);
    let err = read_view_masks_for_image(dir.path(), "png_view", 7, 4).unwrap_err().to_string();
    assert_has(&err, &["0.png"]);
}

#[test]
fn png_mask_with_an_absurd_header_is_not_decoded() {
    let dir = tempfile::tempdir().unwrap();
    // Signature + IHDR of a 20000×20000 greyscale PNG (4·10^8 pixels) and a token IDAT: the
    // header alone must be enough to refuse it.
    let mut bytes = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut bytes, 20_000, 20_000);
        encoder.set_color(png::ColorType::Grayscale);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().unwrap();
        writer.write_chunk(png::chunk::IDAT, &[0x78, 0x9c, 0x03, 0x00]).unwrap();
        drop(writer);
    }
    std::fs::write(dir.path().join("0.png"), &bytes).unwrap();
    write(dir.path(), "metadata.csv", "id,area\n0,1\n");
    let err = read_sam_png_folder(dir.path()).unwrap_err().to_string();
    assert_has(&err, &["[20000, 20000]", "400000000 pixels", "2^28", "0.png"]);
    assert!(read_view_masks(
        dir.path().parent().unwrap(),
        &dir.path().file_name().unwrap().to_string_lossy()
    )
    .unwrap_err()
    .to_string()
    .contains("2^28"));
}

/// Collects everything `tracing` writes while `f` runs (on this thread).
fn capture_logs<T>(f: impl FnOnce() -> T) -> (T, String) {
    #[derive(Clone, Default)]
    struct Sink(Arc<Mutex<Vec<u8>>>);
    impl Write for Sink {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let sink = Sink::default();
    let writer = sink.clone();
    let subscriber = tracing_subscriber::fmt()
        .with_writer(move || writer.clone())
        .with_ansi(false)
        .without_time()
        .finish();
    let out = tracing::subscriber::with_default(subscriber, f);
    let text = String::from_utf8(sink.0.lock().unwrap().clone()).unwrap();
    (out, text)
}

#[test]
fn area_and_bbox_are_recomputed_and_counted_without_a_log_line() {
    let dir = tempfile::tempdir().unwrap();
    let rle = Rle::encode(&block_mask());
    let s = rle.to_coco_string();
    // SAM's own values for the block: area 6, bbox [1, 1, 1, 2] (w = x_max - x_min).
    let entry = |area: &str, bbox: &str| {
        format!(r#"{{"segmentation": {{"size": [4, 6], "counts": "{s}"}}, "area": {area}, "bbox": {bbox}}}"#)
    };
    let json = format!(
        "[{}, {}, {}, {}]",
        entry("6", "[1, 1, 1, 2]"),
        entry("999999", "[1, 1, 1, 2]"),
        entry("6", "[1, 1, 2, 3]"),
        entry("6.5", "[0, 0, 6000, 4000]"),
    );
    let path = write(dir.path(), "lying.json", &json);
    // The count is the reader's answer; the library logs nothing (a caller reading many views
    // says it once: tests/bad_inputs.rs).
    let (file, logs) = capture_logs(|| read_sam_json(&path).unwrap());
    for (i, m) in file.masks.iter().enumerate() {
        assert_eq!((m.area, m.bbox_xywh), (6, [1.0, 1.0, 1.0, 2.0]), "mask {i}");
    }
    assert_eq!(file.recomputed, 3, "three of the four masks lie");
    assert!(logs.is_empty(), "the reader logs nothing: {logs}");

    // A truthful file (and one without the fields) counts none.
    let path = write(dir.path(), "honest.json", &format!("[{}]", entry("6", "[1, 1, 1, 2]")));
    assert_eq!(read_sam_json(&path).unwrap().recomputed, 0);
    let path = write(
        dir.path(),
        "bare.json",
        &format!(r#"[{{"segmentation": {{"size": [4, 6], "counts": "{s}"}}}}]"#),
    );
    let file = read_sam_json(&path).unwrap();
    assert_eq!(file.recomputed, 0);
    assert_eq!((file.masks[0].area, file.masks[0].bbox_xywh), (6, [1.0, 1.0, 1.0, 2.0]));

    // The same for a PNG folder's metadata.csv, and through the per-view reader.
    let folder = dir.path().join("png");
    write_png_folder(
        &folder,
        &[block_mask(), block_mask()],
        &["0,6,1,1,1,2,1.5,2.5,0.9,0.95,0,0,6,4", "1,7,0,0,5,3,1.5,2.5,0.9,0.95,0,0,6,4"],
    );
    let (file, logs) = capture_logs(|| read_sam_png_folder(&folder).unwrap());
    assert_eq!((file.masks[1].area, file.masks[1].bbox_xywh), (6, [1.0, 1.0, 1.0, 2.0]));
    assert_eq!(file.recomputed, 1);
    assert!(logs.is_empty(), "{logs}");
    assert_eq!(read_view_masks(dir.path(), "png").unwrap().map(|f| f.recomputed), Some(1));
    assert_eq!(read_view_masks(dir.path(), "lying").unwrap().map(|f| f.recomputed), Some(3));
}

#[test]
fn segment_anythings_own_output_agrees_with_the_recomputed_values() {
    // Made by tools/fixtures/make_rle_fixtures.py with segment-anything's generator: if our
    // bbox convention differed from SAM's, every mask here would be counted.
    let fixtures = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures"));
    let file = read_sam_json(&fixtures.join("rle_sam_amg_coco_rle.json")).unwrap();
    assert!(file.masks.len() >= 3);
    assert_eq!(file.recomputed, 0);
    assert_eq!(read_sam_png_folder(&fixtures.join("rle_sam_png")).unwrap().recomputed, 0);
}

/// Writes a SAM PNG folder with the given masks (8-bit, 255 inside) and metadata rows.
fn write_png_folder(dir: &Path, masks: &[Plane<bool>], rows: &[&str]) {
    std::fs::create_dir_all(dir).unwrap();
    let mut csv = String::from(
        "id,area,bbox_x0,bbox_y0,bbox_w,bbox_h,point_input_x,point_input_y,predicted_iou,stability_score,crop_box_x0,crop_box_y0,crop_box_w,crop_box_h\n",
    );
    for (i, (m, row)) in masks.iter().zip(rows).enumerate() {
        let pixels = m.map(|&v| if v { 255u8 } else { 0 });
        write_png_luma8(&dir.join(format!("{i}.png")), &pixels).unwrap();
        csv.push_str(row);
        csv.push('\n');
    }
    std::fs::write(dir.join("metadata.csv"), csv).unwrap();
}

#[test]
fn colmap_keypoints_follow_the_cameras_to_the_loaded_resolution() {
    let root = tempfile::tempdir().unwrap();
    colmap_fixture::write_scene(root.path());
    let full = load_scene(root.path(), &LoadOptions::default()).unwrap();
    // Point 1 projects onto its keypoints at full resolution (fixture worked out by hand)...
    let p1 = full.points.as_ref().unwrap()[0].xyz;
    let pixel = |scene: &splatseg_scene::Scene, name: &str| {
        let view = scene.views.iter().find(|v| v.name == name).unwrap();
        let uv = scene.camera(view).project(view.world_from_cam.inverse().transform_point(p1)).unwrap();
        (uv, view.keypoints[0].xy)
    };
    for name in ["a_front.png", "b_side.png"] {
        let (uv, kp) = pixel(&full, name);
        assert!((uv - kp).length() < 1e-9, "{name}: {uv} vs {kp}");
    }
    // ...and still does at --resolution 2, both with images resized on load and with images_2/.
    let options = LoadOptions { resolution: 2, ..LoadOptions::default() };
    for with_folder in [false, true] {
        if with_folder {
            for (name, w, h) in colmap_fixture::IMAGE_SIZES {
                colmap_fixture::write_png(&root.path().join("images_2").join(name), w / 2, h / 2);
            }
        }
        let half = load_scene(root.path(), &options).unwrap();
        assert_eq!(half.views[0].image_path.to_string_lossy().contains("images_2"), with_folder);
        for name in ["a_front.png", "b_side.png"] {
            let (uv, kp) = pixel(&half, name);
            assert!((uv - kp).length() < 1e-9, "{name}: {uv} vs {kp}");
        }
        let (_, kp) = pixel(&half, "a_front.png");
        assert_eq!(kp, DVec2::new(35.0, 25.0));
        // Pixel-corner origin: the keypoint not on a point, (10.5, 20.25), halves exactly.
        let b = half.views.iter().find(|v| v.name == "b_side.png").unwrap();
        assert_eq!(b.keypoints[1].xy, DVec2::new(5.25, 10.125));
        assert_eq!(b.keypoints[1].point3d_id, -1);
        // The OPENCV camera's 64×48 image halves too.
        let d = half.views.iter().find(|v| v.name == "sub/d_opencv.png").unwrap();
        assert_eq!(d.keypoints[0].xy, DVec2::new(0.75, 1.25));
    }
}
