//! Segment Anything mask files: JSON with compressed and uncompressed counts, binary masks,
//! defaults, write → read, the PNG-folder output and the per-view loader.

use splatseg_scene::image_io::write_png_luma8;
use splatseg_scene::rle::Rle;
use splatseg_scene::sam::{
    check_mask_sizes, read_sam_json, read_sam_png_folder, read_view_masks, write_sam_json,
    write_sam_png_folder, SamMask,
};
use splatseg_scene::Plane;
use std::path::Path;

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

#[test]
fn json_with_compressed_and_uncompressed_counts_reads_the_same_mask() {
    let dir = tempfile::tempdir().unwrap();
    let rle = Rle::encode(&block_mask());
    assert_eq!(rle.counts, vec![5, 3, 1, 3, 12]);
    let json = format!(
        r#"[{{"segmentation": {{"size": [4, 6], "counts": "{}"}}, "area": 6, "bbox": [1, 1, 1, 2],
             "predicted_iou": 0.91, "point_coords": [[1.5, 2.5]], "stability_score": 0.97,
             "crop_box": [0, 0, 6, 4]}},
            {{"segmentation": {{"size": [4, 6], "counts": [5, 3, 1, 3, 12]}}, "extra_field": 1}}]"#,
        rle.to_coco_string()
    );
    let path = dir.path().join("view.json");
    std::fs::write(&path, json).unwrap();
    let masks = read_sam_json(&path).unwrap().masks;
    assert_eq!(masks.len(), 2);
    assert_eq!(masks[0].segmentation, rle);
    assert_eq!(masks[1].segmentation, rle);
    assert_eq!(masks[0].segmentation.decode().unwrap(), block_mask());
    let m = &masks[0];
    assert_eq!(
        (m.area, m.bbox_xywh, m.predicted_iou, m.stability_score),
        (6, [1.0, 1.0, 1.0, 2.0], 0.91, 0.97)
    );
    assert_eq!(m.point_coords, vec![[1.5, 2.5]]);
    // Defaults: area and bbox from the mask (bbox in SAM's convention, w = x_max - x_min, the
    // same as the file's own boxes), scores 1, whole-image crop box, no points.
    let d = &masks[1];
    assert_eq!((d.area, d.bbox_xywh), (6, [1.0, 1.0, 1.0, 2.0]));
    assert_eq!((d.predicted_iou, d.stability_score), (1.0, 1.0));
    assert_eq!(d.crop_box_xywh, [0.0, 0.0, 6.0, 4.0]);
    assert!(d.point_coords.is_empty());
}

#[test]
fn binary_mask_segmentations_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let rows: Vec<String> = (0..4)
        .map(|y| {
            let cells: Vec<&str> =
                (0..6).map(|x| if *block_mask().get(x, y) { "true" } else { "false" }).collect();
            format!("[{}]", cells.join(","))
        })
        .collect();
    let path = dir.path().join("b.json");
    std::fs::write(&path, format!(r#"[{{"segmentation": [{}]}}]"#, rows.join(","))).unwrap();
    let masks = read_sam_json(&path).unwrap().masks;
    assert_eq!(masks[0].segmentation.decode().unwrap(), block_mask());
}

#[test]
fn written_json_reads_back_identically_and_uses_string_counts() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = SamMask::from_rle(Rle::encode(&block_mask()));
    a.predicted_iou = 0.875;
    a.stability_score = 0.9375;
    a.point_coords = vec![[2.0, 3.0]];
    a.crop_box_xywh = [0.0, 0.0, 3.0, 4.0];
    let b = SamMask::from_rle(Rle::encode(&Plane::filled(6, 4, true)));
    let path = dir.path().join("out/view.json");
    write_sam_json(&path, &[a.clone(), b.clone()]).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let value: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert!(value[0]["segmentation"]["counts"].is_string());
    assert_eq!(value[0]["segmentation"]["size"], serde_json::json!([4, 6]));
    assert_eq!(value[1]["area"], serde_json::json!(24));
    assert_eq!(read_sam_json(&path).unwrap().masks, vec![a, b]);
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
fn png_folder_is_read_with_its_metadata() {
    let dir = tempfile::tempdir().unwrap();
    let full = Plane::filled(6, 4, true);
    write_png_folder(
        dir.path(),
        &[block_mask(), full.clone()],
        &["0,6,1,1,1,2,1.5,2.5,0.9,0.95,0,0,6,4", "1,24,0,0,5,3,3.0,2.0,0.8,0.85,0,0,6,4"],
    );
    let masks = read_sam_png_folder(dir.path()).unwrap().masks;
    assert_eq!(masks.len(), 2);
    assert_eq!(masks[0].segmentation.decode().unwrap(), block_mask());
    assert_eq!(masks[1].segmentation.decode().unwrap(), full);
    assert_eq!((masks[0].area, masks[0].bbox_xywh), (6, [1.0, 1.0, 1.0, 2.0]));
    assert_eq!(masks[1].point_coords, vec![[3.0, 2.0]]);
    assert_eq!((masks[1].predicted_iou, masks[1].stability_score), (0.8, 0.85));
    assert_eq!(masks[1].crop_box_xywh, [0.0, 0.0, 6.0, 4.0]);
}

#[test]
fn per_view_loader_finds_json_or_png_folder() {
    let dir = tempfile::tempdir().unwrap();
    let a = SamMask::from_rle(Rle::encode(&block_mask()));
    write_sam_json(&dir.path().join("frame_001.json"), std::slice::from_ref(&a)).unwrap();
    write_png_folder(
        &dir.path().join("frame_002"),
        &[block_mask()],
        &["0,6,1,1,1,2,1.5,2.5,0.9,0.95,0,0,6,4"],
    );
    let json = read_view_masks(dir.path(), "frame_001").unwrap().unwrap().masks;
    assert_eq!(json, vec![a]);
    let folder = read_view_masks(dir.path(), "frame_002").unwrap().unwrap().masks;
    assert_eq!(folder[0].segmentation.decode().unwrap(), block_mask());
    assert!(read_view_masks(dir.path(), "frame_003").unwrap().is_none());
}

#[test]
fn mask_sizes_are_checked_against_the_image() {
    let masks = vec![SamMask::from_rle(Rle::encode(&block_mask()))];
    check_mask_sizes(&masks, 6, 4, Path::new("v.json")).unwrap();
    let err = check_mask_sizes(&masks, 8, 4, Path::new("v.json")).unwrap_err().to_string();
    assert!(err.contains("mask 0 is 6×4 but the image is 8×4") && err.contains("v.json"), "{err}");
}

fn fixture(name: &str) -> std::path::PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures")).join(name)
}

