//! The boundary band `B_ε(M) = (M ⊕ D_ε) \ (M ⊖ D_ε)` with a disk `D_ε` of radius ε pixels
//! (integer offsets `dx² + dy² ≤ ε²`), for every instance of a label map at once.
//!
//! A pixel `x` lies in the band of label `g` exactly when the disk around `x` holds a pixel of
//! `g` (so `x ∈ M ⊕ D`) and a pixel that is not `g` (so `x ∉ M ⊖ D`). So a pixel whose disk
//! holds one label only is in no band, and a pixel whose disk holds labels `S` (|S| ≥ 2) is in
//! the band of every label of `S`. Pixels outside the image are ignored (the image border is
//! not an object boundary), as OpenCV's default erosion border does.
//!
//! Work: one pass computes, per pixel, how far its row stays constant (capped at ε + 1); a
//! pixel is then "uniform" when the `2ε + 1` row segments of its disk are constant with its
//! label, checked with at most `2ε + 1` lookups. Only non-uniform pixels (a strip about 2ε wide
//! along the boundaries) scan their disk for the labels it holds.

use splatseg_scene::Plane;

/// The boundary band radius of the paper's boundary mIoU, in pixels.
pub const PAPER_BAND_RADIUS_PX: u32 = 5;

/// Half-widths of the disk's rows: `[2r + 1]`, entry `dy + r` = `floor(sqrt(r² − dy²))`.
pub fn disk_row_half_widths(radius_px: u32) -> Vec<usize> {
    let r = radius_px as i64;
    (-r..=r)
        .map(|dy| {
            let rem = r * r - dy * dy;
            let mut w = (rem as f64).sqrt() as i64;
            // Guard against rounding of the float square root.
            while (w + 1) * (w + 1) <= rem {
                w += 1;
            }
            while w * w > rem {
                w -= 1;
            }
            w as usize
        })
        .collect()
}

/// For every pixel, the largest `h ≤ cap` such that the in-image pixels of its row within
/// `h` columns all carry its label. `labels`: `[H, W]`. Returns `[H, W]`.
fn row_constancy(labels: &Plane<u32>, cap: usize) -> Vec<u8> {
    let (w, h) = labels.size();
    let mut out = vec![0u8; w * h];
    for y in 0..h {
        let row = labels.row(y);
        let out_row = &mut out[y * w..(y + 1) * w];
        // Distance to the previous different label (left), capped; image edges are "far".
        let mut run_start = 0usize;
        for x in 0..w {
            if x > 0 && row[x] != row[x - 1] {
                run_start = x;
            }
            let left = if run_start == 0 { cap } else { (x - run_start).min(cap) };
            out_row[x] = left as u8;
        }
        let mut run_end = w - 1;
        for x in (0..w).rev() {
            if x + 1 < w && row[x] != row[x + 1] {
                run_end = x;
            }
            let right = if run_end == w - 1 { cap } else { (run_end - x).min(cap) };
            out_row[x] = out_row[x].min(right as u8);
        }
    }
    out
}

/// For every pixel, the column of the last pixel of its run of equal labels in its row.
/// `labels`: `[H, W]`. Returns `[H, W]`.
fn run_ends(labels: &Plane<u32>) -> Vec<u32> {
    let (w, h) = labels.size();
    let mut out = vec![0u32; w * h];
    for y in 0..h {
        let row = labels.row(y);
        let out_row = &mut out[y * w..(y + 1) * w];
        let mut end = w.saturating_sub(1);
        for x in (0..w).rev() {
            if x + 1 < w && row[x] != row[x + 1] {
                end = x;
            }
            out_row[x] = end as u32;
        }
    }
    out
}

/// Precomputed state to enumerate the band pixels of one label map.
pub struct BandScanner<'a> {
    labels: &'a Plane<u32>,
    half_widths: Vec<usize>,
    radius: usize,
    row_const: Vec<u8>,
    /// `[H, W]`: for each pixel, the column of the last pixel of its row run (same label).
    run_end: Vec<u32>,
}

impl<'a> BandScanner<'a> {
    /// Prepares the scan of `labels` (`[H, W]`) with a disk of `radius_px`.
    pub fn new(labels: &'a Plane<u32>, radius_px: u32) -> Self {
        let radius = radius_px as usize;
        let cap = (radius + 1).min(u8::MAX as usize);
        BandScanner {
            labels,
            half_widths: disk_row_half_widths(radius_px),
            radius,
            row_const: row_constancy(labels, cap),
            run_end: run_ends(labels),
        }
    }

    /// True when every in-image pixel of the disk around `(x, y)` carries the label of `(x, y)`.
    #[inline]
    fn is_uniform(&self, x: usize, y: usize) -> bool {
        let (w, h) = self.labels.size();
        let label = self.labels.data[y * w + x];
        let y0 = y.saturating_sub(self.radius);
        let y1 = (y + self.radius).min(h - 1);
        (y0..=y1).all(|yy| {
            let i = yy * w + x;
            let half = self.half_widths[yy + self.radius - y];
            self.labels.data[i] == label && self.row_const[i] as usize >= half
        })
    }

