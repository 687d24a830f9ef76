//! Which pixels of a tile a splat can reach: the ellipse `σ ≤ ln(opacity / alpha_min)` (outside it
//! α < alpha_min and the pixel is skipped anyway), as a bounding box and exact per-row spans, each
//! widened by a 1 px margin so float rounding can never drop a pixel the blending rule keeps.
//! Used by the forward and backward rasteriser alike (same pixels, same order).

use crate::project::Splat2d;

/// Extra pixels kept on each side of the exact ellipse.
pub(crate) const MARGIN_PX: f32 = 1.0;

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

/// What [`Footprint::new`] computes of a splat before it looks at the tile: made once per splat
/// (a contribution pass visits a splat in several tiles), then clipped to each tile by
/// [`Footprint::in_tile`], which gives exactly [`Footprint::new`]'s footprint.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Reach {
    /// The pixel box over the whole image plane, half-open `(x0, x1, y0, y1)` before clipping:
    /// `x0 = −⌊0.5 − (mx − ex)⌋`, `x1 = ⌊mx + ex − 0.5⌋ + 1` (likewise y).
    span: [i32; 4],
    /// `2 · ln(opacity / alpha_min)`.
    two_smax: f32,
    /// `a·c − b²`.
    det: f32,
    /// Which footprint the splat has.
    kind: ReachKind,
}

/// Whether a splat reaches pixels, and how its footprint is bounded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
enum ReachKind {
    /// Opacity below `alpha_min`: no pixel.
    #[default]
    Nothing,
    /// A conic that is not positive definite: the whole tile.
    WholeTile,
    /// The ellipse's box ([`Reach::span`]).
    Ellipse,
}

impl Reach {
    /// The reach of a splat whose ellipse covers `span` (see [`Reach::span`]).
    #[inline(always)]
    pub(crate) fn ellipse(span: [i32; 4], two_smax: f32, det: f32) -> Self {
        Reach { span, two_smax, det, kind: ReachKind::Ellipse }
    }

    /// The reach of a splat whose conic is not positive definite (or whose `two_smax` is not
    /// finite): every pixel of a tile.
    #[inline(always)]
    pub(crate) fn whole_tile(two_smax: f32, det: f32) -> Self {
        Reach { span: [0; 4], two_smax, det, kind: ReachKind::WholeTile }
    }

    /// The reach of `s` for the threshold `alpha_min`. A culled splat (in no tile's list, so
    /// never asked for its footprint) gets the empty reach without its logarithm.
    #[inline(always)]
    pub fn new(s: &Splat2d, alpha_min: f32) -> Self {
        if s.opacity < alpha_min || s.is_culled() {
            return Reach::default();
        }
        let [a, b, c] = s.conic;
        let det = a * c - b * b;
        let [mx, my] = s.mean2d;
        let two_smax = 2.0 * (s.opacity / alpha_min).ln();
        if !(det > 0.0 && a > 0.0 && two_smax.is_finite()) {
            return Reach::whole_tile(two_smax, det);
        }
        let ex = (two_smax * c / det).sqrt() + MARGIN_PX;
        let ey = (two_smax * a / det).sqrt() + MARGIN_PX;
        Reach::ellipse(pixel_span(mx, my, ex, ey), two_smax, det)
    }
}

impl Footprint {
    /// [`Footprint::new`] from the splat's precomputed [`Reach`] (made with the same
    /// `alpha_min`): the same footprint, field for field, without its logarithm, square roots
    /// and divisions (test `in_tile_equals_new`).
    #[inline(always)]
    pub fn in_tile(s: &Splat2d, reach: &Reach, tile: (usize, usize, usize, usize)) -> Option<Self> {
        let conic = s.conic;
        let [mx, my] = s.mean2d;
        let (two_smax, det) = (reach.two_smax, reach.det);
        match reach.kind {
            ReachKind::Nothing => None,
            ReachKind::WholeTile => {
                Some(Footprint { mx, my, conic, two_smax, det, bbox: tile, exact: false })
            }
            ReachKind::Ellipse => {
                let (x0, x1, y0, y1) = tile;
                let [lx, hx, ly, hy] = reach.span;
                // `span_lo` / `span_hi` of the same edges, clipped to the tile.
                let bx0 = lx.max(x0 as i32) as usize;
                let bx1 = (hx.max(0) as usize).min(x1);
                let by0 = ly.max(y0 as i32) as usize;
                let by1 = (hy.max(0) as usize).min(y1);
                let bbox = (bx0, bx1, by0, by1);
                (bx0 < bx1 && by0 < by1).then_some(Footprint {
                    mx,
                    my,
                    conic,
                    two_smax,
                    det,
                    bbox,
                    exact: true,
                })
            }
        }
    }

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

