//! Small numeric kernels written so the compiler vectorises them (fixed lane counts, no branches, no
//! library calls in the loops); shared by the fused CPU ops.

/// Lanes of the partial sums: independent accumulators the compiler keeps in SIMD registers. The lane
/// order is fixed, so results are reproducible.
const LANES: usize = 8;

/// `Σ a·b` with `LANES` partial sums.
#[inline]
pub fn dot(a: &[f32], b: &[f32]) -> f32 {
    let mut lanes = [0f32; LANES];
    let (a_chunks, b_chunks) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    let tail: f32 = a_chunks.remainder().iter().zip(b_chunks.remainder()).map(|(x, y)| x * y).sum();
    for (x, y) in a_chunks.zip(b_chunks) {
        for lane in 0..LANES {
            lanes[lane] += x[lane] * y[lane];
        }
    }
    lanes.iter().sum::<f32>() + tail
}

/// `Σ v` with `LANES` partial sums.
#[inline]
pub fn sum(values: &[f32]) -> f32 {
    let mut lanes = [0f32; LANES];
    let chunks = values.chunks_exact(LANES);
    let tail: f32 = chunks.remainder().iter().sum();
    for chunk in chunks {
        for lane in 0..LANES {
            lanes[lane] += chunk[lane];
        }
    }
    lanes.iter().sum::<f32>() + tail
}

/// `Σ (v − mean)²` with `LANES` partial sums.
#[inline]
pub fn squared_deviation(values: &[f32], mean: f32) -> f32 {
    let mut lanes = [0f32; LANES];
    let chunks = values.chunks_exact(LANES);
    let tail: f32 = chunks.remainder().iter().map(|v| (v - mean) * (v - mean)).sum();
    for chunk in chunks {
        for lane in 0..LANES {
            let d = chunk[lane] - mean;
            lanes[lane] += d * d;
        }
    }
    lanes.iter().sum::<f32>() + tail
}

/// The largest value (−∞ for none; NaN-free input).
#[inline]
pub fn max_of(values: &[f32]) -> f32 {
    let larger = |m: f32, v: f32| if v > m { v } else { m };
    let mut lanes = [f32::NEG_INFINITY; LANES];
    let chunks = values.chunks_exact(LANES);
    let tail = chunks.remainder().iter().fold(f32::NEG_INFINITY, |m, &v| larger(m, v));
    for chunk in chunks {
        for lane in 0..LANES {
            lanes[lane] = larger(lanes[lane], chunk[lane]);
        }
    }
    lanes.iter().fold(tail, |m, &v| larger(m, v))
}

/// Replaces every `v` by `exp(v − shift)` and returns their sum: the numerator and denominator of a
/// softmax. Needs `v ≤ shift` (as with `shift` = the maximum); relative error below 3e-7 (tested).
/// Runs 16 lanes wide with AVX-512 ([`crate::math512`], within a few ulp), else 8 lanes wide with AVX2
/// where the CPU has it (same arithmetic as the portable loop, so the same results).
pub fn exp_shifted_in_place(values: &mut [f32], shift: f32) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if crate::skinny::has_avx512() {
        // SAFETY: the CPU supports AVX-512F (just detected).
        return unsafe { crate::math512::exp_shifted_in_place(values, shift) };
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2 (just detected).
        return unsafe { exp_shifted_in_place_avx2(values, shift) };
    }
    exp_shifted_in_place_portable(values, shift)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn exp_shifted_in_place_avx2(values: &mut [f32], shift: f32) -> f32 {
    exp_shifted_in_place_portable(values, shift)
}

#[inline(always)]
fn exp_shifted_in_place_portable(values: &mut [f32], shift: f32) -> f32 {
    let mut lanes = [0f32; LANES];
    let mut chunks = values.chunks_exact_mut(LANES);
    for chunk in &mut chunks {
        for lane in 0..LANES {
            chunk[lane] = exp_non_positive(chunk[lane] - shift);
            lanes[lane] += chunk[lane];
        }
    }
    let mut tail = 0.0;
    for value in chunks.into_remainder() {
        *value = exp_non_positive(*value - shift);
        tail += *value;
    }
    lanes.iter().sum::<f32>() + tail
}

