//! Blender `transforms_*.json` and instant-ngp `transforms.json` on small hand-made folders:
//! axes conversion, intrinsics precedence, extension lookup, compositing, missing frames.

use glam::{DVec2, DVec3};
use splatseg_scene::image_io::{write_png_rgb8, RgbImage};
use splatseg_scene::load::{load_image_rgb, LoadOptions, SceneFormat};
use splatseg_scene::transforms::read_transforms;
use splatseg_scene::{load_scene, Scene};
use std::path::Path;

fn write_rgba_png(path: &Path, width: u32, height: u32) {
    std::fs::create_dir_all(path.parent().expect("parent")).expect("mkdir");
    // Left half: opaque red. Right half: red at alpha 128.
    let rgba: Vec<u8> = (0..height)
        .flat_map(|_| (0..width).flat_map(|x| [255, 0, 0, if x < width / 2 { 255 } else { 128 }]))
        .collect();
    let mut encoder = png::Encoder::new(std::fs::File::create(path).expect("create"), width, height);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.write_header().expect("header").write_image_data(&rgba).expect("png");
}

fn write_rgb_png(path: &Path, width: u32, height: u32) {
    std::fs::create_dir_all(path.parent().expect("parent")).expect("mkdir");
    write_png_rgb8(path, &RgbImage::filled(width as usize, height as usize, [0; 3])).expect("png");
}

/// A camera-to-world matrix (OpenGL axes) with identity rotation at `t`, as JSON.
fn gl_matrix(t: [f64; 3]) -> String {
    format!("[[1,0,0,{}],[0,1,0,{}],[0,0,1,{}],[0,0,0,1]]", t[0], t[1], t[2])
}

fn project(scene: &Scene, view: usize, p: DVec3) -> Option<DVec2> {
    let v = &scene.views[view];
    scene.camera(v).project(v.world_from_cam.inverse().transform_point(p))
}

#[test]
fn blender_scene_converts_opengl_axes_and_composites_alpha() {
    let dir = tempfile::tempdir().expect("tempdir");
    let angle = 2.0 * (0.5f64).atan(); // fx = 0.5 * 8 / tan(angle / 2) = 8
    let json = format!(
        r#"{{"camera_angle_x": {angle}, "frames": [
            {{"file_path": "./train/r_0", "rotation": 0.1, "transform_matrix": {}}},
            {{"file_path": "./train/r_1", "transform_matrix": {}}}]}}"#,
        gl_matrix([0.0, 0.0, 2.0]),
        gl_matrix([1.0, 0.0, 2.0])
    );
    std::fs::write(dir.path().join("transforms_train.json"), json).expect("write");
    write_rgba_png(&dir.path().join("train/r_0.png"), 8, 6);
    write_rgba_png(&dir.path().join("train/r_1.png"), 8, 6);

    let scene = load_scene(dir.path(), &LoadOptions::default()).expect("loads");
    assert_eq!(scene.format, SceneFormat::Blender);
    assert_eq!(scene.cameras.len(), 1);
    let cam = &scene.cameras[0];
    assert_eq!((cam.width, cam.height, cam.cx, cam.cy), (8, 6, 4.0, 3.0));
    assert!((cam.fx - 8.0).abs() < 1e-12 && cam.fy == cam.fx);
    assert_eq!((scene.views[1].name.as_str(), scene.views[1].stem.as_str()), ("train/r_1.png", "r_1"));

    // An OpenGL camera at z = 2 looks down −z: the origin is straight ahead at depth 2, and a
    // point up (+y in the world) appears above the centre (smaller v) in OpenCV pixels.
    let v0 = &scene.views[0];
    let p_in_cam = v0.world_from_cam.inverse().transform_point(DVec3::ZERO);
    assert!((p_in_cam - DVec3::new(0.0, 0.0, 2.0)).length() < 1e-12);
    assert!((project(&scene, 0, DVec3::ZERO).expect("in front") - DVec2::new(4.0, 3.0)).length() < 1e-12);
    let up = project(&scene, 0, DVec3::new(0.0, 0.5, 0.0)).expect("in front");
    assert!((up - DVec2::new(4.0, 1.0)).length() < 1e-12, "{up:?}");
    let right = project(&scene, 1, DVec3::new(1.5, 0.0, 0.0)).expect("in front");
    assert!((right - DVec2::new(6.0, 3.0)).length() < 1e-12, "{right:?}");

    let options = LoadOptions { background: [0.0, 0.0, 1.0], ..LoadOptions::default() };
    let rgb = load_image_rgb(&scene, &scene.views[0], &options).expect("loads");
    assert_eq!(rgb.pixel(0, 0), [255, 0, 0], "opaque pixel keeps its colour");
    assert_eq!(rgb.pixel(7, 0), [128, 0, 127], "alpha 128 over blue");
}

