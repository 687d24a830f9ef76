//! The mask decoder with its prompt-independent work done once per image, in batches of prompts on
//! plain f32 buffers (matrix products by `gemm` and the few-row kernel, no per-op tensors): a batch's
//! token-side layers and its products with the per-image panels run on all of its prompts' rows at
//! once; what involves a prompt's own `[N, D]` image tokens runs per prompt, a tile of cells at a time
//! ([`super::image_update`]).
//!
//! Same results as [`MaskDecoder::forward`] up to floating-point reassociation (tested against it).
//! With `E` the image tokens `[N, D]`, `P` their positional encoding, `T` tokens, `H` heads of width
//! `d` and `A·U` an attention output written as its weights `A` `[N, H·T]` times `U[h·T + t] = W_o,h
//! v_t,h` (so the `[N, H·d]` head outputs are never formed):
//!
//! - First block: its image side is `E` for every prompt, so the token→image keys `(E + P)·W_kᵀ`,
//!   values `E·W_vᵀ` and the image→token queries `(E + P)·W_qᵀ` are computed once per image; per
//!   prompt only the attentions over the `T` tokens and `X₁ = LN(E + b_o + A₁·U₁)` remain.
//! - Second block: `X₁ = γ⊙(E + b_o + A₁U₁ − μ)/σ + β` per row, so any projection of it is
//!   `W X₁ᵢ = (W(γ⊙(E + b_o))ᵢ + A₁ᵢ·W(γ⊙U₁) − μᵢ Wγ)/σᵢ + Wβ`: the `[N, H·d]` projections of
//!   `γ⊙(E + b_o)` and of `P` are shared, and per prompt the token→image scores and values and the
//!   image→token scores need only `H·T`-wide products with `A₁` instead of `D`-wide ones with `X₁`.
//! - Final attention: only the tokens whose outputs are used (the IoU token while decoding, fused with
//!   the last update of the image tokens; the mask tokens of the masks asked for later) attend, with
//!   the scores `(W_k,hᵀ q)·x` folded into `D`-wide vectors.
//! - The IoU head needs only the tokens: masks are upscaled afterwards, and only for the prompts and
//!   mask outputs the caller asks for (the automatic mask generator's predicted-IoU filter runs first).

use std::sync::Arc;

use candle_core::{Device, Tensor};

use super::image_panels::{ImageKeys, ImageValues};
use super::image_update::{update_tokens, FirstUpdate, OnlineAttention, TILE};
use super::mask_decoder::{MaskDecoder, NUM_HEADS};
use super::packed_decoder::{add_into, added, project, PackedAttention, PackedDecoder};
use super::second_block::{second_image_scores, second_token_to_image, FirstBlockTrace};
use crate::dense::{matmul, softmax_columns, softmax_runs, Linear, View, ViewMut};
use crate::error::{ModelsError, ModelsResult};
use crate::kernels::{dot, squared_deviation, sum};
use crate::skinny::MAX_ROWS;

/// Per-image, prompt-independent inputs of the decoder's attentions; projections are `[N, H·d]`.
#[derive(Debug, Clone)]
pub struct DecoderImage {
    packed: Arc<PackedDecoder>,
    /// `E + b_o` of the first image→token attention, `[N, D]` (rows are cells).
    first_residual: Vec<f32>,
    /// Row means of `E + b_o` and the sums of squares of its centred rows `c`, `[N]` each.
    first_residual_mean: Vec<f32>,
    first_residual_squares: Vec<f32>,
    /// `c·W_o` `[N, H·d]` (`W_o` `[D, H·d]` the first image→token output projection): `c·U₁[h·T + t]
    /// = (c·W_o,h)·v_t,h`, the cross terms of the first norm's variances.
    first_centred_out: ImageKeys,
    /// First block, token→image keys `(E + P)·W_kᵀ + b_k`.
    first_keys: ImageKeys,
    /// First block, token→image values `E·W_vᵀ + b_v`.
    first_values: ImageValues,
    /// First block, image→token queries `(E + P)·W_qᵀ + b_q`.
    first_queries: ImageKeys,
    /// Second block: `γ⊙(E + b_o)` (γ, β: the first block's last norm) projected by the token→image
    /// keys and values and the image→token queries, no biases.
    pub(super) second_keys: ImageKeys,
    pub(super) second_values: ImageValues,
    pub(super) second_queries: ImageKeys,
    /// `P·W_kᵀ` of the second token→image attention and `P·W_qᵀ` of its image→token one.
    pub(super) second_pe_keys: ImageKeys,
    pub(super) second_pe_queries: ImageKeys,
    /// `Wγ` and `Wβ + b` of those three projections, `[H·d]` each.
    pub(super) keys_gamma: Vec<f32>,
    pub(super) keys_beta: Vec<f32>,
    pub(super) values_gamma: Vec<f32>,
    pub(super) values_beta: Vec<f32>,
    pub(super) queries_gamma: Vec<f32>,
    pub(super) queries_beta: Vec<f32>,
    /// Final token→image attention's `P·W_kᵀ`, no bias.
    final_pe_keys: ImageKeys,
    /// Upscaling: `W'` = the first transposed convolution `[D, 4·c1]` with its rows scaled by the last
    /// block's norm γ₂, and `γ⊙(E + b_o)·W'` `[N, 4·c1]`.
    up_weight: Vec<f32>,
    up_shared: Vec<f32>,
    /// `γ·W'`, `β·W' + b_o₂·W'` (first block's norm, second block's image→token output bias), `γ₂·W`,
    /// `β₂·W + b` (last norm, the convolution's bias): `[4·c1]` each.
    up_first_gamma: Vec<f32>,
    up_first_const: Vec<f32>,
    up_second_gamma: Vec<f32>,
    up_second_const: Vec<f32>,
    /// Embedding grid (h, w).
    grid: (usize, usize),
}

