//! SAM's mask decoder: a two-way transformer between prompt tokens and image cells, an upscaling
//! path to 4× the embedding grid, hypernetwork MLPs giving one mask per output token, and an IoU head.

use std::sync::Arc;

use candle_core::{Module, Tensor};

use super::packed_decoder::PackedDecoder;

use crate::activation::gelu_erf;
use crate::error::ModelsResult;
use crate::weights::Weights;

/// Decoder attention heads (8 in every released SAM).
pub(super) const NUM_HEADS: usize = 8;

#[derive(Debug, Clone)]
pub(super) struct Attention {
    pub(super) q: candle_nn::Linear,
    pub(super) k: candle_nn::Linear,
    pub(super) v: candle_nn::Linear,
    pub(super) out: candle_nn::Linear,
    pub(super) internal: usize,
}

impl Attention {
    fn new(w: &Weights, prefix: &str, dim: usize) -> ModelsResult<Self> {
        let internal = w.get_any(&format!("{prefix}.q_proj.weight"))?.dims()[0];
        Ok(Self {
            q: w.linear(&format!("{prefix}.q_proj"), dim, internal)?,
            k: w.linear(&format!("{prefix}.k_proj"), dim, internal)?,
            v: w.linear(&format!("{prefix}.v_proj"), dim, internal)?,
            out: w.linear(&format!("{prefix}.out_proj"), internal, dim)?,
            internal,
        })
    }

    /// `q`: `[B, Nq, D]`, `k`, `v`: `[B, Nk, D]`. Returns `[B, Nq, D]`.
    pub(super) fn forward(&self, q: &Tensor, k: &Tensor, v: &Tensor) -> ModelsResult<Tensor> {
        let (b, nq, _) = q.dims3()?;
        let nk = k.dims()[1];
        let hd = self.internal / NUM_HEADS;
        let split = |x: Tensor, n: usize| -> ModelsResult<Tensor> {
            Ok(x.reshape((b, n, NUM_HEADS, hd))?.transpose(1, 2)?.contiguous()?)
        };
        let q = split(self.q.forward(q)?, nq)?;
        let k = split(self.k.forward(k)?, nk)?;
        let v = split(self.v.forward(v)?, nk)?;
        let scores = (q.matmul(&k.transpose(2, 3)?)? / (hd as f64).sqrt())?;
        let out = candle_nn::ops::softmax_last_dim(&scores)?.matmul(&v)?;
        let out = out.transpose(1, 2)?.reshape((b, nq, self.internal))?;
        Ok(self.out.forward(&out)?)
    }
}

#[derive(Debug, Clone)]
pub(super) struct TwoWayBlock {
    pub(super) self_attn: Attention,
    pub(super) norm1: candle_nn::LayerNorm,
    pub(super) token_to_image: Attention,
    pub(super) norm2: candle_nn::LayerNorm,
    pub(super) lin1: candle_nn::Linear,
    pub(super) lin2: candle_nn::Linear,
    pub(super) norm3: candle_nn::LayerNorm,
    pub(super) norm4: candle_nn::LayerNorm,
    pub(super) image_to_token: Attention,
    pub(super) skip_first_pe: bool,
}

impl TwoWayBlock {
    fn new(w: &Weights, prefix: &str, dim: usize, skip_first_pe: bool) -> ModelsResult<Self> {
        let mlp = w.get_any(&format!("{prefix}.mlp.lin1.weight"))?.dims()[0];
        let ln = |n: &str| w.layer_norm(&format!("{prefix}.{n}"), dim, 1e-5);
        Ok(Self {
            self_attn: Attention::new(w, &format!("{prefix}.self_attn"), dim)?,
            norm1: ln("norm1")?,
            token_to_image: Attention::new(w, &format!("{prefix}.cross_attn_token_to_image"), dim)?,
            norm2: ln("norm2")?,
            lin1: w.linear(&format!("{prefix}.mlp.lin1"), dim, mlp)?,
            lin2: w.linear(&format!("{prefix}.mlp.lin2"), mlp, dim)?,
            norm3: ln("norm3")?,
            norm4: ln("norm4")?,
            image_to_token: Attention::new(w, &format!("{prefix}.cross_attn_image_to_token"), dim)?,
            skip_first_pe,
        })
    }

