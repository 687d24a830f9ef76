//! Depth Anything V2 (Yang et al. 2024): a DINOv2 backbone and a DPT head predicting relative inverse
//! depth (larger = nearer) at the input resolution, for any input whose sides are multiples of 14.
//!
//! Follows the references' resampling: the fusion blocks and the head upsample bilinearly with
//! `align_corners = True`, the head resizes to exactly `(h·14, w·14)` (no padding bug, no
//! nearest-neighbour upsampling, non-square inputs kept non-square).

mod head;
pub mod names;

use std::path::Path;

use candle_core::Tensor;

use crate::checkpoint;
use crate::dinov2::Dinov2;
use crate::error::{ModelKind, ModelsResult};
use crate::resample::{resize_tensor, Resample};
use crate::weights::Weights;
pub use head::{DptHead, DptHeadConfig};

/// A loaded Depth Anything V2 model.
#[derive(Debug, Clone)]
pub struct DepthAnything {
    backbone: Dinov2,
    head: DptHead,
}

impl DepthAnything {
    /// Loads a checkpoint (original `.pth` or Hugging Face folder / model id, see [`checkpoint::resolve`]).
    pub fn load(path: &Path) -> ModelsResult<Self> {
        let files = checkpoint::resolve(path, ModelKind::DepthAnythingV2)?;
        let weights = Weights::load(&files.weights, ModelKind::DepthAnythingV2)?;
        let hf_config = checkpoint::read_config(&files)?;
        Self::from_weights(&weights, hf_config.as_ref())
    }

    /// Builds the model from tensors in either naming.
    pub fn from_weights(weights: &Weights, hf_config: Option<&serde_json::Value>) -> ModelsResult<Self> {
        let backbone_json = hf_config.and_then(|c| c.get("backbone_config"));
        let backbone = Dinov2::from_weights(weights, backbone_json)?;
        let head_weights = if weights.contains("depth_head.scratch.output_conv1.weight") {
            weights.clone().renamed(names::original_to_hf)
        } else {
            weights.clone()
        };
        let config = DptHeadConfig::infer(&head_weights, backbone.config(), hf_config)?;
        let head = DptHead::new(&head_weights, config)?;
        Ok(Self { backbone, head })
    }

    /// The backbone.
    pub fn backbone(&self) -> &Dinov2 {
        &self.backbone
    }

    /// The head configuration.
    pub fn head_config(&self) -> &DptHeadConfig {
        self.head.config()
    }

    /// Relative inverse depth for `pixels` (`[3, H, W]`, ImageNet-normalised, H and W multiples of 14).
    /// Returns `[H, W]`.
    pub fn forward(&self, pixels: &Tensor) -> ModelsResult<Tensor> {
        let (_, h, w) = pixels.dims3()?;
        let p = self.backbone.config().patch_size;
        let layers = self.backbone.normalised_layers(pixels, &self.head.config().layer_indices)?;
        self.head.forward(&layers, h / p, w / p)
    }

    /// Relative inverse depth of an RGB image at its own resolution, the way the reference's
    /// `infer_image` does it: resize (bicubic) so the shorter side is about `input_short_side` px
    /// (rounded down to a multiple of 14, at least 14), run, and resize the prediction back bilinearly
    /// (aligned corners).
    ///
    /// `rgb`: interleaved `[height, width, 3]` in [0, 1]. Returns `[height, width]` row-major.
    pub fn predict(
        &self,
        rgb: &[f32],
        height: usize,
        width: usize,
        input_short_side: usize,
    ) -> ModelsResult<Vec<f32>> {
        let pixels = crate::image::imagenet_normalise(rgb, height, width)?;
        let (in_h, in_w) = model_input_size(height, width, input_short_side, 14);
        let resized = if (in_h, in_w) == (height, width) {
            pixels
        } else {
            resize_tensor(&pixels, in_h, in_w, Resample::Bicubic)?
        };
        let depth = self.forward(&resized)?.unsqueeze(0)?;
        let depth = resize_tensor(&depth, height, width, Resample::BilinearAlignCorners)?;
        Ok(depth.flatten_all()?.to_vec1::<f32>()?)
    }
}

/// Input size for an image: the shorter side scaled to `short_side` keeping the aspect ratio, both
/// sides rounded to the nearest multiple of `multiple` (at least one `multiple`).
pub fn model_input_size(height: usize, width: usize, short_side: usize, multiple: usize) -> (usize, usize) {
    let scale = short_side as f64 / height.min(width).max(1) as f64;
    let round = |v: usize| (((v as f64 * scale) / multiple as f64).round() as usize).max(1) * multiple;
    (round(height), round(width))
}

/// Maps relative inverse depth (larger = nearer) to the merging stage's normalised depth in [0, 1]
/// with 0 = near, 1 = far: `1 − (d − dmin)/(dmax − dmin)`. Non-finite values stay non-finite; a
/// constant map becomes all 0.
///
/// `inverse_depth`: `[H·W]`. Returns `[H·W]`.
pub fn normalise_inverse_depth(inverse_depth: &[f32]) -> Vec<f32> {
    let finite = inverse_depth.iter().copied().filter(|v| v.is_finite());
    let (lo, hi) = finite.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    let range = hi - lo;
    inverse_depth
        .iter()
        .map(|&d| {
            if !d.is_finite() {
                d
            } else if range > 0.0 {
                1.0 - (d - lo) / range
            } else {
                0.0
            }
        })
        .collect()
}
