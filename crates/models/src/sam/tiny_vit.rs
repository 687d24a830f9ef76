//! MobileSAM's image encoder: TinyViT (Wu et al. 2022) as MobileSAM uses it (TinyViT-5M: embed dims
//! [64, 128, 160, 320], depths [2, 2, 6, 2], heads [2, 4, 5, 10], windows [7, 7, 14, 7]).
//!
//! - Patch embedding: two 3×3 stride-2 conv+BN layers with GELU between (`S/4` grid).
//! - Stage 0: MBConv blocks (1×1 expand, 3×3 depthwise, 1×1 project, each conv+BN, GELU, residual).
//! - Stages 1..: TinyViT blocks: windowed attention (the window is zero-padded *before* the attention's own
//!   layer norm, so padded tokens take part as keys) with a learned bias per head and per (|dy|, |dx|)
//!   offset, a residual, a 3×3 depthwise conv+BN, then a pre-norm MLP with a residual.
//! - PatchMerging between stages (1×1, 3×3 depthwise, 1×1, conv+BN with GELU between): stride 2, except
//!   the last merge, which keeps the grid (stride 1), so the output grid is `S/16` (64×64 for 1024).
//! - Neck: 1×1 conv, LayerNorm2d, 3×3 conv, LayerNorm2d, to 256 channels, as SAM's.
//!
//! Batch norms are folded into their convolutions at load (eval mode, ε = 1e-5).

use candle_core::{Device, Module, Tensor};
use rayon::prelude::*;

use crate::activation::gelu_erf;
use crate::conv::{layer_norm_2d, Conv2d};
use crate::error::{ModelsError, ModelsResult};
use crate::weights::{ConvSpec, Weights};

const BN_EPS: f64 = 1e-5;
const LN_EPS: f64 = 1e-5;
const NECK_EPS: f64 = 1e-6;

/// Shapes of a TinyViT encoder, inferred from the checkpoint (the input side is not stored in it).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TinyVitConfig {
    /// Square input side (1024 for MobileSAM).
    pub img_size: usize,
    /// Channels per stage.
    pub embed_dims: Vec<usize>,
    /// Blocks per stage.
    pub depths: Vec<usize>,
    /// Attention heads per stage (0 for the convolutional stage 0).
    pub num_heads: Vec<usize>,
    /// Window side per stage (0 for stage 0).
    pub window_sizes: Vec<usize>,
    /// Output channels of the neck (256).
    pub out_chans: usize,
}

impl TinyVitConfig {
    /// From `image_encoder.`-stripped weights, for an input side `img_size`.
    pub fn infer(w: &Weights, img_size: usize) -> ModelsResult<Self> {
        let is_stage = |i: usize| {
            w.contains(&format!("layers.{i}.blocks.0.conv1.c.weight"))
                || w.contains(&format!("layers.{i}.blocks.0.attn.qkv.weight"))
        };
        let stages = (0..).take_while(|&i| is_stage(i)).count();
        if stages < 2 || w.contains("layers.1.blocks.0.conv1.c.weight") {
            return Err(w.missing("layers.1.blocks.0.attn.qkv.weight", &[]));
        }
        let mut config = Self {
            img_size,
            embed_dims: Vec::new(),
            depths: Vec::new(),
            num_heads: Vec::new(),
            window_sizes: Vec::new(),
            out_chans: w.get_any("neck.0.weight")?.dims()[0],
        };
        for i in 0..stages {
            if i == 0 {
                let depth =
                    (0..).take_while(|j| w.contains(&format!("layers.0.blocks.{j}.conv1.c.weight"))).count();
                config.embed_dims.push(w.get_any("layers.0.blocks.0.conv3.c.weight")?.dims()[0]);
                config.depths.push(depth);
                config.num_heads.push(0);
                config.window_sizes.push(0);
            } else {
                let depth = (0..)
                    .take_while(|j| w.contains(&format!("layers.{i}.blocks.{j}.attn.qkv.weight")))
                    .count();
                let biases = w.get_any(&format!("layers.{i}.blocks.0.attn.attention_biases"))?;
                let offsets = biases.dims().get(1).copied().unwrap_or(0);
                let window = (offsets as f64).sqrt().round() as usize;
                config.embed_dims.push(w.get_any(&format!("layers.{i}.blocks.0.attn.qkv.weight"))?.dims()[1]);
                config.depths.push(depth);
                config.num_heads.push(biases.dims()[0]);
                config.window_sizes.push(window);
            }
        }
        config.check()?;
        Ok(config)
    }

