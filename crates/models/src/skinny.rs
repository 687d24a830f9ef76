//! Products with few rows, `out = x · W` for `x` `[rows, k]` (rows ≤ [`MAX_ROWS`]) and `W` `[k, n]`
//! row-major: the shape of SAM's decoder layers on its 7 tokens. A general matrix product packs `W`
//! into blocks on every call, which costs as much as the arithmetic when `x` has a handful of rows (a
//! `perf` profile of the decoder: a quarter of its time in the token MLPs, mostly packing). Here `W` is
//! packed once (at load) into 32-column panels ([`ColumnPanels`]) and read once per product, one panel
//! at a time, into AVX-512 accumulators for tiles of up to 8 rows, every tile of rows before the next
//! panel (runtime detection; `None` without AVX-512, and the caller falls back to `gemm`).
//! [`skinny_rows`] takes its rows from anywhere (a batch of prompts' rows in their own buffers).
//! Each output is the sequential sum over `k` of fused multiply-adds: the same products as any other
//! order, reassociated and rounded once per step.

/// Largest row count this kernel takes.
pub const MAX_ROWS: usize = 64;

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
    if rows > MAX_ROWS || !has_avx512() {
        return None;
    }
    if rows == 0 || w.n == 0 {
        return Some(());
    }
    assert!(out.len() >= rows * w.n, "out: [{rows}, {}] in {}", w.n, out.len());
    let x_last = x_offset + (rows - 1) * x_rs + k;
    assert!(x_last <= x.len(), "x: [{rows}, {k}] ends at {x_last}, storage {}", x.len());
    let x_rows: Vec<&[f32]> = (0..rows).map(|r| &x[x_offset + r * x_rs..x_offset + r * x_rs + k]).collect();
    let mut out_rows: Vec<&mut [f32]> = out[..rows * w.n].chunks_exact_mut(w.n).collect();
    skinny_rows(&x_rows, w, (k0, k), &mut out_rows, accumulate)
}

/// [`skinny_product`] on rows that need not be evenly spaced: `out_rows[r][c] (+)= Σ_(j < k)
/// x_rows[r][j] · w[k0 + j, c]`, each `x_rows[r]` at least `k` long and each `out_rows[r]` at least
/// `w.n`. Any number of rows: the weights are read one 32-column panel at a time, and each panel (in
/// L1 or L2 by then) serves every tile of 8 rows before the next is read, so a batch of prompts'
/// tokens reads a weight matrix once. `None` (touching nothing) without AVX-512.
pub fn skinny_rows(
    x_rows: &[&[f32]],
    w: &ColumnPanels,
    (k0, k): (usize, usize),
    out_rows: &mut [&mut [f32]],
    accumulate: bool,
) -> Option<()> {
    if !has_avx512() {
        return None;
    }
    let (rows, n) = (x_rows.len(), w.n);
    assert_eq!(out_rows.len(), rows, "{rows} input rows, {} output rows", out_rows.len());
    assert!(k0 + k <= w.k, "w: rows {k0}..{} of {}", k0 + k, w.k);
    assert!(x_rows.iter().all(|r| r.len() >= k), "an input row is shorter than {k}");
    assert!(out_rows.iter().all(|r| r.len() >= n), "an output row is shorter than {n}");
    if rows == 0 || n == 0 {
        return Some(());
    }
    if k == 0 {
        if !accumulate {
            out_rows.iter_mut().for_each(|r| r[..n].fill(0.0));
        }
        return Some(());
    }
    #[cfg(target_arch = "x86_64")]
    // SAFETY: AVX-512F is present (checked above); every input row holds ≥ k values and every output
    // row ≥ n (asserted), the panels hold ⌈n/32⌉·w.k·32 values of which rows k0 .. k0 + k ≤ w.k are
    // read, and the stores past n are masked.
    unsafe {
        let panel_stride = w.k * PANEL;
        for c0 in (0..n).step_by(PANEL) {
            let panel = w.data.as_ptr().add((c0 / PANEL) * panel_stride + k0 * PANEL);
            for r0 in (0..rows).step_by(TILE_ROWS) {
                let tile = (rows - r0).min(TILE_ROWS);
                let mut xs = [std::ptr::null::<f32>(); TILE_ROWS];
                let mut outs = [std::ptr::null_mut::<f32>(); TILE_ROWS];
                for r in 0..tile {
                    xs[r] = x_rows[r0 + r].as_ptr();
                    outs[r] = out_rows[r0 + r].as_mut_ptr().add(c0);
                }
                let args = (n - c0, k, xs, panel, outs, accumulate);
                match tile {
                    8 => avx512::panel_tile::<8>(args),
                    7 => avx512::panel_tile::<7>(args),
                    6 => avx512::panel_tile::<6>(args),
                    5 => avx512::panel_tile::<5>(args),
                    4 => avx512::panel_tile::<4>(args),
                    3 => avx512::panel_tile::<3>(args),
                    2 => avx512::panel_tile::<2>(args),
                    _ => avx512::panel_tile::<1>(args),
                }
            }
        }
        Some(())
    }
    #[cfg(not(target_arch = "x86_64"))]
    None
}

/// The environment variable that turns the AVX-512 kernels off: set (to anything but `0`), every
/// product takes its `gemm` path, as on CPUs without AVX-512. Like NumPy's `NPY_DISABLE_CPU_FEATURES`
/// or oneDNN's `ONEDNN_MAX_CPU_ISA`: to reproduce what other CPUs compute, and for the tests of those
/// paths on an AVX-512 machine. Read from the environment on every check (no state is kept).
pub const DISABLE_AVX512_ENV: &str = "SPLATSEG_DISABLE_AVX512";

