//! CLIP's text tower (OpenAI layout, top-level names): `token_embedding` plus `positional_embedding`,
//! the residual blocks under a causal mask, `ln_final`, the token at the first occurrence of the
//! largest id (EOT, as `argmax` pools), then `text_projection` (`[width, embed_dim]`, `x · proj`).
//!
//! The causal mask lets no token see a later one, so the tokens after the last pooled position cannot
//! change the result: each batch runs only up to it.

use candle_core::{Device, Tensor};
use candle_nn::Module;

use super::block::{causal_mask, BlockShape, ResidualBlock};
use super::config::{ClipConfig, TextConfig};
use crate::error::{ModelsError, ModelsResult};
use crate::weights::Weights;

/// A loaded text tower.
#[derive(Debug, Clone)]
pub struct ClipTextTower {
    config: TextConfig,
    /// `[V, C]`.
    token_embedding: Tensor,
    /// `[context, C]`.
    positions: Tensor,
    blocks: Vec<ResidualBlock>,
    ln_final: candle_nn::LayerNorm,
    /// `[C, E]`.
    projection: Tensor,
}

impl ClipTextTower {
    /// Builds the tower from OpenAI-named `weights` (no prefix) and `config` (which must have a text part).
    pub fn new(weights: &Weights, config: &ClipConfig) -> ModelsResult<Self> {
        let text = config.text.clone().ok_or_else(|| weights.missing("token_embedding.weight", &[]))?;
        let c = text.width;
        let shape = BlockShape {
            width: c,
            heads: text.heads,
            mlp_hidden: text.mlp_hidden,
            activation: config.activation,
            eps: config.layer_norm_eps,
        };
        let blocks = (0..text.layers)
            .map(|i| ResidualBlock::new(weights, &format!("transformer.resblocks.{i}"), shape))
            .collect::<ModelsResult<Vec<_>>>()?;
        Ok(Self {
            token_embedding: weights.get("token_embedding.weight", &[text.vocab_size, c])?,
            positions: weights.get("positional_embedding", &[text.context_length, c])?,
            blocks,
            ln_final: weights.layer_norm("ln_final", c, config.layer_norm_eps)?,
            projection: weights.get("text_projection", &[c, config.embed_dim])?,
            config: text,
        })
    }

    /// The tower's shapes.
    pub fn config(&self) -> &TextConfig {
        &self.config
    }

    /// Text embeddings (not normalised), `[B, E]`, of token rows (each at most the context length,
    /// as [`super::ClipTokenizer::tokenize`] makes them, ids below the vocabulary size).
    pub fn embed(&self, rows: &[Vec<u32>]) -> ModelsResult<Tensor> {
        let (vocab, context) = (self.config.vocab_size, self.config.context_length);
        if rows.is_empty() {
            return Err(ModelsError::Input("no text to embed".into()));
        }
        let mut pooled_at = Vec::with_capacity(rows.len());
        for (r, row) in rows.iter().enumerate() {
            if row.is_empty() || row.len() > context {
                return Err(ModelsError::Input(format!(
                    "text {r} has {} tokens; the text tower takes 1 to {context}",
                    row.len()
                )));
            }
            if let Some(bad) = row.iter().find(|&&id| id as usize >= vocab) {
                return Err(ModelsError::Input(format!(
                    "text {r} holds token id {bad}, beyond the text tower's {vocab} ids (another tokenizer's?)"
                )));
            }
            // the first maximum, as torch's argmax
            let at = row.iter().enumerate().fold(0, |best, (i, &id)| if id > row[best] { i } else { best });
            pooled_at.push(at);
        }
        let n = pooled_at.iter().max().copied().unwrap_or(0) + 1;
        let b = rows.len();
        let ids: Vec<u32> =
            rows.iter().flat_map(|row| (0..n).map(|i| row.get(i).copied().unwrap_or(0))).collect();
        let ids = Tensor::from_vec(ids, b * n, &Device::Cpu)?;
        let c = self.config.width;
        let tokens = self.token_embedding.index_select(&ids, 0)?.reshape((b, n, c))?;
        let mut tokens = tokens.broadcast_add(&self.positions.narrow(0, 0, n)?)?;
        let mask = causal_mask(n)?;
        for block in &self.blocks {
            tokens = block.forward(&tokens, Some(&mask))?;
        }
        let picked: Vec<u32> = pooled_at.iter().enumerate().map(|(r, &at)| (r * n + at) as u32).collect();
        let picked = Tensor::from_vec(picked, b, &Device::Cpu)?;
        let pooled = tokens.reshape((b * n, c))?.index_select(&picked, 0)?;
        let pooled = self.ln_final.forward(&pooled)?;
        Ok(pooled.matmul(&self.projection)?)
    }
}
