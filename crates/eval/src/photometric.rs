//! Photometric image quality: PSNR and SSIM as 3DGS (and GaussianGrouping, which reuses its code)
//! compute them, plus the analytic gradient of SSIM for the training loss
//! `L = 0.8·L1 + 0.2·(1 − SSIM)`.
//!
//! Images are interleaved, row-major `[H, W, C]` `f32` buffers with values in `[0, 1]`
//! (`data[(y * width + x) * channels + c]`). All arithmetic is done in `f64`. Sizes are checked
//! ([`EvalError::BadImage`]); values are not (a NaN in gives a NaN out).
//!
//! - [`psnr`] over the whole image, and [`psnr_masked`] over the pixels of a `[H, W]` mask.
//! - [`ssim`] (the mean), [`ssim_map`] (per pixel and channel), and [`ssim_with_grad`]: the mean
//!   and `∂ SSIM / ∂a`. For the 3DGS loss, `∂L/∂a = 0.8·∂L1/∂a − 0.2·∂ SSIM/∂a`.
//!
//! SSIM follows 3DGS's `utils/loss_utils.py::ssim`: every channel is filtered on its own with an
//! 11×11 Gaussian window (σ = 1.5, the outer product of a normalised 1-D kernel) with zero padding
//! of 5 px and "same"-size output. The window is **not** renormalised near the borders, so border
//! means are pulled towards 0. With `C1 = 0.01²`, `C2 = 0.03²` the SSIM map
//! `(2μaμb + C1)(2σab + C2) / ((μa² + μb² + C1)(σa² + σb² + C2))` is averaged over every pixel and
//! channel. scikit-image's `structural_similarity` (Gaussian weights, σ = 1.5) differs only at the
//! border: it pads by reflection and averages the map without its 5-px border; inside that border
//! both maps are the same function of the images.
//!
//! Work mapping: the filter is separable (a horizontal then a vertical 11-tap pass, the symmetric
//! taps paired). Images are cut into blocks of 64 output rows; rayon runs one task per block, which
//! streams every channel row by row through a ring of the last 11 horizontally filtered rows
//! (reading a 5-row halo above and below). The gradient pipes the block's SSIM derivative rows
//! (with their own halo, recomputed) into a second filter, so nothing image-sized is stored but
//! the result. Every output value is a fixed sequence of operations, per-row sums use 4 fixed
//! lanes and block sums are combined in block order, so results do not depend on the number of
//! threads. The row kernels run as AVX code when the CPU has it, without FMA: bit-identical to the
//! portable code.

use rayon::prelude::*;

use crate::EvalError;

/// Side of the SSIM window in pixels (3DGS: 11).
pub const SSIM_WINDOW_PX: usize = 11;
/// Standard deviation of the SSIM Gaussian window in pixels (3DGS: 1.5).
pub const SSIM_SIGMA_PX: f64 = 1.5;
/// SSIM stabiliser for the means, `(0.01 · data range)²` with a data range of 1.
pub const SSIM_C1: f64 = 0.01 * 0.01;
/// SSIM stabiliser for the variances, `(0.03 · data range)²` with a data range of 1.
pub const SSIM_C2: f64 = 0.03 * 0.03;
/// Output rows per parallel task.
const BLOCK_ROWS: usize = 64;

const RADIUS: usize = SSIM_WINDOW_PX / 2;

/// The normalised 1-D Gaussian taps `exp(−(i − 5)² / (2σ²)) / Σ`, `i = 0..11`; returns `[11]`.
pub fn ssim_gaussian_taps() -> [f64; SSIM_WINDOW_PX] {
    let mut taps = [0.0; SSIM_WINDOW_PX];
    for (i, tap) in taps.iter_mut().enumerate() {
        let d = i as f64 - RADIUS as f64;
        *tap = (-(d * d) / (2.0 * SSIM_SIGMA_PX * SSIM_SIGMA_PX)).exp();
    }
    let sum: f64 = taps.iter().sum();
    taps.iter_mut().for_each(|t| *t /= sum);
    taps
}

/// Peak signal-to-noise ratio `10·log10(1 / MSE)` for images in `[0, 1]`, the MSE taken over every
/// pixel and channel (in `f64`). Identical images give `f64::INFINITY`.
///
/// 3DGS's `metrics.py` computes this per image and reports the mean over test images.
///
/// `a`, `b`: `[H, W, C]`.
pub fn psnr(a: &[f32], b: &[f32], width: usize, height: usize, channels: usize) -> Result<f64, EvalError> {
    check_pair(a, b, width, height, channels)?;
    let sum = ordered_sum(a.len(), |range| squared_error(&a[range.clone()], &b[range]));
    Ok(psnr_from_mse(sum / a.len() as f64))
}

