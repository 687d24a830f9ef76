//! Softmax and GELU pieces with AVX-512 intrinsics, 16 lanes: the exponential of
//! [`crate::kernels::exp_non_positive`] (same range reduction and polynomial, evaluated with fused
//! multiply-adds and `vscalefps`), the in-place `exp(v − shift)` with its sum, the two softmax shapes
//! of SAM's decoder fused into as few passes as they allow — along the columns of a few rows (one pass:
//! each 16-column strip's rows stay in registers) and along long runs (maximum, exponentials with
//! their sum, normalisation) — and the exact GELU of [`crate::kernels::gelu_in_place`] (its `erf`).
//!
//! Results agree with the portable code to a few ulp (the sums run in 16 lanes instead of 8, the
//! polynomial with fused multiply-adds); on one CPU they are the same whatever the thread count.
//! Callers check [`crate::skinny::has_avx512`] first.

#[cfg(target_arch = "x86_64")]
pub(crate) use imp::*;

#[cfg(target_arch = "x86_64")]
mod imp {
    use std::arch::x86_64::*;

    /// Lanes `< remaining` set (all 16 when `remaining ≥ 16`); the AVX-512 kernels' tail mask
    /// (also `skinny`'s).
    #[inline(always)]
    pub(crate) fn lane_mask(remaining: usize) -> __mmask16 {
        if remaining >= 16 {
            0xFFFF
        } else {
            ((1u32 << remaining) - 1) as __mmask16
        }
    }

