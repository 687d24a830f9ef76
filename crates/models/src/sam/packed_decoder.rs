//! The mask decoder's weights as contiguous f32 buffers, and the per-prompt steps that need no image
//! tokens (attention among the prompt tokens, MLPs, heads) plus the upscaling path, on plain buffers.
//! Used by [`super::shared_decoder`]; the candle [`MaskDecoder`] stays the reference it is tested against.

use super::mask_decoder::{Attention, MaskDecoder, Mlp, TwoWayBlock, NUM_HEADS};
use crate::dense::{matmul, softmax_runs, LayerNorm, Linear, View, ViewMut};
use crate::kernels;
use crate::skinny::skinny_product;

/// Epsilon of the transformer's layer norms (PyTorch's default).
const TRANSFORMER_EPS: f32 = 1e-5;
/// Epsilon of the upscaling path's `LayerNorm2d`.
const UPSCALE_EPS: f32 = 1e-6;
/// Embedding cells per tile of the upscaling path (a tile's intermediate maps stay in L2).
const UPSCALE_TILE: usize = 64;

/// One attention's projections.
#[derive(Debug, Clone)]
pub(super) struct PackedAttention {
    pub(super) q: Linear,
    pub(super) k: Linear,
    pub(super) v: Linear,
    pub(super) out: Linear,
    /// Internal width `H·d`.
    pub(super) internal: usize,
}

impl PackedAttention {
    fn new(attn: &Attention) -> candle_core::Result<Self> {
        Ok(Self {
            q: Linear::from_candle(&attn.q)?,
            k: Linear::from_candle(&attn.k)?,
            v: Linear::from_candle(&attn.v)?,
            out: Linear::from_candle(&attn.out)?,
            internal: attn.internal,
        })
    }

    /// Head width d.
    pub(super) fn head_dim(&self) -> usize {
        self.internal / NUM_HEADS
    }

    /// `1/√d`.
    pub(super) fn scale(&self) -> f32 {
        1.0 / (self.head_dim() as f32).sqrt()
    }

    /// Plain attention of each group of `t` tokens among themselves (a batch of prompts' tokens, prompt
    /// after prompt): `q_in`, `k_in`, `v_in` `[B·t, D]`. Returns the output projection `[B·t, D]`.
    pub(super) fn among_tokens(&self, q_in: &[f32], k_in: &[f32], v_in: &[f32], t: usize) -> Vec<f32> {
        let (ci, dh) = (self.internal, self.head_dim());
        let rows = q_in.len() / self.q.inputs;
        let project = |lin: &Linear, x: &[f32]| {
            let mut out = vec![0f32; rows * ci];
            lin.forward(x, rows, &mut out);
            out
        };
        let (q, k, v) = (project(&self.q, q_in), project(&self.k, k_in), project(&self.v, v_in));
        let mut scores = vec![0f32; t * t];
        let mut heads = vec![0f32; rows * ci];
        for g in (0..rows).step_by(t.max(1)) {
            for h in 0..NUM_HEADS {
                let head = |data| View { data, offset: g * ci + h * dh, rs: ci, cs: 1 };
                matmul(
                    t,
                    t,
                    dh,
                    ViewMut::rows(&mut scores, 0, t),
                    head(&q),
                    View::transposed(&k, g * ci + h * dh, ci),
                    false,
                    self.scale(),
                );
                softmax_runs(&mut scores, t, 1.0);
                let out = ViewMut { data: &mut heads, offset: g * ci + h * dh, rs: ci, cs: 1 };
                matmul(t, dh, t, out, View::rows(&scores, 0, t), head(&v), false, 1.0);
            }
        }
        let mut out = vec![0f32; rows * self.out.outputs];
        self.out.forward(&heads, rows, &mut out);
        out
    }

    /// `U[h·T + t] = W_o,h v[t, h]` for head-split values `v` `[T, H·d]`: `[H·T, D]` (no bias). An
    /// attention's output is then `Σ_(h,t) a[h, t] · U[h·T + t] + b_o`.
    pub(super) fn output_rows(&self, v: &[f32], t: usize) -> Vec<f32> {
        let (ci, dh, d) = (self.internal, self.head_dim(), self.out.outputs);
        let mut u = vec![0f32; NUM_HEADS * t * d];
        for h in 0..NUM_HEADS {
            let rows_of_head = &mut u[h * t * d..(h + 1) * t * d];
            let head_rows = (h * dh, dh);
            if skinny_product(t, rows_of_head, (v, h * dh, ci), self.out.weight_t(), head_rows, false)
                .is_some()
            {
                continue;
            }
            matmul(
                t,
                d,
                dh,
                ViewMut { data: &mut u, offset: h * t * d, rs: d, cs: 1 },
                View { data: v, offset: h * dh, rs: ci, cs: 1 },
                View::transposed(&self.out.weight, h * dh, ci),
                false,
                1.0,
            );
        }
        u
    }
}