/// PSNR over the pixels where `mask` is true only: the MSE is the mean over those pixels and every
/// channel. Identical masked pixels give `f64::INFINITY`; a mask selecting nothing is an error.
///
/// `a`, `b`: `[H, W, C]`; `mask`: `[H, W]`.
pub fn psnr_masked(
    a: &[f32],
    b: &[f32],
    mask: &[bool],
    width: usize,
    height: usize,
    channels: usize,
) -> Result<f64, EvalError> {
    check_pair(a, b, width, height, channels)?;
    if mask.len() != width * height {
        return Err(bad_image(format!(
            "mask has {} entries, expected {width}×{height} = {}",
            mask.len(),
            width * height
        )));
    }
    let selected = mask.iter().filter(|&&m| m).count();
    if selected == 0 {
        return Err(bad_image("the PSNR mask selects no pixel".to_string()));
    }
    let sum = ordered_sum(mask.len(), |range| {
        range
            .filter(|&p| mask[p])
            .map(|p| {
                squared_error(&a[p * channels..(p + 1) * channels], &b[p * channels..(p + 1) * channels])
            })
            .sum()
    });
    Ok(psnr_from_mse(sum / (selected * channels) as f64))
}

/// Mean SSIM of `a` and `b` over every pixel and channel, exactly as 3DGS defines it (see the
/// module documentation).
///
/// `a`, `b`: `[H, W, C]`.
pub fn ssim(a: &[f32], b: &[f32], width: usize, height: usize, channels: usize) -> Result<f64, EvalError> {
    let images = Pair::new(a, b, width, height, channels)?;
    let taps = ssim_gaussian_taps();
    let block_sums: Vec<f64> = images
        .blocks()
        .into_par_iter()
        .map_init(
            || RowFilter::<STATS>::new(width, height),
            |stats, (y0, y1)| {
                let mut sum = 0.0;
                for c in 0..channels {
                    stats.start(y0..y1);
                    while let Some((_, row)) = stats.next_row(&taps, &mut |y, r| images.fill_stats(c, y, r)) {
                        sum += ssim_row_sum(row, width);
                    }
                }
                sum
            },
        )
        .collect();
    Ok(block_sums.iter().sum::<f64>() / images.count() as f64)
}

/// The SSIM map (before averaging) of `a` and `b`, as 3DGS's `ssim_map`.
///
/// `a`, `b`: `[H, W, C]`; returns `[H, W, C]`.
pub fn ssim_map(
    a: &[f32],
    b: &[f32],
    width: usize,
    height: usize,
    channels: usize,
) -> Result<Vec<f64>, EvalError> {
    let images = Pair::new(a, b, width, height, channels)?;
    let taps = ssim_gaussian_taps();
    let mut map = vec![0.0; images.count()];
    map.par_chunks_mut(BLOCK_ROWS * width * channels).enumerate().for_each_init(
        || RowFilter::<STATS>::new(width, height),
        |stats, (block, out)| {
            let y0 = block * BLOCK_ROWS;
            let y1 = (y0 + BLOCK_ROWS).min(height);
            for c in 0..channels {
                stats.start(y0..y1);
                while let Some((y, row)) = stats.next_row(&taps, &mut |y, r| images.fill_stats(c, y, r)) {
                    let s = Stats::of_row(row, width);
                    for x in 0..width {
                        out[((y - y0) * width + x) * channels + c] = s.at(x).ssim();
                    }
                }
            }
        },
    );
    Ok(map)
}

