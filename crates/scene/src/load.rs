//! [`Scene`]: cameras, posed views and optional sparse points, whatever format they came from,
//! and [`load_scene`], which detects the format of a folder.

use crate::camera::{Camera, Pose};
use crate::colmap::{find_model_dir, read_colmap};
use crate::error::{SceneError, SceneResult};
use crate::transforms::{find_transforms_file, read_transforms};
use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

pub use crate::images::{check_image_size, check_image_sizes, load_image_rgb, ImageFit};

/// Which on-disk format a scene was read from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum SceneFormat {
    /// COLMAP `sparse/0/{cameras,images,points3D}.bin`.
    ColmapBinary,
    /// COLMAP `sparse/0/{cameras,images,points3D}.txt`.
    ColmapText,
    /// NeRF synthetic / Blender `transforms_{train,val,test}.json`.
    Blender,
    /// instant-ngp / nerfstudio `transforms.json`.
    InstantNgp,
}

/// A 2D keypoint of a COLMAP image, kept so models round-trip.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Keypoint {
    /// Pixel position (pixel-corner origin).
    pub xy: DVec2,
    /// The 3D point it observes, or -1.
    pub point3d_id: i64,
}

/// One posed image.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct View {
    /// Image name as the model lists it (COLMAP `NAME`, or the transforms `file_path` with the
    /// extension that was found), relative to the images folder.
    pub name: String,
    /// File stem of `name` (no folders, no extension): the key that matches per-view inputs such
    /// as `masks/<stem>.json` or `features/<stem>.npy`.
    pub stem: String,
    /// Resolved path of the image file at the chosen resolution.
    pub image_path: PathBuf,
    /// Index into [`Scene::cameras`].
    pub camera_index: usize,
    /// Camera-to-world transform, OpenCV camera axes (see `CONVENTIONS.md`).
    pub world_from_cam: Pose,
    /// COLMAP `IMAGE_ID` (1-based order of appearance for transforms.json scenes).
    pub image_id: u32,
    /// COLMAP 2D keypoints (empty for other formats).
    pub keypoints: Vec<Keypoint>,
}

/// A COLMAP sparse 3D point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SparsePoint {
    /// COLMAP `POINT3D_ID`.
    pub id: u64,
    /// Position in world coordinates.
    pub xyz: DVec3,
    /// Colour.
    pub rgb: [u8; 3],
    /// Mean reprojection error.
    pub error: f64,
    /// Observations as `(IMAGE_ID, POINT2D_IDX)`.
    pub track: Vec<(u32, u32)>,
}

/// A multi-view capture: cameras, posed views and (for COLMAP) sparse points.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    /// The folder the scene was loaded from.
    pub root: PathBuf,
    /// The format it was read from.
    pub format: SceneFormat,
    /// Intrinsics at the chosen resolution.
    pub cameras: Vec<Camera>,
    /// Posed views in file order (COLMAP: sorted by image name, as 3DGS does).
    pub views: Vec<View>,
    /// Sparse points, when the format has them.
    pub points: Option<Vec<SparsePoint>>,
    /// Non-fatal problems found while loading (e.g. listed images that are missing), to be
    /// shown to the user once; loading does not print them itself.
    pub warnings: Vec<String>,
}

impl Scene {
    /// The camera of `view`.
    pub fn camera(&self, view: &View) -> &Camera {
        &self.cameras[view.camera_index]
    }

    /// The view whose image stem is `stem`.
    pub fn view_by_stem(&self, stem: &str) -> Option<&View> {
        self.views.iter().find(|v| v.stem == stem)
    }
}

/// How to load a scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LoadOptions {
    /// Image down-scaling factor as 3DGS's `--resolution` (1, 2, 4 or 8). Uses `images_<f>/`
    /// when present, otherwise images are resized on load.
    pub resolution: u32,
    /// Background RGB in [0, 1] that RGBA images (Blender scenes) are composited onto.
    pub background: [f32; 3],
    /// Which Blender split to read (`train`, `val`, `test`); ignored for other formats.
    pub split: String,
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions { resolution: 1, background: [1.0, 1.0, 1.0], split: "train".to_string() }
    }
}

