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
    /// Antialiased bilinear (triangle filter widened by the scale when shrinking), as PIL's
    /// `Image.resize(..., BILINEAR)` and PyTorch's `bilinear, antialias=True`.
    BilinearAntialias,
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

    /// Output length.
    pub fn out_len(&self) -> usize {
        self.starts.len()
    }

    /// Per output sample, the first and last input index it reads with a non-zero weight (`None`
    /// for an output that reads nothing), or `None` when some output's weights are negative or sum
    /// to more than one: then an output may lie outside the range of the inputs it reads (bicubic),
    /// which is what callers of this rely on.
    pub fn convex_windows(&self) -> Option<Vec<Option<(usize, usize)>>> {
        let taps = self.taps_per_output;
        let convex = |w: &[f32]| w.iter().all(|&v| v >= 0.0) && w.iter().sum::<f32>() <= 1.0 + 1e-5;
        if !self.weights.chunks_exact(taps).all(convex) {
            return None;
        }
        Some(
            self.starts
                .iter()
                .zip(self.weights.chunks_exact(taps))
                .map(|(&start, w)| {
                    let first = w.iter().position(|&v| v > 0.0)?;
                    let last = w.iter().rposition(|&v| v > 0.0)?;
                    Some((start + first, start + last))
                })
                .collect(),
        )
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
        Resample::BicubicAntialias => antialias_taps(axis, o, 2.0, |x| cubic(x, -0.5)),
        Resample::BilinearAntialias => antialias_taps(axis, o, 1.0, |x| (1.0 - x.abs()).max(0.0)),
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

/// PIL's / PyTorch's antialiased taps: the filter (of half-width `radius`) is stretched by the scale
/// when shrinking, and the weights are normalised to sum to one.
fn antialias_taps(axis: AxisResize, o: usize, radius: f64, filter: impl Fn(f64) -> f64) -> Vec<(usize, f64)> {
    let scale = axis.step;
    let (support, inv) = if scale >= 1.0 { (radius * scale, 1.0 / scale) } else { (radius, 1.0) };
    let center = scale * (o as f64 + 0.5);
    let lo = ((center - support + 0.5) as i64).max(0);
    let hi = ((center + support + 0.5) as i64).min(axis.in_len as i64);
    let raw: Vec<(usize, f64)> =
        (lo..hi).map(|j| (j as usize, filter((j as f64 - center + 0.5) * inv))).collect();
    let total: f64 = raw.iter().map(|t| t.1).sum();
    let norm = if total != 0.0 { 1.0 / total } else { 0.0 };
    raw.into_iter().map(|(j, w)| (j, w * norm)).collect()
}

impl AxisTaps {
    /// The taps of `self` applied after `inner`, reading only the first `used` outputs of `inner`
    /// (a crop): `out[o] = Σ_k self[o][k] · inner[k]` for `k < used`.
    pub fn compose(&self, inner: &AxisTaps, in_len: usize) -> AxisTaps {
        let rows = (0..self.out_len())
            .map(|o| {
                let mut dense = vec![0f64; in_len];
                for (t, w) in
                    self.weights[o * self.taps_per_output..(o + 1) * self.taps_per_output].iter().enumerate()
                {
                    let k = self.starts[o] + t;
                    if *w == 0.0 || k >= inner.out_len() {
                        continue;
                    }
                    let inner_w = &inner.weights[k * inner.taps_per_output..(k + 1) * inner.taps_per_output];
                    for (u, iw) in inner_w.iter().enumerate() {
                        if let Some(d) = dense.get_mut(inner.starts[k] + u) {
                            *d += *w as f64 * *iw as f64;
                        }
                    }
                }
                dense.into_iter().enumerate().filter(|(_, w)| *w != 0.0).collect::<Vec<_>>()
            })
            .collect();
        Self::from_rows(rows)
    }

    /// Applies the taps to one row: `src`: `[in_len]` → `dst`: `[out_len]`.
    pub fn apply(&self, src: &[f32], dst: &mut [f32]) {
        for (o, d) in dst.iter_mut().enumerate() {
            let w = &self.weights[o * self.taps_per_output..(o + 1) * self.taps_per_output];
            let start = self.starts[o];
            *d = w.iter().enumerate().map(|(k, wk)| src.get(start + k).map_or(0.0, |v| wk * v)).sum();
        }
    }
}

/// Resizes an interleaved 8-bit RGB image like PIL's `Image.resize(size, BILINEAR)` (which
/// torchvision's `resize` calls): antialiased triangle filter, horizontal pass then vertical pass,
/// each rounded to 8 bits with PIL's 22-bit fixed-point weights; an axis whose size does not change is
/// left alone.
///
/// `rgb`: `[H, W, 3]`. Returns `[out_h, out_w, 3]`.
pub fn resize_rgb8_like_pil(rgb: &[u8], (h, w): (usize, usize), (out_h, out_w): (usize, usize)) -> Vec<u8> {
    let horizontal = if out_w != w { resize_axis_u8(rgb, h, w, out_w, true) } else { rgb.to_vec() };
    if out_h != h {
        resize_axis_u8(&horizontal, h, out_w, out_h, false)
    } else {
        horizontal
    }
}

fn fixed_point_taps(in_len: usize, out_len: usize) -> Vec<(usize, Vec<i64>)> {
    const PRECISION_BITS: u32 = 32 - 8 - 2;
    (0..out_len)
        .map(|o| {
            let taps = taps_of(AxisResize::to_len(in_len, out_len), Resample::BilinearAntialias, o);
            let start = taps.first().map_or(0, |t| t.0);
            let weights = taps
                .iter()
                .map(|(_, w)| {
                    let scaled = w * (1u64 << PRECISION_BITS) as f64;
                    if scaled < 0.0 {
                        (scaled - 0.5) as i64
                    } else {
                        (scaled + 0.5) as i64
                    }
                })
                .collect();
            (start, weights)
        })
        .collect()
}

/// One PIL pass over 8-bit RGB: along x when `along_x`, else along y.
fn resize_axis_u8(rgb: &[u8], h: usize, w: usize, out_len: usize, along_x: bool) -> Vec<u8> {
    let in_len = if along_x { w } else { h };
    let taps = fixed_point_taps(in_len, out_len);
    let (oh, ow) = if along_x { (h, out_len) } else { (out_len, w) };
    let mut out = vec![0u8; oh * ow * 3];
    out.par_chunks_mut(ow * 3).enumerate().for_each(|(y, row)| {
        for x in 0..ow {
            let (o, fixed) = if along_x { (x, y) } else { (y, x) };
            let (start, weights) = &taps[o];
            for c in 0..3 {
                let mut acc: i64 = 1 << 21;
                for (k, wk) in weights.iter().enumerate() {
                    let i = start + k;
                    let src = if along_x { (fixed * w + i) * 3 + c } else { (i * w + fixed) * 3 + c };
                    acc += wk * rgb[src] as i64;
                }
                row[x * 3 + c] = (acc >> 22).clamp(0, 255) as u8;
            }
        }
    });
    out
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
        let mut tmp = Vec::new();
        resize_plane_into(src, rows, cols, (in_h, in_w), &mut tmp, dst);
    });
    out
}

