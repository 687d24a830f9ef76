//! SAM's prompt encoder for point prompts: random-Fourier positional encodings plus learnt
//! per-label embeddings, and the dense "no mask" embedding.

use candle_core::{Device, Tensor};

use crate::error::ModelsResult;
use crate::weights::Weights;

/// The prompt encoder (points only; SAM's automatic mask generator uses nothing else).
#[derive(Debug, Clone)]
pub struct PromptEncoder {
    /// Random frequencies, `[2, D/2]`.
    gaussian: Tensor,
    /// Embedding added to positive points, `[D]`.
    positive: Tensor,
    /// Embedding added to negative points, `[D]`.
    negative: Tensor,
    /// Embedding of the padding point, `[D]`.
    not_a_point: Tensor,
    /// Dense embedding when no mask is given, `[D]`.
    no_mask: Tensor,
    embed_dim: usize,
}

impl PromptEncoder {
    /// From `prompt_encoder.`-stripped weights; `embed_dim` is the decoder width (256).
    pub fn new(w: &Weights, embed_dim: usize) -> ModelsResult<Self> {
        let vec =
            |name: &str| -> ModelsResult<Tensor> { Ok(w.get(name, &[1, embed_dim])?.reshape(embed_dim)?) };
        Ok(Self {
            gaussian: w.get("pe_layer.positional_encoding_gaussian_matrix", &[2, embed_dim / 2])?,
            negative: vec("point_embeddings.0.weight")?,
            positive: vec("point_embeddings.1.weight")?,
            not_a_point: vec("not_a_point_embed.weight")?,
            no_mask: vec("no_mask_embed.weight")?,
            embed_dim,
        })
    }

    /// `coords01`: `[N, 2]` (x, y) in [0, 1]. Returns `[N, D]` = `[sin(2π(2c−1)G), cos(2π(2c−1)G)]`.
    fn encode(&self, coords01: &Tensor) -> ModelsResult<Tensor> {
        let projected = ((coords01 * 2.0)? - 1.0)?.matmul(&self.gaussian)?;
        let projected = (projected * (2.0 * std::f64::consts::PI))?;
        Ok(Tensor::cat(&[projected.sin()?, projected.cos()?], 1)?)
    }

    /// Positional encoding of every cell of an `h × w` embedding grid, `[D, h, w]`.
    pub fn dense_pe(&self, h: usize, w: usize) -> ModelsResult<Tensor> {
        let coords: Vec<f32> = (0..h)
            .flat_map(|y| {
                (0..w).flat_map(move |x| [(x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32])
            })
            .collect();
        let coords = Tensor::from_vec(coords, (h * w, 2), &Device::Cpu)?;
        Ok(self.encode(&coords)?.t()?.reshape((self.embed_dim, h, w))?.contiguous()?)
    }

    /// Sparse embeddings of one labelled point per prompt, plus SAM's padding point.
    ///
    /// `points`: `[B, 2]` pixel coordinates (x, y) in the encoder's input frame; `positive[b]` the label;
    /// `input_size` the encoder's square input side. Returns `[B, 2, D]`.
    pub fn embed_points(
        &self,
        points: &[[f32; 2]],
        positive: &[bool],
        input_size: usize,
    ) -> ModelsResult<Tensor> {
        let b = points.len();
        let coords: Vec<f32> = points
            .iter()
            .flat_map(|p| [(p[0] + 0.5) / input_size as f32, (p[1] + 0.5) / input_size as f32])
            .collect();
        let encoded = self.encode(&Tensor::from_vec(coords, (b, 2), &Device::Cpu)?)?;
        let labels: Vec<Tensor> =
            positive.iter().map(|&p| if p { self.positive.clone() } else { self.negative.clone() }).collect();
        let point = (encoded + Tensor::stack(&labels, 0)?)?;
        let pad = self.not_a_point.unsqueeze(0)?.broadcast_as((b, self.embed_dim))?;
        Ok(Tensor::stack(&[point, pad.contiguous()?], 1)?)
    }

    /// The dense prompt embedding without a mask input, `[D]` (added to every image cell).
    pub fn no_mask_embedding(&self) -> &Tensor {
        &self.no_mask
    }
}