    /// The side of the output grid: `img_size / 4`, halved by every merge but the last.
    pub fn grid(&self) -> usize {
        self.img_size / 4 / (1 << self.embed_dims.len().saturating_sub(2))
    }

    fn check(&self) -> ModelsResult<()> {
        let merges = self.embed_dims.len().saturating_sub(2) as u32;
        let multiple = 4 * 2usize.pow(merges);
        if self.img_size == 0 || !self.img_size.is_multiple_of(multiple) {
            return Err(ModelsError::Input(format!(
                "TinyViT input side {} is not a positive multiple of {multiple}",
                self.img_size
            )));
        }
        Ok(())
    }
}

/// A convolution with its batch norm folded in: dense (groups = 1) or depthwise (groups = channels).
#[derive(Debug, Clone)]
enum ConvBn {
    Dense(Conv2d),
    Depthwise(Depthwise),
}

impl ConvBn {
    /// `prefix.c.weight` + `prefix.bn.{weight,bias,running_mean,running_var}`.
    fn load(
        w: &Weights,
        prefix: &str,
        (in_ch, out_ch): (usize, usize),
        kernel: usize,
        stride: usize,
        depthwise: bool,
    ) -> ModelsResult<Self> {
        let per_group = if depthwise { 1 } else { in_ch };
        let weight = w.get(&format!("{prefix}.c.weight"), &[out_ch, per_group, kernel, kernel])?;
        let bn = |name: &str| w.get(&format!("{prefix}.bn.{name}"), &[out_ch]);
        let (gamma, beta, mean, var) = (bn("weight")?, bn("bias")?, bn("running_mean")?, bn("running_var")?);
        let scale = gamma.div(&(var + BN_EPS)?.sqrt()?)?;
        let weight = weight.broadcast_mul(&scale.reshape((out_ch, 1, 1, 1))?)?;
        let bias = beta.sub(&mean.mul(&scale)?)?;
        let padding = kernel / 2;
        if depthwise {
            Ok(Self::Depthwise(Depthwise {
                weight: weight.flatten_all()?.to_vec1::<f32>()?,
                bias: bias.to_vec1::<f32>()?,
                channels: out_ch,
                kernel,
                stride,
                padding,
            }))
        } else {
            Ok(Self::Dense(Conv2d::new(&weight, Some(bias), stride, padding)?))
        }
    }

    /// `x`: `[C, H, W]`; returns `[C', H', W']`.
    fn forward(&self, x: &Tensor) -> ModelsResult<Tensor> {
        match self {
            Self::Dense(conv) => Ok(conv.forward(x)?.squeeze(0)?),
            Self::Depthwise(conv) => conv.forward(x),
        }
    }
}

/// Depthwise 2D convolution (one `k×k` filter per channel), square kernel, zero padding.
#[derive(Debug, Clone)]
struct Depthwise {
    /// `[C·k·k]`.
    weight: Vec<f32>,
    /// `[C]`.
    bias: Vec<f32>,
    channels: usize,
    kernel: usize,
    stride: usize,
    padding: usize,
}

