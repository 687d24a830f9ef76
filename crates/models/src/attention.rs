//! Scaled dot-product attention shared by the ViTs.

use candle_core::Tensor;

use crate::error::ModelsResult;

/// `softmax(q kᵀ) v` per head; `q`: `[H, N, d]` (already scaled), `k`, `v`: `[H, M, d]`; returns `[H, N, d]`.
pub fn softmax_attention(q: &Tensor, k: &Tensor, v: &Tensor) -> ModelsResult<Tensor> {
    let scores = q.matmul(&k.t()?)?;
    let weights = candle_nn::ops::softmax_last_dim(&scores)?;
    Ok(weights.matmul(v)?)
}
