//! A bound of a mask's stability score read from its low-resolution logits, so that the automatic
//! mask generator upscales only the masks that may pass the stability filter, and keeps exactly the
//! masks it kept before.
//!
//! The stability score counts the upscaled logits above `+offset` (the intersection) and above
//! `−offset` (the union). Upscaling is bilinear twice over (to SAM's square input, then to the
//! image), so each upscaled logit is a weighted mean (non-negative weights summing to at most one)
//! of a small window of low-resolution logits and lies between their minimum and maximum (and 0).
//! A pixel can then be in the intersection only where its window's maximum exceeds `offset`, and is
//! surely in the union where its window's minimum exceeds `−offset`: counting both over the image
//! bounds the intersection from above and the union from below, so the score from above. Outputs
//! with the same window come in runs, so the counts cost about as much as reading the low-resolution
//! logits once per run, not one pass over the image. A margin of 1e-4 of the largest logit keeps the
//! bound safe from the upscaling's f32 rounding.

use crate::resample::AxisTaps;

/// A run of consecutive output rows (or columns) reading the same low-resolution rows (columns),
/// `first..=last` (empty when `first > last`: the outputs read nothing and are 0).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Window {
    first: usize,
    last: usize,
    outputs: u64,
}

/// The runs of windows of both axes of one upscaling.
#[derive(Debug, Clone)]
pub struct StabilityBound {
    rows: Vec<Window>,
    /// The column runs that read something.
    cols: Vec<Window>,
    /// Output columns that read nothing (their logits are 0).
    empty_col_outputs: u64,
    /// Output columns in all.
    col_outputs: u64,
    low_size: (usize, usize),
}

/// Runs of equal windows of one axis, clamped to `low_len` inputs; `None` when the taps are not
/// convex.
fn runs(taps: &AxisTaps, low_len: usize) -> Option<Vec<Window>> {
    let mut runs: Vec<Window> = Vec::new();
    for window in taps.convex_windows()? {
        let (first, last) = match window {
            Some((first, last)) if first < low_len => (first, last.min(low_len - 1)),
            _ => (1, 0),
        };
        match runs.last_mut() {
            Some(run) if (run.first, run.last) == (first, last) => run.outputs += 1,
            _ => runs.push(Window { first, last, outputs: 1 }),
        }
    }
    Some(runs)
}

impl StabilityBound {
    /// The bound for masks upscaled by `rows` and `cols` (as [`crate::sam::Sam::upscale_taps`]
    /// makes them) from `low_size` = (height, width); `None` when an axis is not a weighted mean of
    /// its inputs (the generator then upscales every mask).
    pub fn new(rows: &AxisTaps, cols: &AxisTaps, low_size: (usize, usize)) -> Option<StabilityBound> {
        let all_cols = runs(cols, low_size.1)?;
        let col_outputs = all_cols.iter().map(|w| w.outputs).sum();
        let (cols, empty): (Vec<Window>, Vec<Window>) = all_cols.into_iter().partition(|w| w.first <= w.last);
        Some(StabilityBound {
            rows: runs(rows, low_size.0)?,
            cols,
            empty_col_outputs: empty.iter().map(|w| w.outputs).sum(),
            col_outputs,
            low_size,
        })
    }

