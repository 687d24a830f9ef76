//! Per-image keys and values that every prompt's few tokens attend to, kept both as rows `[N, H·d]`
//! and, where the CPU has AVX-512, packed once per image into column panels for
//! [`crate::skinny::skinny_product`] (a general product would repack the 4,096-row operand on every
//! one of the 1,024 prompts × 8 heads).

use crate::dense::{matmul, View, ViewMut};
use crate::skinny::{has_avx512, skinny_product, skinny_rows, ColumnPanels};

/// Image keys `[N, H·d]`: the tokens' queries are scored against each head's slice.
#[derive(Debug, Clone)]
pub(super) struct ImageKeys {
    /// `[N, H·d]` row-major.
    rows: Vec<f32>,
    /// `rowsᵀ` `[H·d, N]` in panels (AVX-512 only).
    panels: Option<ColumnPanels>,
    /// `H·d`.
    width: usize,
}

impl ImageKeys {
    /// From `rows` `[N, width]`.
    pub(super) fn new(rows: Vec<f32>, width: usize) -> Self {
        let n = rows.len() / width;
        let panels = has_avx512().then(|| ColumnPanels::from_transposed(&rows, n, width));
        Self { rows, panels, width }
    }

    /// `out` `[t, N]` = `x_h · keys_hᵀ` for head `h` (columns `h·d .. h·d + d`) of `x` `[t, H·d]`.
    pub(super) fn head_scores(&self, out: &mut [f32], x: &[f32], t: usize, (h, d): (usize, usize)) {
        let ci = self.width;
        if let Some(panels) = &self.panels {
            if skinny_product(t, out, (x, h * d, ci), panels, (h * d, d), false).is_some() {
                return;
            }
        }
        let n = self.rows.len() / ci;
        let head = View { data: x, offset: h * d, rs: ci, cs: 1 };
        matmul(t, n, d, ViewMut::rows(out, 0, n), head, View::transposed(&self.rows, h * d, ci), false, 1.0);
    }
}

impl ImageKeys {
    /// [`ImageKeys::head_scores`] for a batch of prompts: `out[p]` `[t, N]` = rows `p·t .. p·t + t` of
    /// `x` `[B·t, H·d]` (head `h`) times the keys' head `h`, each panel read once for the whole batch.
    pub(super) fn head_scores_batch(
        &self,
        out: &mut [&mut [f32]],
        x: &[f32],
        t: usize,
        (h, d): (usize, usize),
    ) {
        let ci = self.width;
        let n = self.rows.len() / ci;
        if let Some(panels) = &self.panels {
            let x_rows: Vec<&[f32]> = x.chunks_exact(ci).map(|row| &row[h * d..(h + 1) * d]).collect();
            let mut out_rows: Vec<&mut [f32]> = out.iter_mut().flat_map(|o| o.chunks_exact_mut(n)).collect();
            if x_rows.len() == out_rows.len()
                && skinny_rows(&x_rows, panels, (h * d, d), &mut out_rows, false).is_some()
            {
                return;
            }
        }
        for (p, block) in out.iter_mut().enumerate() {
            self.head_scores(block, &x[p * t * ci..(p + 1) * t * ci], t, (h, d));
        }
    }
}

/// Image values `[N, H·d]`: each head's attention weights mix that head's slice.
#[derive(Debug, Clone)]
pub(super) struct ImageValues {
    /// `[N, H·d]` row-major.
    rows: Vec<f32>,
    /// Per head, its slice `[N, d]` in panels (AVX-512 only).
    panels: Option<Vec<ColumnPanels>>,
    /// `H·d`.
    width: usize,
}

impl ImageValues {
    /// From `rows` `[N, width]` split into `heads` heads.
    pub(super) fn new(rows: Vec<f32>, width: usize, heads: usize) -> Self {
        let (n, d) = (rows.len() / width, width / heads);
        let panels = has_avx512().then(|| {
            (0..heads)
                .map(|h| {
                    let slice: Vec<f32> =
                        rows.chunks_exact(width).flat_map(|r| &r[h * d..(h + 1) * d]).copied().collect();
                    ColumnPanels::from_rows(&slice, n, d)
                })
                .collect()
        });
        Self { rows, panels, width }
    }

    /// Head `h`'s output `heads[s, h·d .. h·d + d]` (`heads` `[t, H·d]`) = `a[s] · values_h` for
    /// `a` the `t` rows of `N` weights starting at `a_offset` of `a`.
    pub(super) fn head_mix(
        &self,
        heads: &mut [f32],
        (a, a_offset): (&[f32], usize),
        t: usize,
        (h, d): (usize, usize),
    ) {
        let ci = self.width;
        let n = self.rows.len() / ci;
        if let Some(panels) = &self.panels {
            let mut out = vec![0f32; t * d];
            if skinny_product(t, &mut out, (a, a_offset, n), &panels[h], (0, n), false).is_some() {
                for (s, row) in out.chunks_exact(d).enumerate() {
                    heads[s * ci + h * d..s * ci + (h + 1) * d].copy_from_slice(row);
                }
                return;
            }
        }
        let out = ViewMut { data: heads, offset: h * d, rs: ci, cs: 1 };
        let values = View { data: &self.rows, offset: h * d, rs: ci, cs: 1 };
        matmul(t, d, n, out, View::rows(a, a_offset, n), values, false, 1.0);
    }

    /// [`ImageValues::head_mix`] for a batch of prompts: `heads` `[B·t, H·d]`, rows `p·t .. p·t + t`
    /// from the `t` rows of `N` weights `a[p]` `[t, N]`; each panel read once for the whole batch.
    pub(super) fn head_mix_batch(&self, heads: &mut [f32], a: &[&[f32]], t: usize, (h, d): (usize, usize)) {
        let ci = self.width;
        let n = self.rows.len() / ci;
        if let Some(panels) = &self.panels {
            let x_rows: Vec<&[f32]> = a.iter().flat_map(|block| block.chunks_exact(n)).collect();
            let mut out_rows: Vec<&mut [f32]> =
                heads.chunks_exact_mut(ci).map(|row| &mut row[h * d..(h + 1) * d]).collect();
            if x_rows.len() == out_rows.len()
                && skinny_rows(&x_rows, &panels[h], (0, n), &mut out_rows, false).is_some()
            {
                return;
            }
        }
        for (p, block) in a.iter().enumerate() {
            self.head_mix(&mut heads[p * t * ci..(p + 1) * t * ci], (block, 0), t, (h, d));
        }
    }
}
