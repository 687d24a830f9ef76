//! Products with few rows, `out = x · W` for `x` `[rows, k]` (rows ≤ [`MAX_ROWS`]) and `W` `[k, n]`
//! row-major: the shape of SAM's decoder layers on its 7 tokens. A general matrix product packs `W`
//! into blocks on every call, which costs as much as the arithmetic when `x` has a handful of rows (a
//! `perf` profile of the decoder: a quarter of its time in the token MLPs, mostly packing). Here `W` is
//! packed once (at load) into 32-column panels ([`ColumnPanels`]) and read once per product, one panel
//! at a time, into AVX-512 accumulators for up to 8 rows (runtime detection; `None` without AVX-512,
//! and the caller falls back to `gemm`).
//! Each output is the sequential sum over `k` of fused multiply-adds: the same products as any other
//! order, reassociated and rounded once per step.

use std::sync::atomic::{AtomicBool, Ordering};

/// Largest row count this kernel takes.
pub const MAX_ROWS: usize = 16;

/// Rows per register tile (8 rows × 2 vectors of 16 columns = 16 accumulators).
const TILE_ROWS: usize = 8;

/// Columns per panel: two 16-lane vectors.
pub const PANEL: usize = 32;

/// A `[k, n]` matrix stored as column panels: panel `p` holds columns `32p .. 32p + 32` of all `k`
/// rows, each row's 32 values contiguous (zeros past `n`), so a tile of the product reads one
/// contiguous stretch of memory (row-major `[k, n]` read 32 columns at a time strides by `4n` bytes
/// per row, a page per row for wide matrices).
#[derive(Debug, Clone)]
pub struct ColumnPanels {
    /// `[⌈n/32⌉, k, 32]`.
    data: Vec<f32>,
    /// Rows.
    pub k: usize,
    /// Columns.
    pub n: usize,
}

impl ColumnPanels {
    /// From `w` `[k, n]` row-major.
    pub fn from_rows(w: &[f32], k: usize, n: usize) -> Self {
        assert_eq!(w.len(), k * n, "w is not [{k}, {n}]");
        let panels = n.div_ceil(PANEL);
        let mut data = vec![0f32; panels * k * PANEL];
        for kk in 0..k {
            for c in 0..n {
                data[((c / PANEL) * k + kk) * PANEL + c % PANEL] = w[kk * n + c];
            }
        }
        Self { data, k, n }
    }

    /// From `w` `[n, k]` row-major, i.e. the panels of `wᵀ` (a linear layer's `[out, in]` weight).
    pub fn from_transposed(w: &[f32], n: usize, k: usize) -> Self {
        assert_eq!(w.len(), k * n, "w is not [{n}, {k}]");
        let panels = n.div_ceil(PANEL);
        let mut data = vec![0f32; panels * k * PANEL];
        for (c, row) in w.chunks_exact(k).enumerate() {
            for (kk, &v) in row.iter().enumerate() {
                data[((c / PANEL) * k + kk) * PANEL + c % PANEL] = v;
            }
        }
        Self { data, k, n }
    }

    /// Element (kk, c).
    pub fn get(&self, kk: usize, c: usize) -> f32 {
        self.data[((c / PANEL) * self.k + kk) * PANEL + c % PANEL]
    }
}

