//! Writing rendered outputs as viewable files: RGB and alpha as 8-bit PNGs, depth as a 16-bit PNG
//! (for viewing) plus a float32 `.npy` (exact metric z), max-weight ids coloured with the label-map
//! palette. All writes are atomic.

use crate::error::{RenderError, RenderResult};
use splatseg_scene::image_io::{write_png_luma16, write_png_luma8, write_png_rgb8, RgbImage};
use splatseg_scene::labels::colour_of_id;
use splatseg_scene::npy::write_npy_f32;
use splatseg_scene::Plane;
use std::path::Path;

fn to_u8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

fn size_error(what: &'static str, got: usize, expected: usize) -> RenderError {
    RenderError::Shape { what, got, expected }
}

/// Writes `rgb` (`[height, width, 3]`, values clamped to [0, 1]) as an 8-bit RGB PNG.
pub fn write_rgb_png(path: &Path, rgb: &[f32], width: usize, height: usize) -> RenderResult<()> {
    let data: Vec<u8> = rgb.iter().map(|&v| to_u8(v)).collect();
    let img = RgbImage::from_vec(width, height, data)
        .ok_or_else(|| size_error("rgb image", rgb.len(), width * height * 3))?;
    Ok(write_png_rgb8(path, &img)?)
}

/// Writes a [0, 1] map (e.g. alpha) as an 8-bit greyscale PNG.
pub fn write_unit_png(path: &Path, plane: &Plane<f32>) -> RenderResult<()> {
    let data: Vec<u8> = plane.data.iter().map(|&v| to_u8(v)).collect();
    let img = Plane::from_vec(plane.width, plane.height, data)
        .ok_or_else(|| size_error("grey image", plane.data.len(), plane.width * plane.height))?;
    Ok(write_png_luma8(path, &img)?)
}

/// 16-bit values for a metric depth map: 0 where there is no surface (depth ≤ 0 or not finite),
/// otherwise `1 + 65534 · (z − z_min) / (z_max − z_min)` over the map's own range (near = dark).
/// Returns the values and `(z_min, z_max)`.
pub fn depth_to_u16(depth: &Plane<f32>) -> (Vec<u16>, (f32, f32)) {
    let valid = |z: f32| z.is_finite() && z > 0.0;
    let (lo, hi) = depth
        .data
        .iter()
        .filter(|&&z| valid(z))
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &z| (lo.min(z), hi.max(z)));
    let span = (hi - lo).max(f32::MIN_POSITIVE);
    let data =
        depth
            .data
            .iter()
            .map(|&z| {
                if valid(z) {
                    1 + ((z - lo) / span * 65534.0).round().clamp(0.0, 65534.0) as u16
                } else {
                    0
                }
            })
            .collect();
    (data, (lo, hi))
}

/// Writes metric depth as a 16-bit PNG (see [`depth_to_u16`]) at `png` and exactly as a float32
/// `[height, width]` `.npy` at `npy`.
pub fn write_depth(png: &Path, npy: &Path, depth: &Plane<f32>) -> RenderResult<()> {
    let (data, _) = depth_to_u16(depth);
    let img = Plane::from_vec(depth.width, depth.height, data)
        .ok_or_else(|| size_error("depth image", depth.data.len(), depth.width * depth.height))?;
    write_png_luma16(png, &img)?;
    Ok(write_npy_f32(npy, &[depth.height, depth.width], &depth.data)?)
}

/// Writes per-pixel Gaussian ids (−1 = none) coloured with the label palette: Gaussian `i` gets
/// `colour_of_id(i + 1)`, no Gaussian is black.
pub fn write_ids_png(path: &Path, ids: &Plane<i32>) -> RenderResult<()> {
    let data: Vec<u8> = ids.data.iter().flat_map(|&id| colour_of_id((id + 1).max(0) as u32)).collect();
    let img = RgbImage::from_vec(ids.width, ids.height, data)
        .ok_or_else(|| size_error("id image", ids.data.len(), ids.width * ids.height))?;
    Ok(write_png_rgb8(path, &img)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_maps_near_to_low_values_and_keeps_zero_for_empty() {
        let plane = Plane { width: 4, height: 1, data: vec![0.0, 2.0, 3.0, 4.0] };
        let (v, range) = depth_to_u16(&plane);
        assert_eq!(range, (2.0, 4.0));
        assert_eq!(v, vec![0, 1, 32768, 65535]);
    }
}
