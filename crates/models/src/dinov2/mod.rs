//! DINOv2 (Oquab et al. 2023, "DINOv2: Learning Robust Visual Features without Supervision"): the ViT
//! backbone, returning normalised patch tokens `[h/14, w/14, C]` for any image whose sides are
//! multiples of 14 (non-square included).
//!
//! Matches the references on the points candle-transformers gets wrong: the positional embeddings are
//! resized bicubically with the reference's exact rule ([`PosEmbedResize`]), height and width are kept
//! apart for non-square images, LayerNorm eps is 1e-6, and no classifier head is needed.

mod block;
pub mod config;
pub mod names;

use std::path::Path;

use candle_core::{Device, Tensor, D};
use candle_nn::Module;

pub use config::{Dinov2Config, PosEmbedResize};
pub use names::Layout;

use crate::checkpoint;
use crate::error::{ModelKind, ModelsError, ModelsResult};
use crate::resample::{AxisResize, AxisTaps, Resample};
use crate::weights::Weights;
use block::Block;

/// A loaded DINOv2 backbone.
#[derive(Debug, Clone)]
pub struct Dinov2 {
    config: Dinov2Config,
    /// `[1, C]`.
    cls_token: Tensor,
    /// Positional embedding of the class token, `[1, C]`.
    cls_pos: Tensor,
    /// Patch positional embeddings channel-major, `[C, M, M]`, for resizing.
    patch_pos_chw: Tensor,
    /// `[R, C]` when the model has registers.
    registers: Option<Tensor>,
    /// Patch projection as a matrix, `[3·p·p, C]` (the conv kernel flattened and transposed).
    patch_proj_t: Tensor,
    /// `[C]`.
    patch_bias: Tensor,
    blocks: Vec<Block>,
    norm: candle_nn::LayerNorm,
}

impl Dinov2 {
    /// Loads a checkpoint from a file, a Hugging Face snapshot folder, or a model id in the local
    /// Hugging Face cache (see [`checkpoint::resolve`]).
    pub fn load(path: &Path) -> ModelsResult<Self> {
        let files = checkpoint::resolve(path, ModelKind::Dinov2)?;
        let weights = Weights::load(&files.weights, ModelKind::Dinov2)?;
        let hf_config = checkpoint::read_config(&files)?;
        Self::from_weights(&weights, hf_config.as_ref())
    }

    /// Builds the model from already-read tensors (any supported naming, any prefix).
    pub fn from_weights(weights: &Weights, hf_config: Option<&serde_json::Value>) -> ModelsResult<Self> {
        let (canonical, layout) = names::canonical(weights)?;
        let config = Dinov2Config::infer(&canonical, layout, hf_config)?;
        Self::new(&canonical, config)
    }

