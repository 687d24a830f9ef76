//! One low-resolution mask to the automatic mask generator's outputs without a full-resolution image
//! of logits: [`MaskScratch::upscale_and_measure`] forms the upscaled logits one row at a time (the
//! same arithmetic as [`resize_plane_into`], so the same values) and, while the row is in L1, counts
//! the stability score's pixels, finds the box and keeps the mask (`logits > 0`) as one byte per
//! pixel; [`MaskScratch::positive_rle`] then reads the column-major COCO RLE off those bytes by rows:
//! a run starts where a pixel differs from the one above it (or, in the first row, from the last of
//! the previous column), so only the changes are visited in column order, never the plane. Same
//! results as thresholding the upscaled logits into a mask, [`stability_score`], [`super::masks::mask_box`]
//! and [`Rle::encode`] (tested). [`MaskScratch::upscale`], [`positive_box`] and [`positive_rle`] are
//! the plain per-step forms (the plane stored, the RLE walked down the columns), kept to time and
//! test against.
//!
//! [`stability_score`]: super::masks::stability_score

use splatseg_scene::rle::Rle;

use crate::resample::{resize_columns_by_columns_into, resize_plane_into, resize_row_from_columns, AxisTaps};

/// Buffers reused across the masks one worker handles.
#[derive(Debug, Default)]
pub struct MaskScratch {
    columns: Vec<f32>,
    /// The transposed planes of [`resize_columns_by_columns_into`].
    transposed: Vec<f32>,
    logits: Vec<f32>,
    /// One upscaled row.
    row: Vec<f32>,
    /// The mask of the last [`MaskScratch::upscale_and_measure`], `[height, width]` row-major, 1 = `logits > 0`.
    mask: Vec<u8>,
    mask_size: (usize, usize),
    /// Changes found by [`MaskScratch::positive_rle`]: (column, row), then sorted by column.
    changes: Vec<(u32, u32)>,
    by_column: Vec<(u32, u32)>,
    column_counts: Vec<u32>,
}

/// What [`MaskScratch::upscale_and_measure`] reads from a mask's upscaled logits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaskMeasures {
    /// Pixels with a logit above `+offset`.
    pub above_high: u64,
    /// Pixels with a logit above `−offset`.
    pub above_low: u64,
    /// [`positive_box`] of the logits.
    pub box_xyxy: [f32; 4],
}

impl MaskMeasures {
    /// SAM's stability score (threshold 0): `above_high / above_low` (NaN when both are 0).
    pub fn stability(&self) -> f32 {
        self.above_high as f32 / self.above_low as f32
    }
}

impl MaskScratch {
    /// Logits `[rows.out_len, cols.out_len]` of the low-resolution `low` `[lh, lw]`.
    pub fn upscale(
        &mut self,
        low: &[f32],
        rows: &AxisTaps,
        cols: &AxisTaps,
        low_size: (usize, usize),
    ) -> &[f32] {
        self.logits.resize(rows.out_len() * cols.out_len(), 0.0);
        resize_plane_into(low, rows, cols, low_size, &mut self.columns, &mut self.logits);
        &self.logits
    }