impl Depthwise {
    fn forward(&self, x: &Tensor) -> ModelsResult<Tensor> {
        let (c, h, w) = x.dims3()?;
        let (k, s, p) = (self.kernel, self.stride, self.padding);
        if c != self.channels || h + 2 * p < k || w + 2 * p < k {
            return Err(ModelsError::Input(format!(
                "depthwise convolution over {} channels ({k}×{k}) given a {c}×{h}×{w} map",
                self.channels
            )));
        }
        let out_h = (h + 2 * p - k) / s + 1;
        let out_w = (w + 2 * p - k) / s + 1;
        let input = x.flatten_all()?.to_vec1::<f32>()?;
        let mut out = vec![0f32; c * out_h * out_w];
        // Each output row accumulates its taps in (ky, kx) order, a whole row per tap (contiguous
        // for stride 1, so it vectorises): the same additions in the same order as a per-pixel loop.
        out.par_chunks_mut(out_h * out_w).enumerate().for_each(|(ch, dst)| {
            let plane = &input[ch * h * w..(ch + 1) * h * w];
            let filter = &self.weight[ch * k * k..(ch + 1) * k * k];
            for (oy, out_row) in dst.chunks_exact_mut(out_w).enumerate() {
                out_row.fill(0.0);
                for ky in 0..k {
                    let Some(iy) = (oy * s + ky).checked_sub(p).filter(|&iy| iy < h) else {
                        continue;
                    };
                    let row = &plane[iy * w..(iy + 1) * w];
                    for kx in 0..k {
                        let f = filter[ky * k + kx];
                        // outputs whose input column ox·s + kx − p lies in 0..w
                        let lo = p.saturating_sub(kx).div_ceil(s);
                        let Some(last) = (w + p).checked_sub(kx + 1) else { continue };
                        let hi = (last / s + 1).min(out_w);
                        if lo >= hi {
                            continue;
                        }
                        let start = lo * s + kx - p;
                        if s == 1 {
                            let taps = out_row[lo..hi].iter_mut().zip(&row[start..start + hi - lo]);
                            taps.for_each(|(o, x)| *o += x * f);
                        } else {
                            let taps = out_row[lo..hi].iter_mut().zip(row[start..].iter().step_by(s));
                            taps.for_each(|(o, x)| *o += x * f);
                        }
                    }
                }
                out_row.iter_mut().for_each(|v| *v += self.bias[ch]);
            }
        });
        Ok(Tensor::from_vec(out, (c, out_h, out_w), &Device::Cpu)?)
    }
}

/// Stage 0's inverted bottleneck.
#[derive(Debug, Clone)]
struct MbConv {
    conv1: ConvBn,
    conv2: ConvBn,
    conv3: ConvBn,
}

impl MbConv {
    fn forward(&self, x: &Tensor) -> ModelsResult<Tensor> {
        let y = gelu_erf(&self.conv1.forward(x)?)?;
        let y = gelu_erf(&self.conv2.forward(&y)?)?;
        let y = self.conv3.forward(&y)?;
        gelu_erf(&(y + x)?)
    }
}

/// Downsampling between stages.
#[derive(Debug, Clone)]
struct PatchMerging {
    conv1: ConvBn,
    conv2: ConvBn,
    conv3: ConvBn,
}

impl PatchMerging {
    fn load(w: &Weights, prefix: &str, dim: usize, out_dim: usize, stride: usize) -> ModelsResult<Self> {
        Ok(Self {
            conv1: ConvBn::load(w, &format!("{prefix}.conv1"), (dim, out_dim), 1, 1, false)?,
            conv2: ConvBn::load(w, &format!("{prefix}.conv2"), (out_dim, out_dim), 3, stride, true)?,
            conv3: ConvBn::load(w, &format!("{prefix}.conv3"), (out_dim, out_dim), 1, 1, false)?,
        })
    }

    fn forward(&self, x: &Tensor) -> ModelsResult<Tensor> {
        let y = gelu_erf(&self.conv1.forward(x)?)?;
        let y = gelu_erf(&self.conv2.forward(&y)?)?;
        self.conv3.forward(&y)
    }
}

/// A TinyViT block.
#[derive(Debug, Clone)]
struct Block {
    norm: candle_nn::LayerNorm,
    /// Output per head: `[q (d), k (d), v (d)]`.
    qkv: candle_nn::Linear,
    proj: candle_nn::Linear,
    /// `attention_biases[h, idx(i, j)]` expanded: `[heads, ws², ws²]`.
    bias: Tensor,
    local_conv: ConvBn,
    mlp_norm: candle_nn::LayerNorm,
    fc1: candle_nn::Linear,
    fc2: candle_nn::Linear,
    heads: usize,
    window: usize,
}

/// Index of each (query, key) pair's offset `(|dy|, |dx|)` in a `ws×ws` window, numbered by first
/// appearance in row-major (query, key) order, as TinyViT's `attention_bias_idxs`.
fn bias_indices(ws: usize) -> Vec<u32> {
    let n = ws * ws;
    let mut index_of = vec![u32::MAX; n];
    let mut next = 0u32;
    let mut idxs = Vec::with_capacity(n * n);
    for a in 0..n {
        for b in 0..n {
            let offset = (a / ws).abs_diff(b / ws) * ws + (a % ws).abs_diff(b % ws);
            if index_of[offset] == u32::MAX {
                index_of[offset] = next;
                next += 1;
            }
            idxs.push(index_of[offset]);
        }
    }
    idxs
}

