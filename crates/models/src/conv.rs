//! 2D convolution as im2col + matrix product.
//!
//! Our own instead of `candle_nn::Conv2d`: candle-core 0.9.2's tiled CPU kernel takes an NCHW input
//! for NHWC whenever `C_in == W` (its contiguity test compares strides that coincide then), which
//! silently corrupts e.g. a 64-channel map 64 pixels wide.

use candle_core::{Device, Tensor};
use rayon::prelude::*;

use crate::error::{ModelsError, ModelsResult};

/// Output rows per im2col chunk are chosen so a chunk's column matrix stays under this many floats.
const MAX_COLUMN_FLOATS: usize = 16 << 20;

/// A convolution with a square kernel, equal stride and zero padding on both axes, groups = 1.
#[derive(Debug, Clone)]
pub struct Conv2d {
    /// `[C_out, C_in·k·k]`.
    weight: Tensor,
    /// `[C_out, 1]`.
    bias: Option<Tensor>,
    in_channels: usize,
    out_channels: usize,
    kernel: usize,
    stride: usize,
    padding: usize,
}

impl Conv2d {
    /// `weight`: `[C_out, C_in, k, k]`; `bias`: `[C_out]`.
    pub fn new(weight: &Tensor, bias: Option<Tensor>, stride: usize, padding: usize) -> ModelsResult<Self> {
        let (out_channels, in_channels, kernel, kernel_w) = weight.dims4()?;
        if kernel != kernel_w || stride == 0 {
            return Err(ModelsError::Input(format!(
                "unsupported convolution kernel {:?}, stride {stride}",
                weight.dims()
            )));
        }
        let weight = weight.reshape((out_channels, in_channels * kernel * kernel))?.contiguous()?;
        let bias = bias.map(|b| b.reshape((out_channels, 1))).transpose()?;
        Ok(Self { weight, bias, in_channels, out_channels, kernel, stride, padding })
    }

    /// `x`: `[1, C_in, H, W]` (or `[C_in, H, W]`). Returns `[1, C_out, H', W']`.
    pub fn forward(&self, x: &Tensor) -> ModelsResult<Tensor> {
        let x = if x.rank() == 4 { x.squeeze(0)? } else { x.clone() };
        let (c, h, w) = x.dims3()?;
        if c != self.in_channels {
            return Err(ModelsError::Input(format!(
                "convolution expects {} channels, got {c}",
                self.in_channels
            )));
        }
        let (k, s, p) = (self.kernel, self.stride, self.padding);
        if h + 2 * p < k || w + 2 * p < k {
            return Err(ModelsError::Input(format!("{h}×{w} map is smaller than the {k}×{k} kernel")));
        }
        let out_h = (h + 2 * p - k) / s + 1;
        let out_w = (w + 2 * p - k) / s + 1;
        let out = if k == 1 && s == 1 && p == 0 {
            self.weight.matmul(&x.reshape((c, h * w))?)?
        } else {
            let input = x.flatten_all()?.to_vec1::<f32>()?;
            let rows_per_chunk = (MAX_COLUMN_FLOATS / (c * k * k * out_w).max(1)).clamp(1, out_h);
            let mut parts = Vec::new();
            let mut y0 = 0;
            while y0 < out_h {
                let rows = rows_per_chunk.min(out_h - y0);
                let cols = im2col(&input, (c, h, w), (k, s, p), y0..y0 + rows, out_w);
                let cols = Tensor::from_vec(cols, (c * k * k, rows * out_w), &Device::Cpu)?;
                parts.push(self.weight.matmul(&cols)?);
                y0 += rows;
            }
            Tensor::cat(&parts, 1)?
        };
        let out = match &self.bias {
            Some(b) => out.broadcast_add(b)?,
            None => out,
        };
        Ok(out.reshape((1, self.out_channels, out_h, out_w))?)
    }
}

/// Columns `[C·k·k, rows·out_w]` of the output rows `out_rows`; `chw` the input shape, `ksp` =
/// (kernel, stride, padding).
fn im2col(
    input: &[f32],
    chw: (usize, usize, usize),
    ksp: (usize, usize, usize),
    out_rows: std::ops::Range<usize>,
    out_w: usize,
) -> Vec<f32> {
    let (c, h, w) = chw;
    let (k, s, p) = ksp;
    let n = out_rows.len() * out_w;
    let mut cols = vec![0f32; c * k * k * n];
    cols.par_chunks_mut(n).enumerate().for_each(|(row, dst)| {
        let ch = row / (k * k);
        let ky = (row / k) % k;
        let kx = row % k;
        let plane = &input[ch * h * w..(ch + 1) * h * w];
        for (i, oy) in out_rows.clone().enumerate() {
            let iy = (oy * s + ky) as isize - p as isize;
            if iy < 0 || iy >= h as isize {
                continue;
            }
            let src = &plane[iy as usize * w..(iy as usize + 1) * w];
            let dst_row = &mut dst[i * out_w..(i + 1) * out_w];
            for (ox, d) in dst_row.iter_mut().enumerate() {
                let ix = (ox * s + kx) as isize - p as isize;
                if ix >= 0 && (ix as usize) < w {
                    *d = src[ix as usize];
                }
            }
        }
    });
    cols
}

