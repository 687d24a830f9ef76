//! CLIP's image tower (OpenAI layout, `visual.*`): patches by a bias-free convolution (`conv1`), the
//! class token (`class_embedding`) in front, learnt positions, `ln_pre`, the residual blocks, `ln_post`
//! on the class token, then `proj` (`[width, embed_dim]`, applied as `x · proj`).

use candle_core::Tensor;
use candle_nn::Module;

use super::block::{BlockShape, ResidualBlock};
use super::config::{ClipConfig, VisionConfig};
use crate::error::{ModelsError, ModelsResult};
use crate::weights::Weights;

/// OpenAI's image normalisation (RGB mean of the training set), used by every CLIP.
pub const CLIP_MEAN: [f32; 3] = [0.481_454_66, 0.457_827_5, 0.408_210_73];
/// OpenAI's image normalisation (RGB standard deviation).
pub const CLIP_STD: [f32; 3] = [0.268_629_54, 0.261_302_6, 0.275_777_1];

/// A loaded image tower.
#[derive(Debug, Clone)]
pub struct ClipImageTower {
    config: VisionConfig,
    /// Class token plus its position, `[1, C]`.
    class_token: Tensor,
    /// Positions of the patches, `[g·g, C]`.
    patch_positions: Tensor,
    /// The patch convolution as a matrix, `[3·p·p, C]`.
    patch_proj_t: Tensor,
    ln_pre: candle_nn::LayerNorm,
    blocks: Vec<ResidualBlock>,
    ln_post: candle_nn::LayerNorm,
    /// `[C, E]`.
    proj: Tensor,
}

impl ClipImageTower {
    /// Builds the tower from OpenAI-named `weights` (no prefix) and `config` (which must have a vision part).
    pub fn new(weights: &Weights, config: &ClipConfig) -> ModelsResult<Self> {
        let vision = config.vision.clone().ok_or_else(|| weights.missing("visual.class_embedding", &[]))?;
        let c = vision.width;
        let p = vision.patch_size;
        let grid = vision.image_size / p;
        let class = weights.get("visual.class_embedding", &[c])?.reshape((1, c))?;
        let positions = weights.get("visual.positional_embedding", &[1 + grid * grid, c])?;
        let class_token = (class + positions.narrow(0, 0, 1)?)?;
        let patch_positions = positions.narrow(0, 1, grid * grid)?.contiguous()?;
        let patch_proj_t =
            weights.get("visual.conv1.weight", &[c, 3, p, p])?.reshape((c, 3 * p * p))?.t()?.contiguous()?;
        let shape = BlockShape {
            width: c,
            heads: vision.heads,
            mlp_hidden: vision.mlp_hidden,
            activation: config.activation,
            eps: config.layer_norm_eps,
        };
        let blocks = (0..vision.layers)
            .map(|i| ResidualBlock::new(weights, &format!("visual.transformer.resblocks.{i}"), shape))
            .collect::<ModelsResult<Vec<_>>>()?;
        Ok(Self {
            class_token,
            patch_positions,
            patch_proj_t,
            ln_pre: weights.layer_norm("visual.ln_pre", c, config.layer_norm_eps)?,
            blocks,
            ln_post: weights.layer_norm("visual.ln_post", c, config.layer_norm_eps)?,
            proj: weights.get("visual.proj", &[c, config.embed_dim])?,
            config: vision,
        })
    }

    /// The tower's shapes.
    pub fn config(&self) -> &VisionConfig {
        &self.config
    }

    /// Image embeddings (not normalised), `[B, E]`, of `pixels` `[B, 3, S, S]` normalised with
    /// [`CLIP_MEAN`] / [`CLIP_STD`], `S` the tower's image size.
    pub fn embed(&self, pixels: &Tensor) -> ModelsResult<Tensor> {
        let s = self.config.image_size;
        let p = self.config.patch_size;
        let dims = pixels.dims();
        if dims.len() != 4 || dims[1] != 3 || dims[2] != s || dims[3] != s || dims[0] == 0 {
            return Err(ModelsError::Input(format!(
                "the CLIP image tower expects pixels [B, 3, {s}, {s}] (B ≥ 1), got {dims:?}"
            )));
        }
        let (b, g, c) = (dims[0], s / p, self.config.width);
        let patches = pixels
            .reshape((b, 3, g, p, g, p))?
            .permute((0, 2, 4, 1, 3, 5))?
            .reshape((b * g * g, 3 * p * p))?
            .contiguous()?;
        let patch_tokens = patches.matmul(&self.patch_proj_t)?.reshape((b, g * g, c))?;
        let patch_tokens = patch_tokens.broadcast_add(&self.patch_positions)?;
        let class = self.class_token.unsqueeze(0)?.broadcast_as((b, 1, c))?.contiguous()?;
        let mut tokens = self.ln_pre.forward(&Tensor::cat(&[&class, &patch_tokens], 1)?)?;
        for block in &self.blocks {
            tokens = block.forward(&tokens, None)?;
        }
        let pooled = self.ln_post.forward(&tokens.narrow(1, 0, 1)?.squeeze(1)?)?;
        Ok(pooled.matmul(&self.proj)?)
    }
}