    /// Upscales `low` `[lh, lw]` row by row (the values of [`MaskScratch::upscale`]) without storing
    /// the logits: the counts of the stability score with `offset`, the box of `logits > 0`, and the
    /// mask kept for [`MaskScratch::positive_rle`].
    pub fn upscale_and_measure(
        &mut self,
        low: &[f32],
        rows: &AxisTaps,
        cols: &AxisTaps,
        low_size: (usize, usize),
        offset: f32,
    ) -> MaskMeasures {
        let (height, width) = (rows.out_len(), cols.out_len());
        resize_columns_by_columns_into(low, cols, low_size, &mut self.columns, &mut self.transposed);
        self.row.resize(width, 0.0);
        self.mask.resize(height * width, 0);
        self.mask_size = (height, width);
        let (high, low_level) = (offset, -offset);
        let (mut above_high, mut above_low) = (0u64, 0u64);
        let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0usize, 0usize);
        for (y, mask_row) in self.mask.chunks_exact_mut(width.max(1)).take(height).enumerate() {
            resize_row_from_columns(&self.columns, rows, low_size.0, y, &mut self.row);
            let (mut high_count, mut low_count, mut positive) = (0u32, 0u32, 0u32);
            for (m, &v) in mask_row.iter_mut().zip(&self.row) {
                let is_positive = u8::from(v > 0.0);
                *m = is_positive;
                positive += u32::from(is_positive);
                high_count += u32::from(v > high);
                low_count += u32::from(v > low_level);
            }
            above_high += u64::from(high_count);
            above_low += u64::from(low_count);
            if positive > 0 {
                let first = mask_row.iter().position(|&m| m != 0).unwrap_or(0);
                let last = mask_row.iter().rposition(|&m| m != 0).unwrap_or(first);
                x0 = x0.min(first);
                x1 = x1.max(last);
                y0 = y0.min(y);
                y1 = y;
            }
        }
        let box_xyxy = if x0 == usize::MAX { [0.0; 4] } else { [x0 as f32, y0 as f32, x1 as f32, y1 as f32] };
        MaskMeasures { above_high, above_low, box_xyxy }
    }

    /// [`positive_rle`] of the mask the last [`MaskScratch::upscale_and_measure`] kept (`crop`'s
    /// size), placed at `crop` (`[x0, y0, x1, y1]`) in a `height × width` image, read by rows.
    pub fn positive_rle(&mut self, crop: &[usize; 4], (height, width): (usize, usize)) -> Rle {
        let (crop_h, crop_w) = self.mask_size;
        debug_assert_eq!((crop[3] - crop[1], crop[2] - crop[0]), (crop_h, crop_w));
        let mask = &self.mask[..crop_h * crop_w];
        // pixel (x, y) of the image: inside the crop, the mask; outside, false
        let at = |x: usize, y: usize| -> bool {
            (crop[0]..crop[2]).contains(&x) && (crop[1]..crop[3]).contains(&y) && {
                mask[(y - crop[1]) * crop_w + x - crop[0]] != 0
            }
        };
        self.changes.clear();
        // the first row: each pixel against the last pixel of the previous column (false before the
        // first); only columns crop[0] ..= crop[2] can differ
        for x in crop[0]..(crop[2] + 1).min(width) {
            let before = x > 0 && at(x - 1, height - 1);
            if at(x, 0) != before {
                self.changes.push((x as u32, 0));
            }
        }
        // the other rows: each pixel against the one above it; rows outside the crop are false, so
        // only rows crop[1] ..= crop[3] can differ from theirs, and only in the crop's columns
        for y in crop[1].max(1)..(crop[3] + 1).min(height) {
            let (above, here) = (crop_row(mask, crop, y - 1), crop_row(mask, crop, y));
            push_row_changes(above, here, crop_w, (crop[0], y), &mut self.changes);
        }
        // column-major order: a counting sort by column keeps each column's rows in order
        self.column_counts.clear();
        self.column_counts.resize(width + 1, 0);
        for &(x, _) in &self.changes {
            self.column_counts[x as usize + 1] += 1;
        }
        for x in 0..width {
            self.column_counts[x + 1] += self.column_counts[x];
        }
        self.by_column.clear();
        self.by_column.resize(self.changes.len(), (0, 0));
        for &(x, y) in &self.changes {
            let slot = &mut self.column_counts[x as usize];
            self.by_column[*slot as usize] = (x, y);
            *slot += 1;
        }
        let mut counts = Vec::with_capacity(self.by_column.len() + 1);
        let mut last = 0u64;
        for &(x, y) in &self.by_column {
            let at = x as u64 * height as u64 + y as u64;
            counts.push((at - last) as u32);
            last = at;
        }
        counts.push((height as u64 * width as u64 - last) as u32);
        Rle { height: height as u32, width: width as u32, counts }
    }
}

/// Row `y` of the image within `crop`'s columns: the mask's row inside the crop, empty (all false)
/// outside.
fn crop_row<'a>(mask: &'a [u8], crop: &[usize; 4], y: usize) -> &'a [u8] {
    let crop_w = crop[2] - crop[0];
    match (crop[1]..crop[3]).contains(&y) {
        true => &mask[(y - crop[1]) * crop_w..(y - crop[1] + 1) * crop_w],
        false => &[],
    }
}

