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

/// `eˣ` for `x ≤ 0`, relative error below 2·10⁻⁴ (degree-5 Taylor polynomial of `2^f` and the
/// exponent set by bits): several times faster than `f32::exp`, plenty for alpha values.
#[inline]
pub fn fast_exp_neg(x: f32) -> f32 {
    let t = (x * std::f32::consts::LOG2_E).max(-126.0);
    let i = floor_small(t);
    let f = t - i;
    let p = 1.0
        + f * (std::f32::consts::LN_2
            + f * (0.240_226_5 + f * (0.055_504_11 + f * (0.009_618_129 + f * 0.001_333_355))));
    f32::from_bits(((i as i32 + 127) as u32) << 23) * p
}

/// `⌊x⌋` for |x| < 2³¹ without a libm call (`f32::floor` is not inlined on baseline x86-64).
#[inline]
fn floor_small(x: f32) -> f32 {
    let t = x as i32 as f32;
    if t > x {
        t - 1.0
    } else {
        t
    }
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
    let alpha = (splat.opacity * fast_exp_neg(power)).min(0.99);
    if alpha < 1.0 / 255.0 {
        0.0
    } else {
        alpha
    }
}

/// The columns `[x0, x1)` of row `y` where `splat`'s alpha can reach 1/255 (the exact span of
/// its ellipse on that row, clipped to its bounding box).
#[inline]
fn row_span(splat: &Splat, y: u32) -> (u32, u32) {
    let [a, b, c] = splat.conic;
    let dy = y as f32 + 0.5 - splat.centre_px[1];
    // a·dx² + 2b·dy·dx + c·dy² ≤ d2, with d2 = 2·ln(255·opacity).
    let d2 = 2.0 * (255.0 * splat.opacity).ln();
    let disc = b * b * dy * dy - a * (c * dy * dy - d2);
    if disc < 0.0 || a <= 0.0 {
        return (0, 0);
    }
    let root = disc.sqrt();
    let lo = (-b * dy - root) / a + splat.centre_px[0] - 0.5;
    let hi = (-b * dy + root) / a + splat.centre_px[0] - 0.5;
    let x0 = (-floor_small(-lo)).max(splat.bbox[0] as f32) as u32;
    let x1 = (floor_small(hi) + 1.0).min(splat.bbox[2] as f32).max(0.0) as u32;
    (x0, x1.max(x0))
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
        let [_, y0, _, y1] = s.bbox;
        for y in y0..y1 {
            let (x0, x1) = row_span(s, y);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_exp_matches_std() {
        for k in 0..=2000 {
            let x = -(k as f32) * 0.01;
            let (fast, exact) = (fast_exp_neg(x), x.exp());
            assert!((fast - exact).abs() <= 2e-4 * exact, "x = {x}: {fast} vs {exact}");
        }
    }
}
