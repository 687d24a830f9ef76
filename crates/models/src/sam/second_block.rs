//! The second block of the shared-work decoder, seen through the first block's image→token weights:
//! `X₁ = γ⊙(E + b_o + A₁U₁ − μ)/σ + β` per row, so any projection of the image tokens is a shared
//! projection of `γ⊙(E + b_o)` plus an `H·T`-wide product with `A₁` (see [`super::shared_decoder`]).

use super::mask_decoder::NUM_HEADS;
use super::packed_decoder::{project, PackedDecoder};
use super::shared_decoder::DecoderImage;
use crate::dense::{matmul, softmax_columns, softmax_runs, View, ViewMut};
use crate::kernels::dot;

/// What a per-prompt attention sees of the first block's image→token weights, for the second block.
pub(super) struct FirstBlockTrace<'a> {
    /// `A₁ᵀ` `[H·T, N]`.
    pub(super) weights: &'a [f32],
    /// `γ⊙U₁` `[H·T, D]`.
    pub(super) scaled_rows: &'a [f32],
    /// Row means and inverse standard deviations of `E + b_o + A₁U₁`, `[N]`.
    pub(super) mean: &'a [f32],
    pub(super) inv_std: &'a [f32],
}

/// Per prompt, `[H·T, N]` buffers of zeros (each allocated zeroed: `vec![v; n]` would copy `v`).
fn per_prompt(prompts: usize, ht: usize, n: usize) -> Vec<Vec<f32>> {
    (0..prompts).map(|_| vec![0f32; ht * n]).collect()
}

/// Head `h`'s `[T, N]` block of each prompt's `[H·T, N]` buffer.
fn head_blocks(buffers: &mut [Vec<f32>], h: usize, block: usize) -> Vec<&mut [f32]> {
    buffers.iter_mut().map(|b| &mut b[h * block..(h + 1) * block]).collect()
}

/// Adds one prompt's first-block part of the second block's scores to `varying` `[H·T, N]`:
/// `C·A₁ᵀ` with `C[(h, t), c] = x_t,h · W_h (γ⊙U₁)_c`, where `x` `[T, D_int]` are the prompt's
/// token-side rows (queries or keys), `w` the image side's projection (keys or queries) and
/// `(t, ci, dh)` = (tokens, internal width, head width).
fn add_first_block_terms(
    varying: &mut [f32],
    w: &crate::dense::Linear,
    x: &[f32],
    trace: &FirstBlockTrace,
    (t, ci, dh): (usize, usize, usize),
    n: usize,
) {
    let ht = NUM_HEADS * t;
    let ht1 = trace.weights.len() / n;
    let rows = project(w, trace.scaled_rows, ht1, false);
    let mut c = vec![0f32; ht * ht1];
    for h in 0..NUM_HEADS {
        let head = View { data: x, offset: h * dh, rs: ci, cs: 1 };
        let out = ViewMut { data: &mut c, offset: h * t * ht1, rs: ht1, cs: 1 };
        matmul(t, ht1, dh, out, head, View::transposed(&rows, h * dh, ci), false, 1.0);
    }
    let (a, c) = (View::rows(trace.weights, 0, n), View::rows(&c, 0, ht1));
    matmul(ht, n, ht1, ViewMut::rows(varying, 0, n), c, a, true, 1.0);
}