/// The exact (erf) GELU in place, `x · (1 + erf(x / √2)) / 2` (as [`crate::activation::gelu_erf`]);
/// 16 lanes wide with AVX-512 ([`crate::math512`], within 1e-6), else 8 lanes wide with AVX2 where the
/// CPU has it (same arithmetic as the portable loop, so the same results).
pub fn gelu_in_place(values: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if crate::skinny::has_avx512() {
        // SAFETY: the CPU supports AVX-512F (just detected).
        return unsafe { crate::math512::gelu_in_place(values) };
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2 (just detected).
        return unsafe { gelu_in_place_avx2(values) };
    }
    gelu_in_place_portable(values)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn gelu_in_place_avx2(values: &mut [f32]) {
    gelu_in_place_portable(values)
}

#[inline(always)]
fn gelu_in_place_portable(values: &mut [f32]) {
    for v in values {
        *v = (erf(*v * std::f32::consts::FRAC_1_SQRT_2) + 1.0) * 0.5 * *v;
    }
}

/// `erf(x)` by Abramowitz & Stegun 7.1.26 (absolute error < 1.5e-7 in exact arithmetic, < 1e-6 in f32 (tested); the formula PyTorch's vectorised
/// CPU `erf` uses): `1 − (a₁t + a₂t² + … + a₅t⁵)·e^(−x²)` with `t = 1 / (1 + p|x|)`, sign restored.
#[inline(always)]
pub fn erf(x: f32) -> f32 {
    const P: f32 = 0.327_591_1;
    const A: [f32; 5] = [0.254_829_6, -0.284_496_74, 1.421_413_8, -1.453_152_1, 1.061_405_4];
    let magnitude = x.abs();
    let t = 1.0 / (1.0 + P * magnitude);
    let poly = t * (A[0] + t * (A[1] + t * (A[2] + t * (A[3] + t * A[4]))));
    let value = 1.0 - poly * exp_non_positive(-magnitude * magnitude);
    value.copysign(x)
}

/// `eˣ` for `x ≤ 0` (below −87 it returns about 1.6e-38 instead of smaller values or 0, which no softmax
/// notices): `2ⁿ · p(r)` with `n = round(x / ln 2)`, `r = x − n·ln 2` in two parts (Cody–Waite) and `p` the
/// degree-7 Taylor polynomial (truncation error < 1e-8 on |r| ≤ ln 2 / 2).
#[inline(always)]
pub fn exp_non_positive(x: f32) -> f32 {
    /// Adding then subtracting 1.5·2²³ rounds an f32 of magnitude < 2²² to the nearest integer.
    const ROUND: f32 = 12_582_912.0;
    const LN2_HI: f32 = 0.693_145_75;
    const LN2_LO: f32 = 1.428_606_8e-6;
    let x = if x < -87.0 { -87.0 } else { x };
    let n = (x * std::f32::consts::LOG2_E + ROUND) - ROUND;
    let r = (x - n * LN2_HI) - n * LN2_LO;
    let mut p = 1.0 / 5040.0;
    p = p * r + 1.0 / 720.0;
    p = p * r + 1.0 / 120.0;
    p = p * r + 1.0 / 24.0;
    p = p * r + 1.0 / 6.0;
    p = p * r + 0.5;
    p = p * r + 1.0;
    p = p * r + 1.0;
    let two_to_n = f32::from_bits(((n as i32 + 127) as u32) << 23);
    p * two_to_n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_is_within_three_ulp_of_f64_over_the_softmax_range() {
        let mut worst = 0f64;
        for i in 0..=870_000 {
            let x = -(i as f32) * 1e-4;
            let ours = f64::from(exp_non_positive(x));
            let exact = f64::from(x).exp();
            worst = worst.max((ours - exact).abs() / exact);
        }
        assert!(worst < 3e-7, "worst relative error {worst}");
        assert_eq!(exp_non_positive(0.0), 1.0);
    }

    #[test]
    fn erf_is_within_1e_6_of_f64() {
        let mut worst = 0f64;
        for i in -600_000..=600_000 {
            let x = i as f32 * 1e-5;
            worst = worst.max((f64::from(erf(x)) - erf_f64(f64::from(x))).abs());
        }
        assert!(worst < 1e-6, "worst absolute error {worst}");
        assert_eq!(erf(-0.37), -erf(0.37));
        assert_eq!(erf(10.0), 1.0);
        assert_eq!(erf(-10.0), -1.0);
    }

    /// `erf` in f64 by its Taylor series (|x| ≤ 3) or continued fraction, accurate to ~1e-15 here.
    fn erf_f64(x: f64) -> f64 {
        if x.abs() > 3.0 {
            // erfc(x) = e^(−x²)/(x√π) · 1/(1 + 1/(2x²)/(1 + 2/(2x²)/(1 + …))) — Lentz-free backward evaluation
            let a = x.abs();
            let mut fraction = 0.0;
            for k in (1..60).rev() {
                fraction = (k as f64 / 2.0) / (a + fraction);
            }
            let erfc = (-a * a).exp() / std::f64::consts::PI.sqrt() / (a + fraction);
            return (1.0 - erfc).copysign(x);
        }
        let (mut term, mut sum) = (x, x);
        for n in 1..200 {
            term *= -x * x / n as f64;
            sum += term / (2 * n + 1) as f64;
        }
        sum * 2.0 / std::f64::consts::PI.sqrt()
    }

    #[test]
    fn softmax_pieces_match_plain_loops() {
        let values: Vec<f32> = (0..1003).map(|i| ((i * 37 % 101) as f32 - 50.0) * 0.13).collect();
        let max = max_of(&values);
        assert_eq!(max, values.iter().cloned().fold(f32::NEG_INFINITY, f32::max));
        let mut exps = values.clone();
        let sum = exp_shifted_in_place(&mut exps, max);
        let expected: Vec<f64> = values.iter().map(|&v| f64::from(v - max).exp()).collect();
        for (a, b) in exps.iter().zip(&expected) {
            assert!((f64::from(*a) - b).abs() <= 3e-7 * b);
        }
        assert!((f64::from(sum) - expected.iter().sum::<f64>()).abs() < 1e-5 * f64::from(sum));
        let b: Vec<f32> = (0..1003).map(|i| (i % 7) as f32 - 3.0).collect();
        let plain: f64 = values.iter().zip(&b).map(|(x, y)| f64::from(*x) * f64::from(*y)).sum();
        assert!((f64::from(dot(&values, &b)) - plain).abs() < 1e-3);
        assert_eq!(max_of(&[]), f32::NEG_INFINITY);
    }
}
