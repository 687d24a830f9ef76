//! CLIP's residual attention block (both towers): `x + attn(ln_1 x)`, then `x + mlp(ln_2 x)`, with
//! PyTorch's `nn.MultiheadAttention` weights (`in_proj_weight` = q, k, v stacked) and the MLP
//! `c_fc` → activation → `c_proj`; open_clip's optional LayerScale (`ls_1.gamma`, `ls_2.gamma`) too.

use candle_core::{Tensor, D};
use candle_nn::Module;

use super::config::Activation;
use crate::activation::gelu_erf;
use crate::error::ModelsResult;
use crate::weights::Weights;

/// Shapes of one tower's blocks.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BlockShape {
    pub width: usize,
    pub heads: usize,
    pub mlp_hidden: usize,
    pub activation: Activation,
    pub eps: f64,
}

#[derive(Debug, Clone)]
pub(crate) struct ResidualBlock {
    ln_1: candle_nn::LayerNorm,
    in_proj: candle_nn::Linear,
    out_proj: candle_nn::Linear,
    ln_2: candle_nn::LayerNorm,
    c_fc: candle_nn::Linear,
    c_proj: candle_nn::Linear,
    /// `[C]` when the model has LayerScale.
    ls_1: Option<Tensor>,
    ls_2: Option<Tensor>,
    shape: BlockShape,
}

impl ResidualBlock {
    pub(crate) fn new(weights: &Weights, prefix: &str, shape: BlockShape) -> ModelsResult<Self> {
        let c = shape.width;
        let in_proj = candle_nn::Linear::new(
            weights.get(&format!("{prefix}.attn.in_proj_weight"), &[3 * c, c])?,
            Some(weights.get(&format!("{prefix}.attn.in_proj_bias"), &[3 * c])?),
        );
        let layer_scale = |name: String| -> ModelsResult<Option<Tensor>> {
            if weights.contains(&name) {
                Ok(Some(weights.get(&name, &[c])?))
            } else {
                Ok(None)
            }
        };
        Ok(Self {
            ln_1: weights.layer_norm(&format!("{prefix}.ln_1"), c, shape.eps)?,
            in_proj,
            out_proj: weights.linear(&format!("{prefix}.attn.out_proj"), c, c)?,
            ln_2: weights.layer_norm(&format!("{prefix}.ln_2"), c, shape.eps)?,
            c_fc: weights.linear(&format!("{prefix}.mlp.c_fc"), c, shape.mlp_hidden)?,
            c_proj: weights.linear(&format!("{prefix}.mlp.c_proj"), shape.mlp_hidden, c)?,
            ls_1: layer_scale(format!("{prefix}.ls_1.gamma"))?,
            ls_2: layer_scale(format!("{prefix}.ls_2.gamma"))?,
            shape,
        })
    }

    /// `tokens`: `[B, N, C]` → `[B, N, C]`; `mask`: `[N, N]` added to the attention scores (the text
    /// tower's causal mask), or none. The token-wise layers run on `[B·N, C]` (candle's products are
    /// fastest on plain matrices).
    pub(crate) fn forward(&self, tokens: &Tensor, mask: Option<&Tensor>) -> ModelsResult<Tensor> {
        let (b, n, c) = tokens.dims3()?;
        let flat = tokens.reshape((b * n, c))?;
        let attended = self.attention(&self.ln_1.forward(&flat)?, (b, n), mask)?;
        let attended = scaled(attended, self.ls_1.as_ref())?;
        let flat = (flat + attended)?;
        let hidden = self.c_fc.forward(&self.ln_2.forward(&flat)?)?;
        let hidden = match self.shape.activation {
            Activation::Gelu => gelu_erf(&hidden)?,
            Activation::QuickGelu => quick_gelu(&hidden)?,
        };
        let mlp = scaled(self.c_proj.forward(&hidden)?, self.ls_2.as_ref())?;
        Ok((flat + mlp)?.reshape((b, n, c))?)
    }

    /// Multi-head self-attention within each of the `b` sequences of `n` tokens, `x`: `[b·n, C]`.
    fn attention(&self, x: &Tensor, (b, n): (usize, usize), mask: Option<&Tensor>) -> ModelsResult<Tensor> {
        let c = x.dims2()?.1;
        let heads = self.shape.heads;
        let head_dim = c / heads;
        // [b, n, 3, H, d] → [3, b, H, n, d]
        let qkv = self.in_proj.forward(x)?.reshape((b, n, 3, heads, head_dim))?.permute((2, 0, 3, 1, 4))?;
        let scale = 1.0 / (head_dim as f64).sqrt();
        let q = (qkv.get(0)?.contiguous()? * scale)?.reshape((b * heads, n, head_dim))?;
        let k = qkv.get(1)?.contiguous()?.reshape((b * heads, n, head_dim))?;
        let v = qkv.get(2)?.contiguous()?.reshape((b * heads, n, head_dim))?;
        let mut scores = q.matmul(&k.t()?)?;
        if let Some(mask) = mask {
            scores = scores.broadcast_add(mask)?;
        }
        let weights = candle_nn::ops::softmax_last_dim(&scores)?;
        let out =
            weights.matmul(&v)?.reshape((b, heads, n, head_dim))?.transpose(1, 2)?.reshape((b * n, c))?;
        Ok(self.out_proj.forward(&out)?)
    }
}

fn scaled(x: Tensor, gamma: Option<&Tensor>) -> ModelsResult<Tensor> {
    Ok(match gamma {
        Some(gamma) => x.broadcast_mul(gamma)?,
        None => x,
    })
}

/// OpenAI's QuickGELU, `x · σ(1.702 x)`; any shape.
pub fn quick_gelu(x: &Tensor) -> ModelsResult<Tensor> {
    Ok((x * candle_nn::ops::sigmoid(&(x * 1.702)?)?)?)
}

/// The causal mask of `n` tokens, `[n, n]`: 0 on and below the diagonal, −∞ above.
pub(crate) fn causal_mask(n: usize) -> ModelsResult<Tensor> {
    let values: Vec<f32> = (0..n * n).map(|i| if i % n > i / n { f32::NEG_INFINITY } else { 0.0 }).collect();
    Ok(Tensor::from_vec(values, (n, n), &candle_core::Device::Cpu)?)
}

/// L2-normalised rows of `x` `[B, E]`.
pub fn l2_normalise_rows(x: &Tensor) -> ModelsResult<Tensor> {
    let norm = x.sqr()?.sum_keepdim(D::Minus1)?.sqrt()?.clamp(1e-12, f32::MAX)?;
    Ok(x.broadcast_div(&norm)?)
}
