//! Tile binning: which splats touch which 16×16 tile, each tile's list sorted front to back.
//!
//! Work mapping: tile rectangles per splat in parallel (one splat per work item); the visible
//! splats' (depth key, index, rectangle) records are sorted once by (depth, index) — a stable
//! radix sort on the depth key — and appended, in that order, to the list of every row of tiles they touch (sequential); then
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

    /// Whether these lists can be those of `n_splats` splats on a `width × height` image: the
    /// tile grid of that image, offsets starting at 0, never decreasing and ending at the
    /// number of entries, every entry a splat index below `n_splats`. (It does not check the
    /// order within a list.) The error says what does not fit.
    pub fn check(&self, n_splats: usize, width: usize, height: usize) -> Result<(), String> {
        let (tx, ty) = (width.div_ceil(TILE_SIZE), height.div_ceil(TILE_SIZE));
        if (self.tiles_x, self.tiles_y) != (tx, ty) {
            return Err(format!("{}×{} tiles, the image has {tx}×{ty}", self.tiles_x, self.tiles_y));
        }
        if self.offsets.len() != tx * ty + 1
            || self.offsets.first() != Some(&0)
            || self.offsets.last() != Some(&self.ids.len())
            || self.offsets.windows(2).any(|w| w[0] > w[1])
        {
            return Err(format!(
                "{} offsets do not bound {} entries in {} tiles",
                self.offsets.len(),
                self.ids.len(),
                tx * ty
            ));
        }
        match self.ids.iter().max() {
            Some(&m) if m as usize >= n_splats => Err(format!("splat index {m} of {n_splats} splats")),
            _ => Ok(()),
        }
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
    [
        floor_clamped(mx - rx, tiles_x),
        ceil_clamped(mx + rx, tiles_x),
        floor_clamped(my - ry, tiles_y),
        ceil_clamped(my + ry, tiles_y),
    ]
}

/// `v.floor().clamp(0.0, hi as f32) as usize` without a libm call (`f32::floor` is one without
/// SSE4.1): NaN and v ≤ 0 give 0, v ≥ hi gives hi, else the truncation.
#[inline]
fn floor_clamped(v: f32, hi: usize) -> usize {
    if v.is_nan() || v <= 0.0 {
        0
    } else if v >= hi as f32 {
        hi
    } else {
        v as usize
    }
}

/// `v.ceil().clamp(0.0, hi as f32) as usize` without a libm call.
#[inline]
fn ceil_clamped(v: f32, hi: usize) -> usize {
    if v.is_nan() || v <= 0.0 {
        0
    } else if v >= hi as f32 {
        hi
    } else {
        let t = v as usize;
        t + ((t as f32) < v) as usize
    }
}

/// The bits of `depth` as an unsigned integer ordered as `f32::total_cmp` orders the floats.
#[inline]
fn depth_order_bits(depth: f32) -> u32 {
    let bits = depth.to_bits() as i32;
    // `total_cmp`'s key: negative floats have their magnitude bits flipped, then the signed
    // order; flipping the sign bit turns that into the unsigned order.
    ((bits ^ (((bits >> 31) as u32) >> 1) as i32) as u32) ^ 0x8000_0000
}

/// One visible splat: its depth key, its index and the tile columns `[x0, x1)` and rows
/// `[y0, y1)` it covers.
#[derive(Clone, Copy, Default)]
struct Placed {
    key: u32,
    id: u32,
    rect: [u32; 4],
}

/// `records` (`[n]`, in index order) ordered by their depth keys: a stable least-significant-digit
/// radix sort, 8 bits per pass (a pass whose byte is the same for every key is skipped), so equal
/// keys keep index order. The four digits' counts are taken in one pass over the records.
fn order_records(mut records: Vec<Placed>) -> Vec<Placed> {
    let mut counts = [[0usize; 256]; 4];
    for r in &records {
        for (d, c) in counts.iter_mut().enumerate() {
            c[((r.key >> (8 * d)) & 0xff) as usize] += 1;
        }
    }
    let mut spare: Vec<Placed> = Vec::new();
    for (d, mut counts) in counts.into_iter().enumerate() {
        if counts.contains(&records.len()) {
            continue;
        }
        if spare.is_empty() {
            spare = vec![Placed::default(); records.len()];
        }
        let mut next = 0;
        for c in &mut counts {
            (*c, next) = (next, next + *c);
        }
        for r in &records {
            let bucket = &mut counts[((r.key >> (8 * d)) & 0xff) as usize];
            spare[*bucket] = *r;
            *bucket += 1;
        }
        std::mem::swap(&mut records, &mut spare);
    }
    records
}