/// Whether the AVX-512 kernel can run here (the CPU has AVX-512F and [`DISABLE_AVX512_ENV`] is not
/// set).
pub fn has_avx512() -> bool {
    if std::env::var_os(DISABLE_AVX512_ENV).is_some_and(|v| v != "0") {
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

#[cfg(target_arch = "x86_64")]
mod avx512 {
    use crate::math512::lane_mask;
    use std::arch::x86_64::*;

    /// `(columns left from this panel on, k, row pointers of x, the panel at row k0, output row
    /// pointers at the panel's first column, accumulate)`; only the first `R` pointers are used.
    pub(super) type TileArgs = (usize, usize, [*const f32; 8], *const f32, [*mut f32; 8], bool);

    /// `R` rows times one 32-column panel (the output masked past the matrix's last column; one
    /// vector per row when at most 16 columns are left).
    ///
    /// # Safety
    /// AVX-512F present; `x[r]` valid for `k` reads, the panel for `k` rows of 32, `out[r]` for
    /// `min(left, 32)` values, for `r < R`.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn panel_tile<const R: usize>((left, k, x, panel, out, accumulate): TileArgs) {
        let (m0, m1) = (lane_mask(left), lane_mask(left.saturating_sub(16)));
        if m1 == 0 {
            return half_panel::<R>(k, x, panel, out, m0, accumulate);
        }
        let mut acc0 = [_mm512_setzero_ps(); R];
        let mut acc1 = [_mm512_setzero_ps(); R];
        if accumulate {
            for r in 0..R {
                acc0[r] = _mm512_maskz_loadu_ps(m0, out[r]);
                acc1[r] = _mm512_maskz_loadu_ps(m1, out[r].add(16));
            }
        }
        for kk in 0..k {
            let row = panel.add(kk * super::PANEL);
            let w0 = _mm512_loadu_ps(row);
            let w1 = _mm512_loadu_ps(row.add(16));
            for r in 0..R {
                let xv = _mm512_set1_ps(*x[r].add(kk));
                acc0[r] = _mm512_fmadd_ps(xv, w0, acc0[r]);
                acc1[r] = _mm512_fmadd_ps(xv, w1, acc1[r]);
            }
        }
        for r in 0..R {
            _mm512_mask_storeu_ps(out[r], m0, acc0[r]);
            _mm512_mask_storeu_ps(out[r].add(16), m1, acc1[r]);
        }
    }

    /// The last panel when at most 16 of its columns are used: one vector per row.
    ///
    /// # Safety
    /// As [`panel_tile`].
    #[allow(clippy::needless_range_loop)] // `r` indexes the pointers and the accumulators
    #[target_feature(enable = "avx512f")]
    unsafe fn half_panel<const R: usize>(
        k: usize,
        x: [*const f32; 8],
        panel: *const f32,
        out: [*mut f32; 8],
        mask: __mmask16,
        accumulate: bool,
    ) {
        let mut acc = [_mm512_setzero_ps(); R];
        if accumulate {
            for r in 0..R {
                acc[r] = _mm512_maskz_loadu_ps(mask, out[r]);
            }
        }
        for kk in 0..k {
            let w0 = _mm512_loadu_ps(panel.add(kk * super::PANEL));
            for r in 0..R {
                acc[r] = _mm512_fmadd_ps(_mm512_set1_ps(*x[r].add(kk)), w0, acc[r]);
            }
        }
        for r in 0..R {
            _mm512_mask_storeu_ps(out[r], mask, acc[r]);
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
        for &rows in &[1usize, 2, 3, 7, 8, 9, 16, 30] {
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
        assert_eq!(checked, 8 * 9 * 4 * 2);
        let w = ColumnPanels::from_rows(&[1.0], 1, 1);
        assert!(skinny_product(MAX_ROWS + 1, &mut [0.0; 17], (&[0.0; 17], 0, 1), &w, (0, 1), false).is_none());
    }

    #[test]
    fn scattered_rows_give_the_rows_of_the_product() {
        if !has_avx512() {
            eprintln!("skipping: this CPU has no AVX-512 (the callers use gemm instead)");
            return;
        }
        let (k, n) = (19usize, 45usize);
        let w_rows = values(k * n, 5);
        let w = ColumnPanels::from_rows(&w_rows, k, n);
        // 11 rows from two buffers, outputs into two buffers in another order
        let (a, b) = (values(6 * k, 6), values(5 * k + 3, 7));
        let x_rows: Vec<&[f32]> =
            (0..11).map(|r| if r % 2 == 0 { &a[(r / 2) * k..] } else { &b[3 + (r / 2) * k..] }).collect();
        let (mut oa, mut ob) = (vec![0f32; 6 * n], vec![0f32; 5 * n]);
        let mut out_rows: Vec<&mut [f32]> = oa.chunks_exact_mut(n).chain(ob.chunks_exact_mut(n)).collect();
        // output row r of the product goes to out_rows[r]: rows 0..6 into oa, 6..11 into ob
        skinny_rows(&x_rows, &w, (0, k), &mut out_rows, false).expect("AVX-512 present");
        for (r, x) in x_rows.iter().enumerate() {
            let got = if r < 6 { &oa[r * n..(r + 1) * n] } else { &ob[(r - 6) * n..(r - 5) * n] };
            for c in 0..n {
                let want: f64 = (0..k).map(|j| f64::from(x[j]) * f64::from(w_rows[j * n + c])).sum();
                assert!((f64::from(got[c]) - want).abs() < 1e-5, "row {r}, column {c}");
            }
        }
    }
}
