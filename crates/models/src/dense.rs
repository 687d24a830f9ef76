//! Dense f32 building blocks on plain row-major buffers: a bounds-checked matrix product (the `gemm`
//! crate, one thread: callers parallelise over independent work), linear layers, row layer norms and
//! softmaxes. Used where many small candle ops would cost more than the arithmetic (SAM's per-prompt
//! decoder).

use gemm::Parallelism;

use crate::kernels::{exp_shifted_in_place, max_of, squared_deviation, sum};
use crate::skinny::{skinny_product, ColumnPanels};

/// A strided read-only matrix inside a slice: element (r, c) is `data[offset + r·rs + c·cs]`.
#[derive(Debug, Clone, Copy)]
pub struct View<'a> {
    /// The storage.
    pub data: &'a [f32],
    /// Index of element (0, 0).
    pub offset: usize,
    /// Row stride.
    pub rs: usize,
    /// Column stride.
    pub cs: usize,
}

impl<'a> View<'a> {
    /// Row-major `[rows, cols]` starting at `offset`, rows `row_len` apart.
    pub fn rows(data: &'a [f32], offset: usize, row_len: usize) -> Self {
        Self { data, offset, rs: row_len, cs: 1 }
    }

    /// The transpose of a row-major matrix whose rows are `row_len` apart: element (r, c) is the
    /// stored (c, r).
    pub fn transposed(data: &'a [f32], offset: usize, row_len: usize) -> Self {
        Self { data, offset, rs: 1, cs: row_len }
    }

    fn check(&self, rows: usize, cols: usize, what: &str) {
        if rows > 0 && cols > 0 {
            let last = self.offset + (rows - 1) * self.rs + (cols - 1) * self.cs;
            assert!(
                last < self.data.len(),
                "{what}: [{rows}, {cols}] view ends at {last}, storage {}",
                self.data.len()
            );
        }
    }
}

/// A strided output matrix: element (r, c) is `data[offset + r·rs + c·cs]`.
#[derive(Debug)]
pub struct ViewMut<'a> {
    /// The storage.
    pub data: &'a mut [f32],
    /// Index of element (0, 0).
    pub offset: usize,
    /// Row stride.
    pub rs: usize,
    /// Column stride.
    pub cs: usize,
}

impl<'a> ViewMut<'a> {
    /// Row-major `[rows, cols]` starting at `offset`, rows `row_len` apart.
    pub fn rows(data: &'a mut [f32], offset: usize, row_len: usize) -> Self {
        Self { data, offset, rs: row_len, cs: 1 }
    }
}

/// `out = scale · lhs · rhs` (`accumulate`: `out += scale · lhs · rhs`) for `lhs` `[m, k]`, `rhs`
/// `[k, n]`, `out` `[m, n]`. Panics if a view reaches outside its slice (a caller's bug, never data).
#[allow(clippy::too_many_arguments)] // the BLAS-style signature reads best at the many call sites
pub fn matmul(
    m: usize,
    n: usize,
    k: usize,
    out: ViewMut,
    lhs: View,
    rhs: View,
    accumulate: bool,
    scale: f32,
) {
    if m == 0 || n == 0 {
        return;
    }
    if k == 0 {
        if !accumulate {
            for r in 0..m {
                for c in 0..n {
                    out.data[out.offset + r * out.rs + c * out.cs] = 0.0;
                }
            }
        }
        return;
    }
    lhs.check(m, k, "lhs");
    rhs.check(k, n, "rhs");
    let last = out.offset + (m - 1) * out.rs + (n - 1) * out.cs;
    assert!(last < out.data.len(), "out: [{m}, {n}] view ends at {last}, storage {}", out.data.len());
    // SAFETY: the three checks above keep every element the product reads or writes inside its slice;
    // `out` is borrowed mutably, so it cannot alias `lhs` or `rhs`.
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            out.data.as_mut_ptr().add(out.offset),
            out.cs as isize,
            out.rs as isize,
            accumulate,
            lhs.data.as_ptr().add(lhs.offset),
            lhs.cs as isize,
            lhs.rs as isize,
            rhs.data.as_ptr().add(rhs.offset),
            rhs.cs as isize,
            rhs.rs as isize,
            1.0,
            scale,
            false,
            false,
            false,
            Parallelism::None,
        );
    }
}

