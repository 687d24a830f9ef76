//! Determinism per seed, and the written folder reads back with the scene crate's readers.

use splatseg_scene::labels::read_label_png;
use splatseg_scene::npy::read_npy;
use splatseg_scene::ply::read_ply;
use splatseg_scene::sam::read_sam_json;
use splatseg_scene::{load_scene, LoadOptions};
use splatseg_synth::{generate, write, SynthConfig, SynthError};
use std::path::Path;

fn small(seed: u64) -> SynthConfig {
    SynthConfig { seed, views: 4, width: 160, height: 120, ..SynthConfig::default() }
}

fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn same_seed_gives_identical_scenes_and_bytes() {
    let (a, b) = (generate(&small(7)).expect("generate"), generate(&small(7)).expect("generate"));
    assert_eq!(a.views, b.views);
    assert_eq!(a.gaussians, b.gaussians);
    assert_eq!(a.gaussian_ids, b.gaussian_ids);
    assert_eq!(a.scene, b.scene);
    let (da, db) = (tempfile::tempdir().expect("tmp"), tempfile::tempdir().expect("tmp"));
    write(da.path(), &a).expect("write");
    write(db.path(), &b).expect("write");
    for file in [
        "gaussians.ply",
        "images/view_002.png",
        "gt/instance/view_001.png",
        "gt/gaussian_ids.npy",
        "gt/objects.json",
        "sam/view_003.json",
        "features/view_000.npy",
        "depth/view_002.npy",
        "sparse/0/images.txt",
        "sparse/0/points3D.txt",
    ] {
        assert_eq!(read(&da.path().join(file)), read(&db.path().join(file)), "{file} differs");
    }
}

#[test]
fn different_seeds_give_different_scenes() {
    let (a, b) = (generate(&small(1)).expect("generate"), generate(&small(2)).expect("generate"));
    assert_ne!(a.views[0].image, b.views[0].image);
    assert_ne!(a.views[0].sam_masks, b.views[0].sam_masks);
    assert_ne!(a.views[0].features, b.views[0].features);
    assert_ne!(a.gaussians.means, b.gaussians.means);
    assert_ne!(a.scene.views[0].world_from_cam, b.scene.views[0].world_from_cam);
}

