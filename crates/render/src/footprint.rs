//! Which pixels of a tile a splat can reach: the ellipse `σ ≤ ln(opacity / alpha_min)` (outside it
//! α < alpha_min and the pixel is skipped anyway), as a bounding box and exact per-row spans, each
//! widened by a 1 px margin so float rounding can never drop a pixel the blending rule keeps.
//! Used by the forward and backward rasteriser alike (same pixels, same order).

use crate::project::Splat2d;

/// Extra pixels kept on each side of the exact ellipse.
const MARGIN_PX: f32 = 1.0;

/// A splat's reach inside one tile.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Footprint {
    mx: f32,
    my: f32,
    /// Conic `(a, b, c)`.
    conic: [f32; 3],
    /// `2 · ln(opacity / alpha_min)`.
    two_smax: f32,
    /// `a·c − b²`.
    det: f32,
    /// Half-open pixel box `(x0, x1, y0, y1)` inside the tile.
    pub bbox: (usize, usize, usize, usize),
    /// False for a conic that is not positive definite: every pixel of the box is visited.
    exact: bool,
}

impl Footprint {
    /// The reach of `s` inside `tile` (`(x0, x1, y0, y1)` half-open); `None` if it reaches no pixel.
    #[inline(always)]
    pub fn new(s: &Splat2d, alpha_min: f32, tile: (usize, usize, usize, usize)) -> Option<Self> {
        if s.opacity < alpha_min {
            return None;
        }
        let [a, b, c] = s.conic;
        let det = a * c - b * b;
        let [mx, my] = s.mean2d;
        let two_smax = 2.0 * (s.opacity / alpha_min).ln();
        let exact = det > 0.0 && a > 0.0 && two_smax.is_finite();
        let mut fp = Footprint { mx, my, conic: s.conic, two_smax, det, bbox: tile, exact };
        if !exact {
            return Some(fp);
        }
        let (x0, x1, y0, y1) = tile;
        let ex = (two_smax * c / det).sqrt() + MARGIN_PX;
        let ey = (two_smax * a / det).sqrt() + MARGIN_PX;
        let (bx0, bx1) = (span_lo(mx - ex, x0), span_hi(mx + ex, x1));
        let (by0, by1) = (span_lo(my - ey, y0), span_hi(my + ey, y1));
        fp.bbox = (bx0, bx1, by0, by1);
        (bx0 < bx1 && by0 < by1).then_some(fp)
    }

    /// Half-open pixel range of row `py` (inside the box) that can reach α ≥ alpha_min.
    #[inline(always)]
    pub fn row(&self, py: usize) -> (usize, usize) {
        let (bx0, bx1, ..) = self.bbox;
        if !self.exact {
            return (bx0, bx1);
        }
        let [a, b, _] = self.conic;
        let dy = self.my - (py as f32 + 0.5);
        // σ = ½(a·dx² + 2b·dx·dy + c·dy²) ≤ smax, a quadratic in dx = mean_x − pixel centre x.
        // Its discriminant is negative (no pixel of the row reaches) when the row's smallest
        // 2σ, dy²·det/a, exceeds 2·smax; rows grazing the ellipse within rounding are kept.
        let disc = a * self.two_smax - dy * dy * self.det;
        if disc < -1e-4 * a * self.two_smax {
            return (bx0, bx0);
        }
        let root = disc.max(0.0).sqrt();
        let dx_lo = (-b * dy - root) / a;
        let dx_hi = (-b * dy + root) / a;
        // Pixel centre x + 0.5 = mx − dx.
        let lo = span_lo(self.mx - dx_hi - MARGIN_PX, bx0).min(bx1);
        let hi = span_hi(self.mx - dx_lo + MARGIN_PX, bx1).max(lo);
        (lo, hi)
    }
}

/// `floor(x)` clamped to ±2³⁰, without a libm call (`f32::floor` is one without SSE4.1).
#[inline(always)]
fn floor_i64(x: f32) -> i64 {
    let x = x.clamp(-1.0e9, 1.0e9);
    let t = x as i64;
    if (t as f32) > x {
        t - 1
    } else {
        t
    }
}

/// First pixel whose centre is at or right of `edge`, at least `lo`.
#[inline]
fn span_lo(edge: f32, lo: usize) -> usize {
    (-floor_i64(0.5 - edge)).max(lo as i64) as usize
}

/// One past the last pixel whose centre is at or left of `edge`, at most `hi`.
#[inline]
fn span_hi(edge: f32, hi: usize) -> usize {
    (floor_i64(edge - 0.5) + 1).clamp(0, hi as i64) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pixel with α ≥ alpha_min lies in a row span; spans are not much wider than needed.
    #[test]
    fn row_spans_cover_every_reachable_pixel() {
        let alpha_min = 1.0 / 255.0;
        let tile = (0, 64, 0, 64);
        let mut visited = 0usize;
        let mut reachable = 0usize;
        for (i, conic) in [[0.05f32, 0.0, 0.05], [0.02, 0.018, 0.02], [1.0, -0.3, 0.2], [0.002, 0.0, 3.0]]
            .into_iter()
            .enumerate()
        {
            let s =
                Splat2d { mean2d: [31.3 + i as f32, 29.8], conic, opacity: 0.8, depth: 1.0, radii: [10, 10] };
            let fp = Footprint::new(&s, alpha_min, tile).expect("reaches the tile");
            for py in 0..64 {
                let (lo, hi) = if (fp.bbox.2..fp.bbox.3).contains(&py) { fp.row(py) } else { (0, 0) };
                visited += hi - lo;
                for px in 0..64 {
                    let dx = s.mean2d[0] - (px as f32 + 0.5);
                    let dy = s.mean2d[1] - (py as f32 + 0.5);
                    let sigma = 0.5 * (conic[0] * dx * dx + conic[2] * dy * dy) + conic[1] * dx * dy;
                    if s.opacity * (-sigma).exp() >= alpha_min {
                        reachable += 1;
                        assert!(
                            (lo..hi).contains(&px),
                            "splat {i}: pixel ({px}, {py}) outside span {lo}..{hi}"
                        );
                    }
                }
            }
        }
        assert!(visited < reachable * 2, "spans visit {visited} pixels for {reachable} reachable ones");
    }
}