    /// `eˣ` for `x ≤ 0` in each lane, as [`crate::kernels::exp_non_positive`]: `2ⁿ · p(r)`, `n =
    /// round(x / ln 2)`, `r = x − n·ln 2` (Cody–Waite), `p` the degree-7 Taylor polynomial.
    #[inline(always)]
    unsafe fn exp16(x: __m512) -> __m512 {
        const LN2_HI: f32 = 0.693_145_75;
        const LN2_LO: f32 = 1.428_606_8e-6;
        let x = _mm512_max_ps(x, _mm512_set1_ps(-87.0));
        let n = _mm512_roundscale_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(_mm512_mul_ps(
            x,
            _mm512_set1_ps(std::f32::consts::LOG2_E),
        ));
        let r = _mm512_fnmadd_ps(n, _mm512_set1_ps(LN2_HI), x);
        let r = _mm512_fnmadd_ps(n, _mm512_set1_ps(LN2_LO), r);
        let mut p = _mm512_set1_ps(1.0 / 5040.0);
        for c in [1.0 / 720.0, 1.0 / 120.0, 1.0 / 24.0, 1.0 / 6.0, 0.5, 1.0, 1.0] {
            p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(c));
        }
        _mm512_scalef_ps(p, n)
    }

    /// Replaces every `v` by `exp(v − shift)` (`v ≤ shift`) and returns their sum.
    ///
    /// # Safety
    /// AVX-512F present.
    #[target_feature(enable = "avx512f")]
    pub(crate) unsafe fn exp_shifted_in_place(values: &mut [f32], shift: f32) -> f32 {
        let shift_v = _mm512_set1_ps(shift);
        let mut total = _mm512_setzero_ps();
        let ptr = values.as_mut_ptr();
        let mut i = 0;
        while i < values.len() {
            let m = lane_mask(values.len() - i);
            let e = exp16(_mm512_sub_ps(_mm512_maskz_loadu_ps(m, ptr.add(i)), shift_v));
            _mm512_mask_storeu_ps(ptr.add(i), m, e);
            total = _mm512_mask_add_ps(total, m, total, e);
            i += 16;
        }
        _mm512_reduce_add_ps(total)
    }

    /// Softmax of one run in place after scaling by `scale` (> 0): the maximum of the raw values (the
    /// scaled maximum is the maximum scaled), the exponentials of `scale·v − max` with their sum, then
    /// the normalisation.
    ///
    /// # Safety
    /// AVX-512F present.
    #[target_feature(enable = "avx512f")]
    pub(crate) unsafe fn softmax_run(run: &mut [f32], scale: f32) {
        let len = run.len();
        if len == 0 {
            return;
        }
        let ptr = run.as_mut_ptr();
        let mut max = _mm512_set1_ps(f32::NEG_INFINITY);
        let mut i = 0;
        while i < len {
            let m = lane_mask(len - i);
            max = _mm512_mask_max_ps(max, m, max, _mm512_maskz_loadu_ps(m, ptr.add(i)));
            i += 16;
        }
        let scale_v = _mm512_set1_ps(scale);
        let shift = _mm512_set1_ps(_mm512_reduce_max_ps(max) * scale);
        let mut total = _mm512_setzero_ps();
        i = 0;
        while i < len {
            let m = lane_mask(len - i);
            let scaled = _mm512_mul_ps(_mm512_maskz_loadu_ps(m, ptr.add(i)), scale_v);
            let e = exp16(_mm512_sub_ps(scaled, shift));
            _mm512_mask_storeu_ps(ptr.add(i), m, e);
            total = _mm512_mask_add_ps(total, m, total, e);
            i += 16;
        }
        let inv = _mm512_set1_ps(1.0 / _mm512_reduce_add_ps(total));
        i = 0;
        while i < len {
            let m = lane_mask(len - i);
            let v = _mm512_mul_ps(_mm512_maskz_loadu_ps(m, ptr.add(i)), inv);
            _mm512_mask_storeu_ps(ptr.add(i), m, v);
            i += 16;
        }
    }

    /// `x · (1 + erf(x / √2)) / 2` in place, `erf` as [`crate::kernels::erf`] (Abramowitz & Stegun
    /// 7.1.26).
    ///
    /// # Safety
    /// AVX-512F present.
    #[target_feature(enable = "avx512f")]
    pub(crate) unsafe fn gelu_in_place(values: &mut [f32]) {
        const P: f32 = 0.327_591_1;
        const A: [f32; 5] = [0.254_829_6, -0.284_496_74, 1.421_413_8, -1.453_152_1, 1.061_405_4];
        let ptr = values.as_mut_ptr();
        let sign_bit = _mm512_set1_ps(-0.0);
        let one = _mm512_set1_ps(1.0);
        let mut i = 0;
        while i < values.len() {
            let m = lane_mask(values.len() - i);
            let v = _mm512_maskz_loadu_ps(m, ptr.add(i));
            let x = _mm512_mul_ps(v, _mm512_set1_ps(std::f32::consts::FRAC_1_SQRT_2));
            let magnitude = _mm512_andnot_ps(sign_bit, x);
            let t = _mm512_div_ps(one, _mm512_fmadd_ps(_mm512_set1_ps(P), magnitude, one));
            let mut poly = _mm512_set1_ps(A[4]);
            for a in [A[3], A[2], A[1], A[0]] {
                poly = _mm512_fmadd_ps(poly, t, _mm512_set1_ps(a));
            }
            poly = _mm512_mul_ps(poly, t);
            let e = exp16(_mm512_sub_ps(_mm512_setzero_ps(), _mm512_mul_ps(magnitude, magnitude)));
            let erf_magnitude = _mm512_fnmadd_ps(poly, e, one);
            let erf = _mm512_or_ps(erf_magnitude, _mm512_and_ps(sign_bit, x));
            let out = _mm512_mul_ps(_mm512_mul_ps(_mm512_add_ps(erf, one), _mm512_set1_ps(0.5)), v);
            _mm512_mask_storeu_ps(ptr.add(i), m, out);
            i += 16;
        }
    }

    /// Rows held in registers by [`softmax_columns`]; taller blocks take the portable path.
    pub(crate) const MAX_COLUMN_ROWS: usize = 16;

    /// Softmax down each column of one block `[rows, cols]` (rows ≤ [`MAX_COLUMN_ROWS`]) after scaling
    /// by `scale` (> 0), in one pass: 16 columns at a time, their `rows` values loaded once.
    ///
    /// # Safety
    /// AVX-512F present, `block.len() == rows·cols`, `rows ≤ MAX_COLUMN_ROWS`.
    #[target_feature(enable = "avx512f")]
    pub(crate) unsafe fn softmax_columns(block: &mut [f32], rows: usize, cols: usize, scale: f32) {
        debug_assert!(rows <= MAX_COLUMN_ROWS && block.len() == rows * cols);
        let ptr = block.as_mut_ptr();
        let scale_v = _mm512_set1_ps(scale);
        let mut strip = [_mm512_setzero_ps(); MAX_COLUMN_ROWS];
        let mut c = 0;
        while c < cols {
            let m = lane_mask(cols - c);
            let mut max = _mm512_set1_ps(f32::NEG_INFINITY);
            for (r, v) in strip.iter_mut().enumerate().take(rows) {
                *v = _mm512_mul_ps(_mm512_maskz_loadu_ps(m, ptr.add(r * cols + c)), scale_v);
                max = _mm512_max_ps(max, *v);
            }
            let mut total = _mm512_setzero_ps();
            for v in strip.iter_mut().take(rows) {
                *v = exp16(_mm512_sub_ps(*v, max));
                total = _mm512_add_ps(total, *v);
            }
            let inv = _mm512_div_ps(_mm512_set1_ps(1.0), total);
            for (r, v) in strip.iter().enumerate().take(rows) {
                _mm512_mask_storeu_ps(ptr.add(r * cols + c), m, _mm512_mul_ps(*v, inv));
            }
            c += 16;
        }
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use crate::kernels::exp_non_positive;
    use crate::skinny::has_avx512;

    #[test]
    fn exponentials_match_the_portable_ones_within_two_ulp() {
        if !has_avx512() {
            eprintln!("skipping: this CPU has no AVX-512 (the portable exponential runs instead)");
            return;
        }
        // every length up to two vectors and beyond, so the masked tails are covered
        let values: Vec<f32> = (0..=87_000).map(|i| -(i as f32) * 1e-3).collect();
        for len in [0usize, 1, 5, 15, 16, 17, 31, 33, values.len()] {
            let mut ours = values[..len].to_vec();
            // SAFETY: AVX-512F checked above.
            let total = unsafe { super::exp_shifted_in_place(&mut ours, -0.25) };
            let mut sum = 0f64;
            for (&x, &e) in values[..len].iter().zip(&ours) {
                let want = exp_non_positive(x + 0.25);
                sum += f64::from(want);
                assert!((e - want).abs() <= 2.0 * f32::EPSILON * want, "exp({x} + 0.25): {e} vs {want}");
            }
            assert!((f64::from(total) - sum).abs() <= 1e-5 * sum.max(1.0), "sum of {len}: {total} vs {sum}");
        }
    }

    #[test]
    fn gelu_matches_the_portable_one() {
        if !has_avx512() {
            eprintln!("skipping: this CPU has no AVX-512 (the portable GELU runs instead)");
            return;
        }
        let values: Vec<f32> = (-20_000..=20_000).map(|i| i as f32 * 6e-4).collect();
        for len in [0usize, 1, 15, 17, values.len()] {
            let mut ours = values[..len].to_vec();
            // SAFETY: AVX-512F checked above.
            unsafe { super::gelu_in_place(&mut ours) };
            for (&x, &g) in values[..len].iter().zip(&ours) {
                let want = (crate::kernels::erf(x * std::f32::consts::FRAC_1_SQRT_2) + 1.0) * 0.5 * x;
                assert!((g - want).abs() <= 1e-6 * want.abs().max(1.0), "gelu({x}): {g} vs {want}");
            }
        }
    }

    #[test]
    fn fused_softmaxes_match_plain_loops() {
        if !has_avx512() {
            eprintln!("skipping: this CPU has no AVX-512 (the portable softmaxes run instead)");
            return;
        }
        let x: Vec<f32> = (0..7 * 37).map(|i| ((i * 53 % 97) as f32 - 48.0) * 0.21).collect();
        let scale = 0.6;
        // along runs of 37, and down the columns of [7, 37]
        let mut runs = x.clone();
        for run in runs.chunks_exact_mut(37) {
            // SAFETY: AVX-512F checked above.
            unsafe { super::softmax_run(run, scale) };
        }
        let mut columns = x.clone();
        // SAFETY: AVX-512F checked above; the block is [7, 37].
        unsafe { super::softmax_columns(&mut columns, 7, 37, scale) };
        let plain = |values: &[f32]| -> Vec<f64> {
            let scaled: Vec<f64> = values.iter().map(|&v| f64::from(v) * f64::from(scale)).collect();
            let max = scaled.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let total: f64 = scaled.iter().map(|v| (v - max).exp()).sum();
            scaled.iter().map(|v| (v - max).exp() / total).collect()
        };
        for (r, run) in x.chunks_exact(37).enumerate() {
            for (c, want) in plain(run).into_iter().enumerate() {
                assert!((f64::from(runs[r * 37 + c]) - want).abs() < 1e-6, "run {r}, {c}");
            }
        }
        for c in 0..37 {
            let column: Vec<f32> = (0..7).map(|r| x[r * 37 + c]).collect();
            for (r, want) in plain(&column).into_iter().enumerate() {
                assert!((f64::from(columns[r * 37 + c]) - want).abs() < 1e-6, "column {c}, {r}");
            }
        }
    }
}
