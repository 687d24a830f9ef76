//! Tile binning: which splats touch which 16×16 tile, each tile's list sorted front to back.
//!
//! Work mapping: tile rectangles per splat in parallel (one splat per work item); the visible
//! splats are sorted once by (depth, index) — one `u64` key per splat, rayon's parallel sort —
//! and appended, in that order, to the list of every row of tiles they touch (sequential); then
//! one rayon work item per row of tiles counts and fills its tiles' lists (a counting sort), so
//! every list comes out front to back (ties in index order) without per-tile sorting. The result
//! is independent of the thread count.
//!
//! A splat covers tiles `floor((mean − r) / 16) .. ceil((mean + r) / 16)` (half-open, clamped to
//! the image), per axis, as gsplat's `isect_tiles`.

use crate::project::Splat2d;
use rayon::prelude::*;

/// Tile edge length in pixels.
pub const TILE_SIZE: usize = 16;

/// Per-tile lists of splat indices, front to back.
#[derive(Clone, Debug, Default)]
pub struct TileBins {
    /// Tiles per row.
    pub tiles_x: usize,
    /// Tile rows.
    pub tiles_y: usize,
    /// `[tiles_x · tiles_y + 1]`: tile `t`'s list is `ids[offsets[t]..offsets[t + 1]]`;
    /// tiles are numbered row-major.
    pub offsets: Vec<usize>,
    /// `[n_intersections]` splat indices, grouped by tile, each group sorted by depth.
    pub ids: Vec<u32>,
}

impl TileBins {
    /// Splat indices of tile `t`, front to back.
    pub fn tile(&self, t: usize) -> &[u32] {
        &self.ids[self.offsets[t]..self.offsets[t + 1]]
    }

    /// Number of (splat, tile) pairs.
    pub fn intersection_count(&self) -> usize {
        self.ids.len()
    }
}

/// Half-open tile rectangle `[x0, x1) × [y0, y1)` a splat covers.
pub fn tile_rect(s: &Splat2d, tiles_x: usize, tiles_y: usize) -> [usize; 4] {
    if s.is_culled() {
        return [0; 4];
    }
    let ts = TILE_SIZE as f32;
    let (rx, ry) = (s.radii[0] as f32 / ts, s.radii[1] as f32 / ts);
    let (mx, my) = (s.mean2d[0] / ts, s.mean2d[1] / ts);
    let clamp = |v: f32, hi: usize| v.clamp(0.0, hi as f32) as usize;
    [
        clamp((mx - rx).floor(), tiles_x),
        clamp((mx + rx).ceil(), tiles_x),
        clamp((my - ry).floor(), tiles_y),
        clamp((my + ry).ceil(), tiles_y),
    ]
}

/// The bits of `depth` as an unsigned integer ordered as `f32::total_cmp` orders the floats.
#[inline]
fn depth_order_bits(depth: f32) -> u32 {
    let bits = depth.to_bits() as i32;
    // `total_cmp`'s key: negative floats have their magnitude bits flipped, then the signed
    // order; flipping the sign bit turns that into the unsigned order.
    ((bits ^ (((bits >> 31) as u32) >> 1) as i32) as u32) ^ 0x8000_0000
}

