//! NeRF/Blender `transforms_{split}.json` and instant-ngp/nerfstudio `transforms.json`.
//!
//! Both list frames with a camera-to-world `transform_matrix` in **OpenGL** camera axes; we
//! store `world_from_cam = transform_matrix · diag(1, −1, −1, 1)` (OpenCV axes, see
//! `CONVENTIONS.md`). Intrinsics come from `fl_x fl_y cx cy w h k1 k2 p1 p2` at the top level or
//! per frame (per-frame values win), falling back to `camera_angle_x` (square pixels, principal
//! point at the image centre, size read from the image header) as Blender scenes have it.
//! `file_path` may omit the extension (`./train/r_0` → `train/r_0.png`). Frames without an
//! image file are skipped with one warning in [`Scene::warnings`].

use crate::camera::{Camera, CameraModel, Distortion, Pose};
use crate::error::{SceneError, SceneResult};
use crate::image_io::image_size;
use crate::images::{camera_at_resolution, check_resolution, locate_image, with_known_extension};
use crate::load::{refuse_shared_stems, LoadOptions, Scene, SceneFormat, View};
use serde::Deserialize;
use std::path::{Path, PathBuf};

const FORMAT: &str = "transforms JSON";

/// Intrinsics a transforms file may give at the top level or per frame.
#[derive(Clone, Debug, Default, Deserialize)]
struct Intrinsics {
    camera_angle_x: Option<f64>,
    camera_angle_y: Option<f64>,
    fl_x: Option<f64>,
    fl_y: Option<f64>,
    cx: Option<f64>,
    cy: Option<f64>,
    w: Option<f64>,
    h: Option<f64>,
    k1: Option<f64>,
    k2: Option<f64>,
    k3: Option<f64>,
    k4: Option<f64>,
    p1: Option<f64>,
    p2: Option<f64>,
    camera_model: Option<String>,
}

impl Intrinsics {
    /// `self` with every value `frame` sets replaced by the frame's.
    fn overlaid_by(&self, frame: &Intrinsics) -> Intrinsics {
        macro_rules! pick {
            ($($f:ident),*) => { Intrinsics { $($f: frame.$f.clone().or_else(|| self.$f.clone()),)* } };
        }
        pick!(camera_angle_x, camera_angle_y, fl_x, fl_y, cx, cy, w, h, k1, k2, k3, k4, p1, p2, camera_model)
    }
}

#[derive(Debug, Deserialize)]
struct TransformsFile {
    #[serde(flatten)]
    intrinsics: Intrinsics,
    frames: Vec<Frame>,
}

#[derive(Debug, Deserialize)]
struct Frame {
    file_path: String,
    transform_matrix: Vec<Vec<f64>>,
    #[serde(flatten)]
    intrinsics: Intrinsics,
}

/// Finds the transforms file for `path`: the file itself, or in a folder
/// `transforms_<split>.json` (Blender) before `transforms.json` (instant-ngp).
pub fn find_transforms_file(path: &Path, split: &str) -> Option<(PathBuf, SceneFormat)> {
    let format_of = |file: &Path| {
        let name = file.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        if name.starts_with("transforms_") {
            SceneFormat::Blender
        } else {
            SceneFormat::InstantNgp
        }
    };
    if path.is_file() {
        return Some((path.to_path_buf(), format_of(path)));
    }
    let blender = path.join(format!("transforms_{split}.json"));
    if blender.is_file() {
        return Some((blender, SceneFormat::Blender));
    }
    let ngp = path.join("transforms.json");
    ngp.is_file().then_some((ngp, SceneFormat::InstantNgp))
}

/// Reads a Blender (`transforms_<options.split>.json`) or instant-ngp (`transforms.json`) scene
/// from the folder `dir` (or the JSON file itself), at `options.resolution`. Views are in file
/// order; `image_id` is the frame's 1-based position in the file.
pub fn read_transforms(dir: &Path, options: &LoadOptions) -> SceneResult<Scene> {
    let (file, format) = find_transforms_file(dir, &options.split).ok_or_else(|| {
        SceneError::missing(format!("transforms_{}.json or transforms.json", options.split), dir)
    })?;
    let base = file.parent().map_or_else(|| PathBuf::from("."), Path::to_path_buf);
    let factor = check_resolution(options, &base)?;
    let text = std::fs::read_to_string(&file).map_err(|e| SceneError::io("cannot read", &file, e))?;
    let parsed = parse_file(&text, &file)?;
    let mut builder = Builder {
        file: &file,
        base: &base,
        factor,
        cameras: Vec::new(),
        views: Vec::new(),
        missing: Vec::new(),
    };
    for (i, frame) in parsed.frames.iter().enumerate() {
        builder.add_frame(i, frame, &parsed.intrinsics)?;
    }
    builder.finish(format)
}

