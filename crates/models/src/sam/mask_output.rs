//! One low-resolution mask to the automatic mask generator's outputs without intermediate images: the
//! upscaled logits go into buffers reused across masks, and the box and the column-major RLE are read
//! straight from them (`logits > 0` is the mask). Same results as thresholding into a mask, taking
//! [`super::masks::mask_box`], placing it in the image and [`Rle::encode`] (tested).

use splatseg_scene::rle::Rle;

use crate::resample::{resize_plane_into, AxisTaps};

/// Buffers reused across the masks one worker handles.
#[derive(Debug, Default)]
pub struct MaskScratch {
    columns: Vec<f32>,
    logits: Vec<f32>,
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
    use crate::sam::masks::mask_box;

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