impl Block {
    fn load(w: &Weights, prefix: &str, dim: usize, heads: usize, window: usize) -> ModelsResult<Self> {
        let n = window * window;
        let biases = w.get(&format!("{prefix}.attn.attention_biases"), &[heads, n])?;
        let idxs = bias_indices(window);
        let idx_name = format!("{prefix}.attn.attention_bias_idxs");
        if w.contains(&idx_name) {
            let stored = w.get(&idx_name, &[n, n])?.flatten_all()?.to_vec1::<f32>()?;
            if stored.iter().zip(&idxs).any(|(a, b)| *a != *b as f32) {
                return Err(ModelsError::Input(format!(
                    "{idx_name} differs from TinyViT's offset numbering for a {window}×{window} window"
                )));
            }
        }
        let idxs = Tensor::from_vec(idxs, n * n, &Device::Cpu)?;
        let bias = biases.index_select(&idxs, 1)?.reshape((heads, n, n))?.contiguous()?;
        let mlp = w.get_any(&format!("{prefix}.mlp.fc1.weight"))?.dims()[0];
        Ok(Self {
            norm: w.layer_norm(&format!("{prefix}.attn.norm"), dim, LN_EPS)?,
            qkv: w.linear(&format!("{prefix}.attn.qkv"), dim, 3 * dim)?,
            proj: w.linear(&format!("{prefix}.attn.proj"), dim, dim)?,
            bias,
            local_conv: ConvBn::load(w, &format!("{prefix}.local_conv"), (dim, dim), 3, 1, true)?,
            mlp_norm: w.layer_norm(&format!("{prefix}.mlp.norm"), dim, LN_EPS)?,
            fc1: w.linear(&format!("{prefix}.mlp.fc1"), dim, mlp)?,
            fc2: w.linear(&format!("{prefix}.mlp.fc2"), mlp, dim)?,
            heads,
            window,
        })
    }

    /// `x`: `[H, W, C]` tokens.
    fn forward(&self, x: &Tensor) -> ModelsResult<Tensor> {
        let (h, w, c) = x.dims3()?;
        let ws = self.window;
        let (hp, wp) = (h.div_ceil(ws) * ws, w.div_ceil(ws) * ws);
        // padding before the attention's norm: padded tokens are LN(0) = bias, and take part as keys
        let padded = x.pad_with_zeros(0, 0, hp - h)?.pad_with_zeros(1, 0, wp - w)?;
        let windows = padded
            .reshape((hp / ws, ws, wp / ws, ws, c))?
            .permute((0, 2, 1, 3, 4))?
            .reshape((hp / ws * (wp / ws), ws * ws, c))?
            .contiguous()?;
        let attended = self
            .attention(&windows)?
            .reshape((hp / ws, wp / ws, ws, ws, c))?
            .permute((0, 2, 1, 3, 4))?
            .reshape((hp, wp, c))?
            .narrow(0, 0, h)?
            .narrow(1, 0, w)?;
        let x = (x + attended)?;
        let map = x.permute((2, 0, 1))?.contiguous()?;
        let x = self.local_conv.forward(&map)?.permute((1, 2, 0))?.contiguous()?;
        let mlp = self.fc2.forward(&gelu_erf(&self.fc1.forward(&self.mlp_norm.forward(&x)?)?)?)?;
        Ok((x + mlp)?)
    }

