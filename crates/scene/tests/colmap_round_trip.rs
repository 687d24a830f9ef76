//! COLMAP models: parsing (text and binary), byte-exact text ↔ binary round trips, the
//! cam_from_world → world_from_cam inversion, image lookup and resolution handling.

use crate::colmap_fixture::{write_png, write_scene, write_text_model};
use glam::{DVec2, DVec3};
use splatseg_scene::colmap::{
    read_colmap, read_model, read_model_binary, read_model_text, write_colmap_binary, write_colmap_text,
    write_model_binary, write_model_text, ColmapCamera,
};
use splatseg_scene::load::{load_image_rgb, LoadOptions, SceneFormat};
use splatseg_scene::{load_scene, Camera, CameraModel, Scene};
use std::path::Path;

fn read_bytes(dir: &Path, name: &str) -> Vec<u8> {
    std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
fn text_model_is_parsed_with_comments_blank_lines_and_empty_points_lines() {
    let dir = tempfile::tempdir().expect("tempdir");
    write_text_model(dir.path());
    let model = read_model_text(dir.path()).expect("fixture parses");
    assert_eq!(model.cameras.len(), 5);
    let opencv = &model.cameras[4];
    assert_eq!((opencv.id, opencv.model, opencv.width, opencv.height), (5, CameraModel::OpenCv, 64, 48));
    assert_eq!(opencv.params, vec![61.0, 59.0, 31.5, 24.5, 0.01, -0.002, 0.0005, -0.0003]);
    let names: Vec<&str> = model.images.iter().map(|i| i.name.as_str()).collect();
    assert_eq!(names, ["b_side.png", "a_front.png", "c_empty.png", "sub/d_opencv.png"], "file order kept");
    assert_eq!(model.images[0].keypoints.len(), 2);
    assert_eq!(model.images[0].keypoints[1].xy, DVec2::new(10.5, 20.25));
    assert_eq!(model.images[0].keypoints[1].point3d_id, -1);
    assert!(model.images[2].keypoints.is_empty(), "empty POINTS2D line");
    assert_eq!(model.images[3].qvec, [0.9, 0.1, 0.2, 0.3], "raw quaternion kept");
    assert_eq!(model.points.len(), 2);
    assert_eq!(model.points[0].track, vec![(1, 0), (3, 0)]);
    assert_eq!(model.points[1].rgb, [0, 0, 255]);
}

#[test]
fn text_to_binary_to_text_is_byte_exact() {
    let fixture = tempfile::tempdir().expect("tempdir");
    write_text_model(fixture.path());
    let original = read_model_text(fixture.path()).expect("fixture parses");

    let text1 = tempfile::tempdir().expect("tempdir");
    write_model_text(text1.path(), &original).expect("write text");
    let bin = tempfile::tempdir().expect("tempdir");
    write_model_binary(bin.path(), &read_model_text(text1.path()).expect("re-read text")).expect("write bin");
    let from_bin = read_model_binary(bin.path()).expect("read bin");
    assert_eq!(from_bin, original);
    let text2 = tempfile::tempdir().expect("tempdir");
    write_model_text(text2.path(), &from_bin).expect("write text again");
    for name in ["cameras.txt", "images.txt", "points3D.txt"] {
        assert_eq!(read_bytes(text1.path(), name), read_bytes(text2.path(), name), "{name}");
    }
    let bin2 = tempfile::tempdir().expect("tempdir");
    write_model_binary(bin2.path(), &read_model_text(text2.path()).expect("read text2")).expect("write bin2");
    for name in ["cameras.bin", "images.bin", "points3D.bin"] {
        assert_eq!(read_bytes(bin.path(), name), read_bytes(bin2.path(), name), "{name}");
    }
}

#[test]
fn binary_layout_matches_colmaps_documented_format() {
    let fixture = tempfile::tempdir().expect("tempdir");
    write_text_model(fixture.path());
    let model = read_model_text(fixture.path()).expect("fixture parses");
    let bin = tempfile::tempdir().expect("tempdir");
    write_model_binary(bin.path(), &model).expect("write bin");

    // cameras.bin: u64 count, then i32 id, i32 model id, u64 width, u64 height, f64 params[].
    let cams = read_bytes(bin.path(), "cameras.bin");
    let param_counts = [4, 3, 4, 5, 8];
    assert_eq!(cams.len(), 8 + param_counts.iter().map(|p| 24 + 8 * p).sum::<usize>());
    assert_eq!(u64::from_le_bytes(cams[0..8].try_into().unwrap()), 5);
    assert_eq!(i32::from_le_bytes(cams[8..12].try_into().unwrap()), 1);
    assert_eq!(i32::from_le_bytes(cams[12..16].try_into().unwrap()), 1, "PINHOLE is model id 1");
    assert_eq!(u64::from_le_bytes(cams[16..24].try_into().unwrap()), 100);
    assert_eq!(u64::from_le_bytes(cams[24..32].try_into().unwrap()), 80);
    assert_eq!(f64::from_le_bytes(cams[32..40].try_into().unwrap()), 100.0);

    // images.bin: first image is id 3, qvec, tvec, camera 1, "b_side.png\0", 2 points.
    let ims = read_bytes(bin.path(), "images.bin");
    assert_eq!(u64::from_le_bytes(ims[0..8].try_into().unwrap()), 4);
    assert_eq!(i32::from_le_bytes(ims[8..12].try_into().unwrap()), 3);
    assert_eq!(f64::from_le_bytes(ims[12..20].try_into().unwrap()), std::f64::consts::FRAC_1_SQRT_2);
    assert_eq!(f64::from_le_bytes(ims[60..68].try_into().unwrap()), 6.0, "TZ");
    assert_eq!(i32::from_le_bytes(ims[68..72].try_into().unwrap()), 1, "camera id");
    assert_eq!(&ims[72..83], b"b_side.png\0");
    assert_eq!(u64::from_le_bytes(ims[83..91].try_into().unwrap()), 2);
    assert_eq!(f64::from_le_bytes(ims[91..99].try_into().unwrap()), 50.0);
    assert_eq!(i64::from_le_bytes(ims[107..115].try_into().unwrap()), 1);

    // points3D.bin: u64 id, f64 xyz, u8 rgb, f64 error, u64 track length, (i32, i32) pairs.
    let pts = read_bytes(bin.path(), "points3D.bin");
    assert_eq!(pts.len(), 8 + (43 + 8 + 2 * 8) + (43 + 8 + 8));
    assert_eq!(u64::from_le_bytes(pts[8..16].try_into().unwrap()), 1);
    assert_eq!(&pts[40..43], &[200, 100, 50]);
    assert_eq!(f64::from_le_bytes(pts[43..51].try_into().unwrap()), 0.25);
    assert_eq!(u64::from_le_bytes(pts[51..59].try_into().unwrap()), 2);
    assert_eq!(i32::from_le_bytes(pts[59..63].try_into().unwrap()), 1);
}

#[test]
fn binary_is_preferred_when_both_exist() {
    let dir = tempfile::tempdir().expect("tempdir");
    write_text_model(dir.path());
    let mut model = read_model_text(dir.path()).expect("parses");
    model.cameras[0].width = 200;
    write_model_binary(dir.path(), &model).expect("write bin");
    let (read, format) = read_model(dir.path()).expect("reads");
    assert_eq!(format, SceneFormat::ColmapBinary);
    assert_eq!(read.cameras[0].width, 200);
}

/// Pixel of world point `p` in the view named `name`.
fn project(scene: &Scene, name: &str, p: DVec3) -> DVec2 {
    let view = scene.views.iter().find(|v| v.name == name).expect("view");
    scene.camera(view).project(view.world_from_cam.inverse().transform_point(p)).expect("in front")
}

#[test]
fn scene_inverts_cam_from_world_and_sorts_views_by_name() {
    let root = tempfile::tempdir().expect("tempdir");
    write_scene(root.path());
    let scene = load_scene(root.path(), &LoadOptions::default()).expect("scene loads");
    assert_eq!(scene.format, SceneFormat::ColmapText);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let names: Vec<&str> = scene.views.iter().map(|v| v.name.as_str()).collect();
    assert_eq!(names, ["a_front.png", "b_side.png", "c_empty.png", "sub/d_opencv.png"]);
    assert_eq!(scene.views[3].stem, "d_opencv");
    assert_eq!(scene.views[0].world_from_cam.centre(), DVec3::new(0.0, 0.0, -5.0));

    // Hand-computed projections of point 1 (see colmap_fixture), matching the keypoints.
    let p1 = scene.points.as_ref().expect("points")[0].xyz;
    assert!((project(&scene, "a_front.png", p1) - DVec2::new(70.0, 50.0)).length() < 1e-9);
    assert!((project(&scene, "b_side.png", p1) - DVec2::new(50.0, 50.0)).length() < 1e-9);

    let cam = |id: u32| scene.cameras.iter().find(|c| c.id == id).expect("camera");
    assert_eq!((cam(2).fx, cam(2).fy, cam(2).cx, cam(2).cy), (60.0, 60.0, 32.0, 24.0));
    assert_eq!((cam(3).distortion.k1, cam(3).distortion.k2), (0.01, 0.0));
    assert_eq!((cam(4).distortion.k1, cam(4).distortion.k2), (0.01, -0.002));
    assert_eq!(
        (cam(5).fx, cam(5).fy, cam(5).distortion.p1, cam(5).distortion.p2),
        (61.0, 59.0, 0.0005, -0.0003)
    );
    let rgb = load_image_rgb(&scene, &scene.views[3], &LoadOptions::default()).expect("image loads");
    assert_eq!(rgb.size(), (64, 48));
}

fn assert_scenes_match(a: &Scene, b: &Scene) {
    assert_eq!(a.cameras, b.cameras);
    assert_eq!(a.points, b.points);
    assert_eq!(a.views.len(), b.views.len());
    for (va, vb) in a.views.iter().zip(&b.views) {
        assert_eq!(
            (&va.name, va.image_id, va.camera_index, &va.keypoints),
            (&vb.name, vb.image_id, vb.camera_index, &vb.keypoints)
        );
        let (pa, pb) = (va.world_from_cam, vb.world_from_cam);
        assert!((pa.rotation - pb.rotation).to_cols_array().iter().all(|d| d.abs() < 1e-12), "{}", va.name);
        assert!((pa.translation - pb.translation).length() < 1e-12, "{}", va.name);
    }
}

#[test]
fn scenes_round_trip_through_binary_and_text_writers() {
    let root = tempfile::tempdir().expect("tempdir");
    write_scene(root.path());
    let images = root.path().join("images");
    let scene = load_scene(root.path(), &LoadOptions::default()).expect("scene loads");

    let bin_dir = root.path().join("sparse_bin");
    write_colmap_binary(&bin_dir, &scene).expect("write binary");
    let from_bin = read_colmap(&bin_dir, &images, &LoadOptions::default()).expect("read binary");
    assert_eq!(from_bin.format, SceneFormat::ColmapBinary);
    assert_scenes_match(&scene, &from_bin);

    let text_dir = root.path().join("sparse_text");
    write_colmap_text(&text_dir, &from_bin).expect("write text");
    let from_text = read_colmap(&text_dir, &images, &LoadOptions::default()).expect("read text");
    assert_scenes_match(&scene, &from_text);
}

#[test]
fn cameras_a_simple_model_cannot_hold_are_written_with_a_larger_model() {
    let mut cam = Camera::pinhole(7, 64, 48, 60.0, 60.0, 32.0, 24.0);
    cam.model = CameraModel::SimplePinhole;
    assert_eq!(ColmapCamera::from_camera(&cam).model, CameraModel::SimplePinhole);
    cam.fy = 61.0;
    let written = ColmapCamera::from_camera(&cam);
    assert_eq!((written.model, written.params.clone()), (CameraModel::Pinhole, vec![60.0, 61.0, 32.0, 24.0]));
    assert_eq!(written.to_camera().fy, 61.0);
    cam.model = CameraModel::SimpleRadial;
    cam.distortion.k1 = 0.1;
    assert_eq!(ColmapCamera::from_camera(&cam).model, CameraModel::OpenCv);
}

#[test]
fn missing_image_files_are_skipped_with_one_warning() {
    let root = tempfile::tempdir().expect("tempdir");
    write_scene(root.path());
    std::fs::remove_file(root.path().join("images").join("b_side.png")).expect("remove");
    let scene = load_scene(root.path(), &LoadOptions::default()).expect("scene loads");
    assert_eq!(scene.views.len(), 3);
    assert_eq!(scene.warnings.len(), 1);
    assert!(scene.warnings[0].starts_with("1 of 4 images"), "{}", scene.warnings[0]);
    assert!(scene.warnings[0].contains("b_side.png"), "{}", scene.warnings[0]);
    // Image 3 (b_side) no longer observes point 1.
    assert_eq!(scene.points.as_ref().expect("points")[0].track, vec![(1, 0)]);
}

#[test]
fn views_sharing_an_image_stem_are_refused_naming_both_images() {
    let root = tempfile::tempdir().expect("tempdir");
    write_scene(root.path());
    let images_txt = root.path().join("sparse/0/images.txt");
    let text = std::fs::read_to_string(&images_txt).expect("read").replace("c_empty.png", "sub/a_front.png");
    std::fs::write(&images_txt, text).expect("write");
    write_png(&root.path().join("images/sub/a_front.png"), 64, 48);
    let err =
        load_scene(root.path(), &LoadOptions::default()).expect_err("two views share a stem").to_string();
    for words in ["a_front.png and sub/a_front.png", "same file stem `a_front`", "rename one", "images.txt"] {
        assert!(err.contains(words), "no `{words}` in: {err}");
    }
}

/// One PINHOLE 101×81 camera and one image, so down-scaling by 2 has to round.
fn odd_sized_scene(root: &Path) {
    let model = root.join("sparse").join("0");
    std::fs::create_dir_all(&model).expect("mkdir");
    std::fs::write(model.join("cameras.txt"), "1 PINHOLE 101 81 100 100 50.5 40.5\n").expect("write");
    std::fs::write(model.join("images.txt"), "1 1 0 0 0 0 0 0 1 img.png\n\n").expect("write");
    std::fs::write(model.join("points3D.txt"), "").expect("write");
    write_png(&root.join("images").join("img.png"), 101, 81);
}

#[test]
fn resolution_uses_images_folder_with_factor_suffix_and_its_exact_size() {
    let root = tempfile::tempdir().expect("tempdir");
    odd_sized_scene(root.path());
    // Without images_2/: 3DGS rounding (51×41), full-resolution image resized on load.
    let options = LoadOptions { resolution: 2, ..LoadOptions::default() };
    let scene = load_scene(root.path(), &options).expect("loads");
    let cam = &scene.cameras[0];
    assert_eq!((cam.width, cam.height), (51, 41));
    assert!((cam.fx - 100.0 * 51.0 / 101.0).abs() < 1e-12);
    assert_eq!(load_image_rgb(&scene, &scene.views[0], &options).expect("resized").size(), (51, 41));

    // With images_2/ holding floor-rounded 50×40 images: the camera takes that exact size.
    write_png(&root.path().join("images_2").join("img.png"), 50, 40);
    let scene = load_scene(root.path(), &options).expect("loads");
    let cam = &scene.cameras[0];
    assert_eq!((cam.width, cam.height), (50, 40));
    assert!((cam.cx - 50.5 * 50.0 / 101.0).abs() < 1e-12);
    assert!(scene.views[0].image_path.ends_with("images_2/img.png"));
    assert_eq!(load_image_rgb(&scene, &scene.views[0], &options).expect("loads").size(), (50, 40));
}
