//! A scene's image files: finding them at a resolution (`images_<f>/` beside `images/`, as
//! 3DGS/COLMAP users keep them), reading their size from the header, and loading them as RGB at
//! the size of their camera (RGBA composited on a background, down-scaled when needed).

use crate::camera::Camera;
use crate::error::{SceneError, SceneResult};
use crate::image_io::{image_size, read_rgb8_alpha, resize_triangle, RgbImage};
use crate::load::{LoadOptions, Scene, View};
use crate::plane::Plane;
use std::path::{Path, PathBuf};

/// Extensions tried, in order, for a file named without one (Blender's `./train/r_0`).
const EXTENSIONS: [&str; 6] = ["png", "jpg", "jpeg", "PNG", "JPG", "JPEG"];

/// Validates `options.resolution` and returns it. `root` is named in the error.
pub(crate) fn check_resolution(options: &LoadOptions, root: &Path) -> SceneResult<u32> {
    match options.resolution {
        f @ (1 | 2 | 4 | 8) => Ok(f),
        f => Err(SceneError::Unsupported {
            what: format!(
                "resolution {f}: the down-scaling factor must be 1, 2, 4 or 8 (3DGS reads other values \
                 of --resolution as a target width; resize the images yourself for other sizes)"
            ),
            path: root.to_path_buf(),
        }),
    }
}

/// `path` if it is a file, else `path` with one of [`EXTENSIONS`] appended.
pub(crate) fn with_known_extension(path: &Path) -> Option<PathBuf> {
    if path.is_file() {
        return Some(path.to_path_buf());
    }
    EXTENSIONS
        .iter()
        .map(|ext| {
            let mut s = path.as_os_str().to_owned();
            s.push(".");
            s.push(ext);
            PathBuf::from(s)
        })
        .find(|p| p.is_file())
}

/// The folder holding images down-scaled by `factor` beside `dir` (`images` → `images_2`).
pub(crate) fn downscaled_dir(dir: &Path, factor: u32) -> Option<PathBuf> {
    let name = dir.file_name()?.to_string_lossy();
    let sibling = dir.with_file_name(format!("{name}_{factor}"));
    sibling.is_dir().then_some(sibling)
}

/// Finds image `rel` of the folder `root` at resolution `factor`: `<root>_<factor>/rel` when
/// that exists, else `<root>/rel` (which then gets resized on load). Extensions are tried
/// when `rel` has none that exists. `None` when neither exists.
pub(crate) fn locate_image(root: &Path, rel: &Path, factor: u32) -> Option<PathBuf> {
    if factor > 1 {
        if let Some(found) = downscaled_dir(root, factor).and_then(|d| with_known_extension(&d.join(rel))) {
            return Some(found);
        }
    }
    with_known_extension(&root.join(rel))
}

/// `camera` with its size set to exactly `width × height`, intrinsics scaled per axis.
fn scaled_to(camera: &Camera, width: u32, height: u32) -> Camera {
    let sx = width as f64 / camera.width as f64;
    let sy = height as f64 / camera.height as f64;
    Camera {
        width,
        height,
        fx: camera.fx * sx,
        fy: camera.fy * sy,
        cx: camera.cx * sx,
        cy: camera.cy * sy,
        ..camera.clone()
    }
}

/// True when an image of `size` is `full_size` down-scaled by `factor` with any rounding
/// (3DGS rounds, some tools floor or ceil).
fn is_downscaled(size: (u32, u32), full_size: (u32, u32), factor: f64) -> bool {
    (size.0 as f64 - full_size.0 as f64 / factor).abs() < 1.0
        && (size.1 as f64 - full_size.1 as f64 / factor).abs() < 1.0
}

/// The full-resolution `camera` at `factor`: [`Camera::downscaled`], except when `sample` (an
/// image of this camera, e.g. from `images_<f>/`) is already down-scaled with another rounding:
/// then the camera takes that image's exact size.
pub(crate) fn camera_at_resolution(camera: &Camera, sample: Option<&Path>, factor: u32) -> Camera {
    if factor == 1 {
        return camera.clone();
    }
    let default = camera.downscaled(factor as f64);
    match sample.and_then(|p| image_size(p).ok()) {
        Some(size)
            if size != (default.width, default.height)
                && is_downscaled(size, (camera.width, camera.height), factor as f64) =>
        {
            scaled_to(camera, size.0, size.1)
        }
        _ => default,
    }
}

