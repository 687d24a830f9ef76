//! SAM's image encoder: a plain ViT (16-px patches, absolute positions, windowed attention with a few
//! global blocks, decomposed relative positions) and a conv neck to 256 channels.

use candle_core::{Module, Tensor};

use super::rel_pos_attention::RelPosAttention;
use crate::activation::gelu_erf;
use crate::conv::{layer_norm_2d, Conv2d};
use crate::error::ModelsResult;
use crate::weights::{ConvSpec, Weights};

/// Shapes of the image encoder, inferred from the checkpoint.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ImageEncoderConfig {
    /// Square input side (1024).
    pub img_size: usize,
    /// Patch side (16).
    pub patch_size: usize,
    /// Token width (768 B, 1024 L, 1280 H).
    pub embed_dim: usize,
    /// Blocks (12, 24, 32).
    pub depth: usize,
    /// Heads (12, 16, 16).
    pub num_heads: usize,
    /// Window side of the windowed blocks (14).
    pub window_size: usize,
    /// Blocks with global attention.
    pub global_blocks: Vec<usize>,
    /// Output channels (256).
    pub out_chans: usize,
}

impl ImageEncoderConfig {
    /// From `image_encoder.`-stripped weights.
    pub fn infer(w: &Weights) -> ModelsResult<Self> {
        let patch = w.get_any("patch_embed.proj.weight")?;
        let (embed_dim, patch_size) = (patch.dims()[0], patch.dims()[2]);
        let grid = w.get_any("pos_embed")?.dims()[1];
        let depth = (0..).take_while(|i| w.contains(&format!("blocks.{i}.norm1.weight"))).count();
        let head_dim = w.get_any("blocks.0.attn.rel_pos_h")?.dims()[1];
        let mut window_size = 0;
        let mut global_blocks = Vec::new();
        for i in 0..depth {
            let len = w.get_any(&format!("blocks.{i}.attn.rel_pos_h"))?.dims()[0];
            let side = len.div_ceil(2);
            if side == grid {
                global_blocks.push(i);
            } else {
                window_size = side;
            }
        }
        let out_chans = w.get_any("neck.0.weight")?.dims()[0];
        Ok(Self {
            img_size: grid * patch_size,
            patch_size,
            embed_dim,
            depth,
            num_heads: embed_dim / head_dim.max(1),
            window_size,
            global_blocks,
            out_chans,
        })
    }

    fn grid(&self) -> usize {
        self.img_size / self.patch_size
    }
}

#[derive(Debug, Clone)]
struct Block {
    norm1: candle_nn::LayerNorm,
    qkv: candle_nn::Linear,
    proj: candle_nn::Linear,
    /// Fused attention holding the `[2·S − 1, head_dim]` relative position tables.
    attention: RelPosAttention,
    norm2: candle_nn::LayerNorm,
    lin1: candle_nn::Linear,
    lin2: candle_nn::Linear,
    /// 0 = global.
    window: usize,
}

/// The image encoder.
#[derive(Debug, Clone)]
pub struct ImageEncoder {
    config: ImageEncoderConfig,
    /// `[3·p·p, C]`.
    patch_proj_t: Tensor,
    /// `[C]`.
    patch_bias: Tensor,
    /// `[G·G, C]`.
    pos_embed: Tensor,
    blocks: Vec<Block>,
    neck_conv1: Conv2d,
    neck_norm1: candle_nn::LayerNorm,
    neck_conv2: Conv2d,
    neck_norm2: candle_nn::LayerNorm,
}