impl DecoderImage {
    /// Embedding grid (h, w).
    pub fn grid(&self) -> (usize, usize) {
        self.grid
    }

    pub(super) fn cells(&self) -> usize {
        self.grid.0 * self.grid.1
    }
}

/// One prompt through the transformer.
#[derive(Debug, Clone)]
struct DecodedPrompt {
    /// The transformer's input tokens `[T, D]` (their own positional terms).
    tokens: Vec<f32>,
    /// Tokens after the last block, before the final attention, `[T, D]`.
    queries: Vec<f32>,
    /// Image tokens after the last block, `[N, D]`.
    keys: Vec<f32>,
    /// How the image tokens came about, for the upscaling path: each block's image→token weights
    /// `Aᵀ` `[H·T, N]` and output rows, and the row means and inverse standard deviations of its norm.
    first_weights: Vec<f32>,
    /// `γ⊙U₁` `[H·T, D]`.
    first_scaled_rows: Vec<f32>,
    first_mean: Vec<f32>,
    first_inv_std: Vec<f32>,
    second_weights: Vec<f32>,
    /// `U₂` `[H·T, D]`.
    second_rows: Vec<f32>,
    second_mean: Vec<f32>,
    second_inv_std: Vec<f32>,
}

/// A batch of prompts through the transformer, ready for the heads.
#[derive(Debug, Clone)]
pub struct DecodedTokens {
    prompts: Vec<DecodedPrompt>,
    /// IoU predictions of every mask output, `[B, M]`.
    pub iou: Tensor,
}

fn packed(decoder: &MaskDecoder) -> ModelsResult<&Arc<PackedDecoder>> {
    decoder.packed.as_ref().ok_or_else(|| {
        ModelsError::Input(format!(
            "the shared-work SAM decoder needs the released two-layer transformer, this one has {}",
            decoder.blocks.len()
        ))
    })
}

/// `v·W` for `v` `[K]` and `W` `[K, M]` (row-major): `[M]`.
fn vec_mat(v: &[f32], w: &[f32]) -> Vec<f32> {
    let cols = w.len() / v.len().max(1);
    let mut out = vec![0f32; cols];
    for (row, &x) in w.chunks_exact(cols).zip(v) {
        out.iter_mut().zip(row).for_each(|(o, r)| *o += x * r);
    }
    out
}

