//! Cue files on disk: `.npy` depth and feature folders, bad inputs rejected with clear errors, and
//! COCO RLE from SAM JSON read the same as the scene crate decodes it.

use crate::descriptors::read_feature_grid;
use crate::{CuesError, DepthKind, DepthSource, MaskInput, NpyDepthSource};
use splatseg_scene::npy::write_npy_f32;
use splatseg_scene::rle::Rle;
use splatseg_scene::Plane;

#[test]
fn npy_depth_is_read_and_resized_to_the_image_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    write_npy_f32(&dir.path().join("v0.npy"), &[2, 3], &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
    let source = NpyDepthSource { dir: dir.path().to_path_buf(), kind: DepthKind::MetricZ, resize: false };
    let same = source.depth("v0", 3, 2).unwrap();
    assert_eq!(same.values.data, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    let refused = source.depth("v0", 6, 4).unwrap_err().to_string();
    for words in ["v0.npy", "shape [2, 3]", "image's [4, 6]", "--resize-depth"] {
        assert!(refused.contains(words), "no `{words}` in: {refused}");
    }
    let transposed = source.depth("v0", 2, 3).unwrap_err().to_string();
    assert!(transposed.contains("(transposed?)") && transposed.contains("[3, 2]"), "{transposed}");
    let source = NpyDepthSource { resize: true, ..source };
    let map = source.depth("v0", 6, 4).unwrap();
    assert_eq!(map.values.size(), (6, 4));
    assert_eq!(map.kind, DepthKind::MetricZ);
    assert!((*map.values.get(0, 0) - 1.0).abs() < 1e-6 && (*map.values.get(5, 3) - 6.0).abs() < 1e-6);
}

#[test]
fn bad_depth_and_feature_files_are_rejected_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let source =
        NpyDepthSource { dir: dir.path().to_path_buf(), kind: DepthKind::InverseRelative, resize: true };
    let missing = source.depth("nope", 4, 4).unwrap_err();
    assert!(matches!(missing, CuesError::Missing { .. }));
    assert!(missing.to_string().contains("nope.npy"), "{missing}");
    write_npy_f32(&dir.path().join("cube.npy"), &[2, 2, 2], &[0.0; 8]).unwrap();
    let shape = source.depth("cube", 4, 4).unwrap_err().to_string();
    assert!(shape.contains("cube.npy") && shape.contains("[2, 2, 2]"), "{shape}");
    write_npy_f32(
        &dir.path().join("inf.npy"),
        &[2, 2],
        &[f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::NAN],
    )
    .unwrap();
    let inf = source.depth("inf", 2, 2).unwrap_err().to_string();
    assert!(inf.contains("inf.npy") && inf.contains("all 4 values are NaN or ±Inf"), "{inf}");
    std::fs::write(dir.path().join("junk.npy"), b"not a numpy file").unwrap();
    let junk = source.depth("junk", 4, 4).unwrap_err().to_string();
    assert!(junk.contains("junk.npy"), "{junk}");
    let flat = read_feature_grid(dir.path(), "cube").unwrap();
    assert_eq!((flat.height, flat.width, flat.channels), (2, 2, 2));
    write_npy_f32(&dir.path().join("plane.npy"), &[2, 2], &[0.0; 4]).unwrap();
    let e = read_feature_grid(dir.path(), "plane").unwrap_err().to_string();
    assert!(e.contains("plane.npy") && e.contains("[h, w, C]"), "{e}");
    write_npy_f32(&dir.path().join("nan.npy"), &[1, 1, 2], &[f32::NAN, 0.0]).unwrap();
    let e = read_feature_grid(dir.path(), "nan").unwrap_err().to_string();
    assert!(e.contains("non-finite"), "{e}");
}

#[test]
fn coco_counts_agree_with_the_scene_crates_rle() {
    let (w, h) = (37, 23);
    let mask =
        Plane::from_vec(w, h, (0..w * h).map(|p| ((p * 7919) % 13) < 5 || (p % w) > 30).collect()).unwrap();
    let rle = Rle::encode(&mask);
    let mut scratch = Vec::new();
    let from_rle = MaskInput::from_coco_counts(&rle.counts, w, h, &mut scratch, (0.9, 0.8)).unwrap();
    assert_eq!(from_rle, MaskInput::from_plane(&mask, 0.9, 0.8));
    assert_eq!(from_rle.area(), mask.data.iter().filter(|&&b| b).count() as u64);
}