/// Mean SSIM (bit-identical to [`ssim`]) and its gradient with respect to the first image,
/// `∂ SSIM / ∂a`.
///
/// With `μa = G∗a`, `Eaa = G∗a²`, `Eab = G∗(a·b)` the per-pixel derivatives of the map `S` are
/// `∂S/∂μa = 2μb(A2 − A1)/(B1B2) − 2μa·S·(1/B1 − 1/B2)`, `∂S/∂Eaa = −S/B2`,
/// `∂S/∂Eab = 2A1/(B1B2)`, and `∂ mean S/∂a = (1/n)·[G∗(∂S/∂μa) + 2a·G∗(∂S/∂Eaa) + b·G∗(∂S/∂Eab)]`
/// (the zero-padded correlation with a symmetric window is its own adjoint).
///
/// Each block streams its derivative rows (plus a 5-row halo, recomputed by both neighbouring
/// blocks) straight into the second filter, so no full-image intermediate is stored.
///
/// `a`, `b`: `[H, W, C]`; the gradient: `[H, W, C]`.
pub fn ssim_with_grad(
    a: &[f32],
    b: &[f32],
    width: usize,
    height: usize,
    channels: usize,
) -> Result<(f64, Vec<f32>), EvalError> {
    let images = Pair::new(a, b, width, height, channels)?;
    let taps = ssim_gaussian_taps();
    let count = images.count() as f64;
    let mut grad = vec![0.0f32; images.count()];
    let block_sums: Vec<f64> = grad
        .par_chunks_mut(BLOCK_ROWS * width * channels)
        .enumerate()
        .map_init(
            || (RowFilter::<STATS>::new(width, height), RowFilter::<DERIVS>::new(width, height)),
            |(stats, derivs), (block, out)| {
                let y0 = block * BLOCK_ROWS;
                let y1 = (y0 + BLOCK_ROWS).min(height);
                let mut sum = 0.0;
                for c in 0..channels {
                    stats.start(y0.saturating_sub(RADIUS)..(y1 + RADIUS).min(height));
                    derivs.start(y0..y1);
                    // `derivs` asks for its input rows in order, exactly the rows `stats` yields.
                    let mut fill_derivs = |y: usize, row: &mut [f64]| {
                        let next = stats.next_row(&taps, &mut |yy, r| images.fill_stats(c, yy, r));
                        let Some((sy, stats_row)) = next else {
                            unreachable!("statistics stream ended before derivative row {y}");
                        };
                        debug_assert_eq!(sy, y);
                        let row_sum = ssim_row_derivatives(stats_row, row, width);
                        if (y0..y1).contains(&y) {
                            sum += row_sum;
                        }
                    };
                    while let Some((y, row)) = derivs.next_row(&taps, &mut fill_derivs) {
                        let (d_mu, rest) = row.split_at(width);
                        let (d_aa, d_ab) = rest.split_at(width);
                        for x in 0..width {
                            let p = (y * width + x) * channels + c;
                            let (av, bv) = (f64::from(a[p]), f64::from(b[p]));
                            out[p - y0 * width * channels] =
                                ((d_mu[x] + 2.0 * av * d_aa[x] + bv * d_ab[x]) / count) as f32;
                        }
                    }
                }
                sum
            },
        )
        .collect();
    Ok((block_sums.iter().sum::<f64>() / count, grad))
}

/// Local statistics per pixel: μa, μb, E[a²], E[b²], E[ab].
const STATS: usize = 5;
/// Derivatives of the SSIM map per pixel: ∂S/∂μa, ∂S/∂E[a²], ∂S/∂E[ab].
const DERIVS: usize = 3;

/// Two validated images of the same shape.
struct Pair<'a> {
    a: &'a [f32],
    b: &'a [f32],
    width: usize,
    height: usize,
    channels: usize,
}

impl<'a> Pair<'a> {
    fn new(
        a: &'a [f32],
        b: &'a [f32],
        width: usize,
        height: usize,
        channels: usize,
    ) -> Result<Self, EvalError> {
        check_pair(a, b, width, height, channels)?;
        Ok(Self { a, b, width, height, channels })
    }

    fn count(&self) -> usize {
        self.width * self.height * self.channels
    }

    /// Row ranges `(y0, y1)` of the parallel blocks, top to bottom.
    fn blocks(&self) -> Vec<(usize, usize)> {
        (0..self.height).step_by(BLOCK_ROWS).map(|y0| (y0, (y0 + BLOCK_ROWS).min(self.height))).collect()
    }

    /// Writes the unfiltered statistics a, b, a², b², ab of row `y`, channel `c` into
    /// `row: [STATS, W]`.
    fn fill_stats(&self, c: usize, y: usize, row: &mut [f64]) {
        let (w, ch) = (self.width, self.channels);
        let (mu_a, rest) = row.split_at_mut(w);
        let (mu_b, rest) = rest.split_at_mut(w);
        let (e_aa, rest) = rest.split_at_mut(w);
        let (e_bb, e_ab) = rest.split_at_mut(w);
        let (mu_a, mu_b, e_aa, e_bb, e_ab) =
            (&mut mu_a[..w], &mut mu_b[..w], &mut e_aa[..w], &mut e_bb[..w], &mut e_ab[..w]);
        let a_row = &self.a[y * w * ch..(y + 1) * w * ch];
        let b_row = &self.b[y * w * ch..(y + 1) * w * ch];
        for x in 0..w {
            let (av, bv) = (f64::from(a_row[x * ch + c]), f64::from(b_row[x * ch + c]));
            mu_a[x] = av;
            mu_b[x] = bv;
            e_aa[x] = av * av;
            e_bb[x] = bv * bv;
            e_ab[x] = av * bv;
        }
    }
}

/// "Same"-size zero-padded Gaussian filtering of `N` quantities, streamed: output rows come one
/// at a time, top to bottom, and each input row is read and filtered horizontally once, into a
/// ring of the last 11 rows.
struct RowFilter<const N: usize> {
    width: usize,
    height: usize,
    /// Next output row to produce, and the end of the requested range.
    next: usize,
    end: usize,
    /// Next input row to load, shifted by the radius (input row + 5) so rows above the image exist.
    next_shifted: usize,
    /// One input row, unpadded: `[N, W]`.
    row: Vec<f64>,
    /// One input row of one quantity, zero-padded by the radius on both sides: `[W + 10]`.
    padded: Vec<f64>,
    /// Horizontally filtered rows; input row `y` lives in slot `(y + 5) % 11`: `[11, N, W]`.
    ring: Vec<f64>,
    /// The current output row: `[N, W]`.
    out: Vec<f64>,
}

