//! Turning RGB images into the models' input tensors.

use candle_core::{Device, Tensor};

use crate::error::{ModelsError, ModelsResult};

/// ImageNet mean (RGB), used by DINOv2 and Depth Anything.
pub const IMAGENET_MEAN: [f32; 3] = [0.485, 0.456, 0.406];
/// ImageNet standard deviation (RGB).
pub const IMAGENET_STD: [f32; 3] = [0.229, 0.224, 0.225];

/// `rgb`: interleaved `[H, W, 3]` in [0, 1]. Returns `[3, H, W]` with `(v − mean) / std` per channel.
pub fn imagenet_normalise(rgb: &[f32], height: usize, width: usize) -> ModelsResult<Tensor> {
    normalise(rgb, height, width, IMAGENET_MEAN, IMAGENET_STD)
}

/// `rgb`: interleaved `[H, W, 3]`. Returns `[3, H, W]` with `(v − mean) / std` per channel.
pub fn normalise(
    rgb: &[f32],
    height: usize,
    width: usize,
    mean: [f32; 3],
    std: [f32; 3],
) -> ModelsResult<Tensor> {
    if rgb.len() != height * width * 3 {
        return Err(ModelsError::Input(format!("{} values for a {width}×{height} RGB image", rgb.len())));
    }
    let plane = height * width;
    let mut chw = vec![0f32; 3 * plane];
    for (i, px) in rgb.chunks_exact(3).enumerate() {
        for c in 0..3 {
            chw[c * plane + i] = (px[c] - mean[c]) / std[c];
        }
    }
    Ok(Tensor::from_vec(chw, (3, height, width), &Device::Cpu)?)
}