#[test]
fn instant_ngp_intrinsics_per_frame_override_the_top_level() {
    let dir = tempfile::tempdir().expect("tempdir");
    let json = format!(
        r#"{{"fl_x": 50, "fl_y": 52, "cx": 31, "cy": 23, "w": 64, "h": 48, "k1": 0.01, "p2": -0.001,
            "aabb_scale": 4, "frames": [
            {{"file_path": "images/a.png", "transform_matrix": {m}}},
            {{"file_path": "images/b", "transform_matrix": {m}}},
            {{"file_path": "images/c.png", "fl_x": 70, "k1": 0, "p2": 0, "transform_matrix": {m}}},
            {{"file_path": "images/gone.png", "transform_matrix": {m}}}]}}"#,
        m = gl_matrix([0.0, 0.0, 0.0])
    );
    std::fs::write(dir.path().join("transforms.json"), json).expect("write");
    for name in ["a.png", "b.png", "c.png"] {
        write_rgb_png(&dir.path().join("images").join(name), 64, 48);
    }
    let scene = load_scene(dir.path(), &LoadOptions::default()).expect("loads");
    assert_eq!(scene.format, SceneFormat::InstantNgp);
    assert_eq!(scene.views.len(), 3);
    assert_eq!(scene.views[1].name, "images/b.png", "extension found for a path without one");
    assert_eq!(scene.views.iter().map(|v| v.image_id).collect::<Vec<_>>(), [1, 2, 3]);
    assert_eq!(scene.cameras.len(), 2, "frame c has its own intrinsics");
    let shared = &scene.cameras[scene.views[0].camera_index];
    assert_eq!(scene.views[1].camera_index, scene.views[0].camera_index);
    assert_eq!((shared.fx, shared.fy, shared.cx, shared.cy), (50.0, 52.0, 31.0, 23.0));
    assert_eq!((shared.distortion.k1, shared.distortion.p2), (0.01, -0.001));
    let own = &scene.cameras[scene.views[2].camera_index];
    assert_eq!((own.fx, own.fy), (70.0, 52.0));
    assert!(own.distortion.is_zero());
    assert_eq!(scene.warnings.len(), 1);
    assert!(
        scene.warnings[0].starts_with("1 of 4 frames listed in transforms.json"),
        "{}",
        scene.warnings[0]
    );
    assert!(scene.warnings[0].contains("images/gone.png"), "{}", scene.warnings[0]);
}

#[test]
fn size_and_focal_fall_back_to_the_image_header_and_camera_angle_x() {
    let dir = tempfile::tempdir().expect("tempdir");
    let json = format!(
        r#"{{"camera_angle_x": 1.5707963267948966, "frames": [{{"file_path": "img/x.jpg", "transform_matrix": {}}}]}}"#,
        gl_matrix([0.0, 0.0, 0.0])
    );
    let file = dir.path().join("transforms.json");
    std::fs::write(&file, json).expect("write");
    std::fs::create_dir_all(dir.path().join("img")).expect("mkdir");
    // What image 0.25.10's encoder wrote for a black 40×30 picture.
    let jpeg = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/jpeg/black_40x30.jpg");
    std::fs::copy(jpeg, dir.path().join("img/x.jpg")).expect("jpeg");
    // The JSON file itself can be given.
    let scene = read_transforms(&file, &LoadOptions::default()).expect("loads");
    let cam = &scene.cameras[0];
    assert_eq!((cam.width, cam.height, cam.cx, cam.cy), (40, 30, 20.0, 15.0));
    assert!((cam.fx - 20.0).abs() < 1e-9 && (cam.fy - 20.0).abs() < 1e-9, "90° field of view");
}

#[test]
fn resolution_prefers_the_suffixed_image_folder() {
    let dir = tempfile::tempdir().expect("tempdir");
    let json = format!(
        r#"{{"fl_x": 40, "fl_y": 40, "cx": 32, "cy": 24, "w": 64, "h": 48,
            "frames": [{{"file_path": "images/a.png", "transform_matrix": {}}}]}}"#,
        gl_matrix([0.0, 0.0, 0.0])
    );
    std::fs::write(dir.path().join("transforms.json"), json).expect("write");
    write_rgb_png(&dir.path().join("images/a.png"), 64, 48);
    write_rgb_png(&dir.path().join("images_4/a.png"), 16, 12);
    let options = LoadOptions { resolution: 4, ..LoadOptions::default() };
    let scene = load_scene(dir.path(), &options).expect("loads");
    assert!(scene.views[0].image_path.ends_with("images_4/a.png"));
    let cam = &scene.cameras[0];
    assert_eq!((cam.width, cam.height, cam.fx, cam.cx), (16, 12, 10.0, 8.0));
    assert_eq!(load_image_rgb(&scene, &scene.views[0], &options).expect("loads").size(), (16, 12));
}

#[test]
fn frames_sharing_an_image_stem_are_refused_naming_both_images() {
    let dir = tempfile::tempdir().expect("tempdir");
    let json = format!(
        r#"{{"camera_angle_x": 1.0, "frames": [
            {{"file_path": "./cam1/0001", "transform_matrix": {}}},
            {{"file_path": "./cam2/0001", "transform_matrix": {}}}]}}"#,
        gl_matrix([0.0, 0.0, 2.0]),
        gl_matrix([1.0, 0.0, 2.0])
    );
    std::fs::write(dir.path().join("transforms.json"), json).expect("write");
    write_rgb_png(&dir.path().join("cam1/0001.png"), 8, 6);
    write_rgb_png(&dir.path().join("cam2/0001.png"), 8, 6);
    let err =
        load_scene(dir.path(), &LoadOptions::default()).expect_err("two frames share a stem").to_string();
    for words in ["cam1/0001.png and cam2/0001.png", "same file stem `0001`", "transforms.json"] {
        assert!(err.contains(words), "no `{words}` in: {err}");
    }
}
