//! Front-to-back alpha compositing of footprints on the CPU: the loop shared by the surface
//! depth (visibility) and the label render-back.
//!
//! Work mapping: one view per call, single-threaded (callers run views in parallel). Splats are
//! sorted by depth (ties by index, so the order is deterministic); each splat walks its bounding
//! box and skips pixels whose transmittance already fell below the caller's stop threshold.

use crate::project::Splat;

/// Sorts `splats` front to back (depth, then Gaussian index).
pub fn sort_by_depth(splats: &mut [Splat]) {
    splats.sort_unstable_by_key(|s| ((s.depth.max(0.0).to_bits() as u64) << 32) | s.index as u64);
}

/// Opacity of `splat` at the centre of pixel `(x, y)`, capped at 0.99 as 3DGS does
/// (0 below 1/255).
#[inline]
pub fn alpha_at(splat: &Splat, x: u32, y: u32) -> f32 {
    let dx = x as f32 + 0.5 - splat.centre_px[0];
    let dy = y as f32 + 0.5 - splat.centre_px[1];
    let [a, b, c] = splat.conic;
    let power = -0.5 * (a * dx * dx + c * dy * dy) - b * dx * dy;
    if power > 0.0 {
        return 0.0;
    }
    let alpha = (splat.opacity * power.exp()).min(0.99);
    if alpha < 1.0 / 255.0 {
        0.0
    } else {
        alpha
    }
}

/// Composites depth-sorted `splats` over a `width × height` image. For every pixel a splat
/// touches while the pixel's transmittance is still ≥ `stop_transmittance`, calls
/// `visit(pixel_index, splat_position, weight = α·T_before, T_after)`.
/// Returns the final transmittance per pixel: `[height * width]`.
pub fn composite(
    splats: &[Splat],
    width: usize,
    height: usize,
    stop_transmittance: f32,
    mut visit: impl FnMut(usize, usize, f32, f32),
) -> Vec<f32> {
    let mut transmittance = vec![1.0f32; width * height];
    for (k, s) in splats.iter().enumerate() {
        let [x0, y0, x1, y1] = s.bbox;
        for y in y0..y1 {
            let row = y as usize * width;
            for x in x0..x1 {
                let p = row + x as usize;
                let t = transmittance[p];
                if t < stop_transmittance {
                    continue;
                }
                let alpha = alpha_at(s, x, y);
                if alpha == 0.0 {
                    continue;
                }
                let t_after = t * (1.0 - alpha);
                transmittance[p] = t_after;
                visit(p, k, alpha * t, t_after);
            }
        }
    }
    transmittance
}