/// The binary masks SAM's generator produced for the fixture, `[h]` rows of '0'/'1' each.
fn sam_fixture_masks() -> Vec<Plane<bool>> {
    let text = std::fs::read_to_string(fixture("rle_sam_amg_masks.json")).unwrap();
    let rows: Vec<Vec<String>> = serde_json::from_str(&text).unwrap();
    rows.iter()
        .map(|m| {
            let data = m.iter().flat_map(|r| r.bytes().map(|b| b == b'1')).collect();
            Plane::from_vec(m[0].len(), m.len(), data).unwrap()
        })
        .collect()
}

#[test]
fn segment_anything_generator_output_is_read_in_every_form() {
    // Made by tools/fixtures/make_rle_fixtures.py with segment-anything's own generator.
    let expected = sam_fixture_masks();
    assert!(expected.len() >= 3);
    let coco = read_sam_json(&fixture("rle_sam_amg_coco_rle.json")).unwrap().masks;
    let uncompressed = read_sam_json(&fixture("rle_sam_amg_uncompressed_rle.json")).unwrap().masks;
    let folder = read_sam_png_folder(&fixture("rle_sam_png")).unwrap().masks;
    assert_eq!(coco, uncompressed);
    assert_eq!(folder.len(), coco.len());
    for (i, ((m, f), mask)) in coco.iter().zip(&folder).zip(&expected).enumerate() {
        assert_eq!(&m.segmentation.decode().unwrap(), mask, "mask {i}");
        assert_eq!(m.size(), (64, 48));
        assert_eq!(m.area, m.segmentation.area(), "mask {i}: SAM's area");
        // SAM's bbox is [x0, y0, x1 - x0, y1 - y0] (max minus min index).
        let ours = m.segmentation.bbox_xywh().map(f64::from);
        assert_eq!([ours[0], ours[1], ours[2] - 1.0, ours[3] - 1.0], m.bbox_xywh, "mask {i}: bbox");
        assert_eq!(m.crop_box_xywh, [0.0, 0.0, 64.0, 48.0]);
        assert_eq!(m.point_coords.len(), 1);
        // The PNG folder carries the same masks and metadata.
        assert_eq!(f, m, "mask {i}: PNG folder");
    }
}

#[test]
fn our_json_strings_equal_segment_anythings() {
    let path = fixture("rle_sam_amg_coco_rle.json");
    let masks = read_sam_json(&path).unwrap().masks;
    let dir = tempfile::tempdir().unwrap();
    let ours = dir.path().join("ours.json");
    write_sam_json(&ours, &masks).unwrap();
    let theirs: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let written: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&ours).unwrap()).unwrap();
    for i in 0..masks.len() {
        assert_eq!(written[i]["segmentation"], theirs[i]["segmentation"], "mask {i}");
        for key in ["area", "predicted_iou", "stability_score"] {
            assert_eq!(written[i][key].as_f64(), theirs[i][key].as_f64(), "mask {i}: {key}");
        }
    }
}

#[test]
fn png_folder_write_read_round_trip() {
    let masks = read_sam_json(&fixture("rle_sam_amg_coco_rle.json")).unwrap().masks;
    let mut no_point = SamMask::from_rle(Rle::encode(&Plane::filled(64, 48, true)));
    no_point.predicted_iou = 0.1 + 0.2; // not exactly representable in decimal
    let mut all = masks.clone();
    all.push(no_point);
    let dir = tempfile::tempdir().unwrap();
    write_sam_png_folder(dir.path(), &all).unwrap();
    assert_eq!(read_sam_png_folder(dir.path()).unwrap().masks, all);
    let csv = std::fs::read_to_string(dir.path().join("metadata.csv")).unwrap();
    assert!(csv.starts_with("id,area,bbox_x0,bbox_y0,bbox_w,bbox_h,point_input_x,point_input_y,"));
    assert_eq!(csv.lines().count(), all.len() + 1);
}