/// One two-way transformer block.
#[derive(Debug, Clone)]
pub(super) struct PackedBlock {
    pub(super) self_attn: PackedAttention,
    pub(super) norm1: LayerNorm,
    pub(super) token_to_image: PackedAttention,
    pub(super) norm2: LayerNorm,
    pub(super) lin1: Linear,
    pub(super) lin2: Linear,
    pub(super) norm3: LayerNorm,
    pub(super) norm4: LayerNorm,
    pub(super) image_to_token: PackedAttention,
    pub(super) skip_first_pe: bool,
}

impl PackedBlock {
    fn new(block: &TwoWayBlock) -> candle_core::Result<Self> {
        let norm = |n: &candle_nn::LayerNorm| LayerNorm::from_candle(n, TRANSFORMER_EPS);
        Ok(Self {
            self_attn: PackedAttention::new(&block.self_attn)?,
            norm1: norm(&block.norm1)?,
            token_to_image: PackedAttention::new(&block.token_to_image)?,
            norm2: norm(&block.norm2)?,
            lin1: Linear::from_candle(&block.lin1)?,
            lin2: Linear::from_candle(&block.lin2)?,
            norm3: norm(&block.norm3)?,
            norm4: norm(&block.norm4)?,
            image_to_token: PackedAttention::new(&block.image_to_token)?,
            skip_first_pe: block.skip_first_pe,
        })
    }

    /// The block's self-attention and its norm on `queries` `[t, D]` (positional terms `tokens`).
    pub(super) fn self_attention(&self, queries: &mut [f32], tokens: &[f32], t: usize) {
        if self.skip_first_pe {
            let out = self.self_attn.among_tokens(queries, queries, queries, t);
            queries.copy_from_slice(&out);
        } else {
            let with_pe = added(queries, tokens);
            let out = self.self_attn.among_tokens(&with_pe, &with_pe, queries, t);
            add_into(queries, &out);
        }
        self.norm1.rows(queries);
    }

    /// The block's MLP with its residual and norm, on `queries` `[t, D]`.
    pub(super) fn mlp(&self, queries: &mut [f32], t: usize) {
        let mut hidden = vec![0f32; t * self.lin1.outputs];
        self.lin1.forward(queries, t, &mut hidden);
        hidden.iter_mut().for_each(|v| *v = v.max(0.0));
        let mut out = vec![0f32; t * self.lin2.outputs];
        self.lin2.forward(&hidden, t, &mut out);
        add_into(queries, &out);
        self.norm3.rows(queries);
    }
}

/// The whole decoder on plain buffers (only the released two-block transformer).
#[derive(Debug, Clone)]
pub(super) struct PackedDecoder {
    /// `[1 + M, D]`: IoU token then the M mask tokens.
    pub(super) output_tokens: Vec<f32>,
    /// Mask outputs M.
    pub(super) num_masks: usize,
    pub(super) blocks: [PackedBlock; 2],
    pub(super) final_attn: PackedAttention,
    pub(super) final_norm: LayerNorm,
    /// `[D, 4·c1]`, columns (dy, dx, c).
    up1_weight: Vec<f32>,
    /// `[4·c1]`.
    up1_bias: Vec<f32>,
    up_norm: LayerNorm,
    /// `[c1, 4·c2]`, columns (dy, dx, c).
    up2_weight: Vec<f32>,
    /// `[4·c2]`.
    up2_bias: Vec<f32>,
    hypernets: Vec<Vec<Linear>>,
    iou_head: Vec<Linear>,
    pub(super) dim: usize,
}

fn mlp_layers(mlp: &Mlp) -> candle_core::Result<Vec<Linear>> {
    mlp.layers.iter().map(Linear::from_candle).collect()
}

/// An MLP (ReLU between layers) on one vector.
fn mlp_forward(layers: &[Linear], x: &[f32]) -> Vec<f32> {
    let mut x = x.to_vec();
    for (i, layer) in layers.iter().enumerate() {
        let mut out = vec![0f32; layer.outputs];
        layer.forward(&x, 1, &mut out);
        if i + 1 < layers.len() {
            out.iter_mut().for_each(|v| *v = v.max(0.0));
        }
        x = out;
    }
    x
}

impl PackedDecoder {
    /// `None` unless the transformer has the released two blocks.
    pub(super) fn new(decoder: &MaskDecoder) -> candle_core::Result<Option<Self>> {
        let [first, second] = decoder.blocks.as_slice() else {
            return Ok(None);
        };
        let vec = |t: &candle_core::Tensor| t.flatten_all()?.to_vec1::<f32>();
        Ok(Some(Self {
            output_tokens: vec(&decoder.output_tokens)?,
            num_masks: decoder.hypernets.len(),
            blocks: [PackedBlock::new(first)?, PackedBlock::new(second)?],
            final_attn: PackedAttention::new(&decoder.final_attn)?,
            final_norm: LayerNorm::from_candle(&decoder.final_norm, TRANSFORMER_EPS)?,
            up1_weight: vec(&decoder.up1_weight)?,
            up1_bias: vec(&decoder.up1_bias)?,
            up_norm: LayerNorm::from_candle(&decoder.up_norm, UPSCALE_EPS)?,
            up2_weight: vec(&decoder.up2_weight)?,
            up2_bias: vec(&decoder.up2_bias)?,
            hypernets: decoder.hypernets.iter().map(mlp_layers).collect::<candle_core::Result<_>>()?,
            iou_head: mlp_layers(&decoder.iou_head)?,
            dim: decoder.dim,
        }))
    }