/// The second block's token→image attention for a batch of prompts, from their first block's traces
/// (one per prompt): `with_pe` `[B·T, D]` are the queries with their positional terms, prompt after
/// prompt. Returns the output projection `[B·T, D]`. The image-side products run on all `B·T` rows
/// at once (each per-image panel read once per batch); the products with each prompt's `A₁` per prompt.
pub(super) fn second_token_to_image(
    packed: &PackedDecoder,
    image: &DecoderImage,
    traces: &[FirstBlockTrace],
    with_pe: &[f32],
    t: usize,
) -> Vec<f32> {
    let attn = &packed.blocks[1].token_to_image;
    let (ci, dh, n) = (attn.internal, attn.head_dim(), image.cells());
    let (ht, bt) = (NUM_HEADS * t, traces.len() * t);
    let q = project(&attn.q, with_pe, bt, true);
    let mut base = per_prompt(traces.len(), ht, n);
    let mut varying = per_prompt(traces.len(), ht, n);
    for h in 0..NUM_HEADS {
        image.second_pe_keys.head_scores_batch(&mut head_blocks(&mut base, h, t * n), &q, t, (h, dh));
        image.second_keys.head_scores_batch(&mut head_blocks(&mut varying, h, t * n), &q, t, (h, dh));
    }
    let scale = attn.scale();
    for (p, trace) in traces.iter().enumerate() {
        let q = &q[p * t * ci..(p + 1) * t * ci];
        let (base, varying) = (&mut base[p], &mut varying[p]);
        add_first_block_terms(varying, &attn.k, q, trace, (t, ci, dh), n);
        for h in 0..NUM_HEADS {
            for s in 0..t {
                let row = h * t + s;
                let qv = &q[s * ci + h * dh..s * ci + (h + 1) * dh];
                let from_beta = dot(qv, &image.keys_beta[h * dh..(h + 1) * dh]);
                let from_gamma = dot(qv, &image.keys_gamma[h * dh..(h + 1) * dh]);
                let scores = &mut base[row * n..(row + 1) * n];
                let varying = &varying[row * n..(row + 1) * n];
                let terms = varying.iter().zip(trace.mean).zip(trace.inv_std);
                for (s, ((v, m), inv)) in scores.iter_mut().zip(terms) {
                    *s = scale * (*s + from_beta + (v - m * from_gamma) * inv);
                }
            }
        }
        softmax_runs(base, n, 1.0);
        // a' = a/σ per image token
        for (row_out, row) in varying.chunks_exact_mut(n).zip(base.chunks_exact(n)) {
            for ((o, a), inv) in row_out.iter_mut().zip(row).zip(trace.inv_std) {
                *o = a * inv;
            }
        }
    }
    let weighted = &varying;
    let mut heads = vec![0f32; bt * ci];
    for h in 0..NUM_HEADS {
        let rows: Vec<&[f32]> = weighted.iter().map(|w| &w[h * t * n..(h + 1) * t * n]).collect();
        image.second_values.head_mix_batch(&mut heads, &rows, t, (h, dh));
    }
    for (p, trace) in traces.iter().enumerate() {
        let weighted = &weighted[p];
        let heads = &mut heads[p * t * ci..(p + 1) * t * ci];
        let ht1 = trace.weights.len() / n;
        // W[(h, t), c] = Σᵢ a'ᵢ A₁[i, c]
        let mut mixed = vec![0f32; ht * ht1];
        matmul(
            ht,
            ht1,
            n,
            ViewMut::rows(&mut mixed, 0, ht1),
            View::rows(weighted, 0, n),
            View::transposed(trace.weights, 0, n),
            false,
            1.0,
        );
        let values_of_rows = project(&attn.v, trace.scaled_rows, ht1, false);
        for h in 0..NUM_HEADS {
            let out = ViewMut { data: heads, offset: h * dh, rs: ci, cs: 1 };
            let rows = View { data: &values_of_rows, offset: h * dh, rs: ci, cs: 1 };
            matmul(t, dh, ht1, out, View::rows(&mixed, h * t * ht1, ht1), rows, true, 1.0);
            for s in 0..t {
                let row = h * t + s;
                let mean_weight = dot(&weighted[row * n..(row + 1) * n], trace.mean);
                let out = &mut heads[s * ci + h * dh..s * ci + (h + 1) * dh];
                let beta = &image.values_beta[h * dh..(h + 1) * dh];
                let gamma = &image.values_gamma[h * dh..(h + 1) * dh];
                for ((o, b), g) in out.iter_mut().zip(beta).zip(gamma) {
                    *o += b - mean_weight * g;
                }
            }
        }
    }
    project(&attn.out, &heads, bt, true)
}

/// The second block's image→token attention weights of a batch of prompts, transposed: per prompt
/// `[H·T, N]` (softmax over each head's `T` rows in every column), from their first block's traces
/// and the keys `k` `[B·T, H·d]` (with biases, prompt after prompt).
pub(super) fn second_image_scores(
    packed: &PackedDecoder,
    image: &DecoderImage,
    traces: &[FirstBlockTrace],
    k: &[f32],
    t: usize,
) -> Vec<Vec<f32>> {
    let attn = &packed.blocks[1].image_to_token;
    let (ci, dh, n) = (attn.internal, attn.head_dim(), image.cells());
    let ht = NUM_HEADS * t;
    let mut scores = per_prompt(traces.len(), ht, n);
    let mut varying = per_prompt(traces.len(), ht, n);
    for h in 0..NUM_HEADS {
        image.second_pe_queries.head_scores_batch(&mut head_blocks(&mut scores, h, t * n), k, t, (h, dh));
        image.second_queries.head_scores_batch(&mut head_blocks(&mut varying, h, t * n), k, t, (h, dh));
    }
    let scale = attn.scale();
    for (p, trace) in traces.iter().enumerate() {
        let k = &k[p * t * ci..(p + 1) * t * ci];
        let (scores, varying) = (&mut scores[p], &mut varying[p]);
        add_first_block_terms(varying, &attn.q, k, trace, (t, ci, dh), n);
        let mut from_beta = vec![0f32; ht];
        let mut from_gamma = vec![0f32; ht];
        for h in 0..NUM_HEADS {
            for s in 0..t {
                let kv = &k[s * ci + h * dh..s * ci + (h + 1) * dh];
                from_beta[h * t + s] = dot(kv, &image.queries_beta[h * dh..(h + 1) * dh]);
                from_gamma[h * t + s] = dot(kv, &image.queries_gamma[h * dh..(h + 1) * dh]);
            }
        }
        for (col, (row, varying)) in scores.chunks_exact_mut(n).zip(varying.chunks_exact(n)).enumerate() {
            let (beta, gamma) = (from_beta[col], from_gamma[col]);
            let terms = varying.iter().zip(trace.mean).zip(trace.inv_std);
            for (s, ((v, m), inv)) in row.iter_mut().zip(terms) {
                *s = scale * (*s + beta + (v - m * gamma) * inv);
            }
        }
        softmax_columns(scores, t, n, 1.0);
    }
    scores
}
