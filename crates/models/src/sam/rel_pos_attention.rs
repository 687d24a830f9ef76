//! SAM's attention with decomposed relative positions, fused into one pass on the CPU.
//!
//! The reference computes `softmax(q·kᵀ·scale + rel_h + rel_w)·v` with the full `[N, N]` scores of every
//! head materialised and the two relative terms broadcast-added as separate tensors. Here each task
//! takes a block of query rows of one window, and for every head computes that block's scores with one
//! matrix product straight from the `qkv` projection (no split, no transposed copies), adds the relative
//! terms and takes the softmax in place, and multiplies by `v` into its own rows of the output. Scores
//! never exceed `ROWS_PER_TASK × N` floats per task, and the tasks run in parallel.

use candle_core::{CpuStorage, CustomOp1, Layout, Shape, Tensor};
use gemm::Parallelism;
use rayon::prelude::*;

use crate::error::ModelsResult;
use crate::kernels::{dot, exp_shifted_in_place, max_of};

/// Query rows per task: small enough that a global block's score slab (`ROWS × 4096` floats, 2 MB) stays
/// in cache, large enough that the matrix products stay efficient.
const ROWS_PER_TASK: usize = 128;

/// `softmax(q·kᵀ·scale + rel_h + rel_w)·v` over windows of `side_h × side_w` tokens.
#[derive(Debug, Clone)]
pub struct RelPosAttention {
    /// Heads; `C / heads` is the head width.
    pub heads: usize,
    /// Window height in tokens (the query and key grids are the same).
    pub side_h: usize,
    /// Window width in tokens.
    pub side_w: usize,
    /// `[2·side_h − 1, head_dim]`: entry `dy + side_h − 1` is the embedding of vertical offset `dy = y_q − y_k`.
    pub rel_pos_h: Vec<f32>,
    /// `[2·side_w − 1, head_dim]`, likewise for horizontal offsets.
    pub rel_pos_w: Vec<f32>,
}

impl RelPosAttention {
    /// `qkv`: `[B, N = side_h·side_w, 3·C]` (the qkv projection of `B` windows, channel `t·C + head·d + c`
    /// for `t` ∈ q, k, v). Returns `[B, N, C]` with channel `head·d + c`, ready for the output projection.
    pub fn forward(&self, qkv: &Tensor) -> ModelsResult<Tensor> {
        Ok(qkv.contiguous()?.apply_op1_no_bwd(self)?)
    }

    /// The whole computation on a contiguous `qkv`: `[B, N, 3·C]` → `[B, N, C]`.
    fn run(&self, qkv: &[f32], batch: usize, tokens: usize, channels: usize) -> Vec<f32> {
        let mut out = vec![0f32; batch * tokens * channels];
        let blocks_per_window = tokens.div_ceil(ROWS_PER_TASK);
        // Each task owns rows [row0, row0 + rows) of one window of `out`: disjoint, so no locking.
        let mut tasks: Vec<(usize, usize, &mut [f32])> = Vec::with_capacity(batch * blocks_per_window);
        for (window, window_out) in out.chunks_mut(tokens * channels).enumerate() {
            for (block, rows_out) in window_out.chunks_mut(ROWS_PER_TASK * channels).enumerate() {
                tasks.push((window, block * ROWS_PER_TASK, rows_out));
            }
        }
        tasks.into_par_iter().for_each_init(
            || Scratch::new(tokens, self.side_h, self.side_w),
            |scratch, (window, row0, rows_out)| {
                let window_qkv = &qkv[window * tokens * 3 * channels..(window + 1) * tokens * 3 * channels];
                self.block(window_qkv, row0, rows_out, channels, scratch);
            },
        );
        out
    }

