//! A branch-free `exp` for the blending loops (like CUDA's `__expf` that gsplat uses): range
//! reduction `x = n·ln2 + r`, `|r| ≤ ln2/2`, and a degree-6 Taylor polynomial; relative error
//! below 4e-7 on [−87, 0]. Inputs below −87 give ≈1e-38 instead of a denormal or zero, which the
//! α ≥ 1/255 test rejects either way.

const LOG2_E: f32 = std::f32::consts::LOG2_E;
const LN2_HI: f32 = 0.693_145_75;
const LN2_LO: f32 = 1.428_606_8e-6;
const ROUND_MAGIC: f32 = 12_582_912.0;

/// `e^x` for `x ≤ 0` (larger inputs are valid up to 88).
#[inline(always)]
pub fn fast_exp(x: f32) -> f32 {
    let x = x.clamp(-87.0, 88.0);
    // Round to nearest by the 1.5·2²³ trick (`f32::round` is a libm call without SSE4.1).
    let n = (x * LOG2_E + ROUND_MAGIC) - ROUND_MAGIC;
    let r = x - n * LN2_HI - n * LN2_LO;
    let p = 1.0
        + r * (1.0 + r * (0.5 + r * (1.0 / 6.0 + r * (1.0 / 24.0 + r * (1.0 / 120.0 + r * (1.0 / 720.0))))));
    p * f32::from_bits(((n as i32 + 127) as u32) << 23)
}

/// [`fast_exp`] on 8 lanes with AVX2: the same operations in the same order (no fused
/// multiply-adds), so the same bits, NaN lanes included.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub unsafe fn fast_exp_avx2(x: std::arch::x86_64::__m256) -> std::arch::x86_64::__m256 {
    use std::arch::x86_64::*;
    let set = _mm256_set1_ps;
    // `f32::clamp` keeps NaN: replace only the lanes below / above the bounds.
    let low = _mm256_cmp_ps::<_CMP_LT_OQ>(x, set(-87.0));
    let x = _mm256_blendv_ps(x, set(-87.0), low);
    let high = _mm256_cmp_ps::<_CMP_GT_OQ>(x, set(88.0));
    let x = _mm256_blendv_ps(x, set(88.0), high);
    let magic = set(ROUND_MAGIC);
    let n = _mm256_sub_ps(_mm256_add_ps(_mm256_mul_ps(x, set(LOG2_E)), magic), magic);
    let r = _mm256_sub_ps(_mm256_sub_ps(x, _mm256_mul_ps(n, set(LN2_HI))), _mm256_mul_ps(n, set(LN2_LO)));
    let mut p = set(1.0 / 720.0);
    for c in [1.0 / 120.0, 1.0 / 24.0, 1.0 / 6.0, 0.5, 1.0, 1.0] {
        p = _mm256_add_ps(set(c), _mm256_mul_ps(r, p));
    }
    // `n` is a whole number in [−126, 127] (or NaN, where `p` is NaN and so is the product).
    let bits = _mm256_slli_epi32::<23>(_mm256_add_epi32(_mm256_cvttps_epi32(n), _mm256_set1_epi32(127)));
    _mm256_mul_ps(p, _mm256_castsi256_ps(bits))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The AVX2 lanes give the bits of the scalar `fast_exp`, over the whole input range, the
    /// clamps and NaN.
    #[test]
    fn avx2_lanes_equal_the_scalar_bits() {
        #[cfg(target_arch = "x86_64")]
        {
            if !std::arch::is_x86_feature_detected!("avx2") {
                eprintln!("no AVX2 on this CPU: nothing to compare");
                return;
            }
            let mut inputs: Vec<f32> = (0..200_000).map(|i| -100.0 + i as f32 * 0.000_95).collect();
            inputs.extend([
                f32::NAN,
                f32::INFINITY,
                f32::NEG_INFINITY,
                -0.0,
                0.0,
                -87.0,
                88.0,
                1e-30,
                -1e-30,
            ]);
            while !inputs.len().is_multiple_of(8) {
                inputs.push(0.5);
            }
            for chunk in inputs.chunks_exact(8) {
                let mut got = [0f32; 8];
                // SAFETY: AVX2 was detected above.
                unsafe {
                    use std::arch::x86_64::*;
                    _mm256_storeu_ps(got.as_mut_ptr(), fast_exp_avx2(_mm256_loadu_ps(chunk.as_ptr())));
                }
                for (&x, &g) in chunk.iter().zip(&got) {
                    assert_eq!(g.to_bits(), fast_exp(x).to_bits(), "exp({x}): {g} vs {}", fast_exp(x));
                }
            }
        }
    }

    #[test]
    fn matches_std_exp() {
        let mut x = -87.0f32;
        while x <= 0.0 {
            let (got, want) = (fast_exp(x), x.exp());
            assert!((got - want).abs() <= 4e-7 * want, "exp({x}): {got} vs {want}");
            x += 0.001_7;
        }
    }
}