    /// Whether the stability score (threshold 0, `offset`) of `low` `[lh·lw]` upscaled is surely
    /// below `thresh`, so that the mask fails the filter `score >= thresh` (as a NaN score does).
    /// `false` whenever it cannot be sure: a threshold ≤ 0, an offset within the margin of 0, a
    /// NaN logit.
    pub fn surely_unstable(&self, low: &[f32], offset: f32, thresh: f32) -> bool {
        let (lh, lw) = self.low_size;
        if thresh <= 0.0 || low.len() != lh * lw {
            return false;
        }
        let mut largest = 0f32;
        for &v in low {
            if v.is_nan() {
                return false;
            }
            largest = largest.max(v.abs());
        }
        let margin = 1e-4 * (1.0 + largest);
        if offset <= margin {
            return false;
        }
        let (above_high, above_low) = (offset - margin, -offset + margin);
        let (mut col_max, mut col_min) = (vec![0f32; lw], vec![0f32; lw]);
        // per low-resolution column, prefix counts of the columns whose maximum may pass +offset
        // and of those whose minimum may not pass −offset
        let (mut may_pass_high, mut may_fail_low) = (vec![0u32; lw + 1], vec![0u32; lw + 1]);
        let (mut intersection_at_most, mut union_at_least) = (0u64, 0u64);
        for rows in &self.rows {
            if rows.first > rows.last {
                // these outputs read nothing: logits 0, in the union only
                union_at_least += rows.outputs * self.col_outputs;
                continue;
            }
            col_max.copy_from_slice(&low[rows.first * lw..(rows.first + 1) * lw]);
            col_min.copy_from_slice(&col_max);
            for r in rows.first + 1..=rows.last {
                let row = &low[r * lw..(r + 1) * lw];
                for ((hi, lo), &v) in col_max.iter_mut().zip(col_min.iter_mut()).zip(row) {
                    *hi = hi.max(v);
                    *lo = lo.min(v);
                }
            }
            for c in 0..lw {
                may_pass_high[c + 1] = may_pass_high[c] + u32::from(col_max[c] > above_high);
                may_fail_low[c + 1] = may_fail_low[c] + u32::from(col_min[c] <= above_low);
            }
            let (mut high_cols, mut low_cols) = (0u64, self.empty_col_outputs);
            for cols in &self.cols {
                let (first, end) = (cols.first, cols.last + 1);
                if may_pass_high[end] != may_pass_high[first] {
                    high_cols += cols.outputs;
                }
                if may_fail_low[end] == may_fail_low[first] {
                    low_cols += cols.outputs;
                }
            }
            intersection_at_most += rows.outputs * high_cols;
            union_at_least += rows.outputs * low_cols;
        }
        // No pixel can be above +offset: the score is 0 (or NaN), below any positive threshold.
        intersection_at_most == 0 || (intersection_at_most as f32 / union_at_least as f32) < thresh
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::resample::{resize_plane_into, AxisResize, Resample};
    use crate::sam::masks::stability_score;

    /// SAM's two bilinear steps for one axis: `low` → `square` → the first `input` of them → `original`.
    fn sam_axis(low: usize, square: usize, input: usize, original: usize) -> AxisTaps {
        let to_square = AxisTaps::new(AxisResize::to_len(low, square), Resample::Bilinear);
        let to_original = AxisTaps::new(AxisResize::to_len(input, original), Resample::Bilinear);
        to_original.compose(&to_square, low)
    }

    /// Low-resolution logits: a disc of radius `radius` (in low pixels) with the given edge
    /// sharpness, plus noise of amplitude `noise`, from a seed.
    fn blob(size: (usize, usize), radius: f32, sharpness: f32, noise: f32, seed: u32) -> Vec<f32> {
        let mut state = seed.wrapping_mul(747_796_405).wrapping_add(1);
        let (cy, cx) = (size.0 as f32 * 0.45, size.1 as f32 * 0.55);
        (0..size.0 * size.1)
            .map(|i| {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let n = (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5;
                let (y, x) = ((i / size.1) as f32, (i % size.1) as f32);
                let d = ((y - cy).powi(2) + (x - cx).powi(2)).sqrt();
                (radius - d) * sharpness + n * noise
            })
            .collect()
    }

    #[test]
    fn the_bound_never_rejects_a_stable_mask_and_rejects_clearly_unstable_ones() {
        // 64² low-resolution logits of a 256² SAM input, for a 120×160 image (input 192×256).
        let low_size = (64, 64);
        let (rows, cols) = (sam_axis(64, 256, 192, 120), sam_axis(64, 256, 256, 160));
        let bound = StabilityBound::new(&rows, &cols, low_size).expect("bilinear taps are convex");
        let (mut tmp, mut full) = (Vec::new(), vec![0f32; 120 * 160]);
        let (mut rejected, mut unstable) = (0, 0);
        let mut seed = 0;
        for radius in [3.0, 8.0, 20.0] {
            for sharpness in [0.05, 0.3, 2.0, 20.0] {
                for noise in [0.0, 1.0, 4.0, 30.0] {
                    seed += 1;
                    let low = blob(low_size, radius, sharpness, noise, seed);
                    resize_plane_into(&low, &rows, &cols, low_size, &mut tmp, &mut full);
                    let exact = stability_score(&full, 0.0, 1.0);
                    for thresh in [0.5, 0.8, 0.95] {
                        let surely = bound.surely_unstable(&low, 1.0, thresh);
                        assert!(
                            !(surely && exact >= thresh),
                            "radius {radius}, sharpness {sharpness}, noise {noise}: rejected at {thresh} a \
                             mask of stability {exact}"
                        );
                        // clearly unstable: more than 0.15 below the threshold
                        if exact < thresh - 0.15 || exact.is_nan() {
                            unstable += 1;
                            rejected += surely as usize;
                        }
                    }
                }
            }
        }
        assert!(unstable >= 20, "the cases hold {unstable} clearly unstable masks");
        // Noisy logits widen every window's extremes, so the bound cannot catch them all (34 of 70
        // here); it must catch a good part, or it saves nothing.
        assert!(rejected * 10 >= unstable * 4, "rejected {rejected} of {unstable} clearly unstable masks");
    }

    #[test]
    fn no_rejection_without_a_positive_threshold_or_with_nan() {
        let low_size = (16, 16);
        let (rows, cols) = (sam_axis(16, 64, 48, 30), sam_axis(16, 64, 64, 40));
        let bound = StabilityBound::new(&rows, &cols, low_size).unwrap();
        let flat = vec![-5.0f32; 256];
        assert!(bound.surely_unstable(&flat, 1.0, 0.95), "nothing above +1: score 0 or NaN");
        assert!(!bound.surely_unstable(&flat, 1.0, 0.0), "a threshold of 0 passes a score of 0");
        let mut nan = flat.clone();
        nan[3] = f32::NAN;
        assert!(!bound.surely_unstable(&nan, 1.0, 0.95));
        // bicubic taps can overshoot: no bound
        let cubic = AxisTaps::new(AxisResize::to_len(16, 40), Resample::Bicubic);
        assert!(StabilityBound::new(&cubic, &cols, low_size).is_none());
    }
}