    /// One block of query rows of one window, all heads; `window_qkv`: `[N, 3·C]`, `rows_out`: `[rows, C]`.
    fn block(&self, window_qkv: &[f32], row0: usize, rows_out: &mut [f32], channels: usize, s: &mut Scratch) {
        let tokens = self.side_h * self.side_w;
        let rows = rows_out.len() / channels;
        let head_dim = channels / self.heads;
        let stride = 3 * channels;
        let scale = 1.0 / (head_dim as f32).sqrt();
        let scores = &mut s.scores[..rows * tokens];
        for head in 0..self.heads {
            let q = &window_qkv[row0 * stride + head * head_dim..];
            let k = &window_qkv[channels + head * head_dim..];
            let v = &window_qkv[2 * channels + head * head_dim..];
            // scores[r, j] = scale · Σ_c q[r, c] · k[j, c]
            // SAFETY: every pointer and stride addresses elements inside its slice: q rows
            // row0..row0+rows, k and v rows 0..N, columns 0..head_dim of this head, scores [rows, N].
            unsafe {
                gemm::gemm(
                    rows,
                    tokens,
                    head_dim,
                    scores.as_mut_ptr(),
                    1,
                    tokens as isize,
                    false,
                    q.as_ptr(),
                    1,
                    stride as isize,
                    k.as_ptr(),
                    stride as isize,
                    1,
                    0.0,
                    scale,
                    false,
                    false,
                    false,
                    Parallelism::None,
                );
            }
            for (r, row) in scores.chunks_mut(tokens).enumerate() {
                let n = row0 + r;
                let (y, x) = (n / self.side_w, n % self.side_w);
                let q_row = &q[r * stride..r * stride + head_dim];
                // rel_h[ky] = q · rel_pos_h[y − ky + side_h − 1]; rel_w[kx] = q · rel_pos_w[x − kx + side_w − 1]
                for (ky, out) in s.rel_h.iter_mut().enumerate() {
                    let offset = (y + self.side_h - 1 - ky) * head_dim;
                    *out = dot(q_row, &self.rel_pos_h[offset..offset + head_dim]);
                }
                for (kx, out) in s.rel_w.iter_mut().enumerate() {
                    let offset = (x + self.side_w - 1 - kx) * head_dim;
                    *out = dot(q_row, &self.rel_pos_w[offset..offset + head_dim]);
                }
                for (key_row, &bias_h) in row.chunks_mut(self.side_w).zip(&s.rel_h) {
                    for (value, &bias_w) in key_row.iter_mut().zip(&s.rel_w) {
                        *value += bias_h + bias_w;
                    }
                }
                let max = max_of(row);
                let sum = exp_shifted_in_place(row, max);
                let inv = 1.0 / sum;
                row.iter_mut().for_each(|value| *value *= inv);
            }
            // rows_out[r, head·d + c] = Σ_j scores[r, j] · v[j, c]
            // SAFETY: as above; rows_out is [rows, C] and this head writes columns head·d..(head+1)·d.
            unsafe {
                gemm::gemm(
                    rows,
                    head_dim,
                    tokens,
                    rows_out[head * head_dim..].as_mut_ptr(),
                    1,
                    channels as isize,
                    false,
                    scores.as_ptr(),
                    1,
                    tokens as isize,
                    v.as_ptr(),
                    1,
                    stride as isize,
                    0.0,
                    1.0,
                    false,
                    false,
                    false,
                    Parallelism::None,
                );
            }
        }
    }
}

/// Per-thread buffers.
struct Scratch {
    /// `[ROWS_PER_TASK, N]`.
    scores: Vec<f32>,
    /// `[side_h]`.
    rel_h: Vec<f32>,
    /// `[side_w]`.
    rel_w: Vec<f32>,
}

impl Scratch {
    fn new(tokens: usize, side_h: usize, side_w: usize) -> Self {
        Self {
            scores: vec![0.0; ROWS_PER_TASK.min(tokens) * tokens],
            rel_h: vec![0.0; side_h],
            rel_w: vec![0.0; side_w],
        }
    }
}

impl CustomOp1 for RelPosAttention {
    fn name(&self) -> &'static str {
        "sam-rel-pos-attention"
    }

    fn cpu_fwd(&self, storage: &CpuStorage, layout: &Layout) -> candle_core::Result<(CpuStorage, Shape)> {
        let (batch, tokens, width) = layout.shape().dims3()?;
        let channels = width / 3;
        if tokens != self.side_h * self.side_w || width != 3 * channels || channels % self.heads != 0 {
            candle_core::bail!(
                "attention expects [B, {}, 3·C] with C divisible by {} heads, got {:?}",
                self.side_h * self.side_w,
                self.heads,
                layout.dims()
            );
        }
        let head_dim = channels / self.heads;
        if self.rel_pos_h.len() != (2 * self.side_h - 1) * head_dim
            || self.rel_pos_w.len() != (2 * self.side_w - 1) * head_dim
        {
            candle_core::bail!("relative position tables do not match the window and head width");
        }
        let qkv = match (storage, layout.contiguous_offsets()) {
            (CpuStorage::F32(data), Some((start, end))) => &data[start..end],
            _ => candle_core::bail!("attention needs a contiguous f32 qkv tensor"),
        };
        let out = self.run(qkv, batch, tokens, channels);
        Ok((CpuStorage::F32(out), Shape::from((batch, tokens, channels))))
    }
}