    /// `x`: `[B, N, C]` windows of `N = ws²` tokens.
    fn attention(&self, x: &Tensor) -> ModelsResult<Tensor> {
        let (b, n, c) = x.dims3()?;
        let heads = self.heads;
        let hd = c / heads;
        let qkv = self
            .qkv
            .forward(&self.norm.forward(x)?)?
            .reshape((b, n, heads, 3, hd))?
            .permute((3, 0, 2, 1, 4))?; // [3, B, heads, N, hd]
        let q = qkv.get(0)?.reshape((b * heads, n, hd))?.contiguous()?;
        let k = qkv.get(1)?.reshape((b * heads, n, hd))?.contiguous()?;
        let v = qkv.get(2)?.reshape((b * heads, n, hd))?.contiguous()?;
        let scale = 1.0 / (hd as f64).sqrt();
        let scores = (q.matmul(&k.t()?)? * scale)?.reshape((b, heads, n, n))?.broadcast_add(&self.bias)?;
        let weights = candle_nn::ops::softmax_last_dim(&scores)?.reshape((b * heads, n, n))?;
        let out =
            weights.matmul(&v)?.reshape((b, heads, n, hd))?.permute((0, 2, 1, 3))?.reshape((b, n, c))?;
        Ok(self.proj.forward(&out)?)
    }
}

#[derive(Debug, Clone)]
enum Stage {
    Conv(Vec<MbConv>),
    Attention(Vec<Block>),
}

/// The TinyViT image encoder with SAM's neck.
#[derive(Debug, Clone)]
pub struct TinyVit {
    config: TinyVitConfig,
    patch1: ConvBn,
    patch2: ConvBn,
    /// Each stage's blocks and the merge after it (none after the last).
    stages: Vec<(Stage, Option<PatchMerging>)>,
    neck_conv1: Conv2d,
    neck_norm1: candle_nn::LayerNorm,
    neck_conv2: Conv2d,
    neck_norm2: candle_nn::LayerNorm,
}

