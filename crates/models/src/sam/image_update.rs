//! The per-prompt updates of the decoder's `[N, D]` image tokens, a tile of cells at a time so each
//! tile stays in cache from the attention product through the layer norm to whatever reads it next
//! (the final attention, [`OnlineAttention`]): `X ← LN(X + Aᵀ·U + b)` with the image→token weights
//! `Aᵀ` `[H·T, N]` and output rows `U` `[H·T, D]`, both blocks' in one pass (the first norm's
//! statistics are known before, so the first block's image tokens are never stored). Done over the
//! whole matrix in separate passes, the 4 MB of image tokens went through the cache six times per
//! prompt.
//!
//! Same arithmetic per element as the untiled passes (each tile's product sums over the same `H·T`
//! terms), so the results are those of the whole-matrix products up to their blocking.

use crate::dense::{matmul, LayerNorm, View, ViewMut};
use crate::kernels::{exp_shifted_in_place, max_of};

/// Cells per tile: a `[TILE, D]` tile of 256-wide tokens is 256 KB, in L2 (1 MB per core here).
pub(super) const TILE: usize = 256;

/// The first block's image→token update, `X₁ = LN(E + b_o + A₁ᵀU₁)`, with its norm's row
/// statistics known beforehand (from [`super::shared_decoder`]'s Gram-matrix form).
pub(super) struct FirstUpdate<'a> {
    /// `E + b_o` `[N, D]`.
    pub(super) residual: &'a [f32],
    /// `A₁ᵀ` `[R, N]`.
    pub(super) weights: &'a [f32],
    /// `U₁` `[R, D]`.
    pub(super) rows: &'a [f32],
    pub(super) norm: &'a LayerNorm,
    /// Row means and inverse standard deviations `[N]`.
    pub(super) mean: &'a [f32],
    pub(super) inv_std: &'a [f32],
}

/// Both image→token updates of the image tokens, a tile at a time, into `keys` (filled tile by
/// tile, `[N, D]`): `X₁ = LN₁(E + b_o + A₁ᵀU₁)` with the known statistics of `first`, then
/// `keys[i] = LN₂(X₁ᵢ + Σ_j weights[j, i]·rows[j] + bias)`. `weights` `[R, N]`, `rows` `[R, D]`. Writes
/// each row's second mean and inverse standard deviation to `mean`, `inv_std` `[N]`, then hands each
/// normalised tile to `then(cell0, tile)` (`tile` `[cells, D]`).
pub(super) fn update_tokens(
    keys: &mut Vec<f32>,
    first: &FirstUpdate,
    (weights, rows): (&[f32], &[f32]),
    bias: Option<&[f32]>,
    norm: &LayerNorm,
    (mean, inv_std): (&mut [f32], &mut [f32]),
    mut then: impl FnMut(usize, &[f32]),
) {
    let d = norm.gamma.len();
    let (r1, r2) = (first.rows.len() / d, rows.len() / d);
    let n = mean.len();
    assert_eq!(weights.len(), r2 * n, "weights are not [{r2}, {n}]");
    assert_eq!(first.weights.len(), r1 * n, "first weights are not [{r1}, {n}]");
    keys.clear();
    keys.reserve(n * d);
    let (gamma1, beta1) = (&first.norm.gamma, &first.norm.beta);
    for cell0 in (0..n).step_by(TILE) {
        let cells = TILE.min(n - cell0);
        keys.extend_from_slice(&first.residual[cell0 * d..(cell0 + cells) * d]);
        let tile = &mut keys[cell0 * d..(cell0 + cells) * d];
        let out = ViewMut::rows(tile, 0, d);
        let first_weights = View::transposed(first.weights, cell0, n);
        matmul(cells, d, r1, out, first_weights, View::rows(first.rows, 0, d), true, 1.0);
        for (c, row) in tile.chunks_exact_mut(d).enumerate() {
            let (m, inv) = (first.mean[cell0 + c], first.inv_std[cell0 + c]);
            for ((x, g), b) in row.iter_mut().zip(gamma1).zip(beta1) {
                *x = (*x - m) * inv * g + b;
            }
        }
        let out = ViewMut::rows(tile, 0, d);
        matmul(cells, d, r2, out, View::transposed(weights, cell0, n), View::rows(rows, 0, d), true, 1.0);
        for (c, row) in tile.chunks_exact_mut(d).enumerate() {
            if let Some(bias) = bias {
                row.iter_mut().zip(bias).for_each(|(x, b)| *x += b);
            }
            let (m, s) = norm.row(row);
            mean[cell0 + c] = m;
            inv_std[cell0 + c] = 1.0 / s;
        }
        then(cell0, tile);
    }
}

