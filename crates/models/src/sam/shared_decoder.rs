//! The mask decoder with its prompt-independent work done once per image, for many prompts at once.
//!
//! Same results as [`MaskDecoder::forward`] up to floating-point reassociation (tested against it).
//! What is shared and what is rearranged, with `E` the image tokens `[N, D]`, `P` the positional
//! encoding `[N, D]`, `T` prompt tokens and `H` heads of width `d`:
//!
//! - First block: its image tokens are `E` for every prompt, so the token→image keys `(E + P)·W_kᵀ`,
//!   values `E·W_vᵀ` and the image→token queries `(E + P)·W_qᵀ` are computed once per image
//!   ([`DecoderImage`]); per prompt only the `T × N` attention itself remains.
//! - Later blocks and the final attention: the image tokens now depend on the prompt (the image→token
//!   update), but every attention between them and the `T` tokens only needs dot products of the
//!   image tokens with `H·T` vectors. Token→image scores are `q_h·(W_k,h (x + p) + b) =
//!   (W_k,hᵀ q_h)·x + q_h·(W_k,h p) + q_h·b`: the image tokens are multiplied by `H·T` (56) columns
//!   instead of projected to the 128-wide internal width, and `P·W_kᵀ` is shared. Values:
//!   `Σᵢ aᵢ (W_v,h xᵢ + b) = W_v,h (Σᵢ aᵢ xᵢ) + b` (the weights sum to 1). Image→token queries
//!   likewise, with the roles of the two sides swapped.
//! - Image→token outputs: `Σⱼ aᵢⱼ W_o,h v_j` is `aᵢ · U` with `U = W_o,h v_j` formed per prompt on the
//!   `T` tokens, so the `[N, 128]` head outputs are never formed.
//! - The IoU head needs only the tokens: masks are upscaled afterwards, and only for the prompts and
//!   mask outputs the caller asks for (the automatic mask generator's predicted-IoU filter runs first).

use candle_core::{Module, Tensor, D};

use super::mask_decoder::{Attention, MaskDecoder, TwoWayBlock, NUM_HEADS};
use crate::error::{ModelsError, ModelsResult};

/// Per-image, prompt-independent inputs of the decoder's attentions (all head-split `[H, N, d]`).
#[derive(Debug, Clone)]
pub struct DecoderImage {
    /// Image tokens, `[N, D]` (embedding plus the "no mask" dense prompt; rows are cells).
    tokens: Tensor,
    /// First block, token→image keys `(E + P)·W_kᵀ + b_k`.
    first_keys: Tensor,
    /// First block, token→image values `E·W_vᵀ + b_v`.
    first_values: Tensor,
    /// First block, image→token queries `(E + P)·W_qᵀ + b_q`.
    first_queries: Tensor,
    /// Blocks after the first: (token→image `P·W_kᵀ`, image→token `P·W_qᵀ`), no biases.
    later_pe: Vec<(Tensor, Tensor)>,
    /// Final token→image attention's `P·W_kᵀ`, no bias.
    final_pe_keys: Tensor,
    /// Embedding grid (h, w).
    grid: (usize, usize),
}

/// A batch of prompts through the transformer: tokens and image tokens, ready for the heads.
#[derive(Debug, Clone)]
pub struct DecodedTokens {
    /// Output tokens after the final attention, `[B, T, D]` (IoU token, mask tokens, prompt tokens).
    queries: Tensor,
    /// Image tokens after the last block, `[B, N, D]`.
    keys: Tensor,
    /// IoU predictions of every mask output, `[B, M]`.
    pub iou: Tensor,
}

/// `[R, H·d]` → `[H, R, d]`.
fn split_heads(x: &Tensor) -> ModelsResult<Tensor> {
    let (rows, width) = x.dims2()?;
    Ok(x.reshape((rows, NUM_HEADS, width / NUM_HEADS))?.transpose(0, 1)?.contiguous()?)
}

/// A projection's weight `[H·d, D]` as `[H, d, D]`.
fn weight_heads(linear: &candle_nn::Linear) -> ModelsResult<Tensor> {
    let (width, dim) = linear.weight().dims2()?;
    Ok(linear.weight().reshape((NUM_HEADS, width / NUM_HEADS, dim))?)
}