impl MaskDecoder {
    /// The prompt-independent part of the decoder for one image: `image` and `image_pe` `[D, h, w]` as
    /// in [`MaskDecoder::forward`].
    pub fn prepare_image(&self, image: &Tensor, image_pe: &Tensor) -> ModelsResult<DecoderImage> {
        let packed = packed(self)?.clone();
        let (d, h, w) = image.dims3()?;
        if d != packed.dim || image_pe.dims3()? != (d, h, w) {
            return Err(ModelsError::Input(format!(
                "SAM decoder input {:?} / positional encoding {:?}, expected [{}, h, w] both",
                image.dims(),
                image_pe.dims(),
                packed.dim
            )));
        }
        let n = h * w;
        let rows =
            |t: &Tensor| -> ModelsResult<Vec<f32>> { Ok(t.reshape((d, n))?.t()?.flatten_all()?.to_vec1()?) };
        let tokens = rows(image)?;
        let pe = rows(image_pe)?;
        let with_pe = added(&tokens, &pe);
        let [first, second] = &packed.blocks;
        let first_residual: Vec<f32> = tokens
            .chunks_exact(d)
            .flat_map(|row| row.iter().zip(&first.image_to_token.out.bias).map(|(x, b)| x + b))
            .collect();
        let (first_residual_mean, first_residual_squares, centred) = centred_rows(&first_residual, d);
        let out_weight = &first.image_to_token.out.weight;
        let first_out_ci = first.image_to_token.internal;
        let mut centred_out = vec![0f32; n * first_out_ci];
        let out = ViewMut::rows(&mut centred_out, 0, first_out_ci);
        matmul(
            n,
            first_out_ci,
            d,
            out,
            View::rows(&centred, 0, d),
            View::rows(out_weight, 0, first_out_ci),
            false,
            1.0,
        );
        drop(centred);
        let (gamma, beta) = (&first.norm4.gamma, &first.norm4.beta);
        let scaled: Vec<f32> = first_residual
            .chunks_exact(d)
            .flat_map(|row| row.iter().zip(gamma).map(|(x, g)| x * g))
            .collect();
        let (t2i, i2t) = (&second.token_to_image, &second.image_to_token);
        let affine = |lin: &Linear| {
            let beta_part: Vec<f32> = lin.apply_to(beta).iter().zip(&lin.bias).map(|(x, b)| x + b).collect();
            (lin.apply_to(gamma), beta_part)
        };
        let (up1_weight, up1_bias) = packed.up1();
        let up_cols = up1_bias.len();
        let gamma2 = &second.norm4.gamma;
        let up_weight: Vec<f32> = up1_weight
            .chunks_exact(up_cols)
            .zip(gamma2)
            .flat_map(|(row, g)| row.iter().map(move |w| w * g))
            .collect();
        let mut up_shared = vec![0f32; n * up_cols];
        matmul(
            n,
            up_cols,
            d,
            ViewMut::rows(&mut up_shared, 0, up_cols),
            View::rows(&scaled, 0, d),
            View::rows(&up_weight, 0, up_cols),
            false,
            1.0,
        );
        let up_first_const = added(&vec_mat(beta, &up_weight), &vec_mat(&i2t.out.bias, &up_weight));
        let up_second_const = added(&vec_mat(&second.norm4.beta, up1_weight), up1_bias);
        let (keys_gamma, keys_beta) = affine(&t2i.k);
        let (values_gamma, values_beta) = affine(&t2i.v);
        let (queries_gamma, queries_beta) = affine(&i2t.q);
        let first_ci = first.token_to_image.internal;
        let first_i2t_ci = first.image_to_token.internal;
        Ok(DecoderImage {
            first_keys: ImageKeys::new(project(&first.token_to_image.k, &with_pe, n, true), first_ci),
            first_values: ImageValues::new(
                project(&first.token_to_image.v, &tokens, n, true),
                first_ci,
                NUM_HEADS,
            ),
            first_queries: ImageKeys::new(project(&first.image_to_token.q, &with_pe, n, true), first_i2t_ci),
            second_keys: ImageKeys::new(project(&t2i.k, &scaled, n, false), t2i.internal),
            second_values: ImageValues::new(project(&t2i.v, &scaled, n, false), t2i.internal, NUM_HEADS),
            second_queries: ImageKeys::new(project(&i2t.q, &scaled, n, false), i2t.internal),
            second_pe_keys: ImageKeys::new(project(&t2i.k, &pe, n, false), t2i.internal),
            second_pe_queries: ImageKeys::new(project(&i2t.q, &pe, n, false), i2t.internal),
            final_pe_keys: ImageKeys::new(
                project(&packed.final_attn.k, &pe, n, false),
                packed.final_attn.internal,
            ),
            up_first_gamma: vec_mat(gamma, &up_weight),
            up_second_gamma: vec_mat(gamma2, up1_weight),
            up_first_const,
            up_second_const,
            up_weight,
            up_shared,
            first_residual,
            first_residual_mean,
            first_residual_squares,
            first_centred_out: ImageKeys::new(centred_out, first_out_ci),
            keys_gamma,
            keys_beta,
            values_gamma,
            values_beta,
            queries_gamma,
            queries_beta,
            grid: (h, w),
            packed,
        })
    }