    /// Builds the model from facebookresearch-named `weights` and an explicit configuration.
    pub fn new(weights: &Weights, config: Dinov2Config) -> ModelsResult<Self> {
        let c = config.hidden_size;
        let p = config.patch_size;
        let m = config.pos_grid;
        let cls_token = weights.get("cls_token", &[1, 1, c])?.reshape((1, c))?;
        let pos = weights.get("pos_embed", &[1, 1 + m * m, c])?.reshape((1 + m * m, c))?;
        let cls_pos = pos.narrow(0, 0, 1)?;
        let patch_pos_chw = pos.narrow(0, 1, m * m)?.t()?.reshape((c, m, m))?.contiguous()?;
        let registers = match config.num_registers {
            0 => None,
            r => Some(weights.get("register_tokens", &[1, r, c])?.reshape((r, c))?),
        };
        let patch_proj_t = weights
            .get("patch_embed.proj.weight", &[c, 3, p, p])?
            .reshape((c, 3 * p * p))?
            .t()?
            .contiguous()?;
        let patch_bias = weights.get("patch_embed.proj.bias", &[c])?;
        let blocks = (0..config.num_layers)
            .map(|i| Block::new(weights, &format!("blocks.{i}"), &config))
            .collect::<ModelsResult<Vec<_>>>()?;
        let norm = weights.layer_norm("norm", c, config.layer_norm_eps)?;
        Ok(Self {
            config,
            cls_token,
            cls_pos,
            patch_pos_chw,
            registers,
            patch_proj_t,
            patch_bias,
            blocks,
            norm,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &Dinov2Config {
        &self.config
    }

    /// Normalised patch tokens for one image.
    ///
    /// `pixels`: `[3, H, W]`, ImageNet-normalised (see [`crate::image::imagenet_normalise`]), H and W
    /// multiples of the patch size. Returns `[H/14, W/14, C]`.
    pub fn patch_features(&self, pixels: &Tensor) -> ModelsResult<Tensor> {
        let (gh, gw) = self.grid_of(pixels)?;
        let mut layers = self.normalised_layers(pixels, &[self.config.num_layers - 1])?;
        let last = layers.pop().ok_or_else(|| ModelsError::Input("no layer output".into()))?;
        Ok(last.reshape((gh, gw, self.config.hidden_size))?)
    }

    /// Patch tokens after the blocks `layer_indices` (0-based), each passed through the final norm, as the
    /// DPT head of Depth Anything reads them. `pixels` as in [`Self::patch_features`]. Returns one
    /// `[h·w, C]` tensor per requested layer, in the order requested.
    pub fn normalised_layers(&self, pixels: &Tensor, layer_indices: &[usize]) -> ModelsResult<Vec<Tensor>> {
        let (gh, gw) = self.grid_of(pixels)?;
        if let Some(bad) = layer_indices.iter().find(|&&i| i >= self.config.num_layers) {
            return Err(ModelsError::Input(format!(
                "layer {bad} requested from a {}-layer model",
                self.config.num_layers
            )));
        }
        let mut tokens = self.embed(pixels, gh, gw)?;
        let skip = 1 + self.config.num_registers;
        let mut outputs: Vec<Option<Tensor>> = vec![None; layer_indices.len()];
        let last_needed = layer_indices.iter().copied().max().unwrap_or(0);
        for (i, block) in self.blocks.iter().enumerate().take(last_needed + 1) {
            tokens = block.forward(&tokens)?;
            for (slot, _) in layer_indices.iter().enumerate().filter(|(_, &l)| l == i) {
                let patches = tokens.narrow(0, skip, gh * gw)?;
                outputs[slot] = Some(self.norm.forward(&patches)?);
            }
        }
        outputs
            .into_iter()
            .map(|o| o.ok_or_else(|| ModelsError::Input("layer not computed".into())))
            .collect()
    }

    /// Patch features of an 8-bit RGB image (`rgb`: interleaved `[height, width, 3]`): resized
    /// bicubically so its long side is about `long_side` px with both sides multiples of 14,
    /// ImageNet-normalised, run. Returns `[h/14, w/14, C]` and the size the model saw `(h, w)`.
    pub fn image_features(
        &self,
        rgb: &[u8],
        (height, width): (usize, usize),
        long_side: usize,
    ) -> ModelsResult<(Tensor, (usize, usize))> {
        let p = self.config.patch_size;
        let unit: Vec<f32> = rgb.iter().map(|&v| v as f32 / 255.0).collect();
        let pixels = crate::image::imagenet_normalise(&unit, height, width)?;
        let scale = long_side as f64 / height.max(width).max(1) as f64;
        let round = |v: usize| (((v as f64 * scale) / p as f64).round() as usize).max(1) * p;
        let (h, w) = (round(height), round(width));
        let resized = if (h, w) == (height, width) {
            pixels
        } else {
            crate::resample::resize_tensor(&pixels, h, w, Resample::Bicubic)?
        };
        Ok((self.patch_features(&resized)?, (h, w)))
    }

    fn grid_of(&self, pixels: &Tensor) -> ModelsResult<(usize, usize)> {
        let p = self.config.patch_size;
        let dims = pixels.dims();
        if dims.len() != 3
            || dims[0] != 3
            || !dims[1].is_multiple_of(p)
            || !dims[2].is_multiple_of(p)
            || dims[1] == 0
            || dims[2] == 0
        {
            return Err(ModelsError::Input(format!(
                "DINOv2 expects pixels [3, H, W] with H and W positive multiples of {p}, got {dims:?}"
            )));
        }
        Ok((dims[1] / p, dims[2] / p))
    }

    /// Tokens `[1 + R + h·w, C]`: class token, registers, patches (with positional embeddings).
    fn embed(&self, pixels: &Tensor, gh: usize, gw: usize) -> ModelsResult<Tensor> {
        let p = self.config.patch_size;
        let patches = pixels
            .reshape((3, gh, p, gw, p))?
            .permute((1, 3, 0, 2, 4))?
            .reshape((gh * gw, 3 * p * p))?
            .contiguous()?;
        let patch_tokens = patches.matmul(&self.patch_proj_t)?.broadcast_add(&self.patch_bias)?;
        let patch_tokens = (patch_tokens + self.patch_positions(gh, gw)?)?;
        let cls = (&self.cls_token + &self.cls_pos)?;
        let mut parts = vec![cls];
        if let Some(registers) = &self.registers {
            parts.push(registers.clone());
        }
        parts.push(patch_tokens);
        Ok(Tensor::cat(&parts, 0)?)
    }

    /// Positional embeddings for an `gh × gw` grid, `[gh·gw, C]`.
    pub fn patch_positions(&self, gh: usize, gw: usize) -> ModelsResult<Tensor> {
        let m = self.config.pos_grid;
        let c = self.config.hidden_size;
        if gh == m && gw == m {
            // both references return the learnt table untouched here
            return Ok(self.patch_pos_chw.reshape((c, m * m))?.t()?.contiguous()?);
        }
        let (rows, cols, mode) = match self.config.pos_embed_resize {
            PosEmbedResize::Size { antialias } => {
                (AxisResize::to_len(m, gh), AxisResize::to_len(m, gw), bicubic(antialias))
            }
            PosEmbedResize::ScaleWithOffset { offset, antialias } => (
                AxisResize { in_len: m, out_len: gh, step: m as f64 / (gh as f64 + offset) },
                AxisResize { in_len: m, out_len: gw, step: m as f64 / (gw as f64 + offset) },
                bicubic(antialias),
            ),
        };
        let rows = AxisTaps::new(rows, mode);
        let cols = AxisTaps::new(cols, mode);
        let resized = crate::resample::resize_tensor_with(&self.patch_pos_chw, &rows, &cols, (c, m, m))?;
        Ok(resized.reshape((c, gh * gw))?.t()?.contiguous()?)
    }
}

fn bicubic(antialias: bool) -> Resample {
    if antialias {
        Resample::BicubicAntialias
    } else {
        Resample::Bicubic
    }
}

/// L2-normalises every token of a `[h, w, C]` feature map along C (the paper's feature convention).
pub fn l2_normalise(features: &Tensor) -> ModelsResult<Tensor> {
    let norm = features.sqr()?.sum_keepdim(D::Minus1)?.sqrt()?.clamp(1e-12, f32::MAX)?;
    Ok(features.broadcast_div(&norm)?)
}

/// The device every model runs on (the CPU).
pub fn device() -> Device {
    Device::Cpu
}