/// Bins `splats [N]` into the tiles of a `width × height` image.
pub fn bin(splats: &[Splat2d], width: usize, height: usize) -> TileBins {
    let tiles_x = width.div_ceil(TILE_SIZE);
    let tiles_y = height.div_ceil(TILE_SIZE);
    let n_tiles = tiles_x * tiles_y;
    let rects: Vec<[usize; 4]> = splats.par_iter().map(|s| tile_rect(s, tiles_x, tiles_y)).collect();
    // Sorted by (depth, index) as one integer key per splat: the depth's bits in `total_cmp`
    // order above the index (no look-ups into the splats while sorting).
    let mut keys: Vec<u64> = splats
        .par_iter()
        .enumerate()
        .filter(|(_, s)| !s.is_culled())
        .map(|(i, s)| (depth_order_bits(s.depth) as u64) << 32 | i as u64)
        .collect();
    keys.par_sort_unstable();
    let order: Vec<u32> = keys.into_iter().map(|k| k as u32).collect();
    // Splats per row of tiles, front to back.
    let mut rows: Vec<Vec<u32>> = vec![Vec::new(); tiles_y];
    for &i in &order {
        let r = &rects[i as usize];
        for row in &mut rows[r[2]..r[3]] {
            row.push(i);
        }
    }
    let counts: Vec<Vec<usize>> = rows
        .par_iter()
        .map(|row| {
            let mut counts = vec![0usize; tiles_x];
            for &i in row {
                let r = &rects[i as usize];
                for c in &mut counts[r[0]..r[1]] {
                    *c += 1;
                }
            }
            counts
        })
        .collect();
    let mut offsets = vec![0usize; n_tiles + 1];
    for (t, &c) in counts.iter().flatten().enumerate() {
        offsets[t + 1] = offsets[t] + c;
    }
    let mut ids = vec![0u32; offsets[n_tiles]];
    let mut slices: Vec<&mut [u32]> = Vec::with_capacity(tiles_y);
    let mut rest = ids.as_mut_slice();
    for ty in 0..tiles_y {
        let (head, tail) = rest.split_at_mut(offsets[(ty + 1) * tiles_x] - offsets[ty * tiles_x]);
        slices.push(head);
        rest = tail;
    }
    slices.into_par_iter().zip(rows.par_iter()).enumerate().for_each(|(ty, (out, row))| {
        let base = offsets[ty * tiles_x];
        let mut cursor: Vec<usize> = (0..tiles_x).map(|tx| offsets[ty * tiles_x + tx] - base).collect();
        for &i in row {
            let r = &rects[i as usize];
            for c in &mut cursor[r[0]..r[1]] {
                out[*c] = i;
                *c += 1;
            }
        }
    });
    TileBins { tiles_x, tiles_y, offsets, ids }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn splat(x: f32, y: f32, r: i32, depth: f32) -> Splat2d {
        Splat2d { mean2d: [x, y], conic: [1.0, 0.0, 1.0], opacity: 0.5, depth, radii: [r, r] }
    }

    /// The integer keys order depths exactly as `total_cmp` does, signs, zeros and
    /// infinities included.
    #[test]
    fn depth_keys_order_as_total_cmp() {
        let depths = [
            f32::NEG_INFINITY,
            -3.5,
            -1e-30,
            -0.0,
            0.0,
            1e-38,
            0.01,
            0.010000001,
            1.0,
            2.5e7,
            f32::MAX,
            f32::INFINITY,
        ];
        for a in depths {
            for b in depths {
                assert_eq!(depth_order_bits(a).cmp(&depth_order_bits(b)), a.total_cmp(&b), "{a} vs {b}");
            }
        }
    }

    #[test]
    fn bins_cover_footprints_and_sort_by_depth() {
        let splats = [splat(8.0, 8.0, 4, 3.0), splat(20.0, 8.0, 10, 1.0), splat(40.0, 40.0, 0, 1.0)];
        let bins = bin(&splats, 48, 32);
        assert_eq!((bins.tiles_x, bins.tiles_y), (3, 2));
        // splat 0 covers tile 0 only; splat 1 covers x in [10, 30] → tiles 0, 1 in row 0 and
        // (y in [-2, 18]) rows 0 and 1; splat 2 is culled.
        assert_eq!(bins.tile(0), &[1, 0]);
        assert_eq!(bins.tile(1), &[1]);
        assert_eq!(bins.tile(2), &[] as &[u32]);
        assert_eq!(bins.tile(3), &[1]);
        assert_eq!(bins.tile(4), &[1]);
        assert_eq!(bins.intersection_count(), 5);
    }
}