/// Appends `(x0 + x, y)` for every `x < len` where `here[x]` differs from `above[x]` (an empty
/// slice is a row of zeros), comparing eight bytes at a time.
fn push_row_changes(
    above: &[u8],
    here: &[u8],
    len: usize,
    (x0, y): (usize, usize),
    changes: &mut Vec<(u32, u32)>,
) {
    let word = |row: &[u8], i: usize| -> u64 {
        match row.get(i..i + 8) {
            Some(bytes) => u64::from_le_bytes(bytes.try_into().unwrap_or([0; 8])),
            None => 0,
        }
    };
    let byte = |row: &[u8], i: usize| row.get(i).copied().unwrap_or(0);
    let whole = len / 8 * 8;
    for i in (0..whole).step_by(8) {
        let mut diff = word(above, i) ^ word(here, i);
        while diff != 0 {
            let x = i + diff.trailing_zeros() as usize / 8;
            changes.push(((x0 + x) as u32, y as u32));
            diff &= !(0xffu64 << ((x - i) * 8));
        }
    }
    for x in whole..len {
        if byte(above, x) != byte(here, x) {
            changes.push(((x0 + x) as u32, y as u32));
        }
    }
}

/// Box `[x0, y0, x1, y1]` (inclusive pixel indices) of `logits > 0` for logits `[H, width]`; all
/// zeros when nothing is positive (SAM's `batched_mask_to_box`).
pub fn positive_box(logits: &[f32], width: usize) -> [f32; 4] {
    let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0usize, 0usize);
    if width == 0 {
        return [0.0; 4];
    }
    for (y, row) in logits.chunks_exact(width).enumerate() {
        if let Some(first) = row.iter().position(|&v| v > 0.0) {
            let last = row.iter().rposition(|&v| v > 0.0).unwrap_or(first);
            x0 = x0.min(first);
            x1 = x1.max(last);
            y0 = y0.min(y);
            y1 = y;
        }
    }
    if x0 == usize::MAX {
        return [0.0; 4];
    }
    [x0 as f32, y0 as f32, x1 as f32, y1 as f32]
}

/// Runs of equal values in column-major order, starting with a (possibly empty) run of `false`.
struct Runs {
    counts: Vec<u32>,
    current: bool,
    run: u32,
}

impl Runs {
    fn push(&mut self, value: bool) {
        if value != self.current {
            self.counts.push(self.run);
            self.run = 0;
            self.current = value;
        }
        self.run += 1;
    }

    fn push_false(&mut self, n: usize) {
        if n == 0 {
            return;
        }
        if self.current {
            self.counts.push(self.run);
            self.run = 0;
            self.current = false;
        }
        self.run += n as u32;
    }
}

/// COCO RLE (column-major) of the `height × width` image whose pixels inside `crop` (`[x0, y0, x1,
/// y1]`) are `logits > 0` (logits `[y1 − y0, x1 − x0]`) and `false` elsewhere.
pub fn positive_rle(logits: &[f32], crop: &[usize; 4], (height, width): (usize, usize)) -> Rle {
    let crop_w = crop[2] - crop[0];
    let mut runs = Runs { counts: Vec::new(), current: false, run: 0 };
    for x in 0..width {
        if x < crop[0] || x >= crop[2] {
            runs.push_false(height);
            continue;
        }
        runs.push_false(crop[1]);
        for y in crop[1]..crop[3] {
            runs.push(logits[(y - crop[1]) * crop_w + x - crop[0]] > 0.0);
        }
        runs.push_false(height - crop[3]);
    }
    let Runs { mut counts, run, .. } = runs;
    if run > 0 || counts.is_empty() {
        counts.push(run);
    }
    Rle { height: height as u32, width: width as u32, counts }
}

#[cfg(test)]
mod tests {
    use splatseg_scene::Plane;

    use super::*;
    use crate::resample::{AxisResize, Resample};
    use crate::sam::masks::{mask_box, stability_score};

    /// SAM's two bilinear steps for one axis: `low` → `square` → the first `input` of them → `original`.
    fn sam_axis(low: usize, square: usize, input: usize, original: usize) -> AxisTaps {
        let to_square = AxisTaps::new(AxisResize::to_len(low, square), Resample::Bilinear);
        let to_original = AxisTaps::new(AxisResize::to_len(input, original), Resample::Bilinear);
        to_original.compose(&to_square, low)
    }

