//! Scoring folders of label-map PNGs and a labelled PLY, with the bad inputs users hit.

use splatseg_eval::{
    evaluate_folders, evaluate_prediction_sets, label_accuracy_3d_files, EvalConfig, EvalError, IdScope,
    PredictionSet,
};
use splatseg_scene::labels::write_label_png;
use splatseg_scene::Plane;
use std::path::Path;

fn write(dir: &Path, stem: &str, w: usize, h: usize, data: &[u32]) {
    write_label_png(&dir.join(format!("{stem}.png")), &Plane::from_vec(w, h, data.to_vec()).unwrap())
        .unwrap();
}

struct Dirs {
    _root: tempfile::TempDir,
    gt: std::path::PathBuf,
    pred: std::path::PathBuf,
}

fn dirs() -> Dirs {
    let root = tempfile::tempdir().unwrap();
    let (gt, pred) = (root.path().join("gt"), root.path().join("pred"));
    std::fs::create_dir_all(&gt).unwrap();
    std::fs::create_dir_all(&pred).unwrap();
    Dirs { _root: root, gt, pred }
}

#[test]
fn scores_matching_stems_and_ignores_other_files() {
    let d = dirs();
    write(&d.gt, "a", 4, 1, &[1, 1, 2, 2]);
    write(&d.gt, "b", 4, 1, &[2, 2, 2, 0]);
    write(&d.pred, "a", 4, 1, &[7, 7, 9, 9]);
    write(&d.pred, "b", 4, 1, &[9, 9, 9, 0]);
    std::fs::write(d.gt.join("gaussian_ids.npy"), b"not a png").unwrap();
    std::fs::write(d.pred.join("notes.txt"), b"hello").unwrap();
    let m = evaluate_folders(&d.gt, &d.pred, &EvalConfig::default()).unwrap();
    assert_eq!(m.views, 2);
    assert_eq!(m.miou, 1.0);
    assert_eq!(m.per_view.iter().map(|v| v.name.as_str()).collect::<Vec<_>>(), ["a", "b"]);
    assert!(m.warnings.is_empty());
}

#[test]
fn missing_prediction_is_scored_as_empty_with_a_warning() {
    let d = dirs();
    write(&d.gt, "a", 2, 1, &[1, 1]);
    write(&d.gt, "b", 2, 1, &[1, 1]);
    write(&d.pred, "a", 2, 1, &[5, 5]);
    let m = evaluate_folders(&d.gt, &d.pred, &EvalConfig::default()).unwrap();
    // Object 1 has 4 pixels over both views, prediction 5 covers 2 of them.
    assert_eq!(m.miou, 0.5);
    assert_eq!(m.warnings.len(), 1);
    assert!(m.warnings[0].contains(": b"), "{}", m.warnings[0]);
}

#[test]
fn prediction_for_unknown_view_is_an_error_naming_it() {
    let d = dirs();
    write(&d.gt, "a", 2, 1, &[1, 1]);
    write(&d.pred, "a", 2, 1, &[5, 5]);
    write(&d.pred, "zebra", 2, 1, &[5, 5]);
    let err = evaluate_folders(&d.gt, &d.pred, &EvalConfig::default()).unwrap_err();
    assert!(matches!(err, EvalError::UnknownView { .. }));
    let msg = err.to_string();
    assert!(
        msg.contains("zebra.png") && msg.ends_with(&d.pred.join("zebra.png").display().to_string()),
        "{msg}"
    );
}

#[test]
fn wrong_size_prediction_names_the_file() {
    let d = dirs();
    write(&d.gt, "a", 4, 2, &[1; 8]);
    write(&d.pred, "a", 2, 4, &[1; 8]);
    let err = evaluate_folders(&d.gt, &d.pred, &EvalConfig::default()).unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains("2×4") && msg.contains("4×2") && msg.ends_with("a.png"), "{msg}");
}

#[test]
fn empty_folders_are_errors() {
    let d = dirs();
    assert!(matches!(
        evaluate_folders(&d.gt, &d.pred, &EvalConfig::default()),
        Err(EvalError::NoLabelMaps { .. })
    ));
    write(&d.gt, "a", 2, 1, &[0, 0]);
    write(&d.pred, "a", 2, 1, &[5, 5]);
    let err = evaluate_folders(&d.gt, &d.pred, &EvalConfig::default()).unwrap_err();
    assert!(matches!(err, EvalError::NoGroundTruth { path: Some(_) }), "{err}");
    let err = evaluate_folders(&d.gt.join("nope"), &d.pred, &EvalConfig::default()).unwrap_err();
    assert!(err.to_string().ends_with("nope"), "{err}");
}