/// A projection's bias `[H·d]` as `[H, 1, d]`.
fn bias_heads(linear: &candle_nn::Linear) -> ModelsResult<Tensor> {
    let width = linear.weight().dims()[0];
    let bias = match linear.bias() {
        Some(b) => b.clone(),
        None => Tensor::zeros(width, linear.weight().dtype(), linear.weight().device())?,
    };
    Ok(bias.reshape((NUM_HEADS, 1, width / NUM_HEADS))?)
}

/// `[H, B·T, C]` → `[B, H·T, C]`.
fn heads_to_batch(x: &Tensor, b: usize) -> ModelsResult<Tensor> {
    let (h, bt, c) = x.dims3()?;
    let t = bt / b;
    Ok(x.reshape((h, b, t, c))?.transpose(0, 1)?.contiguous()?.reshape((b, h * t, c))?)
}

/// `Σ_c x[h, r, c] · bias[h, 0, c]` for `x` `[H, B·T, d]`: `[B, H·T]` (as `[B, H·T, 1]`).
fn bias_scores(x: &Tensor, bias: &Tensor, b: usize) -> ModelsResult<Tensor> {
    let per_row = x.broadcast_mul(bias)?.sum_keepdim(D::Minus1)?; // [H, B·T, 1]
    heads_to_batch(&per_row, b)
}

/// The image side of a cross attention.
enum ImageSide<'a> {
    /// The first block: projections shared by every prompt, `[H, N, d]`.
    Shared { keys: &'a Tensor, values: &'a Tensor },
    /// Prompt-dependent image tokens `[B, N, D]` and the shared `P·W_kᵀ` `[H, N, d]`.
    PerPrompt { tokens: &'a Tensor, pe_projected: &'a Tensor },
}

impl DecoderImage {
    /// Embedding grid (h, w).
    pub fn grid(&self) -> (usize, usize) {
        self.grid
    }
}

impl MaskDecoder {
    /// The prompt-independent part of the decoder for one image: `image` and `image_pe` `[D, h, w]` as
    /// in [`MaskDecoder::forward`].
    pub fn prepare_image(&self, image: &Tensor, image_pe: &Tensor) -> ModelsResult<DecoderImage> {
        let (d, h, w) = image.dims3()?;
        let Some(first) = self.blocks.first() else {
            return Err(ModelsError::Input("the SAM mask decoder has no transformer layers".into()));
        };
        let tokens = image.reshape((d, h * w))?.t()?.contiguous()?;
        let pe = image_pe.reshape((d, h * w))?.t()?.contiguous()?;
        let with_pe = (&tokens + &pe)?;
        let first_keys = split_heads(&first.token_to_image.k.forward(&with_pe)?)?;
        let first_values = split_heads(&first.token_to_image.v.forward(&tokens)?)?;
        let first_queries = split_heads(&first.image_to_token.q.forward(&with_pe)?)?;
        let project = |linear: &candle_nn::Linear| split_heads(&pe.matmul(&linear.weight().t()?)?);
        let later_pe = self.blocks[1..]
            .iter()
            .map(|b| Ok((project(&b.token_to_image.k)?, project(&b.image_to_token.q)?)))
            .collect::<ModelsResult<_>>()?;
        let final_pe_keys = project(&self.final_attn.k)?;
        Ok(DecoderImage {
            tokens,
            first_keys,
            first_values,
            first_queries,
            later_pe,
            final_pe_keys,
            grid: (h, w),
        })
    }