    /// `queries`: `[B, Nq, D]`, `keys`: `[B, HW, D]`; `query_pe` like queries, `key_pe`: `[1, HW, D]`.
    fn forward(
        &self,
        queries: &Tensor,
        keys: &Tensor,
        query_pe: &Tensor,
        key_pe: &Tensor,
    ) -> ModelsResult<(Tensor, Tensor)> {
        let queries = if self.skip_first_pe {
            self.self_attn.forward(queries, queries, queries)?
        } else {
            let q = (queries + query_pe)?;
            (queries + self.self_attn.forward(&q, &q, queries)?)?
        };
        let queries = self.norm1.forward(&queries)?;
        let q = (&queries + query_pe)?;
        let k = keys.broadcast_add(key_pe)?;
        let queries = self.norm2.forward(&(&queries + self.token_to_image.forward(&q, &k, keys)?)?)?;
        let mlp = self.lin2.forward(&self.lin1.forward(&queries)?.relu()?)?;
        let queries = self.norm3.forward(&(queries + mlp)?)?;
        let q = (&queries + query_pe)?;
        let keys = self.norm4.forward(&(keys + self.image_to_token.forward(&k, &q, &queries)?)?)?;
        Ok((queries, keys))
    }
}

#[derive(Debug, Clone)]
pub(super) struct Mlp {
    pub(super) layers: Vec<candle_nn::Linear>,
}

impl Mlp {
    fn new(w: &Weights, prefix: &str) -> ModelsResult<Self> {
        let layers = (0..)
            .map_while(|i| {
                let name = format!("{prefix}.layers.{i}");
                let weight = w.shape_of(&format!("{name}.weight"))?;
                Some(w.linear(&name, weight[1], weight[0]))
            })
            .collect::<ModelsResult<Vec<_>>>()?;
        if layers.is_empty() {
            return Err(w.missing(&format!("{prefix}.layers.0.weight"), &[]));
        }
        Ok(Self { layers })
    }

    pub(super) fn forward(&self, x: &Tensor) -> ModelsResult<Tensor> {
        let mut x = x.clone();
        for (i, layer) in self.layers.iter().enumerate() {
            x = layer.forward(&x)?;
            if i + 1 < self.layers.len() {
                x = x.relu()?;
            }
        }
        Ok(x)
    }
}

/// The mask decoder.
#[derive(Debug, Clone)]
pub struct MaskDecoder {
    /// `[1 + M, D]`: IoU token then the M mask tokens.
    pub(super) output_tokens: Tensor,
    pub(super) blocks: Vec<TwoWayBlock>,
    pub(super) final_attn: Attention,
    pub(super) final_norm: candle_nn::LayerNorm,
    /// First 2× transposed conv as a matrix with columns ordered (dy, dx, c): `[D, 4·D/4]`.
    pub(super) up1_weight: Tensor,
    /// `[D/4]`, repeated per (dy, dx) as `[4·D/4]`.
    pub(super) up1_bias: Tensor,
    pub(super) up_norm: candle_nn::LayerNorm,
    /// Second 2× transposed conv, `[D/4, 4·D/8]`, columns (dy, dx, c).
    pub(super) up2_weight: Tensor,
    /// `[4·D/8]`.
    pub(super) up2_bias: Tensor,
    pub(super) hypernets: Vec<Mlp>,
    pub(super) iou_head: Mlp,
    pub(super) dim: usize,
    /// The same weights as contiguous buffers for the shared-work path (`None` unless the transformer
    /// has the released two blocks).
    pub(super) packed: Option<Arc<PackedDecoder>>,
}

impl MaskDecoder {
    /// From `mask_decoder.`-stripped weights.
    pub fn new(w: &Weights) -> ModelsResult<Self> {
        let iou_token = w.get_any("iou_token.weight")?;
        let dim = iou_token.dims()[1];
        let mask_tokens = w.get_any("mask_tokens.weight")?;
        let num_masks = mask_tokens.dims()[0];
        let mask_tokens = w.get("mask_tokens.weight", &[num_masks, dim])?;
        let depth = (0..).take_while(|i| w.contains(&format!("transformer.layers.{i}.norm1.weight"))).count();
        let blocks = (0..depth)
            .map(|i| TwoWayBlock::new(w, &format!("transformer.layers.{i}"), dim, i == 0))
            .collect::<ModelsResult<Vec<_>>>()?;
        // ConvTranspose2d(k = s = 2) as a matrix whose output columns are (dy, dx, c): the upscaled map
        // stays channels-last in 2×2 blocks, so no pixel shuffle of the large maps is needed
        let convt = |name: &str, cin: usize, cout: usize| -> ModelsResult<(Tensor, Tensor)> {
            let weight = w.get(&format!("{name}.weight"), &[cin, cout, 2, 2])?;
            let weight = weight.permute((0, 2, 3, 1))?.reshape((cin, 4 * cout))?.contiguous()?;
            let bias =
                w.get(&format!("{name}.bias"), &[cout])?.unsqueeze(0)?.repeat((4, 1))?.reshape(4 * cout)?;
            Ok((weight, bias))
        };
        let (up1_weight, up1_bias) = convt("output_upscaling.0", dim, dim / 4)?;
        let (up2_weight, up2_bias) = convt("output_upscaling.3", dim / 4, dim / 8)?;
        let mut decoder = Self {
            output_tokens: Tensor::cat(&[w.get("iou_token.weight", &[1, dim])?, mask_tokens], 0)?,
            blocks,
            final_attn: Attention::new(w, "transformer.final_attn_token_to_image", dim)?,
            final_norm: w.layer_norm("transformer.norm_final_attn", dim, 1e-5)?,
            up1_weight,
            up1_bias,
            up_norm: w.layer_norm("output_upscaling.1", dim / 4, 1e-6)?,
            up2_weight,
            up2_bias,
            hypernets: (0..num_masks)
                .map(|i| Mlp::new(w, &format!("output_hypernetworks_mlps.{i}")))
                .collect::<ModelsResult<Vec<_>>>()?,
            iou_head: Mlp::new(w, "iou_prediction_head")?,
            dim,
            packed: None,
        };
        decoder.packed = PackedDecoder::new(&decoder)?.map(Arc::new);
        Ok(decoder)
    }

