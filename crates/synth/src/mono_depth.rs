//! Simulated monocular relative depth (as Depth Anything V2 gives): inverse depth, distorted by
//! a smooth multiplicative and additive low-frequency field, with per-pixel noise, then
//! min–max normalised to [0, 1] per image (1 = nearest, 0 = farthest; pixels with no surface
//! count as farther than everything).

use crate::noise::{hash, normal, stream, value_noise2};
use splatseg_scene::Plane;

/// Peak relative size of the smooth multiplicative distortion.
const SCALE_DISTORTION: f64 = 0.12;
/// Peak size of the smooth additive distortion, as a fraction of the inverse-depth range.
const SHIFT_DISTORTION: f64 = 0.05;
/// Per-pixel noise, as a fraction of the inverse-depth range.
const PIXEL_NOISE: f64 = 0.008;
/// Low-frequency field cells across the image.
const CELLS: f64 = 2.0;

/// Relative depth `[H, W]` in [0, 1] from metric z depth `depth_z` (`[H, W]`, 0 = no surface).
pub fn relative_depth(depth_z: &Plane<f32>, seed: u64, view: usize) -> Plane<f32> {
    let (w, h) = depth_z.size();
    let inverse: Vec<f64> =
        depth_z.data.iter().map(|&z| if z > 0.0 { 1.0 / z as f64 } else { 0.0 }).collect();
    let (lo, hi) = inverse
        .iter()
        .filter(|&&d| d > 0.0)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &d| (lo.min(d), hi.max(d)));
    if !lo.is_finite() {
        return Plane::filled(w, h, 0.0);
    }
    let range = (hi - lo).max(1e-9);
    let key = |k: u64| hash(seed, &[stream::MONO_DEPTH, view as u64, k]);
    let distorted: Vec<f64> = inverse
        .iter()
        .enumerate()
        .map(|(i, &d)| {
            let (x, y) = ((i % w) as f64 / w as f64 * CELLS, (i / w) as f64 / h as f64 * CELLS);
            let d = if d > 0.0 { d } else { lo - 0.05 * range };
            let scale = 1.0 + SCALE_DISTORTION * (2.0 * value_noise2(key(0), x, y) - 1.0);
            let shift = SHIFT_DISTORTION * range * (2.0 * value_noise2(key(1), x, y) - 1.0);
            d * scale + shift + PIXEL_NOISE * range * normal(key(2 + i as u64))
        })
        .collect();
    let (lo, hi) =
        distorted.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &d| (lo.min(d), hi.max(d)));
    let span = (hi - lo).max(1e-12);
    Plane { width: w, height: h, data: distorted.iter().map(|&d| ((d - lo) / span) as f32).collect() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearer_is_larger_and_range_is_unit() {
        // Left half at 2 m, right half at 6 m.
        let z = Plane::from_vec(64, 32, (0..64 * 32).map(|i| if i % 64 < 32 { 2.0 } else { 6.0 }).collect())
            .expect("size");
        let d = relative_depth(&z, 1, 0);
        let lo = d.data.iter().cloned().fold(f32::INFINITY, f32::min);
        let hi = d.data.iter().cloned().fold(f32::NEG_INFINITY, f32::max);
        assert!(lo.abs() < 1e-6 && (hi - 1.0).abs() < 1e-6);
        let mean = |left: bool| {
            let v: Vec<f32> = (0..64 * 32).filter(|i| (i % 64 < 32) == left).map(|i| d.data[i]).collect();
            v.iter().sum::<f32>() / v.len() as f32
        };
        assert!(mean(true) > mean(false) + 0.5);
    }
}