/// ConvTranspose2d with kernel = stride = `factor`, no padding: every input pixel writes its own
/// `factor × factor` output block, so it is one matrix product and a pixel shuffle.
#[derive(Debug, Clone)]
pub struct PatchConvTranspose {
    /// `[C_in, C_out·f·f]`.
    weight: Tensor,
    /// `[C_out]`.
    bias: Tensor,
    factor: usize,
    out_channels: usize,
}

impl PatchConvTranspose {
    /// `weight`: `[C_in, C_out, f, f]` (PyTorch's ConvTranspose2d layout); `bias`: `[C_out]`.
    pub fn new(weight: &Tensor, bias: Tensor) -> ModelsResult<Self> {
        let (c_in, out_channels, factor, _) = weight.dims4()?;
        let weight = weight.reshape((c_in, out_channels * factor * factor))?;
        Ok(Self { weight, bias, factor, out_channels })
    }

    /// `x`: `[B, C_in, H, W]`. Returns `[B, C_out, H·f, W·f]`.
    pub fn forward(&self, x: &Tensor) -> ModelsResult<Tensor> {
        let (b, c_in, h, w) = x.dims4()?;
        let (f, c) = (self.factor, self.out_channels);
        let pixels = x.permute((0, 2, 3, 1))?.reshape((b * h * w, c_in))?;
        let blocks = pixels.matmul(&self.weight)?; // [B·H·W, C_out·f·f]
        let out = blocks
            .reshape((b, h, w, c, f, f))?
            .permute((0, 3, 1, 4, 2, 5))? // [B, C_out, H, f, W, f]
            .reshape((b, c, h * f, w * f))?
            .broadcast_add(&self.bias.reshape((1, c, 1, 1))?)?;
        Ok(out)
    }
}

/// Layer norm over the channels of a `[B, C, H, W]` map (SAM's `LayerNorm2d`).
pub fn layer_norm_2d(x: &Tensor, norm: &candle_nn::LayerNorm) -> ModelsResult<Tensor> {
    use candle_core::Module;
    let channels_last = x.permute((0, 2, 3, 1))?.contiguous()?;
    Ok(norm.forward(&channels_last)?.permute((0, 3, 1, 2))?.contiguous()?)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn naive(
        x: &[f32],
        (c, h, w): (usize, usize, usize),
        wt: &[f32],
        co: usize,
        k: usize,
        s: usize,
        p: usize,
    ) -> Vec<f32> {
        let oh = (h + 2 * p - k) / s + 1;
        let ow = (w + 2 * p - k) / s + 1;
        let mut out = vec![0f32; co * oh * ow];
        for o in 0..co {
            for y in 0..oh {
                for xx in 0..ow {
                    let mut acc = 0f32;
                    for ci in 0..c {
                        for ky in 0..k {
                            for kx in 0..k {
                                let iy = (y * s + ky) as isize - p as isize;
                                let ix = (xx * s + kx) as isize - p as isize;
                                if iy >= 0 && ix >= 0 && (iy as usize) < h && (ix as usize) < w {
                                    acc += x[(ci * h + iy as usize) * w + ix as usize]
                                        * wt[((o * c + ci) * k + ky) * k + kx];
                                }
                            }
                        }
                    }
                    out[(o * oh + y) * ow + xx] = acc;
                }
            }
        }
        out
    }

    #[test]
    fn matches_direct_convolution_including_channels_equal_width() {
        // (16, 16, 16) is the shape candle 0.9.2's kernel gets wrong
        for (c, h, w, k, s, p) in
            [(16, 16, 16, 3, 1, 1), (3, 5, 7, 3, 2, 1), (4, 6, 4, 1, 1, 0), (2, 9, 5, 3, 1, 0)]
        {
            let x: Vec<f32> = (0..c * h * w).map(|i| ((i * 7919) % 101) as f32 / 50.0 - 1.0).collect();
            let co = 5;
            let wt: Vec<f32> = (0..co * c * k * k).map(|i| ((i * 104729) % 97) as f32 / 48.0 - 1.0).collect();
            let conv =
                Conv2d::new(&Tensor::from_vec(wt.clone(), (co, c, k, k), &Device::Cpu).unwrap(), None, s, p)
                    .unwrap();
            let ours =
                conv.forward(&Tensor::from_vec(x.clone(), (1, c, h, w), &Device::Cpu).unwrap()).unwrap();
            let ours = ours.flatten_all().unwrap().to_vec1::<f32>().unwrap();
            let reference = naive(&x, (c, h, w), &wt, co, k, s, p);
            assert_eq!(ours.len(), reference.len());
            for (a, b) in ours.iter().zip(&reference) {
                assert!((a - b).abs() < 1e-3, "{c}×{h}×{w} k{k}: {a} vs {b}");
            }
        }
    }
}