    /// The two-way transformer and the IoU head for a batch of prompts on a prepared image.
    ///
    /// `sparse`: `[B, T', D]` prompt tokens. Masks come from [`MaskDecoder::masks_of`].
    pub fn decode_tokens(&self, image: &DecoderImage, sparse: &Tensor) -> ModelsResult<DecodedTokens> {
        let (b, t_sparse, d) = sparse.dims3()?;
        let packed = &image.packed;
        if d != packed.dim {
            return Err(ModelsError::Input(format!(
                "SAM prompt tokens {:?}, expected width {}",
                sparse.dims(),
                packed.dim
            )));
        }
        let sparse = sparse.flatten_all()?.to_vec1::<f32>()?;
        let mut prompts = Vec::with_capacity(b);
        let mut iou = Vec::with_capacity(b * packed.num_masks);
        // batches whose B·T rows the few-row kernel takes in one call
        let t = packed.output_tokens.len() / d + t_sparse;
        let batch = (MAX_ROWS / t.max(1)).max(1);
        for chunk in sparse.chunks(batch * t_sparse * d) {
            let count = chunk.len() / (t_sparse * d).max(1);
            for (decoded, iou_token) in decode_batch(packed, image, chunk, count) {
                iou.extend(packed.iou(&iou_token));
                prompts.push(decoded);
            }
        }
        let iou = Tensor::from_vec(iou, (b, packed.num_masks), &Device::Cpu)?;
        Ok(DecodedTokens { prompts, iou })
    }

    /// Low-resolution logits of the mask outputs `outputs` (indices into the M outputs) of prompt
    /// `prompt` of a decoded batch: `[S, 4h, 4w]`.
    pub fn masks_of(
        &self,
        image: &DecoderImage,
        decoded: &DecodedTokens,
        prompt: usize,
        outputs: &[usize],
    ) -> ModelsResult<Tensor> {
        let packed = &image.packed;
        let Some(one) = decoded.prompts.get(prompt) else {
            return Err(ModelsError::Input(format!(
                "prompt {prompt} of a batch of {}",
                decoded.prompts.len()
            )));
        };
        if let Some(bad) = outputs.iter().find(|&&o| o >= packed.num_masks) {
            return Err(ModelsError::Input(format!("mask output {bad} of {}", packed.num_masks)));
        }
        let which: Vec<usize> = outputs.iter().map(|&o| 1 + o).collect();
        let final_tokens = final_attention(packed, image, one, &which);
        let hyper: Vec<f32> = outputs
            .iter()
            .zip(final_tokens.chunks_exact(packed.dim))
            .flat_map(|(&o, token)| packed.hyper(o, token))
            .collect();
        let (h, w) = image.grid;
        let first_rows = rows_through_upscaling(image, &one.first_scaled_rows);
        let second_rows = rows_through_upscaling(image, &one.second_rows);
        let layer = |cell0, cells, out: &mut [f32]| {
            first_upscaling_layer(image, one, (&first_rows, &second_rows), cell0, cells, out)
        };
        let logits = packed.upscale(layer, &hyper, (h, w));
        Ok(Tensor::from_vec(logits, (outputs.len(), 4 * h, 4 * w), &Device::Cpu)?)
    }
}