/// `out[r, c] (+)= Σ_(j < k) x[x_offset + r·x_rs + j] · w[k0 + j, c]` for `r < rows`, `c < w.n`,
/// writing `out[r·n + c]` (`accumulate`: adding to it). `x` `[rows, k]` with row stride `x_rs` (unit
/// column stride), `w` rows `k0 .. k0 + k` of a panel-stored matrix, `out` `[rows, n]` row-major.
/// Returns `None` (touching nothing) when the CPU lacks AVX-512 or `rows > MAX_ROWS`. Panics if a
/// matrix reaches outside its storage (a caller's bug, never data).
pub fn skinny_product(
    rows: usize,
    out: &mut [f32],
    (x, x_offset, x_rs): (&[f32], usize, usize),
    w: &ColumnPanels,
    (k0, k): (usize, usize),
    accumulate: bool,
) -> Option<()> {
    let n = w.n;
    if rows > MAX_ROWS || !has_avx512() {
        return None;
    }
    if rows == 0 || n == 0 {
        return Some(());
    }
    assert!(out.len() >= rows * n, "out: [{rows}, {n}] in {}", out.len());
    assert!(k0 + k <= w.k, "w: rows {k0}..{} of {}", k0 + k, w.k);
    if k == 0 {
        if !accumulate {
            out[..rows * n].fill(0.0);
        }
        return Some(());
    }
    let x_last = x_offset + (rows - 1) * x_rs + k - 1;
    assert!(x_last < x.len(), "x: [{rows}, {k}] ends at {x_last}, storage {}", x.len());
    #[cfg(target_arch = "x86_64")]
    // SAFETY: AVX-512F is present (checked above); the asserts keep every read of `x` inside its
    // slice, the panels hold ⌈n/32⌉·w.k·32 values and rows k0 .. k0 + k ≤ w.k are read, and every
    // write of `out` stays within rows × n (masked past n).
    unsafe {
        let x_ptr = x.as_ptr().add(x_offset);
        let w_ptr = w.data.as_ptr().add(k0 * PANEL);
        let panel_stride = w.k * PANEL;
        let mut r0 = 0;
        while r0 < rows {
            let tile = (rows - r0).min(TILE_ROWS);
            let (xp, op) = (x_ptr.add(r0 * x_rs), out.as_mut_ptr().add(r0 * n));
            let args = (n, k, xp, x_rs, w_ptr, panel_stride, op, accumulate);
            match tile {
                8 => avx512::rows_tile::<8>(args),
                7 => avx512::rows_tile::<7>(args),
                6 => avx512::rows_tile::<6>(args),
                5 => avx512::rows_tile::<5>(args),
                4 => avx512::rows_tile::<4>(args),
                3 => avx512::rows_tile::<3>(args),
                2 => avx512::rows_tile::<2>(args),
                _ => avx512::rows_tile::<1>(args),
            }
            r0 += tile;
        }
        Some(())
    }
    #[cfg(not(target_arch = "x86_64"))]
    None
}

/// Set by [`disable_avx512_kernels`].
static PORTABLE_ONLY: AtomicBool = AtomicBool::new(false);