/// The records of the visible splats of `splats` (`[N]`), in index order: counted per chunk,
/// then written in place (no per-thread lists joined afterwards).
fn visible_records(splats: &[Splat2d], tiles_x: usize, tiles_y: usize) -> Vec<Placed> {
    const CHUNK: usize = 16_384;
    let counts: Vec<usize> =
        splats.par_chunks(CHUNK).map(|c| c.iter().filter(|s| !s.is_culled()).count()).collect();
    let mut records = vec![Placed::default(); counts.iter().sum()];
    let mut outs: Vec<&mut [Placed]> = Vec::with_capacity(counts.len());
    let mut rest = records.as_mut_slice();
    for &n in &counts {
        let (head, tail) = rest.split_at_mut(n);
        outs.push(head);
        rest = tail;
    }
    outs.into_par_iter().zip(splats.par_chunks(CHUNK)).enumerate().for_each(|(k, (out, chunk))| {
        let visible = chunk.iter().enumerate().filter(|(_, s)| !s.is_culled());
        for (slot, (i, s)) in out.iter_mut().zip(visible) {
            let r = tile_rect(s, tiles_x, tiles_y);
            *slot = Placed {
                key: depth_order_bits(s.depth),
                id: (k * CHUNK + i) as u32,
                rect: r.map(|v| v as u32),
            };
        }
    });
    records
}