/// A linear layer `y = x·Wᵀ + b` with `weight` `[out, in]` and `bias` `[out]` (zeros when absent).
#[derive(Debug, Clone)]
pub struct Linear {
    /// `[out, in]`, row-major.
    pub weight: Vec<f32>,
    /// `[out]`.
    pub bias: Vec<f32>,
    /// Input width.
    pub inputs: usize,
    /// Output width.
    pub outputs: usize,
    /// `Wᵀ` `[in, out]` in column panels: what the few-row kernel ([`crate::skinny`]) reads.
    weight_t: ColumnPanels,
}

impl Linear {
    /// From `weight` `[out, in]` (row-major) and `bias` `[out]`.
    pub fn new(weight: Vec<f32>, bias: Vec<f32>, inputs: usize, outputs: usize) -> Self {
        assert_eq!(weight.len(), inputs * outputs, "weight is not [{outputs}, {inputs}]");
        assert_eq!(bias.len(), outputs, "bias is not [{outputs}]");
        let weight_t = ColumnPanels::from_transposed(&weight, outputs, inputs);
        Self { weight, bias, inputs, outputs, weight_t }
    }

    /// `Wᵀ` `[in, out]` in column panels.
    pub fn weight_t(&self) -> &ColumnPanels {
        &self.weight_t
    }

    /// From a candle linear layer.
    pub fn from_candle(linear: &candle_nn::Linear) -> candle_core::Result<Self> {
        let (outputs, inputs) = linear.weight().dims2()?;
        let weight = linear.weight().flatten_all()?.to_vec1::<f32>()?;
        let bias = match linear.bias() {
            Some(b) => b.flatten_all()?.to_vec1::<f32>()?,
            None => vec![0.0; outputs],
        };
        Ok(Self::new(weight, bias, inputs, outputs))
    }

    /// `x` `[rows, in]` → `out` `[rows, out]`.
    pub fn forward(&self, x: &[f32], rows: usize, out: &mut [f32]) {
        self.forward_no_bias(x, rows, out);
        for row in out[..rows * self.outputs].chunks_exact_mut(self.outputs) {
            row.iter_mut().zip(&self.bias).for_each(|(v, b)| *v += b);
        }
    }

    /// `x·Wᵀ` without the bias: `x` `[rows, in]` → `out` `[rows, out]`.
    pub fn forward_no_bias(&self, x: &[f32], rows: usize, out: &mut [f32]) {
        let few_rows =
            skinny_product(rows, out, (x, 0, self.inputs), &self.weight_t, (0, self.inputs), false);
        if few_rows.is_some() {
            return;
        }
        matmul(
            rows,
            self.outputs,
            self.inputs,
            ViewMut::rows(out, 0, self.outputs),
            View::rows(x, 0, self.inputs),
            View::transposed(&self.weight, 0, self.inputs),
            false,
            1.0,
        );
    }

    /// `W·v` for one input vector `v` `[in]` (no bias): `[out]`.
    pub fn apply_to(&self, v: &[f32]) -> Vec<f32> {
        self.weight.chunks_exact(self.inputs).map(|row| crate::kernels::dot(row, v)).collect()
    }
}

/// A layer norm over the last axis.
#[derive(Debug, Clone)]
pub struct LayerNorm {
    /// `[C]`.
    pub gamma: Vec<f32>,
    /// `[C]`.
    pub beta: Vec<f32>,
    /// Added to the variance.
    pub eps: f32,
}

impl LayerNorm {
    /// From a candle layer norm (whose epsilon is not readable, so it is passed in).
    pub fn from_candle(norm: &candle_nn::LayerNorm, eps: f32) -> candle_core::Result<Self> {
        let gamma = norm.weight().flatten_all()?.to_vec1::<f32>()?;
        let beta = match norm.bias() {
            Some(b) => b.flatten_all()?.to_vec1::<f32>()?,
            None => vec![0.0; gamma.len()],
        };
        Ok(Self { gamma, beta, eps })
    }