/// Resizes one plane `src` `[in_h, in_w]` into `dst` `[rows.out_len, cols.out_len]` (overwritten),
/// columns first through `tmp` (resized as needed, so a caller can reuse it across planes).
pub fn resize_plane_into(
    src: &[f32],
    rows: &AxisTaps,
    cols: &AxisTaps,
    (in_h, in_w): (usize, usize),
    tmp: &mut Vec<f32>,
    dst: &mut [f32],
) {
    let out_w = cols.out_len();
    resize_columns_into(src, cols, (in_h, in_w), tmp);
    for (y, dst_row) in dst.chunks_exact_mut(out_w).take(rows.out_len()).enumerate() {
        resize_row_from_columns(tmp, rows, in_h, y, dst_row);
    }
}

/// The first half of [`resize_plane_into`]: every input row of `src` `[in_h, in_w]` resized along
/// its columns into `tmp` `[in_h, cols.out_len]` (resized as needed).
pub fn resize_columns_into(src: &[f32], cols: &AxisTaps, (in_h, in_w): (usize, usize), tmp: &mut Vec<f32>) {
    let out_w = cols.out_len();
    tmp.clear();
    tmp.resize(in_h * out_w, 0.0);
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
}

/// [`resize_columns_into`] computed a whole input column at a time: `src` transposed into
/// `scratch`, each output column the weighted sum of its input columns (contiguous, so the sums run
/// in vector registers), transposed back into `tmp` `[in_h, cols.out_len]`. Every value is the same
/// sum in the same order (from 0, tap by tap, taps past the input skipped), so the same bits.
pub fn resize_columns_by_columns_into(
    src: &[f32],
    cols: &AxisTaps,
    (in_h, in_w): (usize, usize),
    tmp: &mut Vec<f32>,
    scratch: &mut Vec<f32>,
) {
    let out_w = cols.out_len();
    scratch.clear();
    scratch.resize((in_w + out_w) * in_h, 0.0);
    let (src_t, out_t) = scratch.split_at_mut(in_w * in_h);
    transpose_into(&src[..in_h * in_w], in_h, in_w, src_t);
    for (x, sums) in out_t.chunks_exact_mut(in_h.max(1)).take(out_w).enumerate() {
        let start = cols.starts[x];
        let w = &cols.weights[x * cols.taps_per_output..(x + 1) * cols.taps_per_output];
        for (k, &wk) in w.iter().enumerate() {
            let Some(column) = src_t.get((start + k) * in_h..(start + k + 1) * in_h) else { break };
            for (sum, &v) in sums.iter_mut().zip(column) {
                *sum += wk * v;
            }
        }
    }
    tmp.clear();
    tmp.resize(in_h * out_w, 0.0);
    transpose_into(out_t, out_w, in_h, tmp);
}