impl<const N: usize> RowFilter<N> {
    fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            next: 0,
            end: 0,
            next_shifted: 0,
            row: vec![0.0; N * width],
            padded: vec![0.0; width + 2 * RADIUS],
            ring: vec![0.0; SSIM_WINDOW_PX * N * width],
            out: vec![0.0; N * width],
        }
    }

    /// Restarts the stream at output rows `rows`.
    fn start(&mut self, rows: std::ops::Range<usize>) {
        self.next = rows.start;
        self.end = rows.end;
        self.next_shifted = rows.start;
    }

    /// The next output row `(y, filtered: [N, W])`, or `None` past the range. `fill(y, row)`
    /// writes input row `y` of every quantity into `row: [N, W]`; it is called once per input
    /// row inside the image, in increasing `y`.
    fn next_row(
        &mut self,
        taps: &[f64; SSIM_WINDOW_PX],
        fill: &mut dyn FnMut(usize, &mut [f64]),
    ) -> Option<(usize, &[f64])> {
        if self.next >= self.end {
            return None;
        }
        let y = self.next;
        while self.next_shifted <= y + 2 * RADIUS {
            self.load(self.next_shifted, taps, fill);
            self.next_shifted += 1;
        }
        let row_len = N * self.width;
        let window: [&[f64]; SSIM_WINDOW_PX] =
            std::array::from_fn(|k| &self.ring[((y + k) % SSIM_WINDOW_PX) * row_len..][..row_len]);
        symmetric_sum(taps, &window, &mut self.out);
        self.next += 1;
        Some((y, &self.out))
    }

    /// Filters input row `shifted − 5` horizontally into its ring slot (zeros outside the image).
    fn load(
        &mut self,
        shifted: usize,
        taps: &[f64; SSIM_WINDOW_PX],
        fill: &mut dyn FnMut(usize, &mut [f64]),
    ) {
        let (width, row_len) = (self.width, N * self.width);
        let slot = shifted % SSIM_WINDOW_PX;
        let dst = &mut self.ring[slot * row_len..(slot + 1) * row_len];
        let Some(y) = shifted.checked_sub(RADIUS).filter(|&y| y < self.height) else {
            dst.fill(0.0);
            return;
        };
        fill(y, &mut self.row);
        for (src, dst) in self.row.chunks_exact(width).zip(dst.chunks_exact_mut(width)) {
            self.padded[RADIUS..RADIUS + width].copy_from_slice(src);
            let shifted_src: [&[f64]; SSIM_WINDOW_PX] = std::array::from_fn(|k| &self.padded[k..k + width]);
            symmetric_sum(taps, &shifted_src, dst);
        }
    }
}

/// `out[i] = taps[5]·t[5][i] + Σ_{k<5} taps[k]·(t[k][i] + t[10−k][i])` (the taps are symmetric);
/// every term is at least as long as `out`. Named, equal-length slices let the loop vectorise.
/// Horizontally the terms are one row shifted by `k`; vertically, the 11 rows of the window.
fn symmetric_sum(taps: &[f64; SSIM_WINDOW_PX], terms: &[&[f64]; SSIM_WINDOW_PX], out: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU has the feature `symmetric_sum_avx` is compiled for.
        return unsafe { symmetric_sum_avx(taps, terms, out) };
    }
    symmetric_sum_any(taps, terms, out)
}

/// [`symmetric_sum_any`] compiled for AVX. No FMA: the same IEEE operations in the same order,
/// so the results are bit-identical to the portable build (and across machines).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn symmetric_sum_avx(taps: &[f64; SSIM_WINDOW_PX], terms: &[&[f64]; SSIM_WINDOW_PX], out: &mut [f64]) {
    symmetric_sum_any(taps, terms, out)
}

#[inline(always)]
fn symmetric_sum_any(taps: &[f64; SSIM_WINDOW_PX], terms: &[&[f64]; SSIM_WINDOW_PX], out: &mut [f64]) {
    let n = out.len();
    let [t0, t1, t2, t3, t4, t5, t6, t7, t8, t9, t10] = *terms;
    let (t0, t1, t2, t3, t4, t5) = (&t0[..n], &t1[..n], &t2[..n], &t3[..n], &t4[..n], &t5[..n]);
    let (t6, t7, t8, t9, t10) = (&t6[..n], &t7[..n], &t8[..n], &t9[..n], &t10[..n]);
    let [g0, g1, g2, g3, g4, g5, ..] = *taps;
    for i in 0..n {
        out[i] = g5 * t5[i]
            + g4 * (t4[i] + t6[i])
            + g3 * (t3[i] + t7[i])
            + g2 * (t2[i] + t8[i])
            + g1 * (t1[i] + t9[i])
            + g0 * (t0[i] + t10[i]);
    }
}

