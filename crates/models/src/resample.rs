//! Separable image resampling with PyTorch's `interpolate` semantics (bicubic with and without
//! antialiasing, bilinear with and without aligned corners), on `[C, H, W]` f32 tensors.
//!
//! Each output row/column is a short weighted sum of input rows/columns; the taps per axis are
//! computed once ([`AxisTaps`]) and applied to every channel in parallel.

use candle_core::{Device, Tensor};
use rayon::prelude::*;

use crate::error::{ModelsError, ModelsResult};

/// Which interpolation and how output positions map onto input positions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Resample {
    /// `mode="bicubic", align_corners=False, antialias=False` (Keys' cubic, a = −0.75, clamped borders).
    Bicubic,
    /// `mode="bicubic", antialias=True` (a = −0.5, support widened by the scale when shrinking).
    BicubicAntialias,
    /// `mode="bilinear", align_corners=False`.
    Bilinear,
    /// `mode="bilinear", align_corners=True`.
    BilinearAlignCorners,
}

/// How one axis is resized: lengths and the step between output samples, measured in input samples
/// (`in_len / out_len` when PyTorch is given a `size`, `1 / scale_factor` when it is given a factor).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisResize {
    /// Input length.
    pub in_len: usize,
    /// Output length.
    pub out_len: usize,
    /// Input samples per output sample.
    pub step: f64,
}

impl AxisResize {
    /// Resize to `out_len` samples (PyTorch's `size=`).
    pub fn to_len(in_len: usize, out_len: usize) -> Self {
        Self { in_len, out_len, step: in_len as f64 / out_len.max(1) as f64 }
    }
}

/// Per output sample: first input index and the weights of consecutive input samples.
#[derive(Debug, Clone)]
pub struct AxisTaps {
    /// `starts[o]`: first input index read by output `o`; `[out_len]`.
    starts: Vec<usize>,
    /// Weights, `taps_per_output` per output sample; `[out_len, taps_per_output]`.
    weights: Vec<f32>,
    taps_per_output: usize,
}

fn cubic(x: f64, a: f64) -> f64 {
    let x = x.abs();
    if x <= 1.0 {
        ((a + 2.0) * x - (a + 3.0)) * x * x + 1.0
    } else if x < 2.0 {
        (((x - 5.0) * x + 8.0) * x - 4.0) * a
    } else {
        0.0
    }
}

impl AxisTaps {
    /// The taps of one axis for `mode`.
    pub fn new(axis: AxisResize, mode: Resample) -> Self {
        let rows: Vec<Vec<(usize, f64)>> = (0..axis.out_len).map(|o| taps_of(axis, mode, o)).collect();
        Self::from_rows(rows)
    }

    fn from_rows(rows: Vec<Vec<(usize, f64)>>) -> Self {
        let mut starts = Vec::with_capacity(rows.len());
        let spans: Vec<(usize, usize)> = rows
            .iter()
            .map(|r| {
                let lo = r.iter().map(|t| t.0).min().unwrap_or(0);
                let hi = r.iter().map(|t| t.0).max().unwrap_or(0);
                (lo, hi)
            })
            .collect();
        let taps_per_output = spans.iter().map(|(lo, hi)| hi - lo + 1).max().unwrap_or(1);
        let mut weights = vec![0f32; rows.len() * taps_per_output];
        for (o, (row, (lo, _))) in rows.iter().zip(&spans).enumerate() {
            starts.push(*lo);
            for &(index, w) in row {
                weights[o * taps_per_output + index - lo] += w as f32;
            }
        }
        Self { starts, weights, taps_per_output }
    }

    fn out_len(&self) -> usize {
        self.starts.len()
    }
}

fn taps_of(axis: AxisResize, mode: Resample, o: usize) -> Vec<(usize, f64)> {
    let last = axis.in_len as i64 - 1;
    let clamp = |i: i64| i.clamp(0, last) as usize;
    match mode {
        Resample::Bicubic => {
            let src = (o as f64 + 0.5) * axis.step - 0.5;
            let floor = src.floor();
            let t = src - floor;
            (-1..3).map(|k| (clamp(floor as i64 + k), cubic(k as f64 - t, -0.75))).collect()
        }
        Resample::BicubicAntialias => {
            let scale = axis.step;
            let (support, inv) = if scale >= 1.0 { (2.0 * scale, 1.0 / scale) } else { (2.0, 1.0) };
            let center = scale * (o as f64 + 0.5);
            let lo = ((center - support + 0.5) as i64).max(0);
            let hi = ((center + support + 0.5) as i64).min(axis.in_len as i64);
            let raw: Vec<(usize, f64)> =
                (lo..hi).map(|j| (j as usize, cubic((j as f64 - center + 0.5) * inv, -0.5))).collect();
            let total: f64 = raw.iter().map(|t| t.1).sum();
            let norm = if total != 0.0 { 1.0 / total } else { 0.0 };
            raw.into_iter().map(|(j, w)| (j, w * norm)).collect()
        }
        Resample::Bilinear => {
            let src = ((o as f64 + 0.5) * axis.step - 0.5).max(0.0);
            let i0 = (src.floor() as i64).min(last);
            let lambda = src - i0 as f64;
            vec![(clamp(i0), 1.0 - lambda), (clamp(i0 + 1), lambda)]
        }
        Resample::BilinearAlignCorners => {
            let scale =
                if axis.out_len > 1 { (axis.in_len as f64 - 1.0) / (axis.out_len as f64 - 1.0) } else { 0.0 };
            let src = o as f64 * scale;
            let i0 = (src.floor() as i64).min(last);
            let lambda = src - i0 as f64;
            vec![(clamp(i0), 1.0 - lambda), (clamp(i0 + 1), lambda)]
        }
    }
}

