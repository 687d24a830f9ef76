//! COLMAP sparse models (`cameras`, `images`, `points3D`), binary and text, read and write.
//!
//! COLMAP stores `cam_from_world` (`QW QX QY QZ TX TY TZ`); [`read_colmap`] inverts it into
//! `world_from_cam` and sorts views by image name (as 3DGS does). The exact file contents are
//! available as a [`ColmapModel`] ([`read_model`]), which round-trips byte for byte between text
//! and binary; [`write_colmap_text`] / [`write_colmap_binary`] write a [`Scene`].
//!
//! Supported camera models: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV. Others
//! (fisheye, FULL_OPENCV, ...) are reported as [`SceneError::Unsupported`].

mod binary;
mod model;
mod text;

pub use binary::{
    parse_cameras_bin, parse_images_bin, parse_points_bin, read_model_binary, write_model_binary,
};
pub use model::{ColmapCamera, ColmapImage, ColmapModel};
pub use text::{parse_cameras_txt, parse_images_txt, parse_points_txt, read_model_text, write_model_text};

use crate::camera::Camera;
use crate::error::{SceneError, SceneResult};
use crate::images::{camera_at_resolution, check_resolution, locate_image};
use crate::load::{refuse_shared_stems, Keypoint, LoadOptions, Scene, SceneFormat, View};
use glam::DVec2;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Reads the model in `model_dir` (`.bin` preferred when both `.bin` and `.txt` exist) and
/// returns it with the format it was read from.
pub fn read_model(model_dir: &Path) -> SceneResult<(ColmapModel, SceneFormat)> {
    let has = |ext: &str| model_dir.join(format!("cameras.{ext}")).is_file();
    let (ext, format) = if has("bin") {
        ("bin", SceneFormat::ColmapBinary)
    } else if has("txt") {
        ("txt", SceneFormat::ColmapText)
    } else {
        return Err(SceneError::missing(
            "COLMAP model (cameras.bin or cameras.txt)",
            model_dir.join("cameras.bin"),
        ));
    };
    for name in ["images", "points3D"] {
        let file = model_dir.join(format!("{name}.{ext}"));
        if !file.is_file() {
            return Err(SceneError::missing(format!("COLMAP {name}.{ext} beside cameras.{ext}"), file));
        }
    }
    let model = if ext == "bin" { read_model_binary(model_dir)? } else { read_model_text(model_dir)? };
    Ok((model, format))
}

/// Reads the COLMAP model in `model_dir` (e.g. `scene/sparse/0`) with its images in
/// `images_dir` (e.g. `scene/images`) at `options.resolution`.
///
/// Views are sorted by image name. Images listed by the model but absent from `images_dir` are
/// skipped with one warning in [`Scene::warnings`] (their observations are dropped from point
/// tracks). At resolution `f > 1`, `images_<f>/` beside `images_dir` is used when it holds the
/// image; cameras are down-scaled to match, and so are the views' keypoints (same per-axis
/// factors, pixel-corner origin), so `camera.project` of a point lands on its keypoints.
pub fn read_colmap(model_dir: &Path, images_dir: &Path, options: &LoadOptions) -> SceneResult<Scene> {
    if !model_dir.is_dir() {
        return Err(SceneError::missing("COLMAP model folder", model_dir));
    }
    let (model, format) = read_model(model_dir)?;
    if !images_dir.is_dir() {
        return Err(SceneError::missing("images folder of the COLMAP model", images_dir));
    }
    let images_file =
        model_dir.join(if format == SceneFormat::ColmapBinary { "images.bin" } else { "images.txt" });
    let mut scene = model_to_scene(model, format, &images_file, images_dir, options)?;
    scene.root = images_dir.parent().map_or_else(|| images_dir.to_path_buf(), Path::to_path_buf);
    Ok(scene)
}