    /// IoU predictions `[M]` from the final IoU token `[D]`.
    pub(super) fn iou(&self, iou_token: &[f32]) -> Vec<f32> {
        mlp_forward(&self.iou_head, iou_token)
    }

    /// Hypernetwork output `[D/8]` of mask output `output` from its final mask token `[D]`.
    pub(super) fn hyper(&self, output: usize, mask_token: &[f32]) -> Vec<f32> {
        mlp_forward(&self.hypernets[output], mask_token)
    }

    /// `[D, 4·c1]` weight and `[4·c1]` bias of the first transposed convolution (columns (dy, dx, c)).
    pub(super) fn up1(&self) -> (&[f32], &[f32]) {
        (&self.up1_weight, &self.up1_bias)
    }

    /// Low-resolution logits `[S, 4h, 4w]` (row-major) from the `S` hypernetwork outputs (`hyper`
    /// `[S, D/8]`): the two transposed convolutions (with norm and GELUs) and the product, a tile of
    /// cells at a time. `first_layer(cell0, cells, out)` writes the first transposed convolution's
    /// output with its bias, `[cells, 4·c1]`, for the image tokens after the transformer of cells
    /// `cell0..cell0 + cells` (rows = cells).
    pub(super) fn upscale(
        &self,
        first_layer: impl Fn(usize, usize, &mut [f32]),
        hyper: &[f32],
        (h, w): (usize, usize),
    ) -> Vec<f32> {
        let c1 = self.up1_bias.len() / 4;
        let c2 = self.up2_bias.len() / 4;
        let s = hyper.len() / c2;
        let (out_h, out_w) = (4 * h, 4 * w);
        let mut logits = vec![0f32; s * out_h * out_w];
        let mut first = vec![0f32; UPSCALE_TILE * 4 * c1];
        let mut second = vec![0f32; UPSCALE_TILE * 16 * c2];
        let mut blocked = vec![0f32; s * UPSCALE_TILE * 16];
        for cell0 in (0..h * w).step_by(UPSCALE_TILE) {
            let cells = UPSCALE_TILE.min(h * w - cell0);
            let first = &mut first[..cells * 4 * c1];
            first_layer(cell0, cells, first);
            for sub in first.chunks_exact_mut(c1) {
                self.up_norm.row(sub);
            }
            kernels::gelu_in_place(first);
            let second = &mut second[..cells * 16 * c2];
            matmul(
                cells * 4,
                4 * c2,
                c1,
                ViewMut::rows(second, 0, 4 * c2),
                View::rows(first, 0, c1),
                View::rows(&self.up2_weight, 0, 4 * c2),
                false,
                1.0,
            );
            for (sub, bias) in second
                .chunks_exact_mut(4 * c2)
                .flat_map(|r| r.chunks_exact_mut(c2))
                .zip(self.up2_bias.chunks_exact(c2).cycle())
            {
                sub.iter_mut().zip(bias).for_each(|(v, b)| *v += b);
            }
            kernels::gelu_in_place(second);
            // blocked[m, r] for sub-pixel rows r = (cell, dy1, dx1, dy2, dx2)
            let rows = cells * 16;
            matmul(
                s,
                rows,
                c2,
                ViewMut::rows(&mut blocked, 0, rows),
                View::rows(hyper, 0, c2),
                View::transposed(second, 0, c2),
                false,
                1.0,
            );
            for m in 0..s {
                let plane = &mut logits[m * out_h * out_w..(m + 1) * out_h * out_w];
                for (r, &value) in blocked[m * rows..(m + 1) * rows].iter().enumerate() {
                    let cell = cell0 + r / 16;
                    let (y, x) = (cell / w, cell % w);
                    let (dy1, dx1, dy2, dx2) = ((r >> 3) & 1, (r >> 2) & 1, (r >> 1) & 1, r & 1);
                    plane[(4 * y + 2 * dy1 + dy2) * out_w + 4 * x + 2 * dx1 + dx2] = value;
                }
            }
        }
        logits
    }
}

/// `a + b` element-wise.
pub(super) fn added(a: &[f32], b: &[f32]) -> Vec<f32> {
    a.iter().zip(b).map(|(x, y)| x + y).collect()
}

/// `a += b` element-wise.
pub(super) fn add_into(a: &mut [f32], b: &[f32]) {
    a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
}

/// `x·Wᵀ` (`with_bias`: `+ b`) for `x` `[rows, in]`.
pub(super) fn project(lin: &Linear, x: &[f32], rows: usize, with_bias: bool) -> Vec<f32> {
    let mut out = vec![0f32; rows * lin.outputs];
    if with_bias {
        lin.forward(x, rows, &mut out);
    } else {
        lin.forward_no_bias(x, rows, &mut out);
    }
    out
}