#[test]
fn written_folder_loads_back_with_the_scene_readers() {
    let s = generate(&small(3)).expect("generate");
    let dir = tempfile::tempdir().expect("tmp");
    let summary = write(dir.path(), &s).expect("write");
    assert_eq!(summary.views, 4);
    assert_eq!(summary.gaussians, s.gaussians.len());
    assert_eq!(summary.files, 4 * 6 + 6);

    let loaded = load_scene(dir.path(), &LoadOptions::default()).expect("COLMAP text model loads");
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    assert_eq!(loaded.cameras.len(), 1);
    let (cam, ours) = (&loaded.cameras[0], &s.scene.cameras[0]);
    assert_eq!((cam.width, cam.height), (ours.width, ours.height));
    assert!((cam.fx - ours.fx).abs() < 1e-6 && (cam.cx - ours.cx).abs() < 1e-9);
    assert_eq!(loaded.views.len(), 4);
    for (l, o) in loaded.views.iter().zip(&s.scene.views) {
        assert_eq!(l.stem, o.stem);
        assert!(l.image_path.is_file(), "{}", l.image_path.display());
        let p = glam::DVec3::new(0.3, -0.2, 0.5);
        let d = (l.world_from_cam.transform_point(p) - o.world_from_cam.transform_point(p)).length();
        assert!(d < 1e-6, "{}: pose differs by {d}", l.stem);
    }
    assert!(!loaded.points.as_ref().expect("points").is_empty());

    let g = read_ply(&dir.path().join("gaussians.ply")).expect("PLY reads back");
    assert_eq!(g.means, s.gaussians.means);
    assert_eq!(g.sh_dc, s.gaussians.sh_dc);
    assert_eq!(g.log_scales, s.gaussians.log_scales);
    assert_eq!(g.sh_degree, 0);

    let ids = read_npy(&dir.path().join("gt/gaussian_ids.npy")).expect("ids");
    assert_eq!(ids.shape, vec![s.gaussians.len()]);
    assert!(ids.data.iter().zip(&s.gaussian_ids).all(|(&a, &b)| a == b as f32));

    for (v, sv) in s.views.iter().enumerate() {
        let stem = &sv.stem;
        let labels = read_label_png(&dir.path().join(format!("gt/instance/{stem}.png"))).expect("labels");
        assert_eq!(labels, sv.gt_instance, "view {v}");
        let masks = read_sam_json(&dir.path().join(format!("sam/{stem}.json"))).expect("SAM JSON").masks;
        assert_eq!(masks.len(), sv.sam_masks.len());
        for (m, o) in masks.iter().zip(&sv.sam_masks) {
            assert_eq!(m.segmentation, o.segmentation);
            assert_eq!(m.area, o.area);
        }
        let f = read_npy(&dir.path().join(format!("features/{stem}.npy"))).expect("features");
        assert_eq!(f.shape, vec![120usize.div_ceil(14), 160usize.div_ceil(14), 32]);
        let depth = read_npy(&dir.path().join(format!("gt/depth/{stem}.npy"))).expect("depth");
        assert_eq!(depth.to_plane().expect("2D"), sv.gt_depth_z);
        let rel = read_npy(&dir.path().join(format!("depth/{stem}.npy"))).expect("relative depth");
        assert_eq!(rel.shape, vec![120, 160]);
    }
    let objects: serde_json::Value =
        serde_json::from_slice(&read(&dir.path().join("gt/objects.json"))).expect("objects JSON");
    let list = objects["objects"].as_array().expect("objects list");
    assert_eq!(list.len(), s.objects.len());
    assert_eq!(list[3]["name"], "white_box");
    assert_eq!(list[3]["tags"][0], "white_on_white");
}

#[test]
fn bad_configs_are_rejected_with_a_message() {
    for config in [
        SynthConfig { views: 0, ..SynthConfig::default() },
        SynthConfig { width: 0, ..SynthConfig::default() },
        SynthConfig { fov_x_deg: f64::NAN, ..SynthConfig::default() },
        SynthConfig { gaussian_spacing_px: 0.0, ..SynthConfig::default() },
    ] {
        match generate(&config) {
            Err(SynthError::Config(msg)) => assert!(!msg.is_empty()),
            other => panic!("expected a config error, got {:?}", other.map(|s| s.views.len())),
        }
    }
}

#[test]
fn writing_into_a_file_path_fails_cleanly() {
    let s = generate(&small(0)).expect("generate");
    let dir = tempfile::tempdir().expect("tmp");
    let file = dir.path().join("not_a_dir");
    std::fs::write(&file, b"x").expect("write");
    let err = write(&file, &s).expect_err("cannot write into a file");
    assert!(err.to_string().contains("not_a_dir"), "{err}");
}

#[test]
fn rewriting_with_fewer_views_removes_the_stale_view_files_only() {
    let dir = tempfile::tempdir().expect("tmp");
    write(dir.path(), &generate(&small(0)).expect("generate")).expect("write");
    let keep = dir.path().join("sam").join("notes.txt");
    std::fs::write(&keep, b"mine").expect("write");
    let fewer = SynthConfig { views: 2, ..small(0) };
    write(dir.path(), &generate(&fewer).expect("generate")).expect("write");
    for folder in ["images", "gt/instance", "gt/depth", "sam", "features", "depth"] {
        let names: Vec<String> = std::fs::read_dir(dir.path().join(folder))
            .expect("folder")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with("view_"))
            .collect();
        assert_eq!(names.len(), 2, "{folder}: {names:?}");
    }
    assert!(keep.is_file());
    let loaded = load_scene(dir.path(), &LoadOptions::default()).expect("loads");
    assert_eq!(loaded.views.len(), 2);
}