/// Parses the JSON text of a transforms file; `path` is only named in errors.
fn parse_file(text: &str, path: &Path) -> SceneResult<TransformsFile> {
    let parsed: TransformsFile =
        serde_json::from_str(text).map_err(|e| SceneError::invalid(FORMAT, path, e.to_string()))?;
    if parsed.frames.is_empty() {
        return Err(SceneError::invalid(FORMAT, path, "the file lists no frames"));
    }
    Ok(parsed)
}

/// Parses the text of a transforms file without looking at any image: every frame's
/// `world_from_cam` (in file order), with the errors [`read_transforms`] gives for them.
/// `path` is only named in errors. The fuzz targets' entry point.
pub fn parse_transforms_json(text: &str, path: &Path) -> SceneResult<Vec<Pose>> {
    let parsed = parse_file(text, path)?;
    parsed
        .frames
        .iter()
        .enumerate()
        .map(|(i, frame)| {
            pose_from_opengl(&frame.transform_matrix).map_err(|reason| {
                SceneError::invalid(
                    FORMAT,
                    path,
                    format!("frame {i} ({}): transform_matrix {reason}", frame.file_path),
                )
            })
        })
        .collect()
}

struct Builder<'a> {
    file: &'a Path,
    base: &'a Path,
    factor: u32,
    /// Full-resolution cameras, deduplicated.
    cameras: Vec<Camera>,
    views: Vec<View>,
    missing: Vec<String>,
}

impl Builder<'_> {
    fn invalid(&self, reason: String) -> SceneError {
        SceneError::invalid(FORMAT, self.file, reason)
    }

    fn add_frame(&mut self, index: usize, frame: &Frame, top: &Intrinsics) -> SceneResult<()> {
        let what = format!("frame {index} ({})", frame.file_path);
        let world_from_cam = pose_from_opengl(&frame.transform_matrix)
            .map_err(|reason| self.invalid(format!("{what}: transform_matrix {reason}")))?;
        let clean = frame.file_path.trim_start_matches("./");
        let full = self.base.join(clean);
        let (Some(root), Some(file_name)) = (full.parent(), full.file_name()) else {
            return Err(self.invalid(format!("{what}: file_path names no file")));
        };
        let Some(image_path) = locate_image(root, Path::new(file_name), self.factor) else {
            self.missing.push(frame.file_path.clone());
            return Ok(());
        };
        let intrinsics = top.overlaid_by(&frame.intrinsics);
        let camera = self.camera_for(&intrinsics, &full, &image_path, &what)?;
        crate::limits::check_pixels(
            &format!("{what}: the camera"),
            camera.width as u64,
            camera.height as u64,
        )
        .map_err(|reason| self.invalid(reason))?;
        let camera_index = match self.cameras.iter().position(|c| same_intrinsics(c, &camera)) {
            Some(i) => i,
            None => {
                self.cameras.push(Camera { id: self.cameras.len() as u32 + 1, ..camera });
                self.cameras.len() - 1
            }
        };
        let found_name =
            image_path.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let name = match Path::new(clean).parent().map(|p| p.to_string_lossy().into_owned()) {
            Some(dir) if !dir.is_empty() => format!("{dir}/{found_name}"),
            _ => found_name,
        };
        let stem = image_path.file_stem().map_or_else(String::new, |s| s.to_string_lossy().into_owned());
        self.views.push(View {
            name,
            stem,
            image_path,
            camera_index,
            world_from_cam,
            image_id: index as u32 + 1,
            keypoints: Vec::new(),
        });
        Ok(())
    }

    /// The full-resolution camera of one frame. `full` is the frame's path at full resolution
    /// (maybe without extension), `found` the file located at the chosen resolution.
    fn camera_for(&self, intr: &Intrinsics, full: &Path, found: &Path, what: &str) -> SceneResult<Camera> {
        match intr.camera_model.as_deref() {
            None | Some("OPENCV" | "PINHOLE" | "SIMPLE_PINHOLE") => {}
            Some(other) => {
                return Err(SceneError::Unsupported {
                    what: format!("camera_model {other} ({what}); supported: OPENCV, PINHOLE"),
                    path: self.file.to_path_buf(),
                })
            }
        }
        for (name, value) in [("k3", intr.k3), ("k4", intr.k4)] {
            if value.is_some_and(|v| v != 0.0) {
                return Err(SceneError::Unsupported {
                    what: format!("distortion coefficient {name} ({what}); supported: k1 k2 p1 p2"),
                    path: self.file.to_path_buf(),
                });
            }
        }
        let (width, height) = match (intr.w, intr.h) {
            (Some(w), Some(h)) => (self.pixels(w, "w", what)?, self.pixels(h, "h", what)?),
            _ => match with_known_extension(full) {
                Some(full_res) => image_size(&full_res)?,
                None => {
                    let (w, h) = image_size(found)?;
                    (w.saturating_mul(self.factor), h.saturating_mul(self.factor))
                }
            },
        };
        let focal_from_angle = |angle: f64, size: u32| 0.5 * size as f64 / (0.5 * angle).tan();
        let fx = match (intr.fl_x, intr.camera_angle_x) {
            (Some(f), _) => f,
            (None, Some(a)) => focal_from_angle(a, width),
            (None, None) => {
                return Err(self.invalid(format!("{what}: no focal length (needs fl_x or camera_angle_x)")))
            }
        };
        let fy = match (intr.fl_y, intr.camera_angle_y) {
            (Some(f), _) => f,
            (None, Some(a)) if intr.fl_x.is_none() => focal_from_angle(a, height),
            _ => fx,
        };
        let distortion = Distortion {
            k1: intr.k1.unwrap_or(0.0),
            k2: intr.k2.unwrap_or(0.0),
            p1: intr.p1.unwrap_or(0.0),
            p2: intr.p2.unwrap_or(0.0),
        };
        let camera = Camera {
            id: 0,
            model: if distortion.is_zero() { CameraModel::Pinhole } else { CameraModel::OpenCv },
            width,
            height,
            fx,
            fy,
            cx: intr.cx.unwrap_or(width as f64 / 2.0),
            cy: intr.cy.unwrap_or(height as f64 / 2.0),
            distortion,
        };
        if let Some(why) = camera.defect() {
            return Err(self.invalid(format!("{what}: invalid intrinsics: {why}")));
        }
        Ok(camera)
    }

    fn pixels(&self, v: f64, name: &str, what: &str) -> SceneResult<u32> {
        if v >= 1.0 && v <= u32::MAX as f64 && v.fract() == 0.0 {
            Ok(v as u32)
        } else {
            Err(self.invalid(format!("{what}: image {name} = {v} is not a positive whole number of pixels")))
        }
    }

    fn finish(self, format: SceneFormat) -> SceneResult<Scene> {
        let listed = self.views.len() + self.missing.len();
        if self.views.is_empty() {
            return Err(SceneError::missing(
                format!(
                    "image files: none of the {listed} frames listed in {} exists (first: {})",
                    self.file.display(),
                    self.missing.first().map_or("", String::as_str)
                ),
                self.base,
            ));
        }
        let cameras = self
            .cameras
            .iter()
            .enumerate()
            .map(|(i, camera)| {
                let sample = self.views.iter().find(|v| v.camera_index == i).map(|v| v.image_path.as_path());
                camera_at_resolution(camera, sample, self.factor)
            })
            .collect();
        refuse_shared_stems(&self.views, FORMAT, self.file)?;
        let mut warnings = Vec::new();
        if !self.missing.is_empty() {
            let file_name =
                self.file.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            let shown: Vec<&str> = self.missing.iter().take(5).map(String::as_str).collect();
            let more = if self.missing.len() > shown.len() { ", ..." } else { "" };
            warnings.push(format!(
                "{} of {listed} frames listed in {file_name} have no image file; using the other {} (missing: {}{more})",
                self.missing.len(),
                self.views.len(),
                shown.join(", ")
            ));
        }
        Ok(Scene {
            root: self.base.to_path_buf(),
            format,
            cameras,
            views: self.views,
            points: None,
            warnings,
        })
    }
}