/// Softmax attention of a few query rows over all `N` image tokens, fed a tile of tokens at a time
/// (the running-maximum softmax: each tile's weights are taken against the largest score so far, and
/// what was summed before is rescaled when the maximum grows — the same weighted mean up to rounding).
///
/// Scores of row `r` at cell `i`: `scale · (folded[r]·x_i + base[r, i] + offset[r])`.
pub(super) struct OnlineAttention<'a> {
    /// `[R, D]`: what each row's score is a dot product of the token with.
    folded: &'a [f32],
    /// `[R, N]`: the part of the scores that does not depend on the tokens.
    base: &'a [f32],
    /// `[R]`.
    offset: &'a [f32],
    scale: f32,
    n: usize,
    /// Largest score so far per row (`−∞` before the first tile).
    max: Vec<f32>,
    /// `Σ exp(s − max)` per row.
    total: Vec<f32>,
    /// `Σ exp(s − max)·x` `[R, D]`.
    sum: Vec<f32>,
    /// A tile's scores `[R, TILE]`.
    scores: Vec<f32>,
}

impl<'a> OnlineAttention<'a> {
    /// For `R = offset.len()` rows over `N = base.len() / R` tokens.
    pub(super) fn new(folded: &'a [f32], base: &'a [f32], offset: &'a [f32], scale: f32) -> Self {
        let rows = offset.len();
        let d = folded.len() / rows.max(1);
        Self {
            folded,
            base,
            offset,
            scale,
            n: base.len() / rows.max(1),
            max: vec![f32::NEG_INFINITY; rows],
            total: vec![0.0; rows],
            sum: vec![0.0; rows * d],
            scores: vec![0.0; rows * TILE],
        }
    }

    /// Takes in tokens `cell0 .. cell0 + cells` (`tile` `[cells, D]`, cells ≤ [`TILE`]).
    pub(super) fn add(&mut self, cell0: usize, tile: &[f32]) {
        let rows = self.offset.len();
        let d = self.folded.len() / rows;
        let cells = tile.len() / d;
        let scores = &mut self.scores[..rows * cells];
        let out = ViewMut::rows(scores, 0, cells);
        matmul(rows, cells, d, out, View::rows(self.folded, 0, d), View::transposed(tile, 0, d), false, 1.0);
        for (r, row) in scores.chunks_exact_mut(cells).enumerate() {
            let base = &self.base[r * self.n + cell0..r * self.n + cell0 + cells];
            let offset = self.offset[r];
            row.iter_mut().zip(base).for_each(|(s, b)| *s = (*s + b + offset) * self.scale);
            let max = self.max[r].max(max_of(row));
            let sum = &mut self.sum[r * d..(r + 1) * d];
            if max > self.max[r] && self.max[r] > f32::NEG_INFINITY {
                let factor = exp_shifted_in_place(&mut [self.max[r]], max);
                self.total[r] *= factor;
                sum.iter_mut().for_each(|v| *v *= factor);
            }
            self.max[r] = max;
            self.total[r] += exp_shifted_in_place(row, max);
        }
        let out = ViewMut::rows(&mut self.sum, 0, d);
        matmul(rows, d, cells, out, View::rows(scores, 0, cells), View::rows(tile, 0, d), true, 1.0);
    }

    /// The attention's weighted means of the tokens, `[R, D]`.
    pub(super) fn finish(mut self) -> Vec<f32> {
        let d = self.sum.len() / self.total.len().max(1);
        for (row, total) in self.sum.chunks_exact_mut(d).zip(&self.total) {
            let inv = 1.0 / total;
            row.iter_mut().for_each(|v| *v *= inv);
        }
        self.sum
    }
}