    /// Decoder width D.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// All mask logits and IoU predictions for a batch of prompts.
    ///
    /// `image`: `[D, h, w]` image embedding + dense prompt embedding; `image_pe`: `[D, h, w]`;
    /// `sparse`: `[B, T, D]`. Returns (`[B, M, 4h, 4w]` logits, `[B, M]` IoU predictions), M = 1 + 3.
    pub fn forward(
        &self,
        image: &Tensor,
        image_pe: &Tensor,
        sparse: &Tensor,
    ) -> ModelsResult<(Tensor, Tensor)> {
        let (d, h, w) = image.dims3()?;
        let b = sparse.dims()[0];
        let m = self.hypernets.len();
        let tokens = Tensor::cat(
            &[self.output_tokens.unsqueeze(0)?.broadcast_as((b, 1 + m, d))?.contiguous()?, sparse.clone()],
            1,
        )?;
        let keys0 =
            image.reshape((d, h * w))?.t()?.unsqueeze(0)?.broadcast_as((b, h * w, d))?.contiguous()?;
        let key_pe = image_pe.reshape((d, h * w))?.t()?.unsqueeze(0)?.contiguous()?;
        let mut queries = tokens.clone();
        let mut keys = keys0;
        for block in &self.blocks {
            (queries, keys) = block.forward(&queries, &keys, &tokens, &key_pe)?;
        }
        let q = (&queries + &tokens)?;
        let k = keys.broadcast_add(&key_pe)?;
        let queries = self.final_norm.forward(&(&queries + self.final_attn.forward(&q, &k, &keys)?)?)?;
        let hyper: Vec<Tensor> = self
            .hypernets
            .iter()
            .enumerate()
            .map(|(i, mlp)| mlp.forward(&queries.narrow(1, 1 + i, 1)?.squeeze(1)?))
            .collect::<ModelsResult<_>>()?;
        let hyper = Tensor::stack(&hyper, 1)?; // [B, M, D/8]
        let masks = self.upscale_masks(&keys, &hyper, (h, w))?;
        let iou = self.iou_head.forward(&queries.narrow(1, 0, 1)?.squeeze(1)?)?;
        Ok((masks, iou))
    }
}

impl MaskDecoder {
    /// The upscaling path and the hypernetwork product: `keys` `[B, h·w, D]` (the transformer's image
    /// tokens, rows = cells), `hyper` `[B, S, D/8]` (one hypernetwork output per wanted mask). Returns
    /// `[B, S, 4h, 4w]` logits.
    pub(super) fn upscale_masks(
        &self,
        keys: &Tensor,
        hyper: &Tensor,
        (h, w): (usize, usize),
    ) -> ModelsResult<Tensor> {
        let (b, _, d) = keys.dims3()?;
        let s = hyper.dims()[1];
        let c1 = d / 4;
        let c2 = d / 8;
        // channels-last in 2×2 blocks: columns of the products are (dy, dx, c)
        let up = keys.reshape((b * h * w, d))?.matmul(&self.up1_weight)?.broadcast_add(&self.up1_bias)?; // [B·h·w, (dy1, dx1, c1)]
        let up = gelu_erf(&self.up_norm.forward(&up.reshape((b * h * w * 4, c1))?)?)?;
        let up = gelu_erf(&up.matmul(&self.up2_weight)?.broadcast_add(&self.up2_bias)?)?; // [B·h·w·4, (dy2, dx2, c2)]
        let up = up.reshape((b, h * w * 16, c2))?; // pixels ordered (y, x, dy1, dx1, dy2, dx2)
        let blocked = hyper.matmul(&up.transpose(1, 2)?)?; // [B, S, h·w·16]
                                                           // pixel (4y + 2·dy1 + dy2, 4x + 2·dx1 + dx2)
        Ok(blocked.reshape(vec![b * s, h, w, 2, 2, 2, 2])?.permute(vec![0, 1, 3, 5, 2, 4, 6])?.reshape((
            b,
            s,
            4 * h,
            4 * w,
        ))?)
    }
}
