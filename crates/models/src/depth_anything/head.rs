//! The DPT head of Depth Anything V2: reassemble four backbone layers at 4×, 2×, 1×, ½× the patch grid,
//! fuse them coarse-to-fine with residual conv units, and predict one channel at the input resolution.

use candle_core::Tensor;

use crate::conv::{Conv2d, PatchConvTranspose};
use crate::dinov2::Dinov2Config;
use crate::error::{ModelsError, ModelsResult};
use crate::resample::{resize_tensor, Resample};
use crate::weights::{ConvSpec, Weights};

/// Shapes of the head, inferred from the checkpoint.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DptHeadConfig {
    /// Backbone blocks (0-based) whose normalised outputs feed the head.
    pub layer_indices: Vec<usize>,
    /// Channels of the four reassembled maps (`neck_hidden_sizes`).
    pub neck_sizes: [usize; 4],
    /// Channels inside the fusion stage.
    pub fusion_size: usize,
    /// Channels of the head's hidden conv (32).
    pub head_hidden: usize,
    /// Output scale (1 for relative depth).
    pub max_depth: f32,
    /// Metric models end in a sigmoid, relative ones in a ReLU.
    pub metric: bool,
}

impl DptHeadConfig {
    /// From Hugging Face-named `weights`, the backbone and the optional `config.json`.
    pub fn infer(
        weights: &Weights,
        backbone: &Dinov2Config,
        hf_config: Option<&serde_json::Value>,
    ) -> ModelsResult<Self> {
        let mut neck_sizes = [0usize; 4];
        for (i, size) in neck_sizes.iter_mut().enumerate() {
            *size =
                weights.get_any(&format!("neck.reassemble_stage.layers.{i}.projection.weight"))?.dims()[0];
        }
        let fusion_size = weights.get_any("neck.convs.0.weight")?.dims()[0];
        let head_hidden = weights.get_any("head.conv2.weight")?.dims()[0];
        let json_indices = hf_config
            .and_then(|c| c.get("backbone_config"))
            .and_then(|b| b.get("out_indices"))
            .and_then(|v| v.as_array())
            .map(|a| {
                a.iter()
                    .filter_map(|v| v.as_u64())
                    .map(|v| (v as usize).saturating_sub(1))
                    .collect::<Vec<_>>()
            });
        let layer_indices = match json_indices {
            Some(indices) if indices.len() == 4 => indices,
            _ => match backbone.num_layers {
                12 => vec![2, 5, 8, 11],
                24 => vec![4, 11, 17, 23],
                40 => vec![9, 19, 29, 39],
                n => {
                    return Err(ModelsError::Config {
                        reason: format!("cannot tell which of the backbone's {n} layers feed the head; give a config.json with backbone_config.out_indices"),
                        path: weights.path().to_path_buf(),
                    })
                }
            },
        };
        let metric =
            hf_config.and_then(|c| c.get("depth_estimation_type")).and_then(|v| v.as_str()) == Some("metric");
        let max_depth =
            hf_config.and_then(|c| c.get("max_depth")).and_then(|v| v.as_f64()).unwrap_or(1.0) as f32;
        Ok(Self { layer_indices, neck_sizes, fusion_size, head_hidden, max_depth, metric })
    }
}

/// How a reassemble layer changes the grid.
#[derive(Debug, Clone)]
enum Resize {
    /// Transposed conv with kernel = stride = factor.
    Up(PatchConvTranspose),
    Identity,
    /// 3×3 conv, stride 2, padding 1.
    Down(Conv2d),
}

#[derive(Debug, Clone)]
struct ResidualUnit {
    conv1: Conv2d,
    conv2: Conv2d,
}

impl ResidualUnit {
    fn new(weights: &Weights, prefix: &str, channels: usize) -> ModelsResult<Self> {
        let spec = ConvSpec::same(channels, channels, 3);
        Ok(Self {
            conv1: weights.conv2d(&format!("{prefix}.convolution1"), spec)?,
            conv2: weights.conv2d(&format!("{prefix}.convolution2"), spec)?,
        })
    }

    /// `x`: `[1, C, H, W]`.
    fn forward(&self, x: &Tensor) -> ModelsResult<Tensor> {
        let y = self.conv1.forward(&x.relu()?)?;
        let y = self.conv2.forward(&y.relu()?)?;
        Ok((y + x)?)
    }
}

#[derive(Debug, Clone)]
struct FusionLayer {
    projection: Conv2d,
    residual1: ResidualUnit,
    residual2: ResidualUnit,
}

/// The DPT neck and head.
#[derive(Debug, Clone)]
pub struct DptHead {
    config: DptHeadConfig,
    projections: Vec<Conv2d>,
    resizes: Vec<Resize>,
    convs: Vec<Conv2d>,
    fusion: Vec<FusionLayer>,
    conv1: Conv2d,
    conv2: Conv2d,
    conv3: Conv2d,
}

