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

#[cfg(test)]
mod tests {
    use super::*;

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