#[test]
fn several_prediction_sets_in_one_pass() {
    let d = dirs();
    let merged = d.pred.parent().unwrap().join("merged");
    std::fs::create_dir_all(&merged).unwrap();
    write(&d.gt, "a", 4, 1, &[1, 1, 2, 2]);
    write(&d.pred, "a", 4, 1, &[3, 4, 5, 6]); // raw: over-segmented
    write(&merged, "a", 4, 1, &[3, 3, 5, 5]);
    write(&d.gt, "b", 4, 1, &[1, 1, 2, 2]);
    write(&d.pred, "b", 4, 1, &[3, 4, 5, 6]);
    write(&merged, "b", 4, 1, &[3, 3, 5, 5]);
    let local = |dir| PredictionSet { dir, id_scope: IdScope::PerView };
    let sets =
        evaluate_prediction_sets(&d.gt, &[local(&d.pred), local(&merged)], &EvalConfig::default()).unwrap();
    // Raw, view-local: 8 masks of 2 px; each instance (4 px over both views) best matches one
    // (view, id) mask of 1 px: IoU 1/4. Consistency 1/4 as well.
    assert_eq!((sets[0].miou, sets[0].pred_masks, sets[0].consistency), (0.25, 8, 0.25));
    // Merged, view-local: 4 masks; each instance matches one view's mask: 2/4.
    assert_eq!((sets[1].miou, sets[1].pred_masks), (0.5, 4));
    assert_eq!(sets[1].per_view_miou, Some(1.0));
    // The same merged maps read as global ids: 3 and 5 are the same objects in both views.
    let global = PredictionSet { dir: &merged, id_scope: IdScope::Global };
    let sets = evaluate_prediction_sets(&d.gt, &[global], &EvalConfig::default()).unwrap();
    assert_eq!((sets[0].miou, sets[0].pred_masks, sets[0].consistency), (1.0, 2, 1.0));
}

#[test]
fn label_accuracy_from_npy_and_ply() {
    use splatseg_scene::Gaussians;
    let root = tempfile::tempdir().unwrap();
    let npy = root.path().join("gaussian_ids.npy");
    let ply = root.path().join("gaussians.ply");
    splatseg_scene::npy::write_npy_f32(&npy, &[4], &[1.0, 1.0, 2.0, 0.0]).unwrap();
    let n = 4;
    let g = Gaussians {
        means: vec![[0.0; 3]; n],
        sh_dc: vec![[0.0; 3]; n],
        raw_opacities: vec![0.0; n],
        log_scales: vec![[0.0; 3]; n],
        rotations: vec![[1.0, 0.0, 0.0, 0.0]; n],
        object_ids: Some(vec![8, 8, -1, 3]),
        ..Default::default()
    };
    splatseg_scene::ply::write_ply(&ply, &g).unwrap();
    let acc = label_accuracy_3d_files(&npy, &ply).unwrap();
    assert!((acc.accuracy - 2.0 / 3.0).abs() < 1e-12, "{acc:?}");

    // Fewer Gaussians than ground-truth ids.
    splatseg_scene::ply::write_ply(&ply, &g.select(&[0, 1, 2])).unwrap();
    let msg = label_accuracy_3d_files(&npy, &ply).unwrap_err().to_string();
    assert!(
        msg.contains("3 predicted Gaussian ids but 4 ground-truth ids") && msg.ends_with("gaussians.ply"),
        "{msg}"
    );
    // No object ids at all.
    splatseg_scene::ply::write_ply(&ply, &Gaussians { object_ids: None, ..g.clone() }).unwrap();
    let msg = label_accuracy_3d_files(&npy, &ply).unwrap_err().to_string();
    assert!(msg.contains("object_id") && msg.contains("splatseg run"), "{msg}");
    // Non-integer ground truth.
    splatseg_scene::npy::write_npy_f32(&npy, &[4], &[1.0, 1.5, 2.0, 0.0]).unwrap();
    let msg = label_accuracy_3d_files(&npy, &ply).unwrap_err().to_string();
    assert!(msg.contains("entry 1 is 1.5") && msg.ends_with("gaussian_ids.npy"), "{msg}");
}
