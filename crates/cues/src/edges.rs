//! Laplacian-of-Gaussian edge strength (paper §4.1 "Boundary Localization").
//!
//! `edge = minmax(|Laplacian(GaussianBlur(grey, σ = 2))|)`, per image, in [0, 1]. A step edge's
//! |LoG| is zero on the step itself and peaks about σ px either side of it, so boundary statistics
//! should look at a band a few pixels wide around a shared boundary (the merge stage does).

use crate::filter::{gaussian_blur, laplacian, normalise_min_max};
use splatseg_scene::Plane;

/// The paper's LoG scale (σ = 2 px).
pub const LOG_SIGMA_PX: f32 = 2.0;

/// Grey value (Rec. 601 luma, as OpenCV's `COLOR_RGB2GRAY`) of an RGB image.
///
/// `rgb`: `[H, W]` of `[r, g, b]`, any consistent range (usually [0, 1]).
pub fn grey_from_rgb(rgb: &Plane<[f32; 3]>) -> Plane<f32> {
    rgb.map(|&[r, g, b]| 0.299 * r + 0.587 * g + 0.114 * b)
}

/// LoG edge-strength map: Gaussian blur with `sigma_px`, 3×3 Laplacian, absolute value,
/// min–max normalised to [0, 1] over the image. Continuous (no thresholding).
///
/// `grey`: `[H, W]` grey image. Returns `[H, W]`.
pub fn log_edges(grey: &Plane<f32>, sigma_px: f32) -> Plane<f32> {
    let mut edges = laplacian(&gaussian_blur(grey, sigma_px));
    edges.data.iter_mut().for_each(|v| *v = v.abs());
    normalise_min_max(&mut edges);
    edges
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_peaks_near_a_step_and_vanishes_in_flat_areas() {
        // Vertical step between columns 19 and 20.
        let data = (0..40).flat_map(|_| (0..40).map(|x| if x < 20 { 0.1 } else { 0.9 })).collect();
        let edges = log_edges(&Plane::from_vec(40, 40, data).unwrap(), LOG_SIGMA_PX);
        let row = edges.row(20);
        let peak_x = (0..40).max_by(|&a, &b| row[a].total_cmp(&row[b])).unwrap();
        assert!((16..=23).contains(&peak_x), "peak at {peak_x}");
        assert!(row[2] < 1e-3 && row[37] < 1e-3, "flat areas respond: {} {}", row[2], row[37]);
        assert!((row[peak_x] - 1.0).abs() < 1e-6);
        assert!(edges.data.iter().all(|v| (0.0..=1.0).contains(v)));
    }

    #[test]
    fn a_weak_step_gives_a_proportionally_weaker_response() {
        // Strong step at x = 10, weak step (1/10 of the contrast) at x = 30.
        let data = (0..40)
            .flat_map(|_| {
                (0..40).map(|x| {
                    if x < 10 {
                        0.0
                    } else if x < 30 {
                        0.5
                    } else {
                        0.55
                    }
                })
            })
            .collect();
        let edges = log_edges(&Plane::from_vec(40, 40, data).unwrap(), LOG_SIGMA_PX);
        let row = edges.row(20);
        let weak = row[24..36].iter().cloned().fold(0.0f32, f32::max);
        assert!((weak - 0.1).abs() < 0.02, "weak edge response {weak}");
    }
}