/// A batch of prompts (`sparse` `[B, T', D]`) through both blocks, and each one's IoU token through
/// the final attention (`[D]`, fused with the last update of its image tokens). The token-side layers
/// and the products with the per-image panels run on the `B·T` rows of the whole batch (each weight
/// matrix and panel read once per batch); what involves a prompt's own image tokens, per prompt.
fn decode_batch(
    packed: &PackedDecoder,
    image: &DecoderImage,
    sparse: &[f32],
    prompts: usize,
) -> Vec<(DecodedPrompt, Vec<f32>)> {
    let d = packed.dim;
    let n = image.cells();
    let per_prompt = sparse.len() / prompts.max(1);
    let mut tokens = Vec::with_capacity(prompts * (packed.output_tokens.len() + per_prompt));
    for prompt in sparse.chunks_exact(per_prompt) {
        tokens.extend_from_slice(&packed.output_tokens);
        tokens.extend_from_slice(prompt);
    }
    let bt = tokens.len() / d;
    let t = bt / prompts;
    let ht = NUM_HEADS * t;
    let [first, second] = &packed.blocks;
    let mut queries = tokens.clone();

    // ---- first block: the image side is shared
    first.self_attention(&mut queries, &tokens, t);
    let attn = &first.token_to_image;
    let (ci, dh) = (attn.internal, attn.head_dim());
    let q = project(&attn.q, &added(&queries, &tokens), bt, true);
    let mut scores = vec![0f32; bt * n];
    let mut heads = vec![0f32; bt * ci];
    for h in 0..NUM_HEADS {
        image.first_keys.head_scores(&mut scores, &q, bt, (h, dh));
        softmax_runs(&mut scores, n, attn.scale());
        image.first_values.head_mix(&mut heads, (&scores, 0), bt, (h, dh));
    }
    drop(scores);
    add_into(&mut queries, &project(&attn.out, &heads, bt, true));
    first.norm2.rows(&mut queries);
    first.mlp(&mut queries, bt);

    let attn = &first.image_to_token;
    let dh = attn.head_dim();
    let k = project(&attn.k, &added(&queries, &tokens), bt, true);
    let v = project(&attn.v, &queries, bt, true);
    // A₁ᵀ [H·T, N] per prompt: each head's T rows of scores, softmax down each column
    let mut a_first: Vec<Vec<f32>> = (0..prompts).map(|_| vec![0f32; ht * n]).collect();
    for h in 0..NUM_HEADS {
        let mut blocks: Vec<&mut [f32]> =
            a_first.iter_mut().map(|a| &mut a[h * t * n..(h + 1) * t * n]).collect();
        image.first_queries.head_scores_batch(&mut blocks, &k, t, (h, dh));
    }
    // the cross terms c·U₁ of the first norm's variances, per prompt [H·T, N]
    let mut cross: Vec<Vec<f32>> = (0..prompts).map(|_| vec![0f32; ht * n]).collect();
    for h in 0..NUM_HEADS {
        let mut blocks: Vec<&mut [f32]> =
            cross.iter_mut().map(|c| &mut c[h * t * n..(h + 1) * t * n]).collect();
        image.first_centred_out.head_scores_batch(&mut blocks, &v, t, (h, dh));
    }
    let gamma = &first.norm4.gamma;
    let mut firsts = Vec::with_capacity(prompts);
    for (p, (a_first, cross)) in a_first.into_iter().zip(cross).enumerate() {
        let mut a_first = a_first;
        softmax_columns(&mut a_first, t, n, attn.scale());
        let u_first = attn.output_rows(&v[p * t * ci..(p + 1) * t * ci], t);
        let (mean, inv_std) = first_norm_statistics(image, &a_first, &u_first, &cross, first.norm4.eps);
        let scaled_rows: Vec<f32> =
            u_first.chunks_exact(d).flat_map(|row| row.iter().zip(gamma).map(|(u, g)| u * g)).collect();
        firsts.push((u_first, a_first, scaled_rows, mean, inv_std));
    }
    let traces: Vec<FirstBlockTrace> = firsts
        .iter()
        .map(|(_, weights, scaled_rows, mean, inv_std)| FirstBlockTrace {
            weights,
            scaled_rows,
            mean,
            inv_std,
        })
        .collect();

    // ---- second block: the image side through the first block's weights
    second.self_attention(&mut queries, &tokens, t);
    let attended = second_token_to_image(packed, image, &traces, &added(&queries, &tokens), t);
    add_into(&mut queries, &attended);
    second.norm2.rows(&mut queries);
    second.mlp(&mut queries, bt);

    let attn = &second.image_to_token;
    let k = project(&attn.k, &added(&queries, &tokens), bt, true);
    let weights = second_image_scores(packed, image, &traces, &k, t);
    drop(traces);
    let v = project(&attn.v, &queries, bt, true);
    let final_queries = final_queries(packed, image, (&queries, &tokens), t, &[0]);
    let mut out = Vec::with_capacity(prompts);
    let parts = firsts.into_iter().zip(weights).zip(final_queries).enumerate();
    for (p, (((u_first, a_first, scaled_rows, mean, inv_std), weights), query)) in parts {
        let u_second = attn.output_rows(&v[p * t * ci..(p + 1) * t * ci], t);
        let mut second_mean = vec![0f32; n];
        let mut second_inv_std = vec![0f32; n];
        // both updates of the image tokens a tile at a time; the IoU token's final attention reads each
        // tile while it is in cache
        let mut attention = query.attention(&packed.final_attn);
        let mut keys = Vec::new();
        let first_update = FirstUpdate {
            residual: &image.first_residual,
            weights: &a_first,
            rows: &u_first,
            norm: &first.norm4,
            mean: &mean,
            inv_std: &inv_std,
        };
        let stats = (&mut second_mean[..], &mut second_inv_std[..]);
        let (rows, bias) = ((&weights[..], &u_second[..]), Some(&attn.out.bias[..]));
        update_tokens(&mut keys, &first_update, rows, bias, &second.norm4, stats, |cell0, tile| {
            attention.add(cell0, tile)
        });
        let iou_token = final_output(packed, &query, attention.finish());
        let decoded = DecodedPrompt {
            tokens: tokens[p * t * d..(p + 1) * t * d].to_vec(),
            queries: queries[p * t * d..(p + 1) * t * d].to_vec(),
            keys,
            first_weights: a_first,
            first_scaled_rows: scaled_rows,
            first_mean: mean,
            first_inv_std: inv_std,
            second_weights: weights,
            second_rows: u_second,
            second_mean,
            second_inv_std,
        };
        out.push((decoded, iou_token));
    }
    out
}