#[cfg(test)]
mod tests {
    use candle_core::Device;
    use rand::{Rng, SeedableRng};

    use super::*;

    /// The reference's formula written out term by term in f64: `qkv`: `[B, N, 3·C]` → `[B, N, C]`.
    fn naive(op: &RelPosAttention, qkv: &[f32], batch: usize, channels: usize) -> Vec<f64> {
        let (sh, sw) = (op.side_h, op.side_w);
        let n = sh * sw;
        let hd = channels / op.heads;
        let at = |b: usize, token: usize, t: usize, head: usize, c: usize| {
            f64::from(qkv[(b * n + token) * 3 * channels + t * channels + head * hd + c])
        };
        let mut out = vec![0f64; batch * n * channels];
        for b in 0..batch {
            for head in 0..op.heads {
                for i in 0..n {
                    let (yq, xq) = (i / sw, i % sw);
                    let logits: Vec<f64> = (0..n)
                        .map(|j| {
                            let (yk, xk) = (j / sw, j % sw);
                            let (dh, dw) = ((yq + sh - 1 - yk) * hd, (xq + sw - 1 - xk) * hd);
                            (0..hd)
                                .map(|c| {
                                    let q = at(b, i, 0, head, c);
                                    q * at(b, j, 1, head, c) / (hd as f64).sqrt()
                                        + q * f64::from(op.rel_pos_h[dh + c])
                                        + q * f64::from(op.rel_pos_w[dw + c])
                                })
                                .sum()
                        })
                        .collect();
                    let max = logits.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                    let weights: Vec<f64> = logits.iter().map(|l| (l - max).exp()).collect();
                    let sum: f64 = weights.iter().sum();
                    for c in 0..hd {
                        out[(b * n + i) * channels + head * hd + c] =
                            (0..n).map(|j| weights[j] / sum * at(b, j, 2, head, c)).sum();
                    }
                }
            }
        }
        out
    }

    #[test]
    fn matches_the_formula_over_several_row_blocks_and_non_square_windows() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        // 12 × 13 = 156 tokens: two row blocks, the second partial
        let (batch, heads, hd, sh, sw) = (2, 3, 4, 12, 13);
        let channels = heads * hd;
        let mut random = |len: usize| (0..len).map(|_| rng.gen_range(-1.5f32..1.5)).collect::<Vec<_>>();
        let op = RelPosAttention {
            heads,
            side_h: sh,
            side_w: sw,
            rel_pos_h: random((2 * sh - 1) * hd),
            rel_pos_w: random((2 * sw - 1) * hd),
        };
        let qkv = random(batch * sh * sw * 3 * channels);
        let expected = naive(&op, &qkv, batch, channels);
        let input = Tensor::from_vec(qkv, (batch, sh * sw, 3 * channels), &Device::Cpu).unwrap();
        let ours = op.forward(&input).unwrap();
        assert_eq!(ours.dims(), &[batch, sh * sw, channels]);
        let ours = ours.flatten_all().unwrap().to_vec1::<f32>().unwrap();
        let max_err = ours.iter().zip(&expected).map(|(a, b)| (f64::from(*a) - b).abs()).fold(0.0, f64::max);
        assert!(max_err < 2e-6, "max |ours − formula| = {max_err}");
        // the relative terms matter: dropping them changes the result
        let plain = RelPosAttention {
            rel_pos_h: vec![0.0; op.rel_pos_h.len()],
            rel_pos_w: vec![0.0; op.rel_pos_w.len()],
            ..op
        };
        let plain = plain.forward(&input).unwrap().flatten_all().unwrap().to_vec1::<f32>().unwrap();
        assert!(plain.iter().zip(&expected).any(|(a, b)| (f64::from(*a) - b).abs() > 1e-2));
    }

    #[test]
    fn rejects_a_qkv_that_does_not_match_the_window() {
        let op = RelPosAttention {
            heads: 2,
            side_h: 3,
            side_w: 3,
            rel_pos_h: vec![0.0; 20],
            rel_pos_w: vec![0.0; 20],
        };
        let qkv = Tensor::zeros((1, 8, 24), candle_core::DType::F32, &Device::Cpu).unwrap();
        assert!(op.forward(&qkv).is_err());
    }
}