/// The five local statistics of one pixel and the SSIM terms built from them.
#[derive(Clone, Copy)]
struct Local {
    mu_a: f64,
    mu_b: f64,
    e_aa: f64,
    e_bb: f64,
    e_ab: f64,
}

/// One row of filtered statistics split by quantity, each `[W]`.
struct Stats<'r> {
    mu_a: &'r [f64],
    mu_b: &'r [f64],
    e_aa: &'r [f64],
    e_bb: &'r [f64],
    e_ab: &'r [f64],
}

impl<'r> Stats<'r> {
    /// `row: [STATS, W]`.
    fn of_row(row: &'r [f64], width: usize) -> Self {
        let (mu_a, rest) = row.split_at(width);
        let (mu_b, rest) = rest.split_at(width);
        let (e_aa, rest) = rest.split_at(width);
        let (e_bb, e_ab) = rest.split_at(width);
        Self { mu_a, mu_b, e_aa, e_bb, e_ab }
    }

    #[inline(always)]
    fn at(&self, x: usize) -> Local {
        Local {
            mu_a: self.mu_a[x],
            mu_b: self.mu_b[x],
            e_aa: self.e_aa[x],
            e_bb: self.e_bb[x],
            e_ab: self.e_ab[x],
        }
    }
}

/// The four factors of SSIM: `S = A1·A2 / (B1·B2)`.
struct Terms {
    a1: f64,
    a2: f64,
    b1: f64,
    b2: f64,
}

impl Local {
    #[inline(always)]
    fn terms(self) -> Terms {
        let mu_ab = self.mu_a * self.mu_b;
        let (mu_aa, mu_bb) = (self.mu_a * self.mu_a, self.mu_b * self.mu_b);
        Terms {
            a1: 2.0 * mu_ab + SSIM_C1,
            a2: 2.0 * (self.e_ab - mu_ab) + SSIM_C2,
            b1: mu_aa + mu_bb + SSIM_C1,
            b2: (self.e_aa - mu_aa) + (self.e_bb - mu_bb) + SSIM_C2,
        }
    }

    #[inline(always)]
    fn ssim(self) -> f64 {
        let t = self.terms();
        (t.a1 * t.a2) / (t.b1 * t.b2)
    }
}

/// Sum of the SSIM map over one row of statistics `row: [STATS, W]`.
fn ssim_row_sum(row: &[f64], width: usize) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU has the feature `ssim_row_sum_avx` is compiled for.
        return unsafe { ssim_row_sum_avx(row, width) };
    }
    ssim_row_sum_any(row, width)
}

/// [`ssim_row_sum_any`] compiled for AVX (no FMA: bit-identical results).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn ssim_row_sum_avx(row: &[f64], width: usize) -> f64 {
    ssim_row_sum_any(row, width)
}

#[inline(always)]
fn ssim_row_sum_any(row: &[f64], width: usize) -> f64 {
    let s = Stats::of_row(row, width);
    lane_sum(width, |x| s.at(x).ssim())
}

/// `Σ_{x<n} f(x)` accumulated in 4 interleaved lanes (a fixed order the compiler can vectorise),
/// combined as `(l0 + l1) + (l2 + l3)`, plus the tail.
#[inline(always)]
fn lane_sum(n: usize, mut f: impl FnMut(usize) -> f64) -> f64 {
    let mut lanes = [0.0f64; 4];
    let full = n - n % 4;
    for x0 in (0..full).step_by(4) {
        for (j, lane) in lanes.iter_mut().enumerate() {
            *lane += f(x0 + j);
        }
    }
    let tail: f64 = (full..n).map(f).sum();
    (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]) + tail
}

/// SSIM derivatives of one row: reads `row: [STATS, W]`, writes `out: [DERIVS, W]` (∂S/∂μa,
/// ∂S/∂E[a²], ∂S/∂E[ab]) and returns the row's SSIM sum.
fn ssim_row_derivatives(row: &[f64], out: &mut [f64], width: usize) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU has the feature `ssim_row_derivatives_avx` is compiled for.
        return unsafe { ssim_row_derivatives_avx(row, out, width) };
    }
    ssim_row_derivatives_any(row, out, width)
}

/// [`ssim_row_derivatives_any`] compiled for AVX (no FMA: bit-identical results).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn ssim_row_derivatives_avx(row: &[f64], out: &mut [f64], width: usize) -> f64 {
    ssim_row_derivatives_any(row, out, width)
}

