//! The quantisation helpers the compact formats share: bytes from values in a range and back,
//! the sigmoid and its inverse, and SH coefficients between the INRIA channel-major order and the
//! coefficient-major order (colour channel fastest) of SPZ.

/// `x` rounded to the nearest integer and clamped to `0..=255` (NaN gives 0; writers validate first).
pub(crate) fn to_u8(x: f32) -> u8 {
    x.round().clamp(0.0, 255.0) as u8
}

/// The opacity in (0, 1) of a raw (pre-sigmoid) opacity.
pub(crate) fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}

/// The raw opacity of a byte `a` = round(opacity · 255). 0 and 255 would give ±∞, so the opacity is
/// clamped to half a step inside (0, 1): `[0.5/255, 1 − 0.5/255]`, which quantises back to the same
/// byte (logit ±6.23).
pub(crate) fn logit_of_byte(a: u8) -> f32 {
    let p = (a as f32 / 255.0).clamp(0.5 / 255.0, 1.0 - 0.5 / 255.0);
    (p / (1.0 - p)).ln()
}

/// `[N, 3, K]` INRIA order (`sh_rest[n·3K + c·K + k]`) → `[N, K, 3]` (`out[n·3K + k·3 + c]`).
pub(crate) fn sh_rest_to_coefficient_major(sh_rest: &[f32], rest_per_channel: usize) -> Vec<f32> {
    let k = rest_per_channel;
    let mut out = vec![0.0; sh_rest.len()];
    if k == 0 {
        return out;
    }
    for (row_in, row_out) in sh_rest.chunks_exact(3 * k).zip(out.chunks_exact_mut(3 * k)) {
        for c in 0..3 {
            for j in 0..k {
                row_out[j * 3 + c] = row_in[c * k + j];
            }
        }
    }
    out
}

/// The inverse of [`sh_rest_to_coefficient_major`]: `[N, K, 3]` → `[N, 3, K]` (the SPZ reader
/// does it in place, in parallel; this checks the writer's order).
#[cfg(test)]
pub(crate) fn sh_rest_to_channel_major(coefficient_major: &[f32], rest_per_channel: usize) -> Vec<f32> {
    let k = rest_per_channel;
    let mut out = vec![0.0; coefficient_major.len()];
    if k == 0 {
        return out;
    }
    for (row_in, row_out) in coefficient_major.chunks_exact(3 * k).zip(out.chunks_exact_mut(3 * k)) {
        for c in 0..3 {
            for j in 0..k {
                row_out[c * k + j] = row_in[j * 3 + c];
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn opacity_bytes_give_finite_logits_that_quantise_back() {
        for a in 0..=255u8 {
            let raw = logit_of_byte(a);
            assert!(raw.is_finite(), "byte {a}");
            assert_eq!(to_u8(sigmoid(raw) * 255.0), a, "byte {a}");
        }
    }

    #[test]
    fn sh_orders_are_inverse_and_interleave_the_channels() {
        // One Gaussian, K = 3: channel-major r0 r1 r2 g0 g1 g2 b0 b1 b2.
        let inria = [1.0, 2.0, 3.0, 10.0, 20.0, 30.0, 100.0, 200.0, 300.0];
        let spz = sh_rest_to_coefficient_major(&inria, 3);
        assert_eq!(spz, vec![1.0, 10.0, 100.0, 2.0, 20.0, 200.0, 3.0, 30.0, 300.0]);
        assert_eq!(sh_rest_to_channel_major(&spz, 3), inria.to_vec());
    }
}