impl DptHead {
    /// Builds the head from Hugging Face-named `weights`.
    pub fn new(weights: &Weights, config: DptHeadConfig) -> ModelsResult<Self> {
        let hidden = weights.get_any("neck.reassemble_stage.layers.0.projection.weight")?.dims()[1];
        let f = config.fusion_size;
        let mut projections = Vec::new();
        let mut resizes = Vec::new();
        let mut convs = Vec::new();
        for (i, &channels) in config.neck_sizes.iter().enumerate() {
            let prefix = format!("neck.reassemble_stage.layers.{i}");
            projections.push(weights.conv2d(
                &format!("{prefix}.projection"),
                ConvSpec { padding: 0, ..ConvSpec::same(hidden, channels, 1) },
            )?);
            resizes.push(match i {
                0 | 1 => {
                    let factor = 4 >> i;
                    let w = weights
                        .get(&format!("{prefix}.resize.weight"), &[channels, channels, factor, factor])?;
                    let bias = weights.get(&format!("{prefix}.resize.bias"), &[channels])?;
                    Resize::Up(PatchConvTranspose::new(&w, bias)?)
                }
                2 => Resize::Identity,
                _ => Resize::Down(weights.conv2d(
                    &format!("{prefix}.resize"),
                    ConvSpec { stride: 2, ..ConvSpec::same(channels, channels, 3) },
                )?),
            });
            convs.push(weights.conv2d(
                &format!("neck.convs.{i}"),
                ConvSpec { bias: false, ..ConvSpec::same(channels, f, 3) },
            )?);
        }
        let fusion = (0..4)
            .map(|i| {
                let prefix = format!("neck.fusion_stage.layers.{i}");
                Ok(FusionLayer {
                    projection: weights.conv2d(
                        &format!("{prefix}.projection"),
                        ConvSpec { padding: 0, ..ConvSpec::same(f, f, 1) },
                    )?,
                    residual1: ResidualUnit::new(weights, &format!("{prefix}.residual_layer1"), f)?,
                    residual2: ResidualUnit::new(weights, &format!("{prefix}.residual_layer2"), f)?,
                })
            })
            .collect::<ModelsResult<Vec<_>>>()?;
        let conv1 = weights.conv2d("head.conv1", ConvSpec::same(f, f / 2, 3))?;
        let conv2 = weights.conv2d("head.conv2", ConvSpec::same(f / 2, config.head_hidden, 3))?;
        let conv3 = weights
            .conv2d("head.conv3", ConvSpec { padding: 0, ..ConvSpec::same(config.head_hidden, 1, 1) })?;
        Ok(Self { config, projections, resizes, convs, fusion, conv1, conv2, conv3 })
    }

    /// The configuration.
    pub fn config(&self) -> &DptHeadConfig {
        &self.config
    }

    /// `layers`: four `[gh·gw, C]` normalised token maps. Returns depth `[gh·14, gw·14]`.
    pub fn forward(&self, layers: &[Tensor], gh: usize, gw: usize) -> ModelsResult<Tensor> {
        if layers.len() != 4 {
            return Err(ModelsError::Input(format!("the DPT head needs 4 layers, got {}", layers.len())));
        }
        let mut maps = Vec::with_capacity(4);
        for (i, tokens) in layers.iter().enumerate() {
            let (_, c) = tokens.dims2()?;
            let grid = tokens.t()?.reshape((1, c, gh, gw))?.contiguous()?;
            let projected = self.projections[i].forward(&grid)?;
            let resized = match &self.resizes[i] {
                Resize::Up(up) => up.forward(&projected)?,
                Resize::Identity => projected,
                Resize::Down(conv) => conv.forward(&projected)?,
            };
            maps.push(self.convs[i].forward(&resized)?);
        }
        // coarse to fine: fusion layer k handles maps[3 − k]
        let mut fused: Option<Tensor> = None;
        for (k, layer) in self.fusion.iter().enumerate() {
            let map = &maps[3 - k];
            let target = if k < 3 { Some(maps[2 - k].dims4()?) } else { None };
            let mut x = match &fused {
                None => map.clone(),
                Some(prev) => {
                    let residual = if prev.dims() == map.dims() {
                        map.clone()
                    } else {
                        resize4(map, prev.dims4()?.2, prev.dims4()?.3, Resample::Bilinear)?
                    };
                    (prev + layer.residual1.forward(&residual)?)?
                }
            };
            x = layer.residual2.forward(&x)?;
            let (_, _, h, w) = x.dims4()?;
            let (th, tw) = target.map(|t| (t.2, t.3)).unwrap_or((2 * h, 2 * w));
            x = resize4(&x, th, tw, Resample::BilinearAlignCorners)?;
            fused = Some(layer.projection.forward(&x)?);
        }
        let fused = fused.ok_or_else(|| ModelsError::Input("no fusion layers".into()))?;
        let x = self.conv1.forward(&fused)?;
        let x = resize4(&x, gh * 14, gw * 14, Resample::BilinearAlignCorners)?;
        let x = self.conv2.forward(&x)?.relu()?;
        let x = self.conv3.forward(&x)?;
        let x = if self.config.metric { candle_nn::ops::sigmoid(&x)? } else { x.relu()? };
        let x = (x * self.config.max_depth as f64)?;
        Ok(x.squeeze(0)?.squeeze(0)?)
    }
}

/// Resizes `[1, C, H, W]` to `[1, C, h, w]`.
fn resize4(x: &Tensor, h: usize, w: usize, mode: Resample) -> ModelsResult<Tensor> {
    Ok(resize_tensor(&x.squeeze(0)?, h, w, mode)?.unsqueeze(0)?)
}