/// Row means of `x` `[N, D]`, the sums of squares of its centred rows, and the centred rows.
fn centred_rows(x: &[f32], d: usize) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let mut means = Vec::with_capacity(x.len() / d);
    let mut squares = Vec::with_capacity(x.len() / d);
    let mut centred = Vec::with_capacity(x.len());
    for row in x.chunks_exact(d) {
        let mean = sum(row) / d as f32;
        means.push(mean);
        squares.push(squared_deviation(row, mean));
        centred.extend(row.iter().map(|v| v - mean));
    }
    (means, squares, centred)
}

/// Row means and inverse standard deviations `[N]` of the first block's `E + b_o + A₁U₁` without
/// forming it: with `c` the centred rows of `E + b_o` and `Ũ₁` the centred rows of `U₁`, row `i` less
/// its mean is `c_i + A₁ᵢŨ₁`, so its mean is `mean(E_i + b_o) + A₁ᵢ·mean(U₁)` and its sum of squares
/// `|c_i|² + 2·A₁ᵢ·(c_i·U₁ᵀ) + A₁ᵢᵀ(Ũ₁Ũ₁ᵀ)A₁ᵢ` (`c_i·Ũ₁ = c_i·U₁`: `c_i` sums to zero). `weights` `A₁ᵀ`
/// `[H·T, N]`, `rows` `U₁` `[H·T, D]`, `cross` `c·U₁ᵀ` transposed `[H·T, N]`: `H·T`-wide work per cell
/// instead of `D`-wide.
fn first_norm_statistics(
    image: &DecoderImage,
    weights: &[f32],
    rows: &[f32],
    cross: &[f32],
    eps: f32,
) -> (Vec<f32>, Vec<f32>) {
    let n = image.cells();
    let ht = weights.len() / n;
    let d = rows.len() / ht;
    let (row_means, _, centred) = centred_rows(rows, d);
    let mut gram = vec![0f32; ht * ht];
    let out = ViewMut::rows(&mut gram, 0, ht);
    matmul(ht, ht, d, out, View::rows(&centred, 0, d), View::transposed(&centred, 0, d), false, 1.0);
    // G·A₁ [H·T, N]
    let mut spread = vec![0f32; ht * n];
    let out = ViewMut::rows(&mut spread, 0, n);
    matmul(ht, n, ht, out, View::rows(&gram, 0, ht), View::rows(weights, 0, n), false, 1.0);
    let mut mean = image.first_residual_mean.clone();
    let mut squares = image.first_residual_squares.clone();
    for r in 0..ht {
        let a = &weights[r * n..(r + 1) * n];
        let (g, c, u) = (&spread[r * n..(r + 1) * n], &cross[r * n..(r + 1) * n], row_means[r]);
        for ((((m, q), a), g), c) in mean.iter_mut().zip(squares.iter_mut()).zip(a).zip(g).zip(c) {
            *m += a * u;
            *q += a * (g + 2.0 * c);
        }
    }
    let inv_std = squares.iter().map(|q| 1.0 / (q.max(0.0) / d as f32 + eps).sqrt()).collect();
    (mean, inv_std)
}