    /// The two-way transformer and the IoU head for a batch of prompts on a prepared image.
    ///
    /// `sparse`: `[B, T', D]` prompt tokens. Masks come from [`MaskDecoder::masks_of`].
    pub fn decode_tokens(&self, image: &DecoderImage, sparse: &Tensor) -> ModelsResult<DecodedTokens> {
        let (b, _, d) = sparse.dims3()?;
        let m = self.hypernets.len();
        let tokens = Tensor::cat(
            &[self.output_tokens.unsqueeze(0)?.broadcast_as((b, 1 + m, d))?.contiguous()?, sparse.clone()],
            1,
        )?;
        let mut queries = tokens.clone();
        let mut keys: Option<Tensor> = None;
        for (i, block) in self.blocks.iter().enumerate() {
            let side = match (&keys, i) {
                (None, _) => ImageSide::Shared { keys: &image.first_keys, values: &image.first_values },
                (Some(k), i) => ImageSide::PerPrompt { tokens: k, pe_projected: &image.later_pe[i - 1].0 },
            };
            queries = block_tokens(block, &queries, &tokens, side)?;
            let q = (&queries + &tokens)?;
            let update = match &keys {
                None => image_to_token(
                    &block.image_to_token,
                    &q,
                    &queries,
                    ImageQueries::Shared(&image.first_queries),
                )?
                .broadcast_add(&image.tokens)?,
                Some(k) => {
                    let pe_q = &image.later_pe[i - 1].1;
                    (k + image_to_token(
                        &block.image_to_token,
                        &q,
                        &queries,
                        ImageQueries::PerPrompt(k, pe_q),
                    )?)?
                }
            };
            keys = Some(block.norm4.forward(&update)?);
        }
        let keys = match keys {
            Some(k) => k,
            None => image.tokens.unsqueeze(0)?.broadcast_as((b, image.tokens.dims()[0], d))?.contiguous()?,
        };
        let q = (&queries + &tokens)?;
        let side = ImageSide::PerPrompt { tokens: &keys, pe_projected: &image.final_pe_keys };
        let attended = token_to_image(&self.final_attn, &q, side)?;
        let queries = self.final_norm.forward(&(&queries + attended)?)?;
        let iou = self.iou_head.forward(&queries.narrow(1, 0, 1)?.squeeze(1)?)?;
        Ok(DecodedTokens { queries, keys, iou })
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
        let tokens = decoded.queries.get(prompt)?; // [T, D]
        let hyper = outputs
            .iter()
            .map(|&o| self.hypernets[o].forward(&tokens.narrow(0, 1 + o, 1)?))
            .collect::<ModelsResult<Vec<_>>>()?;
        let hyper = Tensor::cat(&hyper, 0)?.unsqueeze(0)?; // [1, S, D/8]
        let keys = decoded.keys.narrow(0, prompt, 1)?;
        Ok(self.upscale_masks(&keys, &hyper, image.grid)?.squeeze(0)?)
    }
}

/// A block's token-side steps up to and including the token→image attention and the MLP.
fn block_tokens(
    block: &TwoWayBlock,
    queries: &Tensor,
    query_pe: &Tensor,
    image: ImageSide,
) -> ModelsResult<Tensor> {
    let queries = if block.skip_first_pe {
        block.self_attn.forward(queries, queries, queries)?
    } else {
        let q = (queries + query_pe)?;
        (queries + block.self_attn.forward(&q, &q, queries)?)?
    };
    let queries = block.norm1.forward(&queries)?;
    let q = (&queries + query_pe)?;
    let queries = block.norm2.forward(&(&queries + token_to_image(&block.token_to_image, &q, image)?)?)?;
    let mlp = block.lin2.forward(&block.lin1.forward(&queries)?.relu()?)?;
    Ok(block.norm3.forward(&(queries + mlp)?)?)
}

/// Token→image attention: `queries` `[B, T, D]` (with their positional terms) attend to the image
/// tokens. Returns the output projection `[B, T, D]`.
fn token_to_image(attn: &Attention, queries: &Tensor, image: ImageSide) -> ModelsResult<Tensor> {
    let (b, t, _) = queries.dims3()?;
    let head_dim = attn.internal / NUM_HEADS;
    let scale = 1.0 / (head_dim as f64).sqrt();
    let q = split_heads(&attn.q.forward(queries)?.reshape((b * t, attn.internal))?)?; // [H, B·T, d]
    let heads_out = match image {
        ImageSide::Shared { keys, values } => {
            let scores = (q.matmul(&keys.t()?)? * scale)?; // [H, B·T, N]
            candle_nn::ops::softmax_last_dim(&scores)?.matmul(values)? // [H, B·T, d]
        }
        ImageSide::PerPrompt { tokens, pe_projected } => {
            // (W_k,hᵀ q) per head and token: [B, H·T, D]
            let folded = heads_to_batch(&q.matmul(&weight_heads(&attn.k)?)?, b)?;
            let from_tokens = folded.matmul(&tokens.transpose(1, 2)?)?; // [B, H·T, N]
            let from_pe = heads_to_batch(&q.matmul(&pe_projected.t()?)?, b)?; // [B, H·T, N]
            let from_bias = bias_scores(&q, &bias_heads(&attn.k)?, b)?; // [B, H·T, 1]
            let scores = ((from_tokens + from_pe)?.broadcast_add(&from_bias)? * scale)?;
            let weights = candle_nn::ops::softmax_last_dim(&scores)?; // [B, H·T, N]
            let mixed = weights.matmul(tokens)?; // [B, H·T, D]
            let n_tok = mixed.dims()[1] / NUM_HEADS;
            let mixed =
                mixed.reshape((b, NUM_HEADS, n_tok, mixed.dims()[2]))?.transpose(0, 1)?.contiguous()?;
            let mixed = mixed.reshape((NUM_HEADS, b * n_tok, mixed.dims()[3]))?; // [H, B·T, D]
            mixed.matmul(&weight_heads(&attn.v)?.transpose(1, 2)?)?.broadcast_add(&bias_heads(&attn.v)?)?
        }
    };
    let out = heads_out.transpose(0, 1)?.contiguous()?.reshape((b, t, attn.internal))?;
    Ok(attn.out.forward(&out)?)
}