fn same_intrinsics(a: &Camera, b: &Camera) -> bool {
    a.model == b.model
        && (a.width, a.height) == (b.width, b.height)
        && [a.fx, a.fy, a.cx, a.cy] == [b.fx, b.fy, b.cx, b.cy]
        && a.distortion == b.distortion
}

/// `world_from_cam` (OpenCV axes) from a camera-to-world matrix in OpenGL axes, `[3 or 4][4]`
/// row-major. Errors say what is wrong with the matrix.
pub fn pose_from_opengl(matrix: &[Vec<f64>]) -> Result<Pose, String> {
    if !(3..=4).contains(&matrix.len()) || matrix.iter().any(|row| row.len() != 4) {
        return Err("must be 4x4 (or 3x4)".into());
    }
    if matrix.iter().flatten().any(|v| !v.is_finite()) {
        return Err("has a non-finite entry".into());
    }
    let rows: Vec<[f64; 4]> = matrix[..3].iter().map(|r| [r[0], -r[1], -r[2], r[3]]).collect();
    let pose_in = |i: usize, j: usize| rows[i][j];
    let col = |j: usize| glam::DVec3::new(pose_in(0, j), pose_in(1, j), pose_in(2, j));
    let (x, y, z) = (col(0), col(1), col(2));
    let det = x.dot(y.cross(z));
    let orthonormal = [x.length(), y.length(), z.length()].iter().all(|l| (l - 1.0).abs() < 1e-3)
        && x.dot(y).abs() < 1e-3
        && y.dot(z).abs() < 1e-3
        && x.dot(z).abs() < 1e-3;
    if !orthonormal || det < 0.0 {
        return Err(format!(
            "is not a rotation plus translation (determinant {det:.4}); scaled poses are not supported"
        ));
    }
    Ok(Pose::from_rows(&rows))
}