/// Loads the scene at `path`, detecting its format:
///
/// - a folder with `sparse/0/` (or `sparse/`) holding `cameras.{bin,txt}` and an `images/`
///   folder beside it → COLMAP (checked first, as 3DGS does);
/// - a folder with `transforms_<split>.json` → NeRF/Blender;
/// - a folder with `transforms.json`, or a `.json` file → instant-ngp / nerfstudio;
/// - a COLMAP model folder itself (`cameras.*` inside) → COLMAP, with images in the first of
///   `../images`, `../../images` and `images/` that exists.
///
/// Non-fatal problems (e.g. listed images that are missing) are returned in
/// [`Scene::warnings`]; nothing is printed.
pub fn load_scene(path: &Path, options: &LoadOptions) -> SceneResult<Scene> {
    if !path.exists() {
        return Err(SceneError::missing("scene folder", path));
    }
    if path.is_file() {
        return match path.extension().and_then(|e| e.to_str()) {
            Some("json") => read_transforms(path, options),
            _ => Err(SceneError::Unsupported {
                what: "scene file (give a scene folder, a COLMAP model folder or a transforms .json)".into(),
                path: path.to_path_buf(),
            }),
        };
    }
    if let Some(model_dir) = find_model_dir(path) {
        let images_dir = path.join("images");
        if !images_dir.is_dir() {
            return Err(SceneError::missing(
                format!("images folder beside the COLMAP model {}", model_dir.display()),
                images_dir,
            ));
        }
        return with_root(read_colmap(&model_dir, &images_dir, options), path);
    }
    if find_transforms_file(path, &options.split).is_some() {
        return with_root(read_transforms(path, options), path);
    }
    if path.join("cameras.bin").is_file() || path.join("cameras.txt").is_file() {
        let candidates = [path.join("../images"), path.join("../../images"), path.join("images")];
        let Some(images_dir) = candidates.iter().find(|d| d.is_dir()) else {
            return Err(SceneError::missing(
                "images folder of the COLMAP model (looked for ../images, ../../images and images/)",
                path.join("../images"),
            ));
        };
        return read_colmap(path, images_dir, options);
    }
    if path.join("images").is_dir() {
        return Err(SceneError::missing(
            "COLMAP model beside images/ (sparse/0/cameras.bin or sparse/0/cameras.txt)",
            path.join("sparse").join("0"),
        ));
    }
    if path.join("transforms_train.json").is_file() {
        return Err(SceneError::missing(
            format!("Blender split \"{}\"", options.split),
            path.join(format!("transforms_{}.json", options.split)),
        ));
    }
    Err(SceneError::missing(
        "a scene: COLMAP (sparse/0/ + images/), Blender (transforms_train.json) or instant-ngp (transforms.json)",
        path,
    ))
}

/// An error when two views share an image stem (e.g. `cam1/0001.jpg` and `cam2/0001.jpg`): every
/// per-view file, read (`<stem>.json`, `<stem>.npy`) or written (`masks/<stem>.png`,
/// `<stem>_rgb.png`), is named by the stem, so the two views would read each other's inputs and
/// overwrite each other's outputs. The message names both images; `listing` (the file that lists
/// the images) is the path given.
pub(crate) fn refuse_shared_stems(views: &[View], format: &'static str, listing: &Path) -> SceneResult<()> {
    let mut first_of_stem: std::collections::BTreeMap<&str, &View> = std::collections::BTreeMap::new();
    for v in views {
        if let Some(first) = first_of_stem.insert(v.stem.as_str(), v) {
            return Err(SceneError::invalid(
                format,
                listing,
                format!(
                    "the images {} and {} have the same file stem `{}`; per-view files (SAM masks \
                     <stem>.json, features and depth <stem>.npy, label maps and renders) are named by \
                     the stem, so one view would take the other's inputs and overwrite its outputs: \
                     rename one of the images ({} and {})",
                    first.name,
                    v.name,
                    v.stem,
                    first.image_path.display(),
                    v.image_path.display()
                ),
            ));
        }
    }
    Ok(())
}

fn with_root(scene: SceneResult<Scene>, root: &Path) -> SceneResult<Scene> {
    scene.map(|s| Scene { root: root.to_path_buf(), ..s })
}