impl ImageEncoder {
    /// Builds the encoder from `image_encoder.`-stripped weights.
    pub fn new(w: &Weights, config: ImageEncoderConfig) -> ModelsResult<Self> {
        let c = config.embed_dim;
        let p = config.patch_size;
        let g = config.grid();
        let head_dim = c / config.num_heads;
        let patch_proj_t =
            w.get("patch_embed.proj.weight", &[c, 3, p, p])?.reshape((c, 3 * p * p))?.t()?.contiguous()?;
        let patch_bias = w.get("patch_embed.proj.bias", &[c])?;
        let pos_embed = w.get("pos_embed", &[1, g, g, c])?.reshape((g * g, c))?;
        let mlp = w.get_any("blocks.0.mlp.lin1.weight")?.dims()[0];
        let blocks = (0..config.depth)
            .map(|i| {
                let pre = format!("blocks.{i}");
                let window = if config.global_blocks.contains(&i) { 0 } else { config.window_size };
                let side = if window == 0 { g } else { window };
                Ok(Block {
                    norm1: w.layer_norm(&format!("{pre}.norm1"), c, 1e-6)?,
                    qkv: w.linear(&format!("{pre}.attn.qkv"), c, 3 * c)?,
                    proj: w.linear(&format!("{pre}.attn.proj"), c, c)?,
                    attention: RelPosAttention {
                        heads: config.num_heads,
                        side_h: side,
                        side_w: side,
                        rel_pos_h: w
                            .get(&format!("{pre}.attn.rel_pos_h"), &[2 * side - 1, head_dim])?
                            .flatten_all()?
                            .to_vec1()?,
                        rel_pos_w: w
                            .get(&format!("{pre}.attn.rel_pos_w"), &[2 * side - 1, head_dim])?
                            .flatten_all()?
                            .to_vec1()?,
                    },
                    norm2: w.layer_norm(&format!("{pre}.norm2"), c, 1e-6)?,
                    lin1: w.linear(&format!("{pre}.mlp.lin1"), c, mlp)?,
                    lin2: w.linear(&format!("{pre}.mlp.lin2"), mlp, c)?,
                    window,
                })
            })
            .collect::<ModelsResult<Vec<_>>>()?;
        let o = config.out_chans;
        Ok(Self {
            patch_proj_t,
            patch_bias,
            pos_embed,
            blocks,
            neck_conv1: w
                .conv2d("neck.0", ConvSpec { padding: 0, bias: false, ..ConvSpec::same(c, o, 1) })?,
            neck_norm1: w.layer_norm("neck.1", o, 1e-6)?,
            neck_conv2: w.conv2d("neck.2", ConvSpec { bias: false, ..ConvSpec::same(o, o, 3) })?,
            neck_norm2: w.layer_norm("neck.3", o, 1e-6)?,
            config,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &ImageEncoderConfig {
        &self.config
    }

    /// `pixels`: `[3, S, S]` normalised and padded to `img_size`. Returns `[out_chans, G, G]`.
    pub fn forward(&self, pixels: &Tensor) -> ModelsResult<Tensor> {
        let p = self.config.patch_size;
        let g = self.config.grid();
        let c = self.config.embed_dim;
        let patches = pixels
            .reshape((3, g, p, g, p))?
            .permute((1, 3, 0, 2, 4))?
            .reshape((g * g, 3 * p * p))?
            .contiguous()?;
        let mut x = patches.matmul(&self.patch_proj_t)?.broadcast_add(&self.patch_bias)?;
        x = (x + &self.pos_embed)?.reshape((g, g, c))?;
        for block in &self.blocks {
            x = block.forward(&x)?;
        }
        let x = x.permute((2, 0, 1))?.unsqueeze(0)?.contiguous()?;
        let x = layer_norm_2d(&self.neck_conv1.forward(&x)?, &self.neck_norm1)?;
        let x = layer_norm_2d(&self.neck_conv2.forward(&x)?, &self.neck_norm2)?;
        Ok(x.squeeze(0)?)
    }
}

impl Block {
    /// `x`: `[H, W, C]`.
    fn forward(&self, x: &Tensor) -> ModelsResult<Tensor> {
        let (h, w, c) = x.dims3()?;
        let normed = self.norm1.forward(x)?;
        let attended = if self.window == 0 {
            self.attention(&normed.unsqueeze(0)?)?.squeeze(0)?
        } else {
            let ws = self.window;
            let (hp, wp) = (h.div_ceil(ws) * ws, w.div_ceil(ws) * ws);
            let padded = normed.pad_with_zeros(0, 0, hp - h)?.pad_with_zeros(1, 0, wp - w)?;
            let windows = padded
                .reshape((hp / ws, ws, wp / ws, ws, c))?
                .permute((0, 2, 1, 3, 4))?
                .reshape((hp / ws * (wp / ws), ws, ws, c))?
                .contiguous()?;
            let out = self.attention(&windows)?;
            out.reshape((hp / ws, wp / ws, ws, ws, c))?
                .permute((0, 2, 1, 3, 4))?
                .reshape((hp, wp, c))?
                .narrow(0, 0, h)?
                .narrow(1, 0, w)?
        };
        let x = (x + attended)?;
        let mlp = self.lin2.forward(&gelu_erf(&self.lin1.forward(&self.norm2.forward(&x)?)?)?)?;
        Ok((x + mlp)?)
    }

    /// Attention over each `[S, S]` window with decomposed relative positions; `x`: `[B, S, S, C]`.
    fn attention(&self, x: &Tensor) -> ModelsResult<Tensor> {
        let (b, sh, sw, c) = x.dims4()?;
        let qkv = self.qkv.forward(x)?.reshape((b, sh * sw, 3 * c))?;
        let out = self.attention.forward(&qkv)?.reshape((b, sh, sw, c))?;
        Ok(self.proj.forward(&out)?)
    }
}
