//! One pre-norm ViT block with LayerScale: `x + γ₁·attn(norm₁ x)`, then `x + γ₂·mlp(norm₂ x)`.

use candle_core::Tensor;
use candle_nn::Module;

use super::config::Dinov2Config;
use crate::activation::gelu_erf;
use crate::error::ModelsResult;
use crate::weights::Weights;

#[derive(Debug, Clone)]
pub(crate) struct Block {
    norm1: candle_nn::LayerNorm,
    qkv: candle_nn::Linear,
    proj: candle_nn::Linear,
    /// `[C]`.
    ls1: Tensor,
    norm2: candle_nn::LayerNorm,
    fc1: candle_nn::Linear,
    fc2: candle_nn::Linear,
    /// `[C]`.
    ls2: Tensor,
    num_heads: usize,
}

impl Block {
    pub(crate) fn new(weights: &Weights, prefix: &str, config: &Dinov2Config) -> ModelsResult<Self> {
        let c = config.hidden_size;
        let eps = config.layer_norm_eps;
        Ok(Self {
            norm1: weights.layer_norm(&format!("{prefix}.norm1"), c, eps)?,
            qkv: weights.linear(&format!("{prefix}.attn.qkv"), c, 3 * c)?,
            proj: weights.linear(&format!("{prefix}.attn.proj"), c, c)?,
            ls1: weights.get(&format!("{prefix}.ls1.gamma"), &[c])?,
            norm2: weights.layer_norm(&format!("{prefix}.norm2"), c, eps)?,
            fc1: weights.linear(&format!("{prefix}.mlp.fc1"), c, config.mlp_hidden)?,
            fc2: weights.linear(&format!("{prefix}.mlp.fc2"), config.mlp_hidden, c)?,
            ls2: weights.get(&format!("{prefix}.ls2.gamma"), &[c])?,
            num_heads: config.num_heads,
        })
    }

    /// `tokens`: `[N, C]` → `[N, C]`.
    pub(crate) fn forward(&self, tokens: &Tensor) -> ModelsResult<Tensor> {
        let attended = self.attention(&self.norm1.forward(tokens)?)?;
        let tokens = (tokens + attended.broadcast_mul(&self.ls1)?)?;
        let hidden = gelu_erf(&self.fc1.forward(&self.norm2.forward(&tokens)?)?)?;
        let mlp = self.fc2.forward(&hidden)?;
        Ok((tokens + mlp.broadcast_mul(&self.ls2)?)?)
    }

    /// Multi-head self-attention, `x`: `[N, C]`.
    fn attention(&self, x: &Tensor) -> ModelsResult<Tensor> {
        let (n, c) = x.dims2()?;
        let heads = self.num_heads;
        let head_dim = c / heads;
        let qkv = self.qkv.forward(x)?.reshape((n, 3, heads, head_dim))?.permute((1, 2, 0, 3))?;
        let scale = 1.0 / (head_dim as f64).sqrt();
        let q = (qkv.get(0)?.contiguous()? * scale)?;
        let k = qkv.get(1)?.contiguous()?;
        let v = qkv.get(2)?.contiguous()?;
        let out = crate::attention::softmax_attention(&q, &k, &v)?;
        let out = out.transpose(0, 1)?.reshape((n, c))?;
        Ok(self.proj.forward(&out)?)
    }
}