    /// Low-resolution logits of one kind: a disc, noise, all negative, all positive, a corner.
    fn low_logits(kind: usize, (lh, lw): (usize, usize), seed: u32) -> Vec<f32> {
        let mut state = seed.wrapping_mul(747_796_405).wrapping_add(1);
        (0..lh * lw)
            .map(|i| {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let noise = (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5;
                let (y, x) = ((i / lw) as f32, (i % lw) as f32);
                match kind {
                    0 => 6.0 - ((y - lh as f32 * 0.4).powi(2) + (x - lw as f32 * 0.6).powi(2)).sqrt() + noise,
                    1 => noise * 8.0,
                    2 => -3.0,
                    3 => 2.0,
                    _ => 1.5 - x - y + noise,
                }
            })
            .collect()
    }

    #[test]
    fn the_row_pass_gives_the_plain_steps_stability_box_and_rle() {
        let low_size = (16, 16);
        let mut scratch = MaskScratch::default();
        let mut plain = MaskScratch::default();
        let mut compared = 0;
        // (crop height, width) upscaled from 16² placed in images of (height, width) at crops
        for ((ch, cw), (height, width), at) in [
            ((30, 41), (30, 41), (0, 0)),
            ((29, 40), (45, 60), (0, 0)),
            ((29, 40), (45, 60), (12, 16)),
            ((29, 40), (45, 60), (0, 16)),
            ((29, 40), (41, 60), (12, 0)),
            ((33, 17), (40, 30), (3, 7)),
        ] {
            let rows = sam_axis(16, 64, 64 * ch / ch.max(cw), ch);
            let cols = sam_axis(16, 64, 64 * cw / ch.max(cw), cw);
            let crop = [at.1, at.0, at.1 + cw, at.0 + ch];
            assert!(crop[2] <= width && crop[3] <= height, "the crop {crop:?} lies in the image");
            for kind in 0..5 {
                for offset in [0.5f32, 1.0] {
                    let low = low_logits(kind, low_size, (kind * 7 + ch) as u32);
                    let measures = scratch.upscale_and_measure(&low, &rows, &cols, low_size, offset);
                    let logits = plain.upscale(&low, &rows, &cols, low_size);
                    let (want, got) = (stability_score(logits, 0.0, offset), measures.stability());
                    assert!(want.to_bits() == got.to_bits(), "kind {kind}: stability {got} vs {want}");
                    assert_eq!(measures.box_xyxy, positive_box(logits, cw), "kind {kind}");
                    let rle = scratch.positive_rle(&crop, (height, width));
                    assert_eq!(
                        rle,
                        positive_rle(logits, &crop, (height, width)),
                        "kind {kind}, crop {crop:?}"
                    );
                    compared += 1;
                }
            }
        }
        assert_eq!(compared, 60);
    }

    #[test]
    fn row_changes_are_found_in_every_byte_of_a_word_and_in_the_tail() {
        let above = [0u8, 1, 1, 0, 0, 0, 0, 1, 1, 0, 1];
        let here = [1u8, 1, 0, 0, 0, 0, 1, 1, 0, 0, 0];
        let mut changes = Vec::new();
        push_row_changes(&above, &here, 11, (5, 2), &mut changes);
        assert_eq!(changes, [(5, 2), (7, 2), (11, 2), (13, 2), (15, 2)]);
        changes.clear();
        push_row_changes(&[], &here, 11, (0, 1), &mut changes);
        assert_eq!(changes, [(0, 1), (1, 1), (6, 1), (7, 1)]);
    }

    #[test]
    fn box_and_rle_match_thresholding_the_mask() {
        let (ch, cw) = (7, 9);
        let mut state = 12u32;
        let logits: Vec<f32> = (0..ch * cw)
            .map(|_| {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                (state >> 8) as f32 / (1u32 << 24) as f32 - 0.7
            })
            .collect();
        let mask = Plane::from_vec(cw, ch, logits.iter().map(|&v| v > 0.0).collect()).unwrap();
        assert_eq!(positive_box(&logits, cw), mask_box(&mask));
        assert_eq!(positive_rle(&logits, &[0, 0, cw, ch], (ch, cw)), Rle::encode(&mask));
        // the crop placed at (3, 2) in a 13×11 image
        let (height, width) = (11, 13);
        let mut full = Plane::filled(width, height, false);
        for y in 0..ch {
            for x in 0..cw {
                *full.get_mut(3 + x, 2 + y) = *mask.get(x, y);
            }
        }
        assert_eq!(positive_rle(&logits, &[3, 2, 3 + cw, 2 + ch], (height, width)), Rle::encode(&full));
        // empty, and positive in the first pixel
        let none = vec![-1.0; 6];
        assert_eq!(positive_box(&none, 3), [0.0; 4]);
        assert_eq!(positive_rle(&none, &[0, 0, 3, 2], (2, 3)).counts, vec![6]);
        let first = [1.0, -1.0, -1.0, -1.0];
        assert_eq!(positive_rle(&first, &[0, 0, 2, 2], (2, 2)).counts, vec![0, 1, 3]);
    }
}