/// Builds the scene; `images_file` is only used in messages.
fn model_to_scene(
    model: ColmapModel,
    format: SceneFormat,
    images_file: &Path,
    images_dir: &Path,
    options: &LoadOptions,
) -> SceneResult<Scene> {
    let factor = check_resolution(options, images_dir)?;
    let cameras_file = images_file.with_file_name(match format {
        SceneFormat::ColmapBinary => "cameras.bin",
        _ => "cameras.txt",
    });
    let mut cameras_by_id = BTreeMap::new();
    for camera in &model.cameras {
        let full = camera.to_camera();
        if let Some(why) = full.defect() {
            return Err(SceneError::invalid(
                "COLMAP cameras",
                &cameras_file,
                format!("camera {}: {why}", camera.id),
            ));
        }
        if cameras_by_id.insert(camera.id, full).is_some() {
            return Err(SceneError::invalid(
                "COLMAP cameras",
                &cameras_file,
                format!("camera id {} appears twice", camera.id),
            ));
        }
    }
    if model.images.is_empty() {
        return Err(SceneError::invalid("COLMAP images", images_file, "the model lists no images"));
    }
    let mut seen_ids = BTreeMap::new();
    for image in &model.images {
        if let Some(first) = seen_ids.insert(image.id, image.name.as_str()) {
            return Err(SceneError::invalid(
                "COLMAP images",
                images_file,
                format!("image id {} appears twice ({first} and {})", image.id, image.name),
            ));
        }
    }
    let camera_index: BTreeMap<u32, usize> =
        cameras_by_id.keys().enumerate().map(|(i, &id)| (id, i)).collect();

    let mut images = model.images;
    images.sort_by(|a, b| a.name.cmp(&b.name).then(a.id.cmp(&b.id)));
    let mut views = Vec::with_capacity(images.len());
    let mut missing = Vec::new();
    for image in images {
        let bad = |reason: String| SceneError::invalid("COLMAP images", images_file, reason);
        let &index = camera_index.get(&image.camera_id).ok_or_else(|| {
            bad(format!(
                "image {} ({}) uses camera {}, which the model does not have",
                image.id, image.name, image.camera_id
            ))
        })?;
        let world_from_cam = image.world_from_cam().ok_or_else(|| {
            bad(format!("image {} ({}) has a zero rotation quaternion", image.id, image.name))
        })?;
        let Some(image_path) = locate_image(images_dir, Path::new(&image.name), factor) else {
            missing.push(image.name);
            continue;
        };
        let stem =
            Path::new(&image.name).file_stem().map_or_else(String::new, |s| s.to_string_lossy().into_owned());
        views.push(View {
            name: image.name,
            stem,
            image_path,
            camera_index: index,
            world_from_cam,
            image_id: image.id,
            keypoints: image.keypoints,
        });
    }
    let listed = views.len() + missing.len();
    if views.is_empty() && listed > 0 {
        return Err(SceneError::missing(
            format!(
                "image files: none of the {listed} images listed in the model exists (first: {})",
                missing[0]
            ),
            images_dir,
        ));
    }
    let full_cameras: Vec<&Camera> = cameras_by_id.values().collect();
    let cameras: Vec<Camera> = full_cameras
        .iter()
        .enumerate()
        .map(|(i, camera)| {
            let sample = views.iter().find(|v| v.camera_index == i).map(|v| v.image_path.as_path());
            camera_at_resolution(camera, sample, factor)
        })
        .collect();
    for view in &mut views {
        scale_keypoints(&mut view.keypoints, full_cameras[view.camera_index], &cameras[view.camera_index]);
    }
    let mut points = model.points;
    refuse_shared_stems(&views, "COLMAP images", images_file)?;
    let mut warnings = Vec::new();
    if !missing.is_empty() {
        warnings.push(missing_images_warning(&missing, listed, images_file, images_dir));
        let kept: BTreeSet<u32> = views.iter().map(|v| v.image_id).collect();
        for p in &mut points {
            p.track.retain(|(image_id, _)| kept.contains(image_id));
        }
    }
    Ok(Scene { root: images_dir.to_path_buf(), format, cameras, views, points: Some(points), warnings })
}

/// Moves keypoints measured on `full`'s images onto `scaled`'s (the same camera at the loaded
/// resolution): with the pixel-corner origin of `CONVENTIONS.md`, positions scale per axis by
/// the image size ratio, exactly as the intrinsics do (a pixel centre `i + 0.5` lands on the
/// centre of the pixel covering it at the new size).
fn scale_keypoints(keypoints: &mut [Keypoint], full: &Camera, scaled: &Camera) {
    if (full.width, full.height) == (scaled.width, scaled.height) || full.width == 0 || full.height == 0 {
        return;
    }
    let sx = scaled.width as f64 / full.width as f64;
    let sy = scaled.height as f64 / full.height as f64;
    for k in keypoints {
        k.xy = DVec2::new(k.xy.x * sx, k.xy.y * sy);
    }
}

fn missing_images_warning(
    missing: &[String],
    listed: usize,
    images_file: &Path,
    images_dir: &Path,
) -> String {
    let shown: Vec<&str> = missing.iter().take(5).map(String::as_str).collect();
    let more = if missing.len() > shown.len() { ", ..." } else { "" };
    format!(
        "{} of {listed} images listed in {} have no image file in {}; using the other {} (missing: {}{more})",
        missing.len(),
        images_file.display(),
        images_dir.display(),
        listed - missing.len(),
        shown.join(", ")
    )
}

/// The COLMAP model of a scene: cameras (model kept when it can hold the intrinsics, see
/// [`ColmapCamera::from_camera`]), `cam_from_world` poses with `QW >= 0`, keypoints and points.
pub fn scene_to_model(scene: &Scene) -> ColmapModel {
    let cameras: Vec<ColmapCamera> = scene.cameras.iter().map(ColmapCamera::from_camera).collect();
    let images = scene
        .views
        .iter()
        .map(|view| {
            let (qvec, tvec) = ColmapImage::qvec_tvec_of(&view.world_from_cam);
            ColmapImage {
                id: view.image_id,
                qvec,
                tvec,
                camera_id: scene.cameras.get(view.camera_index).map_or(0, |c| c.id),
                name: view.name.clone(),
                keypoints: view.keypoints.clone(),
            }
        })
        .collect();
    ColmapModel { cameras, images, points: scene.points.clone().unwrap_or_default() }
}

/// Writes `scene` as a COLMAP text model (`cameras.txt`, `images.txt`, `points3D.txt`) into
/// `model_dir`, each file atomically. Cameras and keypoints are those of the resolution the
/// scene was loaded at (a scene loaded at resolution 2 is written as a model of the
/// half-size images).
pub fn write_colmap_text(model_dir: &Path, scene: &Scene) -> SceneResult<()> {
    write_model_text(model_dir, &scene_to_model(scene))
}

/// Writes `scene` as a COLMAP binary model (`cameras.bin`, `images.bin`, `points3D.bin`) into
/// `model_dir`, each file atomically.
pub fn write_colmap_binary(model_dir: &Path, scene: &Scene) -> SceneResult<()> {
    write_model_binary(model_dir, &scene_to_model(scene))
}

/// The model folder of a COLMAP scene root: `sparse/0/` or `sparse/` holding `cameras.*`.
pub fn find_model_dir(root: &Path) -> Option<PathBuf> {
    let holds_model = |d: &Path| d.join("cameras.bin").is_file() || d.join("cameras.txt").is_file();
    [root.join("sparse").join("0"), root.join("sparse")].into_iter().find(|d| holds_model(d))
}