/// Resizes `planes` (`[C, H, W]`, row-major) along both axes.
///
/// Returns `[C, rows.out_len, cols.out_len]`.
pub fn resize_planes(
    planes: &[f32],
    channels: usize,
    rows: &AxisTaps,
    cols: &AxisTaps,
    in_h: usize,
    in_w: usize,
) -> Vec<f32> {
    let (out_h, out_w) = (rows.out_len(), cols.out_len());
    let mut out = vec![0f32; channels * out_h * out_w];
    out.par_chunks_mut(out_h * out_w).zip(planes.par_chunks(in_h * in_w)).for_each(|(dst, src)| {
        // columns first: [in_h, out_w]
        let mut tmp = vec![0f32; in_h * out_w];
        for y in 0..in_h {
            let row = &src[y * in_w..(y + 1) * in_w];
            for x in 0..out_w {
                let start = cols.starts[x];
                let w = &cols.weights[x * cols.taps_per_output..(x + 1) * cols.taps_per_output];
                let mut acc = 0f32;
                for (k, wk) in w.iter().enumerate() {
                    if let Some(v) = row.get(start + k) {
                        acc += wk * v;
                    }
                }
                tmp[y * out_w + x] = acc;
            }
        }
        for y in 0..out_h {
            let start = rows.starts[y];
            let w = &rows.weights[y * rows.taps_per_output..(y + 1) * rows.taps_per_output];
            let dst_row = &mut dst[y * out_w..(y + 1) * out_w];
            for (k, wk) in w.iter().enumerate() {
                if *wk == 0.0 || start + k >= in_h {
                    continue;
                }
                let src_row = &tmp[(start + k) * out_w..(start + k + 1) * out_w];
                for (d, s) in dst_row.iter_mut().zip(src_row) {
                    *d += wk * s;
                }
            }
        }
    });
    out
}

/// Resizes a `[C, H, W]` tensor to `[C, out_h, out_w]` with PyTorch's `size=` semantics.
pub fn resize_tensor(input: &Tensor, out_h: usize, out_w: usize, mode: Resample) -> ModelsResult<Tensor> {
    let (c, h, w) = input.dims3()?;
    let rows = AxisTaps::new(AxisResize::to_len(h, out_h), mode);
    let cols = AxisTaps::new(AxisResize::to_len(w, out_w), mode);
    resize_tensor_with(input, &rows, &cols, (c, h, w))
}

/// Resizes a `[C, H, W]` tensor with explicit per-axis taps.
pub fn resize_tensor_with(
    input: &Tensor,
    rows: &AxisTaps,
    cols: &AxisTaps,
    chw: (usize, usize, usize),
) -> ModelsResult<Tensor> {
    let (c, h, w) = chw;
    if input.dims() != [c, h, w] {
        return Err(ModelsError::Input(format!("resize expects [{c}, {h}, {w}], got {:?}", input.dims())));
    }
    let data = input.flatten_all()?.to_vec1::<f32>()?;
    let out = resize_planes(&data, c, rows, cols, h, w);
    Ok(Tensor::from_vec(out, (c, rows.out_len(), cols.out_len()), &Device::Cpu)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identity_when_sizes_match() {
        let data: Vec<f32> = (0..2 * 5 * 7).map(|i| (i as f32 * 0.37).sin()).collect();
        for mode in [
            Resample::Bicubic,
            Resample::BicubicAntialias,
            Resample::Bilinear,
            Resample::BilinearAlignCorners,
        ] {
            let rows = AxisTaps::new(AxisResize::to_len(5, 5), mode);
            let cols = AxisTaps::new(AxisResize::to_len(7, 7), mode);
            let out = resize_planes(&data, 2, &rows, &cols, 5, 7);
            for (a, b) in out.iter().zip(&data) {
                assert!((a - b).abs() < 1e-6, "{mode:?}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn bilinear_matches_hand_computed_values() {
        // [1, 1, 2] -> width 4, align_corners=False: torch gives [0, 0.25, 0.75, 1] for input [0, 1].
        let rows = AxisTaps::new(AxisResize::to_len(1, 1), Resample::Bilinear);
        let cols = AxisTaps::new(AxisResize::to_len(2, 4), Resample::Bilinear);
        let out = resize_planes(&[0.0, 1.0], 1, &rows, &cols, 1, 2);
        assert_eq!(out, vec![0.0, 0.25, 0.75, 1.0]);
        // align_corners=True: [0, 1/3, 2/3, 1].
        let cols = AxisTaps::new(AxisResize::to_len(2, 4), Resample::BilinearAlignCorners);
        let out = resize_planes(&[0.0, 1.0], 1, &rows, &cols, 1, 2);
        for (a, b) in out.iter().zip([0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0]) {
            assert!((a - b).abs() < 1e-6);
        }
    }

    #[test]
    fn bicubic_preserves_constants_and_weights_sum_to_one() {
        for mode in [Resample::Bicubic, Resample::BicubicAntialias] {
            for (i, o) in [(37, 3), (4, 9), (37, 52), (5, 2)] {
                let taps = AxisTaps::new(AxisResize::to_len(i, o), mode);
                for w in taps.weights.chunks(taps.taps_per_output) {
                    let s: f32 = w.iter().sum();
                    assert!((s - 1.0).abs() < 1e-5, "{mode:?} {i}->{o}: sum {s}");
                }
            }
        }
    }
}