/// Whether the AVX-512 kernel can run here.
pub fn has_avx512() -> bool {
    if PORTABLE_ONLY.load(Ordering::Relaxed) {
        return false;
    }
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// From now on, in this process, [`has_avx512`] is false and every caller takes its `gemm` path: lets
/// a test on an AVX-512 machine check the paths other CPUs take (in its own test binary: it is global).
#[doc(hidden)]
pub fn disable_avx512_kernels() {
    PORTABLE_ONLY.store(true, Ordering::Relaxed);
}

#[cfg(target_arch = "x86_64")]
mod avx512 {
    use std::arch::x86_64::*;

    /// `(n, k, x, x_rs, w, panel_stride, out, accumulate)`.
    pub(super) type TileArgs = (usize, usize, *const f32, usize, *const f32, usize, *mut f32, bool);

    /// Lanes `< remaining` set (all 16 when `remaining ≥ 16`).
    #[inline(always)]
    fn lane_mask(remaining: usize) -> __mmask16 {
        if remaining >= 16 {
            0xFFFF
        } else {
            ((1u32 << remaining) - 1) as __mmask16
        }
    }

    /// `R` rows of the product over all `n` columns, one 32-column panel at a time (the last one's
    /// output masked).
    ///
    /// # Safety
    /// AVX-512F present; `x` valid for `R` rows of `k` (row stride `x_rs`), `w` for `⌈n/32⌉` panels
    /// `panel_stride` apart of `k` rows of 32, `out` for `[R, n]` row-major.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn rows_tile<const R: usize>(
        (n, k, x, x_rs, w, panel_stride, out, accumulate): TileArgs,
    ) {
        let mut c0 = 0;
        let mut panel = w;
        while c0 < n {
            let (m0, m1) = (lane_mask(n - c0), lane_mask((n - c0).saturating_sub(16)));
            if m1 == 0 {
                half_panel::<R>(k, x, x_rs, panel, out.add(c0), n, m0, accumulate);
                break;
            }
            let mut acc0 = [_mm512_setzero_ps(); R];
            let mut acc1 = [_mm512_setzero_ps(); R];
            if accumulate {
                for r in 0..R {
                    acc0[r] = _mm512_maskz_loadu_ps(m0, out.add(r * n + c0));
                    acc1[r] = _mm512_maskz_loadu_ps(m1, out.add(r * n + c0 + 16));
                }
            }
            for kk in 0..k {
                let row = panel.add(kk * super::PANEL);
                let w0 = _mm512_loadu_ps(row);
                let w1 = _mm512_loadu_ps(row.add(16));
                for r in 0..R {
                    let xv = _mm512_set1_ps(*x.add(r * x_rs + kk));
                    acc0[r] = _mm512_fmadd_ps(xv, w0, acc0[r]);
                    acc1[r] = _mm512_fmadd_ps(xv, w1, acc1[r]);
                }
            }
            for r in 0..R {
                _mm512_mask_storeu_ps(out.add(r * n + c0), m0, acc0[r]);
                _mm512_mask_storeu_ps(out.add(r * n + c0 + 16), m1, acc1[r]);
            }
            c0 += super::PANEL;
            panel = panel.add(panel_stride);
        }
    }

    /// The last panel when at most 16 of its columns are used: one vector per row.
    ///
    /// # Safety
    /// As [`rows_tile`], with `panel` the last panel and `out` at its first column.
    #[allow(clippy::too_many_arguments)]
    #[allow(clippy::needless_range_loop)] // `r` also offsets the row pointers
    #[target_feature(enable = "avx512f")]
    unsafe fn half_panel<const R: usize>(
        k: usize,
        x: *const f32,
        x_rs: usize,
        panel: *const f32,
        out: *mut f32,
        n: usize,
        mask: __mmask16,
        accumulate: bool,
    ) {
        let mut acc = [_mm512_setzero_ps(); R];
        if accumulate {
            for r in 0..R {
                acc[r] = _mm512_maskz_loadu_ps(mask, out.add(r * n));
            }
        }
        for kk in 0..k {
            let w0 = _mm512_loadu_ps(panel.add(kk * super::PANEL));
            for r in 0..R {
                acc[r] = _mm512_fmadd_ps(_mm512_set1_ps(*x.add(r * x_rs + kk)), w0, acc[r]);
            }
        }
        for r in 0..R {
            _mm512_mask_storeu_ps(out.add(r * n), mask, acc[r]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic values in (−1, 1).
    fn values(len: usize, seed: u64) -> Vec<f32> {
        let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        (0..len)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 40) as f32 / (1u64 << 23) as f32 - 1.0
            })
            .collect()
    }

    #[test]
    fn matches_the_definition_with_tails_strides_and_accumulation() {
        if !has_avx512() {
            eprintln!("skipping: this CPU has no AVX-512 (the callers use gemm instead)");
            let w = ColumnPanels::from_rows(&[1.0], 1, 1);
            assert!(skinny_product(1, &mut [0.0], (&[1.0], 0, 1), &w, (0, 1), false).is_none());
            return;
        }
        let mut checked = 0;
        for &rows in &[1usize, 2, 3, 7, 8, 9, 16] {
            for &n in &[1usize, 4, 15, 16, 17, 32, 33, 100, 256] {
                for &k in &[1usize, 7, 16, 56] {
                    for accumulate in [false, true] {
                        let (x_rs, x_offset, k0) = (k + 3, 5, 2);
                        let x = values(x_offset + rows * x_rs, (rows * 1000 + n * 10 + k) as u64);
                        let w_rows = values((k0 + k + 1) * n, (n * 1000 + k) as u64 + 7);
                        let w = ColumnPanels::from_rows(&w_rows, k0 + k + 1, n);
                        let w_t: Vec<f32> = (0..n)
                            .flat_map(|c| (0..k0 + k + 1).map(move |kk| (kk, c)))
                            .map(|(kk, c)| w_rows[kk * n + c])
                            .collect();
                        let w2 = ColumnPanels::from_transposed(&w_t, n, k0 + k + 1);
                        assert_eq!(w.data, w2.data);
                        assert_eq!(w.get(k0, n - 1), w_rows[k0 * n + n - 1]);
                        let start = values(rows * n + 3, 99);
                        let mut out = start.clone();
                        skinny_product(rows, &mut out, (&x, x_offset, x_rs), &w, (k0, k), accumulate)
                            .expect("AVX-512 present");
                        for r in 0..rows {
                            for c in 0..n {
                                let mut want: f64 =
                                    if accumulate { f64::from(start[r * n + c]) } else { 0.0 };
                                for kk in 0..k {
                                    want += f64::from(x[x_offset + r * x_rs + kk])
                                        * f64::from(w_rows[(k0 + kk) * n + c]);
                                }
                                let got = f64::from(out[r * n + c]);
                                assert!(
                                    (got - want).abs() < 1e-5,
                                    "rows {rows} n {n} k {k} acc {accumulate}: ({r}, {c}) {got} vs {want}"
                                );
                            }
                        }
                        // nothing past the output written
                        assert_eq!(out[rows * n..], start[rows * n..]);
                        checked += 1;
                    }
                }
            }
        }
        assert_eq!(checked, 7 * 9 * 4 * 2);
        let w = ColumnPanels::from_rows(&[1.0], 1, 1);
        assert!(skinny_product(MAX_ROWS + 1, &mut [0.0; 17], (&[0.0; 17], 0, 1), &w, (0, 1), false).is_none());
    }
}