/// How an image of a given size relates to its camera.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFit {
    /// Exactly the camera's size.
    Exact,
    /// Full resolution while the scene is loaded at `resolution > 1`: resized on load.
    Resize,
}

/// Checks an image of `size` against `view`'s camera at `options.resolution`; the error names
/// the file and both sizes.
fn fit_of(scene: &Scene, view: &View, size: (u32, u32), options: &LoadOptions) -> SceneResult<ImageFit> {
    let path = &view.image_path;
    let camera = scene.cameras.get(view.camera_index).ok_or_else(|| {
        SceneError::invalid("scene", path, format!("view {} has no camera {}", view.name, view.camera_index))
    })?;
    let target = (camera.width, camera.height);
    let factor = options.resolution.max(1) as f64;
    if size == target {
        return Ok(ImageFit::Exact);
    }
    if factor > 1.0 && is_downscaled(target, size, factor) {
        return Ok(ImageFit::Resize);
    }
    let hint = if factor > 1.0 {
        format!(
            " (at resolution {} the image should be {}x{} or about {}x{} at full size)",
            options.resolution,
            target.0,
            target.1,
            (target.0 as f64 * factor).round(),
            (target.1 as f64 * factor).round()
        )
    } else {
        String::new()
    };
    Err(SceneError::invalid(
        "image",
        path,
        format!(
            "image is {}x{} but its camera {} is {}x{}{hint}",
            size.0, size.1, camera.id, target.0, target.1
        ),
    ))
}

/// Checks, from the file header only, that the image of `view` can be loaded at the size of its
/// camera (the same rule as [`load_image_rgb`]).
pub fn check_image_size(scene: &Scene, view: &View, options: &LoadOptions) -> SceneResult<ImageFit> {
    let size = image_size(&view.image_path)?;
    fit_of(scene, view, size, options)
}

/// Checks every view's image (header only) against its camera with [`check_image_size`]:
/// call it before allocating anything of a camera's size, so a camera that declares a size its
/// image does not have is an error naming the image and both sizes.
pub fn check_image_sizes(scene: &Scene, options: &LoadOptions) -> SceneResult<()> {
    scene.views.iter().try_for_each(|view| check_image_size(scene, view, options).map(|_| ()))
}

/// Reads the image of `view` as 8-bit RGB at the size of its camera.
///
/// Images with alpha (Blender scenes) are composited on `options.background`. An image at full
/// resolution while the scene was loaded at `options.resolution = f > 1` is resized with a
/// triangle (area-like) filter. Any other size disagreement with the camera is an error naming
/// the file and both sizes.
pub fn load_image_rgb(scene: &Scene, view: &View, options: &LoadOptions) -> SceneResult<RgbImage> {
    let (rgb, alpha) = read_rgb8_alpha(&view.image_path)?;
    let fit = fit_of(scene, view, (rgb.width as u32, rgb.height as u32), options)?;
    let rgb = composite_on(rgb, alpha.as_ref(), options.background);
    match fit {
        ImageFit::Exact => Ok(rgb),
        ImageFit::Resize => {
            let camera = scene.camera(view);
            Ok(resize_triangle(&rgb, camera.width as usize, camera.height as usize))
        }
    }
}

/// `rgb` with each pixel of alpha `a` (`alpha`: `[height, width]` 8-bit, `None` = opaque)
/// made `a·colour + (1 − a)·background`. `background`: RGB in [0, 1].
pub fn composite_on(mut rgb: RgbImage, alpha: Option<&Plane<u8>>, background: [f32; 3]) -> RgbImage {
    let Some(alpha) = alpha else { return rgb };
    let bg = background.map(|c| c.clamp(0.0, 1.0) * 255.0);
    for (px, &a) in rgb.data.chunks_exact_mut(3).zip(&alpha.data) {
        let a = a as f32 / 255.0;
        for (out, &b) in px.iter_mut().zip(&bg) {
            *out = (*out as f32 * a + b * (1.0 - a)).round() as u8;
        }
    }
    rgb
}