impl TinyVit {
    /// Builds the encoder from `image_encoder.`-stripped weights.
    pub fn new(w: &Weights, config: TinyVitConfig) -> ModelsResult<Self> {
        config.check()?;
        let dims = &config.embed_dims;
        let patch1 = ConvBn::load(w, "patch_embed.seq.0", (3, dims[0] / 2), 3, 2, false)?;
        let patch2 = ConvBn::load(w, "patch_embed.seq.2", (dims[0] / 2, dims[0]), 3, 2, false)?;
        let last = dims.len() - 1;
        let mut stages = Vec::with_capacity(dims.len());
        for (i, &dim) in dims.iter().enumerate() {
            let stage = if i == 0 {
                let expanded = w.get_any("layers.0.blocks.0.conv1.c.weight")?.dims()[0];
                let blocks = (0..config.depths[0])
                    .map(|j| {
                        let pre = format!("layers.0.blocks.{j}");
                        Ok(MbConv {
                            conv1: ConvBn::load(w, &format!("{pre}.conv1"), (dim, expanded), 1, 1, false)?,
                            conv2: ConvBn::load(
                                w,
                                &format!("{pre}.conv2"),
                                (expanded, expanded),
                                3,
                                1,
                                true,
                            )?,
                            conv3: ConvBn::load(w, &format!("{pre}.conv3"), (expanded, dim), 1, 1, false)?,
                        })
                    })
                    .collect::<ModelsResult<Vec<_>>>()?;
                Stage::Conv(blocks)
            } else {
                let blocks = (0..config.depths[i])
                    .map(|j| {
                        let pre = format!("layers.{i}.blocks.{j}");
                        Block::load(w, &pre, dim, config.num_heads[i], config.window_sizes[i])
                    })
                    .collect::<ModelsResult<Vec<_>>>()?;
                Stage::Attention(blocks)
            };
            let merge = if i < last {
                let stride = if i + 1 == last { 1 } else { 2 };
                Some(PatchMerging::load(w, &format!("layers.{i}.downsample"), dim, dims[i + 1], stride)?)
            } else {
                None
            };
            stages.push((stage, merge));
        }
        let (c, o) = (dims[last], config.out_chans);
        Ok(Self {
            patch1,
            patch2,
            stages,
            neck_conv1: w
                .conv2d("neck.0", ConvSpec { padding: 0, bias: false, ..ConvSpec::same(c, o, 1) })?,
            neck_norm1: w.layer_norm("neck.1", o, NECK_EPS)?,
            neck_conv2: w.conv2d("neck.2", ConvSpec { bias: false, ..ConvSpec::same(o, o, 3) })?,
            neck_norm2: w.layer_norm("neck.3", o, NECK_EPS)?,
            config,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &TinyVitConfig {
        &self.config
    }

    /// Runs at another input side (TinyViT has no absolute positions; the side must be a multiple of 16
    /// for the four-stage model).
    pub fn set_img_size(&mut self, side: usize) -> ModelsResult<()> {
        let mut config = self.config.clone();
        config.img_size = side;
        config.check()?;
        self.config = config;
        Ok(())
    }

    /// `pixels`: `[3, S, S]` normalised and padded to `img_size`. Returns `[out_chans, S/16, S/16]`.
    pub fn forward(&self, pixels: &Tensor) -> ModelsResult<Tensor> {
        let side = self.config.img_size;
        if pixels.dims() != [3, side, side] {
            return Err(ModelsError::Input(format!(
                "TinyViT expects a [3, {side}, {side}] input, got {:?}",
                pixels.dims()
            )));
        }
        let mut x = gelu_erf(&self.patch1.forward(pixels)?)?;
        x = self.patch2.forward(&x)?; // [C, H, W]
        for (stage, merge) in &self.stages {
            x = match stage {
                Stage::Conv(blocks) => {
                    for block in blocks {
                        x = block.forward(&x)?;
                    }
                    x
                }
                Stage::Attention(blocks) => {
                    let mut tokens = x.permute((1, 2, 0))?.contiguous()?;
                    for block in blocks {
                        tokens = block.forward(&tokens)?;
                    }
                    tokens.permute((2, 0, 1))?.contiguous()?
                }
            };
            if let Some(merge) = merge {
                x = merge.forward(&x)?;
            }
        }
        let x = x.unsqueeze(0)?;
        let x = layer_norm_2d(&self.neck_conv1.forward(&x)?, &self.neck_norm1)?;
        let x = layer_norm_2d(&self.neck_conv2.forward(&x)?, &self.neck_norm2)?;
        Ok(x.squeeze(0)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depthwise_rows_match_a_per_pixel_loop() {
        for (c, h, w, k, stride, padding) in [
            (3, 7, 9, 3, 1, 1),
            (2, 8, 5, 3, 2, 1),
            (2, 6, 6, 3, 1, 0),
            (1, 4, 3, 5, 2, 2),
            (2, 2, 2, 3, 1, 1),
        ] {
            let values = |len: usize, seed: usize| -> Vec<f32> {
                (0..len).map(|i| (((i + seed) * 37 % 101) as f32 - 50.0) * 0.03).collect()
            };
            let conv = Depthwise {
                weight: values(c * k * k, 3),
                bias: values(c, 5),
                channels: c,
                kernel: k,
                stride,
                padding,
            };
            let input = values(c * h * w, 7);
            let x = Tensor::from_vec(input.clone(), (c, h, w), &Device::Cpu).unwrap();
            let ours = conv.forward(&x).unwrap();
            let (_, out_h, out_w) = ours.dims3().unwrap();
            assert_eq!(
                (out_h, out_w),
                ((h + 2 * padding - k) / stride + 1, (w + 2 * padding - k) / stride + 1)
            );
            let ours = ours.flatten_all().unwrap().to_vec1::<f32>().unwrap();
            for ch in 0..c {
                for oy in 0..out_h {
                    for ox in 0..out_w {
                        let mut acc = 0f32;
                        for ky in 0..k {
                            for kx in 0..k {
                                let iy = (oy * stride + ky) as isize - padding as isize;
                                let ix = (ox * stride + kx) as isize - padding as isize;
                                if (0..h as isize).contains(&iy) && (0..w as isize).contains(&ix) {
                                    acc += input[(ch * h + iy as usize) * w + ix as usize]
                                        * conv.weight[(ch * k + ky) * k + kx];
                                }
                            }
                        }
                        // the same additions in the same order: identical
                        assert_eq!(ours[(ch * out_h + oy) * out_w + ox], acc + conv.bias[ch]);
                    }
                }
            }
        }
    }

    #[test]
    fn bias_indices_number_offsets_by_first_appearance() {
        // 2×2 window: offsets (0,0)=0, (0,1)=1, (1,0)=2, (1,1)=3
        assert_eq!(bias_indices(2), vec![0, 1, 2, 3, 1, 0, 3, 2, 2, 3, 0, 1, 3, 2, 1, 0]);
        let idx = bias_indices(7);
        assert_eq!(idx.iter().max(), Some(&48));
    }
}