#[inline(always)]
fn ssim_row_derivatives_any(row: &[f64], out: &mut [f64], width: usize) -> f64 {
    let s = Stats::of_row(row, width);
    let (d_mu, rest) = out.split_at_mut(width);
    let (d_aa, d_ab) = rest.split_at_mut(width);
    let (d_mu, d_aa, d_ab) = (&mut d_mu[..width], &mut d_aa[..width], &mut d_ab[..width]);
    lane_sum(width, |x| {
        let local = s.at(x);
        let t = local.terms();
        // The same expression as `Local::ssim`, so the value is bit-identical to `ssim`'s.
        let value = (t.a1 * t.a2) / (t.b1 * t.b2);
        let (inv_b1, inv_b2) = (1.0 / t.b1, 1.0 / t.b2);
        let inv_denom = inv_b1 * inv_b2;
        d_mu[x] = 2.0 * local.mu_b * (t.a2 - t.a1) * inv_denom - 2.0 * local.mu_a * value * (inv_b1 - inv_b2);
        d_aa[x] = -value * inv_b2;
        d_ab[x] = 2.0 * t.a1 * inv_denom;
        value
    })
}

fn psnr_from_mse(mse: f64) -> f64 {
    if mse == 0.0 {
        f64::INFINITY
    } else {
        -10.0 * mse.log10()
    }
}

fn squared_error(a: &[f32], b: &[f32]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(&x, &y)| {
            let d = f64::from(x) - f64::from(y);
            d * d
        })
        .sum()
}

/// `Σ part(chunk)` over fixed chunks of `0..len`, computed in parallel and added in chunk order.
fn ordered_sum(len: usize, part: impl Fn(std::ops::Range<usize>) -> f64 + Sync) -> f64 {
    const CHUNK: usize = 1 << 16;
    let parts: Vec<f64> = (0..len.div_ceil(CHUNK))
        .into_par_iter()
        .map(|i| part(i * CHUNK..((i + 1) * CHUNK).min(len)))
        .collect();
    parts.iter().sum()
}

fn bad_image(reason: String) -> EvalError {
    EvalError::BadImage { reason }
}