/// Attention output rows `[R, D]` through the scaled first transposed convolution `W'`: `[R, 4·c1]`.
fn rows_through_upscaling(image: &DecoderImage, rows: &[f32]) -> Vec<f32> {
    let cols = image.up_first_gamma.len();
    let d = image.up_weight.len() / cols;
    let r = rows.len() / d;
    let mut projected = vec![0f32; r * cols];
    let out = ViewMut::rows(&mut projected, 0, cols);
    matmul(r, cols, d, out, View::rows(rows, 0, d), View::rows(&image.up_weight, 0, cols), false, 1.0);
    projected
}

/// The first transposed convolution (with bias) of cells `cell0..cell0 + cells` of a decoded prompt's
/// image tokens, `out` `[cells, 4·c1]`, through both blocks' attention weights: with `X₂ = γ₂⊙(Y − μ₂)/σ₂
/// + β₂`, `Y = X₁ + A₂U₂ + b_o₂` and `X₁ = γ⊙(E + b_o + A₁U₁ − μ₁)/σ₁ + β`, the product `X₂·W` needs
/// the shared `γ⊙(E + b_o)·W'` and per prompt only `H·T`-wide products with `A₁` and `A₂`
/// (`first_rows`, `second_rows`: `γ⊙U₁` and `U₂` through `W'`, from [`rows_through_upscaling`]).
fn first_upscaling_layer(
    image: &DecoderImage,
    prompt: &DecodedPrompt,
    (first_rows, second_rows): (&[f32], &[f32]),
    cell0: usize,
    cells: usize,
    out: &mut [f32],
) {
    let cols = image.up_first_gamma.len();
    let ht1 = first_rows.len() / cols;
    let ht2 = second_rows.len() / cols;
    let out = &mut out[..cells * cols];
    matmul(
        cells,
        cols,
        ht1,
        ViewMut::rows(out, 0, cols),
        View::transposed(&prompt.first_weights, cell0, image.cells()),
        View::rows(first_rows, 0, cols),
        false,
        1.0,
    );
    for (c, row) in out.chunks_exact_mut(cols).enumerate() {
        let i = cell0 + c;
        let (mean, inv_std) = (prompt.first_mean[i], prompt.first_inv_std[i]);
        let shared = &image.up_shared[i * cols..(i + 1) * cols];
        for j in 0..cols {
            row[j] =
                (row[j] + shared[j] - mean * image.up_first_gamma[j]) * inv_std + image.up_first_const[j];
        }
    }
    matmul(
        cells,
        cols,
        ht2,
        ViewMut::rows(out, 0, cols),
        View::transposed(&prompt.second_weights, cell0, image.cells()),
        View::rows(second_rows, 0, cols),
        true,
        1.0,
    );
    for (c, row) in out.chunks_exact_mut(cols).enumerate() {
        let i = cell0 + c;
        let (mean, inv_std) = (prompt.second_mean[i], prompt.second_inv_std[i]);
        let affine = image.up_second_gamma.iter().zip(&image.up_second_const);
        for (v, (gamma, constant)) in row.iter_mut().zip(affine) {
            *v = (*v - mean * gamma) * inv_std + constant;
        }
    }
}

/// The final token→image attention's query side for some of a prompt's tokens.
struct FinalQuery {
    /// The selected tokens `[S, D]` (the residual).
    selected: Vec<f32>,
    /// `[S, H·d]` queries with biases.
    q: Vec<f32>,
    /// Row `h·S + s`: `W_k,hᵀ q_s,h` `[H·S, D]`.
    folded: Vec<f32>,
    /// `q_s,h · (P·W_k,hᵀ)ᵢ` `[H·S, N]`.
    pe_scores: Vec<f32>,
    /// `q_s,h · b_k,h` `[H·S]`.
    from_bias: Vec<f32>,
}

impl FinalQuery {
    /// The attention over the image tokens, to be fed tile by tile.
    fn attention<'a>(&'a self, attn: &PackedAttention) -> OnlineAttention<'a> {
        OnlineAttention::new(&self.folded, &self.pe_scores, &self.from_bias, attn.scale())
    }
}