/// The image side of an image→token attention's queries.
enum ImageQueries<'a> {
    /// First block: `(E + P)·W_qᵀ + b_q`, `[H, N, d]`.
    Shared(&'a Tensor),
    /// Image tokens `[B, N, D]` and the shared `P·W_qᵀ` `[H, N, d]`.
    PerPrompt(&'a Tensor, &'a Tensor),
}

/// Image→token attention: every image token attends to the `T` tokens (`keys_in` `[B, T, D]` with
/// their positional terms, `values_in` without). Returns the output projection `[B, N, D]`.
fn image_to_token(
    attn: &Attention,
    keys_in: &Tensor,
    values_in: &Tensor,
    image: ImageQueries,
) -> ModelsResult<Tensor> {
    let (b, t, _) = keys_in.dims3()?;
    let head_dim = attn.internal / NUM_HEADS;
    let scale = 1.0 / (head_dim as f64).sqrt();
    let k = split_heads(&attn.k.forward(keys_in)?.reshape((b * t, attn.internal))?)?; // [H, B·T, d]
    let v = split_heads(&attn.v.forward(values_in)?.reshape((b * t, attn.internal))?)?; // [H, B·T, d]
    let scores = match image {
        ImageQueries::Shared(queries) => {
            let n = queries.dims()[1];
            // [H, N, B·T] → [B, N, H, T]
            let s = queries.matmul(&k.t()?)?.reshape((NUM_HEADS, n, b, t))?;
            s.permute((2, 1, 0, 3))?.contiguous()?
        }
        ImageQueries::PerPrompt(tokens, pe_projected) => {
            let n = tokens.dims()[1];
            let folded = heads_to_batch(&k.matmul(&weight_heads(&attn.q)?)?, b)?; // [B, H·T, D]
            let from_tokens = tokens.matmul(&folded.transpose(1, 2)?)?; // [B, N, H·T]
            let from_pe = pe_projected.matmul(&k.t()?)?.reshape((NUM_HEADS, n, b, t))?;
            let from_pe = from_pe.permute((2, 1, 0, 3))?.contiguous()?.reshape((b, n, NUM_HEADS * t))?;
            let from_bias = bias_scores(&k, &bias_heads(&attn.q)?, b)?.transpose(1, 2)?; // [B, 1, H·T]
            (from_tokens + from_pe)?.broadcast_add(&from_bias)?.reshape((b, n, NUM_HEADS, t))?
        }
    };
    let n = scores.dims()[1];
    let weights = candle_nn::ops::softmax_last_dim(&(scores * scale)?)?.reshape((b, n, NUM_HEADS * t))?;
    // U[b, (h, t)] = W_o,h v[b, t, h]: [H, B·T, D] → [B, H·T, D]
    let (dim, _) = attn.out.weight().dims2()?;
    let out_heads =
        attn.out.weight().reshape((dim, NUM_HEADS, head_dim))?.permute((1, 2, 0))?.contiguous()?;
    let u = heads_to_batch(&v.matmul(&out_heads)?, b)?;
    let out = weights.matmul(&u)?; // [B, N, D]
    Ok(match attn.out.bias() {
        Some(bias) => out.broadcast_add(bias)?,
        None => out,
    })
}