/// `dst` `[cols, rows]` = `src` `[rows, cols]` transposed, in 32 × 32 blocks.
fn transpose_into(src: &[f32], rows: usize, cols: usize, dst: &mut [f32]) {
    const BLOCK: usize = 32;
    for r0 in (0..rows).step_by(BLOCK) {
        for c0 in (0..cols).step_by(BLOCK) {
            for r in r0..(r0 + BLOCK).min(rows) {
                for c in c0..(c0 + BLOCK).min(cols) {
                    dst[c * rows + r] = src[r * cols + c];
                }
            }
        }
    }
}

/// The second half of [`resize_plane_into`] for one output row `y`: `dst_row` `[out_w]`
/// (overwritten) from the column-resized rows `columns` `[in_h, out_w]`. Row by row, a caller can
/// read each output row while it is in L1 without storing the plane.
pub fn resize_row_from_columns(columns: &[f32], rows: &AxisTaps, in_h: usize, y: usize, dst_row: &mut [f32]) {
    let out_w = dst_row.len();
    let start = rows.starts[y];
    let w = &rows.weights[y * rows.taps_per_output..(y + 1) * rows.taps_per_output];
    dst_row.fill(0.0);
    for (k, wk) in w.iter().enumerate() {
        if *wk == 0.0 || start + k >= in_h {
            continue;
        }
        let src_row = &columns[(start + k) * out_w..(start + k + 1) * out_w];
        for (d, s) in dst_row.iter_mut().zip(src_row) {
            *d += wk * s;
        }
    }
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
    fn columns_by_columns_are_the_same_bits_as_row_by_row() {
        let (mut plain, mut by_columns, mut scratch) = (Vec::new(), Vec::new(), Vec::new());
        let mut compared = 0;
        for mode in [Resample::Bilinear, Resample::Bicubic, Resample::BicubicAntialias] {
            for (in_h, in_w, out_w) in [(5, 7, 19), (9, 16, 40), (3, 33, 8), (1, 1, 5)] {
                let src: Vec<f32> = (0..in_h * in_w).map(|i| (i as f32 * 0.731).sin() * 3.0).collect();
                let cols = AxisTaps::new(AxisResize::to_len(in_w, out_w), mode);
                resize_columns_into(&src, &cols, (in_h, in_w), &mut plain);
                resize_columns_by_columns_into(&src, &cols, (in_h, in_w), &mut by_columns, &mut scratch);
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&by_columns), bits(&plain), "{mode:?} {in_h}x{in_w} -> {out_w}");
                compared += 1;
            }
        }
        assert_eq!(compared, 12);
    }

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