    /// `(dy, disc)` of row `py`: its offset from the centre and the discriminant of
    /// σ = ½(a·dx² + 2b·dx·dy + c·dy²) ≤ smax as a quadratic in dx = mean_x − pixel centre x.
    /// It is negative (no pixel of the row reaches) when the row's smallest 2σ, dy²·det/a,
    /// exceeds 2·smax; [`Self::row`] keeps rows grazing the ellipse within rounding.
    #[inline(always)]
    fn row_discriminant(&self, py: usize) -> (f32, f32) {
        let dy = self.my - (py as f32 + 0.5);
        (dy, self.conic[0] * self.two_smax - dy * dy * self.det)
    }

    /// Whether [`Self::row`] can give row `py` a non-empty span: false exactly where it returns
    /// an empty span for the discriminant alone.
    #[inline(always)]
    fn row_may_reach(&self, py: usize) -> bool {
        !self.exact || self.row_discriminant(py).1 >= -1e-4 * self.conic[0] * self.two_smax
    }

    /// The box's rows `(y0, y1)` (half-open) without those at its top and bottom edges that
    /// [`Self::row`] gives an empty span by the discriminant: every row it drops has no pixel
    /// with α ≥ alpha_min. The rows kept by that test are contiguous (`dy` falls with `py`, so
    /// `dy²` — rounding included — first falls then rises, and the discriminant first rises
    /// then falls), so trimming the two ends drops every such row and keeps every other.
    #[inline(always)]
    pub fn reaching_rows(&self) -> (usize, usize) {
        let (_, _, mut y0, mut y1) = self.bbox;
        while y0 < y1 && !self.row_may_reach(y0) {
            y0 += 1;
        }
        while y1 > y0 && !self.row_may_reach(y1 - 1) {
            y1 -= 1;
        }
        (y0, y1)
    }

