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

/// The second block's token→image attention, from the first block's trace: `with_pe` `[T, D]` are
/// the queries with their positional terms. Returns the output projection `[T, D]`.
pub(super) fn second_token_to_image(
    packed: &PackedDecoder,
    image: &DecoderImage,
    trace: &FirstBlockTrace,
    with_pe: &[f32],
    t: usize,
) -> Vec<f32> {
    let attn = &packed.blocks[1].token_to_image;
    let (ci, dh, n) = (attn.internal, attn.head_dim(), image.cells());
    let ht = NUM_HEADS * t;
    let ht1 = trace.weights.len() / n;
    let q = project(&attn.q, with_pe, t, true);
    // C[(h, t), c] = q_t,h · W_k,h (γ⊙U₁)_c
    let keys_of_rows = project(&attn.k, trace.scaled_rows, ht1, false);
    let mut c = vec![0f32; ht * ht1];
    let mut base = vec![0f32; ht * n];
    let mut varying = vec![0f32; ht * n];
    for h in 0..NUM_HEADS {
        let head = View { data: &q, offset: h * dh, rs: ci, cs: 1 };
        let out = ViewMut { data: &mut c, offset: h * t * ht1, rs: ht1, cs: 1 };
        matmul(t, ht1, dh, out, head, View::transposed(&keys_of_rows, h * dh, ci), false, 1.0);
        image.second_pe_keys.head_scores(&mut base[h * t * n..(h + 1) * t * n], &q, t, (h, dh));
        image.second_keys.head_scores(&mut varying[h * t * n..(h + 1) * t * n], &q, t, (h, dh));
    }
    matmul(
        ht,
        n,
        ht1,
        ViewMut::rows(&mut varying, 0, n),
        View::rows(&c, 0, ht1),
        View::rows(trace.weights, 0, n),
        true,
        1.0,
    );
    let scale = attn.scale();
    for h in 0..NUM_HEADS {
        for s in 0..t {
            let row = h * t + s;
            let qv = &q[s * ci + h * dh..s * ci + (h + 1) * dh];
            let from_beta = dot(qv, &image.keys_beta[h * dh..(h + 1) * dh]);
            let from_gamma = dot(qv, &image.keys_gamma[h * dh..(h + 1) * dh]);
            let scores = &mut base[row * n..(row + 1) * n];
            let varying = &varying[row * n..(row + 1) * n];
            for i in 0..n {
                scores[i] = scale
                    * (scores[i] + from_beta + (varying[i] - trace.mean[i] * from_gamma) * trace.inv_std[i]);
            }
        }
    }
    softmax_runs(&mut base, n, 1.0);
    // a' = a/σ per image token
    for (row_out, row) in varying.chunks_exact_mut(n).zip(base.chunks_exact(n)) {
        for ((o, a), inv) in row_out.iter_mut().zip(row).zip(trace.inv_std) {
            *o = a * inv;
        }
    }
    let weighted = &varying[..];
    let mut heads = vec![0f32; t * ci];
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
        image.second_values.head_mix(&mut heads, (weighted, h * t * n), t, (h, dh));
        let out = ViewMut { data: &mut heads, offset: h * dh, rs: ci, cs: 1 };
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
    project(&attn.out, &heads, t, true)
}

/// The second block's image→token attention weights, transposed: `[H·T, N]` (softmax over each
/// head's `T` rows in every column), from the first block's trace and the keys `k` `[T, H·d]` (with biases).
pub(super) fn second_image_scores(
    packed: &PackedDecoder,
    image: &DecoderImage,
    trace: &FirstBlockTrace,
    k: &[f32],
    t: usize,
) -> Vec<f32> {
    let attn = &packed.blocks[1].image_to_token;
    let (ci, dh, n) = (attn.internal, attn.head_dim(), image.cells());
    let ht = NUM_HEADS * t;
    let ht1 = trace.weights.len() / n;
    // C[(h, t), c] = k_t,h · W_q,h (γ⊙U₁)_c
    let queries_of_rows = project(&attn.q, trace.scaled_rows, ht1, false);
    let mut c = vec![0f32; ht * ht1];
    let mut scores = vec![0f32; ht * n];
    let mut varying = vec![0f32; ht * n];
    for h in 0..NUM_HEADS {
        let head = View { data: k, offset: h * dh, rs: ci, cs: 1 };
        let out = ViewMut { data: &mut c, offset: h * t * ht1, rs: ht1, cs: 1 };
        matmul(t, ht1, dh, out, head, View::transposed(&queries_of_rows, h * dh, ci), false, 1.0);
        image.second_pe_queries.head_scores(&mut scores[h * t * n..(h + 1) * t * n], k, t, (h, dh));
        image.second_queries.head_scores(&mut varying[h * t * n..(h + 1) * t * n], k, t, (h, dh));
    }
    matmul(
        ht,
        n,
        ht1,
        ViewMut::rows(&mut varying, 0, n),
        View::rows(&c, 0, ht1),
        View::rows(trace.weights, 0, n),
        true,
        1.0,
    );
    let mut from_beta = vec![0f32; ht];
    let mut from_gamma = vec![0f32; ht];
    for h in 0..NUM_HEADS {
        for s in 0..t {
            let kv = &k[s * ci + h * dh..s * ci + (h + 1) * dh];
            from_beta[h * t + s] = dot(kv, &image.queries_beta[h * dh..(h + 1) * dh]);
            from_gamma[h * t + s] = dot(kv, &image.queries_gamma[h * dh..(h + 1) * dh]);
        }
    }
    let scale = attn.scale();
    for (col, (row, varying)) in scores.chunks_exact_mut(n).zip(varying.chunks_exact(n)).enumerate() {
        let (beta, gamma) = (from_beta[col], from_gamma[col]);
        for i in 0..n {
            row[i] = scale * (row[i] + beta + (varying[i] - trace.mean[i] * gamma) * trace.inv_std[i]);
        }
    }
    softmax_columns(&mut scores, t, n, 1.0);
    scores
}