    /// Calls `visit(x, y, labels_in_disk)` for every pixel of row `y` whose disk holds at
    /// least two labels; `labels_in_disk` is sorted and deduplicated (the pixel lies in the band
    /// of each of them). `scratch` is reused storage.
    pub fn scan_row(&self, y: usize, scratch: &mut Vec<u32>, mut visit: impl FnMut(usize, &[u32])) {
        let (w, h) = self.labels.size();
        for x in 0..w {
            if self.is_uniform(x, y) {
                continue;
            }
            scratch.clear();
            let y0 = y.saturating_sub(self.radius);
            let y1 = (y + self.radius).min(h - 1);
            for yy in y0..=y1 {
                let half = self.half_widths[yy + self.radius - y];
                let row = self.labels.row(yy);
                let x0 = x.saturating_sub(half);
                let x1 = (x + half).min(w - 1);
                // Visit one pixel per run of the row segment.
                let run_end = &self.run_end[yy * w..(yy + 1) * w];
                let mut xx = x0;
                while xx <= x1 {
                    let l = row[xx];
                    if !scratch.contains(&l) {
                        scratch.push(l);
                    }
                    xx = run_end[xx] as usize + 1;
                }
            }
            scratch.sort_unstable();
            visit(x, scratch);
        }
    }
}

/// The band of one binary mask, computed literally as dilation minus erosion with the disk
/// (out-of-image pixels ignored). `mask`: `[H, W]`. Slow (`O(H·W·ε²)`): a reference for tests
/// and small images.
pub fn band_of_mask_reference(mask: &Plane<bool>, radius_px: u32) -> Plane<bool> {
    let (w, h) = mask.size();
    let r = radius_px as i64;
    let mut out = Plane::filled(w, h, false);
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let (mut any_in, mut all_in) = (false, true);
            for dy in -r..=r {
                for dx in -r..=r {
                    let (xx, yy) = (x + dx, y + dy);
                    if dx * dx + dy * dy > r * r || xx < 0 || yy < 0 || xx >= w as i64 || yy >= h as i64 {
                        continue;
                    }
                    let m = *mask.get(xx as usize, yy as usize);
                    any_in |= m;
                    all_in &= m;
                }
            }
            *out.get_mut(x as usize, y as usize) = any_in && !all_in;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn band_of_label(labels: &Plane<u32>, g: u32, radius: u32) -> Plane<bool> {
        let scanner = BandScanner::new(labels, radius);
        let mut out = Plane::filled(labels.width, labels.height, false);
        let mut scratch = Vec::new();
        for y in 0..labels.height {
            scanner.scan_row(y, &mut scratch, |x, s| {
                if s.contains(&g) {
                    *out.get_mut(x, y) = true;
                }
            });
        }
        out
    }

    fn count(p: &Plane<bool>) -> usize {
        p.data.iter().filter(|b| **b).count()
    }

    #[test]
    fn disk_of_radius_five_has_81_pixels() {
        let hw = disk_row_half_widths(5);
        assert_eq!(hw, vec![0, 3, 4, 4, 4, 5, 4, 4, 4, 3, 0]);
        assert_eq!(hw.iter().map(|w| 2 * w + 1).sum::<usize>(), 81);
    }

    #[test]
    fn single_pixel_band_is_the_disk() {
        // Erosion of one pixel is empty, dilation is the 81-pixel disk (a square would be 121).
        let mut labels = Plane::filled(21, 21, 0u32);
        *labels.get_mut(10, 10) = 1;
        let band = band_of_label(&labels, 1, 5);
        assert_eq!(count(&band), 81);
        assert!(*band.get(15, 10) && *band.get(13, 14) && !band.get(14, 14));
    }

    #[test]
    fn square_band_is_rounded_dilation_minus_shrunk_square() {
        // 15×15 square: dilation = 15² + 4·15·5 + 4·15 (quarter-disk corners) = 585,
        // erosion = 5×5 = 25, band = 560.
        let mut labels = Plane::filled(31, 31, 0u32);
        for y in 8..23 {
            for x in 8..23 {
                *labels.get_mut(x, y) = 4;
            }
        }
        assert_eq!(count(&band_of_label(&labels, 4, 5)), 560);
        // The background's band is the same set (two labels only).
        assert_eq!(band_of_label(&labels, 0, 5), band_of_label(&labels, 4, 5));
    }

    #[test]
    fn image_border_is_not_a_boundary() {
        // Left half label 1, right half label 2, 3 rows: the band is columns 5..=14 only.
        let labels =
            Plane::from_vec(20, 3, (0..60).map(|i| if i % 20 < 10 { 1 } else { 2 }).collect()).unwrap();
        let band = band_of_label(&labels, 1, 5);
        assert_eq!(count(&band), 30);
        for y in 0..3 {
            for x in 0..20 {
                assert_eq!(*band.get(x, y), (5..=14).contains(&x), "({x},{y})");
            }
        }
    }

    #[test]
    fn matches_literal_morphology_on_random_maps() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for trial in 0..12 {
            let (w, h) = (rng.gen_range(1..40), rng.gen_range(1..40));
            // Blobby maps: a few random rectangles painted over a background.
            let mut labels = Plane::filled(w, h, 0u32);
            for _ in 0..rng.gen_range(0..6) {
                let id = rng.gen_range(1..5);
                let (x0, y0) = (rng.gen_range(0..w), rng.gen_range(0..h));
                let (x1, y1) = (rng.gen_range(x0..w), rng.gen_range(y0..h));
                for y in y0..=y1 {
                    for x in x0..=x1 {
                        *labels.get_mut(x, y) = id;
                    }
                }
            }
            // Plus salt noise so thin structures are covered.
            for _ in 0..rng.gen_range(0..8) {
                let (x, y) = (rng.gen_range(0..w), rng.gen_range(0..h));
                *labels.get_mut(x, y) = rng.gen_range(0..5);
            }
            let radius = [5, 1, 2, 0][trial % 4];
            for g in 0..5 {
                let mask = labels.map(|l| *l == g);
                let expected = band_of_mask_reference(&mask, radius);
                assert_eq!(
                    band_of_label(&labels, g, radius),
                    expected,
                    "trial {trial}, label {g}, r {radius}"
                );
            }
        }
    }
}