    /// Normalises one row in place and returns its (mean, standard deviation incl. epsilon). Compiled
    /// for AVX-512 where the CPU has it (the same arithmetic in the same order, so the same results).
    pub fn row(&self, row: &mut [f32]) -> (f32, f32) {
        #[cfg(target_arch = "x86_64")]
        if crate::skinny::has_avx512() {
            // SAFETY: the CPU supports AVX-512F (just detected).
            return unsafe { self.row_avx512(row) };
        }
        self.row_portable(row)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn row_avx512(&self, row: &mut [f32]) -> (f32, f32) {
        self.row_portable(row)
    }

    #[inline(always)]
    fn row_portable(&self, row: &mut [f32]) -> (f32, f32) {
        let n = row.len() as f32;
        let mean = sum(row) / n;
        let var = squared_deviation(row, mean) / n;
        let std = (var + self.eps).sqrt();
        let inv = 1.0 / std;
        for ((v, g), b) in row.iter_mut().zip(&self.gamma).zip(&self.beta) {
            *v = (*v - mean) * inv * g + b;
        }
        (mean, std)
    }

    /// Normalises every row of `x` `[rows, C]` in place.
    pub fn rows(&self, x: &mut [f32]) {
        for row in x.chunks_exact_mut(self.gamma.len()) {
            self.row(row);
        }
    }
}

/// Softmax of every `len`-long run of `x` in place, after scaling by `scale` (> 0).
pub fn softmax_runs(x: &mut [f32], len: usize, scale: f32) {
    if len < 2 * SHORT_RUN_BATCH {
        return softmax_short_runs(x, len, scale);
    }
    #[cfg(target_arch = "x86_64")]
    if crate::skinny::has_avx512() {
        for run in x.chunks_exact_mut(len) {
            // SAFETY: the CPU supports AVX-512F (just detected).
            unsafe { crate::math512::softmax_run(run, scale) };
        }
        return;
    }
    for run in x.chunks_exact_mut(len) {
        if scale != 1.0 {
            run.iter_mut().for_each(|v| *v *= scale);
        }
        let max = max_of(run);
        let inv = 1.0 / exp_shifted_in_place(run, max);
        run.iter_mut().for_each(|v| *v *= inv);
    }
}

/// Softmax down the columns of `x` `[B, rows, cols]`: for each of the `B` blocks and each column, over
/// its `rows` entries, after scaling by `scale` (> 0). Runs along the columns, so the exponentials and
/// the running maxima vectorise however few the rows are.
pub fn softmax_columns(x: &mut [f32], rows: usize, cols: usize, scale: f32) {
    if rows == 0 || cols == 0 {
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if rows <= crate::math512::MAX_COLUMN_ROWS && crate::skinny::has_avx512() {
        for block in x.chunks_exact_mut(rows * cols) {
            // SAFETY: the CPU supports AVX-512F (just detected); the block is [rows, cols], rows ≤ 16.
            unsafe { crate::math512::softmax_columns(block, rows, cols, scale) };
        }
        return;
    }
    let mut max = vec![0f32; cols];
    let mut total = vec![0f32; cols];
    for block in x.chunks_exact_mut(rows * cols) {
        if scale != 1.0 {
            block.iter_mut().for_each(|v| *v *= scale);
        }
        max.copy_from_slice(&block[..cols]);
        for row in block.chunks_exact(cols).skip(1) {
            for (m, &v) in max.iter_mut().zip(row) {
                *m = if v > *m { v } else { *m };
            }
        }
        total.iter_mut().for_each(|s| *s = 0.0);
        for row in block.chunks_exact_mut(cols) {
            row.iter_mut().zip(&max).for_each(|(v, m)| *v -= m);
            exp_shifted_in_place(row, 0.0);
            total.iter_mut().zip(row.iter()).for_each(|(s, v)| *s += v);
        }
        total.iter_mut().for_each(|s| *s = 1.0 / *s);
        for row in block.chunks_exact_mut(cols) {
            row.iter_mut().zip(&total).for_each(|(v, inv)| *v *= inv);
        }
    }
}

/// Short runs are handled this many at a time so the exponentials vectorise across runs.
const SHORT_RUN_BATCH: usize = 8;

/// [`softmax_runs`] for short runs: each run shifted by its maximum, then the exponentials of a
/// batch of runs in one vectorised pass, then each run normalised.
fn softmax_short_runs(x: &mut [f32], len: usize, scale: f32) {
    for batch in x.chunks_mut(len * 64) {
        for run in batch.chunks_exact_mut(len) {
            let max = run.iter().fold(f32::NEG_INFINITY, |m, &v| if v > m { v } else { m });
            run.iter_mut().for_each(|v| *v = (*v - max) * scale);
        }
        exp_shifted_in_place(batch, 0.0);
        for run in batch.chunks_exact_mut(len) {
            let inv = 1.0 / run.iter().sum::<f32>();
            run.iter_mut().for_each(|v| *v *= inv);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strided_products_match_the_definition() {
        // lhs [2, 3] stored transposed, rhs [3, 2] row-major, accumulate onto a non-zero out
        let lhs_t = [1.0, 4.0, 2.0, 5.0, 3.0, 6.0]; // lhs = [[1, 2, 3], [4, 5, 6]]
        let rhs = [1.0, -1.0, 0.5, 2.0, -2.0, 1.0];
        let mut out = [10.0, 0.0, 0.0, 10.0];
        matmul(
            2,
            2,
            3,
            ViewMut::rows(&mut out, 0, 2),
            View::transposed(&lhs_t, 0, 2),
            View::rows(&rhs, 0, 2),
            true,
            2.0,
        );
        // lhs·rhs = [[1 + 1 − 6, −1 + 4 + 3], [4 + 2.5 − 12, −4 + 10 + 6]] = [[−4, 6], [−5.5, 12]]
        assert_eq!(out, [10.0 - 8.0, 12.0, -11.0, 10.0 + 24.0]);
        let lin = Linear::new(vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0], vec![0.5, -0.5], 3, 2);
        assert_eq!((lin.weight_t().get(0, 1), lin.weight_t().get(2, 0)), (4.0, 3.0));
        let mut y = [0.0; 2];
        lin.forward(&[1.0, 0.0, -1.0], 1, &mut y);
        assert_eq!(y, [1.0 - 3.0 + 0.5, 4.0 - 6.0 - 0.5]);
        assert_eq!(lin.apply_to(&[1.0, 0.0, -1.0]), vec![-2.0, -2.0]);
    }

    #[test]
    fn column_softmax_is_the_row_softmax_of_the_transpose() {
        let (blocks, rows, cols) = (3, 7, 37);
        let x: Vec<f32> = (0..blocks * rows * cols).map(|i| ((i * 53 % 97) as f32 - 48.0) * 0.21).collect();
        let mut columns = x.clone();
        softmax_columns(&mut columns, rows, cols, 0.6);
        let mut transposed = vec![0f32; x.len()];
        for b in 0..blocks {
            for r in 0..rows {
                for c in 0..cols {
                    transposed[(b * cols + c) * rows + r] = x[(b * rows + r) * cols + c];
                }
            }
        }
        softmax_runs(&mut transposed, rows, 0.6);
        for b in 0..blocks {
            for r in 0..rows {
                for c in 0..cols {
                    let (a, e) = (columns[(b * rows + r) * cols + c], transposed[(b * cols + c) * rows + r]);
                    assert!((a - e).abs() < 1e-6, "block {b} ({r}, {c}): {a} vs {e}");
                }
            }
        }
    }

    #[test]
    fn layer_norm_and_softmax_rows() {
        let norm = LayerNorm { gamma: vec![1.0, 2.0], beta: vec![0.0, 1.0], eps: 0.0 };
        let mut x = [1.0, 3.0];
        assert_eq!(norm.row(&mut x), (2.0, 1.0));
        assert_eq!(x, [-1.0, 3.0]);
        let mut s = [0.0, 0.0, 1.0, 1.0, 0.0, 0.0];
        softmax_runs(&mut s, 3, 2.0_f32.ln());
        let e = [1.0f32, 1.0, 2.0];
        for (v, want) in s[..3].iter().zip(e.iter().map(|x| x / 4.0)) {
            assert!((v - want).abs() < 1e-6);
        }
        assert!((s[3] - 0.5).abs() < 1e-6 && (s[4] - 0.25).abs() < 1e-6);
        // long runs take the other path: same values
        let long: Vec<f32> = (0..40).map(|i| (i as f32 * 0.37).sin() * 3.0).collect();
        let (mut a, mut b) = (long.clone(), long.clone());
        softmax_runs(&mut a, 20, 0.7);
        softmax_short_runs(&mut b, 20, 0.7);
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 1e-6, "{x} vs {y}");
        }
    }
}