/// Both buffers hold `height × width × channels` values and no size is zero.
fn check_pair(a: &[f32], b: &[f32], width: usize, height: usize, channels: usize) -> Result<(), EvalError> {
    if width == 0 || height == 0 || channels == 0 {
        return Err(bad_image(format!("image size {width}×{height}×{channels} has a zero dimension")));
    }
    let expected = width
        .checked_mul(height)
        .and_then(|n| n.checked_mul(channels))
        .ok_or_else(|| bad_image(format!("image size {width}×{height}×{channels} overflows")))?;
    for (name, len) in [("first", a.len()), ("second", b.len())] {
        if len != expected {
            return Err(bad_image(format!(
                "{name} image has {len} values, expected {height}×{width}×{channels} = {expected} ([H, W, C])"
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Seeded random pair with some structure: `[H, W, C]` each.
    fn pair(width: usize, height: usize, channels: usize, seed: u64) -> (Vec<f32>, Vec<f32>) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let n = width * height * channels;
        let a: Vec<f32> = (0..n)
            .map(|i| {
                let x = (i / channels) % width;
                (0.5 + 0.3 * (x as f32 / 4.0).sin() + rng.gen_range(-0.15..0.15)).clamp(0.0, 1.0)
            })
            .collect();
        let b: Vec<f32> =
            a.iter().map(|&v| (0.8 * v + 0.1 + rng.gen_range(-0.1..0.1)).clamp(0.0, 1.0)).collect();
        (a, b)
    }

    /// Direct 11×11 zero-padded SSIM map, channel by channel: `[H, W, C]`.
    fn brute_force_map(a: &[f32], b: &[f32], w: usize, h: usize, ch: usize) -> Vec<f64> {
        let g = ssim_gaussian_taps();
        let mut map = vec![0.0; a.len()];
        for y in 0..h {
            for x in 0..w {
                for c in 0..ch {
                    let mut l = Local { mu_a: 0.0, mu_b: 0.0, e_aa: 0.0, e_bb: 0.0, e_ab: 0.0 };
                    for (ky, gy) in g.iter().enumerate() {
                        for (kx, gx) in g.iter().enumerate() {
                            let (Some(yy), Some(xx)) =
                                ((y + ky).checked_sub(RADIUS), (x + kx).checked_sub(RADIUS))
                            else {
                                continue;
                            };
                            if yy >= h || xx >= w {
                                continue;
                            }
                            let i = (yy * w + xx) * ch + c;
                            let (av, bv, wt) = (f64::from(a[i]), f64::from(b[i]), gy * gx);
                            l.mu_a += wt * av;
                            l.mu_b += wt * bv;
                            l.e_aa += wt * av * av;
                            l.e_bb += wt * bv * bv;
                            l.e_ab += wt * av * bv;
                        }
                    }
                    map[(y * w + x) * ch + c] = l.ssim();
                }
            }
        }
        map
    }

    #[test]
    fn taps_are_a_normalised_symmetric_gaussian() {
        let t = ssim_gaussian_taps();
        assert!((t.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        for i in 0..SSIM_WINDOW_PX {
            assert_eq!(t[i], t[SSIM_WINDOW_PX - 1 - i]);
        }
        assert!((t[6] / t[5] - (-1.0 / (2.0 * 1.5 * 1.5f64)).exp()).abs() < 1e-15);
    }

    #[test]
    fn map_over_several_blocks_matches_direct_window() {
        // 150 rows span three blocks, so halo rows come from neighbouring blocks; 7 columns is
        // narrower than the window.
        let (w, h, ch) = (7, 150, 2);
        let (a, b) = pair(w, h, ch, 3);
        let ours = ssim_map(&a, &b, w, h, ch).unwrap();
        let direct = brute_force_map(&a, &b, w, h, ch);
        for (i, (o, d)) in ours.iter().zip(&direct).enumerate() {
            assert!((o - d).abs() < 1e-12, "pixel value {i}: {o} vs direct {d}");
        }
        let mean = direct.iter().sum::<f64>() / direct.len() as f64;
        let value = ssim(&a, &b, w, h, ch).unwrap();
        assert!((value - mean).abs() < 1e-12, "{value} vs {mean}");
        let (value_g, _) = ssim_with_grad(&a, &b, w, h, ch).unwrap();
        assert!((value_g - mean).abs() < 1e-12, "{value_g} vs {mean}");
    }

    #[test]
    fn gradient_matches_central_differences() {
        let (w, h, ch) = (13, 9, 2);
        let (a, b) = pair(w, h, ch, 11);
        let (_, grad) = ssim_with_grad(&a, &b, w, h, ch).unwrap();
        let max_grad = grad.iter().fold(0.0f64, |m, &g| m.max(f64::from(g).abs()));
        assert!(max_grad > 1e-4, "gradient is not trivially zero: {max_grad}");
        let step = 1.0 / 256.0; // exact in f32, so the perturbed values are exact too
        for i in 0..a.len() {
            let (mut plus, mut minus) = (a.clone(), a.clone());
            plus[i] += step;
            minus[i] -= step;
            let numeric = (ssim(&plus, &b, w, h, ch).unwrap() - ssim(&minus, &b, w, h, ch).unwrap())
                / (f64::from(plus[i]) - f64::from(minus[i]));
            let err = (numeric - f64::from(grad[i])).abs() / max_grad;
            assert!(err < 1e-3, "index {i}: analytic {} vs numeric {numeric} (rel {err:.2e})", grad[i]);
        }
    }

    #[test]
    fn gradient_across_block_boundaries_matches_central_differences() {
        // 140 rows = three blocks; check the rows around each boundary, where the halo of
        // derivative rows is recomputed by the neighbouring block.
        let (w, h, ch) = (6, 140, 1);
        let (a, b) = pair(w, h, ch, 21);
        let (_, grad) = ssim_with_grad(&a, &b, w, h, ch).unwrap();
        let max_grad = grad.iter().fold(0.0f64, |m, &g| m.max(f64::from(g).abs()));
        let step = 1.0 / 256.0;
        let rows = (0..3).chain(57..72).chain(121..136).chain(137..140);
        for y in rows {
            for x in [0, 2, 5] {
                let i = (y * w + x) * ch;
                let (mut plus, mut minus) = (a.clone(), a.clone());
                plus[i] += step;
                minus[i] -= step;
                let numeric = (ssim(&plus, &b, w, h, ch).unwrap() - ssim(&minus, &b, w, h, ch).unwrap())
                    / (f64::from(plus[i]) - f64::from(minus[i]));
                let err = (numeric - f64::from(grad[i])).abs() / max_grad;
                assert!(err < 1e-3, "row {y}, column {x}: analytic {} vs numeric {numeric}", grad[i]);
            }
        }
    }

    #[test]
    fn dispatched_kernels_are_bit_identical_to_portable_ones() {
        let (w, h, ch) = (37, 1, 5);
        let (a, b) = pair(w, h, ch, 4);
        let row: Vec<f64> =
            a.iter().zip(&b).map(|(&x, &y)| f64::from(x) * 0.7 + f64::from(y) * 0.2).collect();
        let taps = ssim_gaussian_taps();
        let n = w * 3;
        let terms: [&[f64]; SSIM_WINDOW_PX] = std::array::from_fn(|k| &row[k * 3..k * 3 + n]);
        let (mut fast, mut portable) = (vec![0.0; n], vec![0.0; n]);
        symmetric_sum(&taps, &terms, &mut fast);
        symmetric_sum_any(&taps, &terms, &mut portable);
        assert_eq!(fast, portable);
        // A statistics row [STATS, W] with plausible values (variances ≥ 0).
        let stats: Vec<f64> = (0..STATS * w)
            .map(|i| {
                let (q, x) = (i / w, i % w);
                let m = 0.2 + 0.6 * f64::from(a[x]);
                [
                    m,
                    m * 0.9 + 0.05,
                    m * m + 0.01,
                    (m * 0.9 + 0.05).powi(2) + 0.02,
                    m * (m * 0.9 + 0.05) + 0.005,
                ][q]
            })
            .collect();
        assert_eq!(ssim_row_sum(&stats, w).to_bits(), ssim_row_sum_any(&stats, w).to_bits());
        let (mut d_fast, mut d_portable) = (vec![0.0; DERIVS * w], vec![0.0; DERIVS * w]);
        let s_fast = ssim_row_derivatives(&stats, &mut d_fast, w);
        let s_portable = ssim_row_derivatives_any(&stats, &mut d_portable, w);
        assert_eq!(s_fast.to_bits(), s_portable.to_bits());
        assert_eq!(d_fast, d_portable);
    }

    #[test]
    fn identical_images_are_a_maximum() {
        let (w, h, ch) = (20, 17, 3);
        let (a, _) = pair(w, h, ch, 5);
        assert_eq!(psnr(&a, &a, w, h, ch).unwrap(), f64::INFINITY);
        let (value, grad) = ssim_with_grad(&a, &a, w, h, ch).unwrap();
        assert!((value - 1.0).abs() < 1e-12, "ssim of an image with itself: {value}");
        assert!(grad.iter().all(|g| g.abs() < 1e-9), "gradient at the maximum must vanish");
        assert!((ssim(&a, &a, w, h, ch).unwrap() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn psnr_of_a_constant_offset() {
        let a = vec![0.25f32; 4 * 3 * 3];
        let b = vec![0.75f32; 4 * 3 * 3];
        // MSE 0.25 → 10·log10(4).
        let p = psnr(&a, &b, 4, 3, 3).unwrap();
        assert!((p - 10.0 * 4f64.log10()).abs() < 1e-12, "{p}");
    }

    #[test]
    fn masked_psnr_ignores_unselected_pixels() {
        // 2×1 RGB: pixel 0 differs by 0.5, pixel 1 by 0.1.
        let a = vec![0.0f32, 0.0, 0.0, 0.5, 0.5, 0.5];
        let b = vec![0.5f32, 0.5, 0.5, 0.5, 0.5, 0.6];
        let only_first = psnr_masked(&a, &b, &[true, false], 2, 1, 3).unwrap();
        assert!((only_first - 10.0 * 4f64.log10()).abs() < 1e-12);
        let only_second = psnr_masked(&a, &b, &[false, true], 2, 1, 3).unwrap();
        let mse = f64::from(0.6f32 - 0.5f32).powi(2) / 3.0;
        assert!((only_second + 10.0 * mse.log10()).abs() < 1e-9, "{only_second}");
        let all = psnr_masked(&a, &b, &[true, true], 2, 1, 3).unwrap();
        assert_eq!(all, psnr(&a, &b, 2, 1, 3).unwrap());
    }

    #[test]
    fn same_result_on_one_and_two_threads() {
        let (w, h, ch) = (31, 140, 3);
        let (a, b) = pair(w, h, ch, 8);
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| (ssim(&a, &b, w, h, ch).unwrap(), ssim_with_grad(&a, &b, w, h, ch).unwrap()))
        };
        let (one, two) = (run(1), run(2));
        assert_eq!(one.0.to_bits(), two.0.to_bits());
        assert_eq!(one.1 .0.to_bits(), two.1 .0.to_bits());
        assert_eq!(one.1 .1, two.1 .1);
        // `ssim_with_grad`'s value is exactly `ssim`'s.
        assert_eq!(one.0.to_bits(), one.1 .0.to_bits());
    }

    #[test]
    fn bad_sizes_are_errors_not_panics() {
        let a = vec![0.5f32; 12];
        let short = vec![0.5f32; 11];
        for (w, h, c) in [(0, 4, 3), (4, 0, 3), (4, 1, 0)] {
            assert!(matches!(ssim(&a, &a, w, h, c), Err(EvalError::BadImage { .. })));
            assert!(matches!(psnr(&a, &a, w, h, c), Err(EvalError::BadImage { .. })));
        }
        let err = ssim(&a, &short, 4, 1, 3).unwrap_err().to_string();
        assert!(err.contains("second image has 11 values"), "{err}");
        assert!(matches!(ssim_with_grad(&short, &a, 4, 1, 3), Err(EvalError::BadImage { .. })));
        assert!(matches!(ssim_map(&a, &a, 2, 2, 2), Err(EvalError::BadImage { .. })));
        assert!(matches!(psnr(&a, &a, usize::MAX, 2, 2), Err(EvalError::BadImage { .. })));
        assert!(matches!(psnr_masked(&a, &a, &[true; 3], 4, 1, 3), Err(EvalError::BadImage { .. })));
        let none = psnr_masked(&a, &a, &[false; 4], 4, 1, 3).unwrap_err().to_string();
        assert!(none.contains("selects no pixel"), "{none}");
    }
}