/// [`FinalQuery`] of the tokens `which` (indices into the `T` tokens) of each prompt of a batch, from
/// their tokens after the last block, `queries` `[B·T, D]`, with their positional terms `tokens`
/// `[B·T, D]` (prompt after prompt).
fn final_queries(
    packed: &PackedDecoder,
    image: &DecoderImage,
    (queries, tokens): (&[f32], &[f32]),
    t: usize,
    which: &[usize],
) -> Vec<FinalQuery> {
    let d = packed.dim;
    let n = image.cells();
    let attn = &packed.final_attn;
    let (ci, dh) = (attn.internal, attn.head_dim());
    let ts = which.len();
    let prompts = queries.len() / (t * d);
    fn row(x: &[f32], (t, d): (usize, usize), p: usize, i: usize) -> &[f32] {
        &x[(p * t + i) * d..(p * t + i + 1) * d]
    }
    let td = (t, d);
    let selected: Vec<Vec<f32>> =
        (0..prompts).map(|p| which.iter().flat_map(|&i| row(queries, td, p, i).to_vec()).collect()).collect();
    let with_pe: Vec<f32> = (0..prompts)
        .flat_map(|p| which.iter().flat_map(move |&i| added(row(queries, td, p, i), row(tokens, td, p, i))))
        .collect();
    let q_all = project(&attn.q, &with_pe, prompts * ts, true);
    let mut pe_scores: Vec<Vec<f32>> = (0..prompts).map(|_| vec![0f32; NUM_HEADS * ts * n]).collect();
    for h in 0..NUM_HEADS {
        let mut blocks: Vec<&mut [f32]> =
            pe_scores.iter_mut().map(|s| &mut s[h * ts * n..(h + 1) * ts * n]).collect();
        image.final_pe_keys.head_scores_batch(&mut blocks, &q_all, ts, (h, dh));
    }
    selected
        .into_iter()
        .zip(pe_scores)
        .enumerate()
        .map(|(p, (selected, pe_scores))| {
            let q = q_all[p * ts * ci..(p + 1) * ts * ci].to_vec();
            // folded[(h, s)] = W_k,hᵀ q_s,h, [H·S, D]
            let mut folded = vec![0f32; NUM_HEADS * ts * d];
            let mut from_bias = vec![0f32; NUM_HEADS * ts];
            for h in 0..NUM_HEADS {
                let head = View { data: &q, offset: h * dh, rs: ci, cs: 1 };
                let out = ViewMut { data: &mut folded, offset: h * ts * d, rs: d, cs: 1 };
                matmul(ts, d, dh, out, head, View::rows(&attn.k.weight, h * dh * d, d), false, 1.0);
                for s in 0..ts {
                    from_bias[h * ts + s] =
                        dot(&q[s * ci + h * dh..s * ci + (h + 1) * dh], &attn.k.bias[h * dh..(h + 1) * dh]);
                }
            }
            FinalQuery { selected, q, folded, pe_scores, from_bias }
        })
        .collect()
}

/// The final attention's output for a [`FinalQuery`] from the attention's weighted means of the
/// image tokens `mixed` `[H·S, D]` (row `h·S + s`): values, output projection, residual and norm,
/// `[S, D]`.
fn final_output(packed: &PackedDecoder, query: &FinalQuery, mixed: Vec<f32>) -> Vec<f32> {
    let d = packed.dim;
    let attn = &packed.final_attn;
    let (ci, dh) = (attn.internal, attn.head_dim());
    let ts = query.q.len() / ci;
    let mut heads = vec![0f32; ts * ci];
    for h in 0..NUM_HEADS {
        let out = ViewMut { data: &mut heads, offset: h * dh, rs: ci, cs: 1 };
        matmul(
            ts,
            dh,
            d,
            out,
            View::rows(&mixed, h * ts * d, d),
            View::transposed(&attn.v.weight, h * dh * d, d),
            false,
            1.0,
        );
    }
    for row in heads.chunks_exact_mut(ci) {
        add_into(row, &attn.v.bias);
    }
    let mut out = query.selected.clone();
    add_into(&mut out, &project(&attn.out, &heads, ts, true));
    packed.final_norm.rows(&mut out);
    out
}

/// The final token→image attention and norm for the tokens `which` (indices into the `T` tokens) of
/// a decoded prompt, over its stored image tokens: `[S, D]`.
fn final_attention(
    packed: &PackedDecoder,
    image: &DecoderImage,
    prompt: &DecodedPrompt,
    which: &[usize],
) -> Vec<f32> {
    let d = packed.dim;
    let t = prompt.tokens.len() / d;
    let Some(query) = final_queries(packed, image, (&prompt.queries, &prompt.tokens), t, which).pop() else {
        return Vec::new();
    };
    let mut attention = query.attention(&packed.final_attn);
    for (tile, cell0) in prompt.keys.chunks(TILE * d).zip((0..).step_by(TILE)) {
        attention.add(cell0, tile);
    }
    final_output(packed, &query, attention.finish())
}