/// Bins `splats [N]` into the tiles of a `width × height` image.
///
/// The visible splats' records (depth key, index, tile rectangle), made in one pass over the
/// splats, are ordered by (depth, index) once ([`order_records`]; the rectangles travel with the
/// keys instead of being gathered from the splats in depth order); each row of tiles
/// gets, front to back, the (splat, columns) of the splats crossing it (a count then a fill into
/// one flat array), and the rows count and fill their tiles' lists in parallel.
pub fn bin(splats: &[Splat2d], width: usize, height: usize) -> TileBins {
    let tiles_x = width.div_ceil(TILE_SIZE);
    let tiles_y = height.div_ceil(TILE_SIZE);
    let n_tiles = tiles_x * tiles_y;
    // Each visible splat's depth key, index and tile rectangle in one pass over the splats (in
    // index order), then a stable radix sort of these records by depth: (depth, index) order,
    // the rectangles carried along instead of gathered from the splats in depth order.
    let placed = order_records(visible_records(splats, tiles_x, tiles_y));
    // Splats per row of tiles, front to back: `row_items[row_starts[r]..row_starts[r + 1]]`.
    let mut row_starts = vec![0usize; tiles_y + 1];
    for p in &placed {
        for c in &mut row_starts[p.rect[2] as usize + 1..p.rect[3] as usize + 1] {
            *c += 1;
        }
    }
    for r in 0..tiles_y {
        row_starts[r + 1] += row_starts[r];
    }
    let mut row_items = vec![(0u32, 0u32, 0u32); row_starts[tiles_y]];
    let mut cursor = row_starts.clone();
    for p in &placed {
        for c in &mut cursor[p.rect[2] as usize..p.rect[3] as usize] {
            row_items[*c] = (p.id, p.rect[0], p.rect[1]);
            *c += 1;
        }
    }
    drop(placed);
    let rows: Vec<&[(u32, u32, u32)]> =
        (0..tiles_y).map(|r| &row_items[row_starts[r]..row_starts[r + 1]]).collect();
    let counts: Vec<Vec<usize>> = rows
        .par_iter()
        .map(|row| {
            let mut counts = vec![0usize; tiles_x];
            for &(_, x0, x1) in row.iter() {
                for c in &mut counts[x0 as usize..x1 as usize] {
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
        for &(i, x0, x1) in row.iter() {
            for c in &mut cursor[x0 as usize..x1 as usize] {
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

    /// The former [`bin`] (a rectangle per splat kept in index order, a growing list per row of
    /// tiles): the reference the new one is compared with.
    fn bin_reference(splats: &[Splat2d], width: usize, height: usize) -> TileBins {
        let tiles_x = width.div_ceil(TILE_SIZE);
        let tiles_y = height.div_ceil(TILE_SIZE);
        let n_tiles = tiles_x * tiles_y;
        let rects: Vec<[usize; 4]> = splats.par_iter().map(|s| tile_rect(s, tiles_x, tiles_y)).collect();
        // Sorted by (depth, index): one integer key per splat, the depth's bits in `total_cmp`
        // order above the index, sorted as integers.
        let mut keys: Vec<u64> = splats
            .par_iter()
            .enumerate()
            .filter(|(_, s)| !s.is_culled())
            .map(|(i, s)| (depth_order_bits(s.depth) as u64) << 32 | i as u64)
            .collect();
        keys.sort_unstable();
        let order: Vec<u32> = keys.iter().map(|&k| k as u32).collect();
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

    fn splat(x: f32, y: f32, r: i32, depth: f32) -> Splat2d {
        Splat2d { mean2d: [x, y], conic: [1.0, 0.0, 1.0], opacity: 0.5, depth, radii: [r, r] }
    }

    /// The radix sort gives the order of sorting the whole keys, ties (equal depths) and all.
    #[test]
    fn radix_order_equals_a_full_sort() {
        let mut seed = 99u64;
        let mut next = move || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (seed >> 33) as u32
        };
        for (n, spread) in [(0usize, 1u32), (1, 1), (5000, 7), (20_000, u32::MAX), (3000, 1 << 20)] {
            let records: Vec<Placed> = (0..n as u32)
                .map(|id| Placed { key: next() % spread.max(1), id, rect: [id, 1, 2, id ^ 7] })
                .collect();
            let mut sorted: Vec<(u32, u32, [u32; 4])> =
                records.iter().map(|r| (r.key, r.id, r.rect)).collect();
            sorted.sort_unstable();
            let got: Vec<(u32, u32, [u32; 4])> =
                order_records(records).iter().map(|r| (r.key, r.id, r.rect)).collect();
            assert_eq!(got, sorted, "{n} keys over {spread}");
        }
    }

    /// The libm-free floor and ceil clamp exactly as `floor` / `ceil` then `clamp` do.
    #[test]
    fn clamped_floor_and_ceil_equal_the_float_functions() {
        let mut values = vec![
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            -0.0,
            0.0,
            1e-30,
            -1e-30,
            80.0,
            79.99999,
            80.00001,
        ];
        values.extend((-400..2000).map(|i| i as f32 * 0.0625 - 3.3));
        for v in values {
            for hi in [0usize, 1, 80, 1000] {
                assert_eq!(floor_clamped(v, hi), v.floor().clamp(0.0, hi as f32) as usize, "floor {v}, {hi}");
                assert_eq!(ceil_clamped(v, hi), v.ceil().clamp(0.0, hi as f32) as usize, "ceil {v}, {hi}");
            }
        }
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

    /// The binning gives the former binning's tiles and lists: many splats, culled ones, equal
    /// depths, footprints off the image's edges and larger than it, partial edge tiles.
    #[test]
    fn binning_equals_the_former_binning() {
        let mut seed = 31u64;
        let mut next = move || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        for (n, width, height) in [(0usize, 64, 48), (1, 16, 16), (5000, 200, 150), (20_000, 333, 97)] {
            let splats: Vec<Splat2d> = (0..n)
                .map(|_| {
                    let r = if next() < 0.1 { 0 } else { (next() * next() * 120.0) as i32 };
                    let depth = if next() < 0.2 { 3.0 } else { 0.1 + 20.0 * next() };
                    let mut s = splat(
                        next() * 1.4 * width as f32 - 30.0,
                        next() * 1.4 * height as f32 - 30.0,
                        r,
                        depth,
                    );
                    s.radii[1] = (s.radii[1] as f32 * (0.3 + next())) as i32;
                    s
                })
                .collect();
            let (new, old) = (bin(&splats, width, height), bin_reference(&splats, width, height));
            assert_eq!((new.tiles_x, new.tiles_y), (old.tiles_x, old.tiles_y));
            assert_eq!(new.offsets, old.offsets, "{n} splats");
            assert_eq!(new.ids, old.ids, "{n} splats");
            assert!(n < 5000 || new.intersection_count() > n, "{n} splats: few intersections");
            assert_eq!(new.check(n, width, height), Ok(()));
        }
    }

    /// Lists that cannot index the splats or tile the image are refused, each with its reason.
    #[test]
    fn check_refuses_lists_that_do_not_fit() {
        let splats: Vec<Splat2d> = (0..50).map(|i| splat(3.0 * i as f32, 20.0, 9, 1.0 + i as f32)).collect();
        let good = bin(&splats, 100, 60);
        assert!(good.intersection_count() > 50);
        assert_eq!(good.check(50, 100, 60), Ok(()));
        let refused = |bins: &TileBins, n: usize, w: usize, h: usize, what: &str| {
            let err = bins.check(n, w, h).expect_err(what);
            assert!(err.contains(what), "{err}");
        };
        refused(&good, 50, 120, 60, "tiles");
        let top = good.ids.iter().copied().max().unwrap_or(0);
        refused(&good, top as usize, 100, 60, &format!("splat index {top}"));
        let mut b = good.clone();
        b.offsets[3] = b.offsets[4] + 1;
        refused(&b, 50, 100, 60, "offsets");
        let mut b = good.clone();
        b.ids.pop();
        refused(&b, 50, 100, 60, "offsets");
        let mut b = good;
        b.offsets.pop();
        refused(&b, 50, 100, 60, "offsets");
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
