//! Simulated monocular relative depth (as Depth Anything V2 gives): inverse depth, distorted by
//! a smooth multiplicative and additive low-frequency field, with per-pixel noise, then
//! min–max normalised to [0, 1] per image (1 = nearest, 0 = farthest; pixels with no surface
//! count as farther than everything), optionally blurred (a network's soft edges). The sizes are
//! [`CueConfig`]'s.

use crate::config::CueConfig;
use crate::noise::{hash, normal, stream, value_noise2};
use splatseg_scene::Plane;

/// Low-frequency field cells across the image.
const CELLS: f64 = 2.0;

/// Relative depth `[H, W]` in [0, 1] from metric z depth `depth_z` (`[H, W]`, 0 = no surface).
pub fn relative_depth(depth_z: &Plane<f32>, seed: u64, view: usize, cues: &CueConfig) -> Plane<f32> {
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
            let scale = 1.0 + cues.depth_scale_error * (2.0 * value_noise2(key(0), x, y) - 1.0);
            let shift = cues.depth_shift_error * range * (2.0 * value_noise2(key(1), x, y) - 1.0);
            d * scale + shift + cues.depth_pixel_noise * range * normal(key(2 + i as u64))
        })
        .collect();
    let distorted = box_blur(&distorted, w, h, cues.depth_blur_px);
    let (lo, hi) =
        distorted.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &d| (lo.min(d), hi.max(d)));
    let span = (hi - lo).max(1e-12);
    Plane { width: w, height: h, data: distorted.iter().map(|&d| ((d - lo) / span) as f32).collect() }
}

/// `values` (`[h * w]`) averaged over `(2r + 1)²` windows clamped to the image (unchanged for r = 0).
fn box_blur(values: &[f64], w: usize, h: usize, r: usize) -> Vec<f64> {
    if r == 0 {
        return values.to_vec();
    }
    let pass = |src: &[f64], along_rows: bool| -> Vec<f64> {
        let (n, lines) = if along_rows { (w, h) } else { (h, w) };
        let at = |line: usize, k: usize| if along_rows { line * w + k } else { k * w + line };
        let mut out = vec![0.0; src.len()];
        for line in 0..lines {
            for k in 0..n {
                let (a, b) = (k.saturating_sub(r), (k + r).min(n - 1));
                let sum: f64 = (a..=b).map(|j| src[at(line, j)]).sum();
                out[at(line, k)] = sum / (b - a + 1) as f64;
            }
        }
        out
    };
    pass(&pass(values, true), false)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearer_is_larger_and_range_is_unit() {
        // Left half at 2 m, right half at 6 m.
        let z = Plane::from_vec(64, 32, (0..64 * 32).map(|i| if i % 64 < 32 { 2.0 } else { 6.0 }).collect())
            .expect("size");
        let d = relative_depth(&z, 1, 0, &CueConfig::default());
        let lo = d.data.iter().cloned().fold(f32::INFINITY, f32::min);
        let hi = d.data.iter().cloned().fold(f32::NEG_INFINITY, f32::max);
        assert!(lo.abs() < 1e-6 && (hi - 1.0).abs() < 1e-6);
        let mean = |left: bool| {
            let v: Vec<f32> = (0..64 * 32).filter(|i| (i % 64 < 32) == left).map(|i| d.data[i]).collect();
            v.iter().sum::<f32>() / v.len() as f32
        };
        assert!(mean(true) > mean(false) + 0.5);
        // a blur softens the step without moving the halves' order
        let cues = CueConfig { depth_blur_px: 3, ..CueConfig::default() };
        let blurred = relative_depth(&z, 1, 0, &cues);
        let row = |p: &Plane<f32>, x: usize| *p.get(x, 16);
        assert!(row(&blurred, 31) < row(&d, 31) - 0.1 && row(&blurred, 32) > row(&d, 32) + 0.1);
        assert!(row(&blurred, 5) > row(&blurred, 60) + 0.5);
    }
}