    /// Half-open pixel range of row `py` (inside the box) that can reach α ≥ alpha_min.
    #[inline(always)]
    pub fn row(&self, py: usize) -> (usize, usize) {
        let (bx0, bx1, ..) = self.bbox;
        if !self.exact {
            return (bx0, bx1);
        }
        let [a, b, _] = self.conic;
        let (dy, disc) = self.row_discriminant(py);
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

/// `floor(x)` of `x` clamped to ±1e9 (NaN gives 0), without a libm call (`f32::floor` is one
/// without SSE4.1): the truncation, lowered by one where it lies above `x` (exact: |x| ≤ 1e9 <
/// 2³¹, and a value too large for `t as f32` to be exact is a whole number already). Written
/// over `i32` so the eight-lane reaches ([`crate::reach_lanes`]) vectorise it.
#[inline(always)]
pub(crate) fn floor_clamped(x: f32) -> i32 {
    let x = x.clamp(-1.0e9, 1.0e9);
    let t = x as i32;
    if (t as f32) > x {
        t - 1
    } else {
        t
    }
}

/// The half-open pixel box `(x0, x1, y0, y1)` of an ellipse centred at `(mx, my)` with
/// half-extents `(ex, ey)` (margin included), unclipped: [`span_lo`] / [`span_hi`] of its edges.
#[inline(always)]
pub(crate) fn pixel_span(mx: f32, my: f32, ex: f32, ey: f32) -> [i32; 4] {
    [
        -floor_clamped(0.5 - (mx - ex)),
        floor_clamped((mx + ex) - 0.5) + 1,
        -floor_clamped(0.5 - (my - ey)),
        floor_clamped((my + ey) - 0.5) + 1,
    ]
}

/// First pixel whose centre is at or right of `edge`, at least `lo`.
#[inline]
fn span_lo(edge: f32, lo: usize) -> usize {
    (-(floor_clamped(0.5 - edge) as i64)).max(lo as i64) as usize
}

/// One past the last pixel whose centre is at or left of `edge`, at most `hi`.
#[inline]
fn span_hi(edge: f32, hi: usize) -> usize {
    (floor_clamped(edge - 0.5) as i64 + 1).clamp(0, hi as i64) as usize
}

/// Splat `i` of a test set mixing the awkward cases: near and far off the image, conics that
/// are not positive definite or nearly singular, opacities below and at the threshold, culled
/// splats and non-finite fields; `unit` gives uniform numbers in [0, 1).
#[cfg(test)]
pub(crate) fn awkward_splat(i: usize, unit: &mut impl FnMut() -> f32, alpha_min: f32) -> Splat2d {
    let spread = [1.0, 50.0, 5.0e3, 3.0e9][i % 4];
    let mut s = Splat2d {
        mean2d: [spread * (unit() - 0.3), spread * (unit() - 0.3)],
        conic: [2.0 * unit() - 0.2, unit() - 0.5, 2.0 * unit() - 0.2]
            .map(|v| v * [1.0, 1e-4, 10.0, 1e-30][i % 4]),
        opacity: 1.02 * unit(),
        depth: 1.0,
        radii: [5, 5],
    };
    match i % 89 {
        0 => s.opacity = f32::NAN,
        1 => s.conic[0] = f32::INFINITY,
        2 => s.mean2d[1] = f32::NAN,
        3 => s.opacity = alpha_min,
        4 => s.radii = [0, 0],
        5 => s.conic[2] = f32::NAN,
        6 => s.mean2d[0] = f32::INFINITY,
        _ => {}
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The footprint clipped from a precomputed reach is `Footprint::new`'s, field for field
    /// (compared as printed, so NaN fields compare too; a culled splat has none), over random
    /// splats — positive definite
    /// or not, far off the image, opacity below the threshold, non-finite values — and tiles.
    #[test]
    fn in_tile_equals_new() {
        let mut seed = 5u32;
        let mut unit = move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let alpha_min = 1.0 / 255.0;
        let (mut some, mut none, mut whole) = (0, 0, 0);
        for i in 0..200_000 {
            let s = awkward_splat(i, &mut unit, alpha_min);
            let (tx, ty) = ((unit() * 80.0) as usize, (unit() * 60.0) as usize);
            let tile = (16 * tx, (16 * tx + 16).min(1270), 16 * ty, (16 * ty + 16).min(957));
            let reach = Reach::new(&s, alpha_min);
            let (ours, theirs) = (Footprint::in_tile(&s, &reach, tile), Footprint::new(&s, alpha_min, tile));
            if s.is_culled() {
                // In no tile's list: no footprint is ever asked for.
                assert!(ours.is_none());
                continue;
            }
            assert_eq!(format!("{ours:?}"), format!("{theirs:?}"), "{s:?} in {tile:?}");
            match theirs {
                Some(f) if !f.exact => whole += 1,
                Some(_) => some += 1,
                None => none += 1,
            }
        }
        assert!(some > 1000 && none > 1000 && whole > 100, "{some} boxes, {none} none, {whole} whole tiles");
    }

    /// The trimmed rows are exactly the box rows the discriminant test keeps: every dropped row
    /// gets an empty span from `row`, every kept one passes the test (they are contiguous).
    #[test]
    fn reaching_rows_drop_exactly_the_rows_without_reach() {
        let mut seed = 11u32;
        let mut unit = move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let (mut dropped, mut kept) = (0, 0);
        for _ in 0..20_000 {
            let (sx, sy) = (0.3 + 6.0 * unit(), 0.3 + 6.0 * unit());
            let rho = 1.8 * unit() - 0.9;
            let det = (sx * sy) * (sx * sy) * (1.0 - rho * rho);
            let conic = [sy * sy / det, -rho * sx * sy / det, sx * sx / det];
            let s = Splat2d {
                mean2d: [40.0 * unit() - 4.0, 40.0 * unit() - 4.0],
                conic,
                opacity: unit(),
                depth: 1.0,
                radii: [20, 20],
            };
            let tile = (16, 32, 16, 32);
            let Some(fp) = Footprint::new(&s, 1.0 / 255.0, tile) else { continue };
            let (y0, y1) = fp.reaching_rows();
            assert!(fp.bbox.2 <= y0 && y0 <= y1 && y1 <= fp.bbox.3);
            for py in fp.bbox.2..fp.bbox.3 {
                if (y0..y1).contains(&py) {
                    assert!(fp.row_may_reach(py), "{s:?}: kept row {py} fails the test");
                    kept += 1;
                } else {
                    let (lo, hi) = fp.row(py);
                    assert_eq!(lo, hi, "{s:?}: dropped row {py} has the span {lo}..{hi}");
                    dropped += 1;
                }
            }
        }
        assert!(dropped > 1000 && kept > dropped, "{dropped} dropped, {kept} kept");
    }

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
