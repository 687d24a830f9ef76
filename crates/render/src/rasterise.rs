//! Front-to-back alpha blending of depth-sorted splats per 16×16 tile, and its backward.
//!
//! Work mapping: one rayon work item per **row of tiles** (a 16-pixel band of the image), whose
//! tiles are processed left to right; every pixel is computed independently of the others, so
//! outputs do not depend on the thread count. Inside a tile the loop runs over the tile's splats
//! (outer) and the pixels of the splat's footprint (inner), with per-pixel state kept for the
//! 256 pixels; a tile stops when all its pixels are done.
//!
//! Blending rules (3DGS / gsplat): pixel centre `(x + 0.5, y + 0.5)`; `σ = ½(a·dx² + c·dy²) +
//! b·dx·dy`; `α = min(alpha_max, opacity · exp(−σ))`; skipped if `σ < 0` or `α < alpha_min`;
//! the pixel stops *before* a splat that would bring its transmittance to `transmittance_min` or
//! below. Output `Σ_i c_i α_i T_i + T_final · background`.
//!
//! Backward (as 3DGS): no per-pixel per-splat storage; the forward keeps per pixel only the final
//! transmittance and how far down its tile list it blended, and the backward walks each tile's
//! list back to front, recovering `T_i = T_{i+1} / (1 − α_i)`. Per-(splat, tile) partial
//! gradients are written to a buffer laid out like the tile lists (bands own disjoint slices),
//! then added into per-splat totals sequentially in list order: deterministic for any thread
//! count. The buffer is processed in groups of bands to bound its memory.
//!
//! Kernels: on x86-64 CPUs with AVX2 the forward blends 8 pixels of a row at a time and the
//! backward computes a row's α and transmittances 8 at a time, with intrinsics that do the
//! portable code's operations in its order (no fused multiply-adds): the same bits on every CPU
//! (`rasterise_kernels_tests.rs`).

use crate::bin::{TileBins, TILE_SIZE};
use crate::fast_exp::fast_exp;
#[cfg(target_arch = "x86_64")]
use crate::fast_exp::fast_exp_avx2;
use crate::footprint::Footprint;
use crate::project::Splat2d;
use crate::settings::RasterSettings;
use rayon::prelude::*;

const TILE_PIXELS: usize = TILE_SIZE * TILE_SIZE;

/// What to blend.
#[derive(Clone, Copy, Debug)]
pub struct RasterInputs<'a> {
    /// `[N]` projected splats.
    pub splats: &'a [Splat2d],
    /// `[N, channel_count]` per-splat values to blend (colour, features, depth, ...).
    pub channels: &'a [f32],
    /// Number of channels C.
    pub channel_count: usize,
    /// `[C]` value behind everything (weighted by the final transmittance).
    pub background: &'a [f32],
    /// Image width, px.
    pub width: usize,
    /// Image height, px.
    pub height: usize,
    /// Blending rules.
    pub settings: &'a RasterSettings,
}

/// Blended images and what the backward needs.
#[derive(Clone, Debug, Default)]
pub struct RasterOutput {
    /// `[H · W, C]` blended channels including the background term.
    pub channels: Vec<f32>,
    /// `[H · W]` final transmittance (accumulated alpha = 1 − T).
    pub final_t: Vec<f32>,
    /// `[H · W]` 1 + position in its tile's list of the last splat blended into the pixel (0 = none).
    pub walked: Vec<u32>,
    /// `[H · W]` index of the splat with the largest blending weight `α·T` (−1 = none; the
    /// first one wins ties).
    pub max_weight_ids: Vec<i32>,
    /// Number of (pixel, splat) pairs blended.
    pub blends: u64,
}

/// Pixel rectangle of tile `(tx, ty)`: `(x0, x1, y0, y1)`, half-open, clipped to the image.
pub(crate) fn tile_pixels(tx: usize, ty: usize, width: usize, height: usize) -> (usize, usize, usize, usize) {
    let x0 = tx * TILE_SIZE;
    let y0 = ty * TILE_SIZE;
    (x0, (x0 + TILE_SIZE).min(width), y0, (y0 + TILE_SIZE).min(height))
}

/// α of a splat at a pixel, the same arithmetic in the forward and backward passes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PixelAlpha {
    /// `min(alpha_max, opacity · exp(−σ))`.
    pub(crate) alpha: f32,
    /// `exp(−σ)`.
    vis: f32,
    /// Mean − pixel centre, x.
    dx: f32,
    /// Mean − pixel centre, y.
    dy: f32,
    /// True when `alpha_max` clamped α (no gradient flows to opacity or σ).
    clamped: bool,
}

/// [`RowTerms::lanes_avx2`]'s 8 lanes.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(crate) struct AlphaLanes {
    /// Mean − pixel centre, x.
    pub(crate) dx: std::arch::x86_64::__m256,
    /// σ.
    pub(crate) sigma: std::arch::x86_64::__m256,
    /// `exp(−σ)`.
    pub(crate) vis: std::arch::x86_64::__m256,
    /// `opacity · exp(−σ)` before the clamp.
    pub(crate) raw: std::arch::x86_64::__m256,
    /// `min(raw, alpha_max)`.
    pub(crate) alpha: std::arch::x86_64::__m256,
}

/// Per-row constants of a splat: `σ(dx) = ½a·dx² + (b·dy)·dx + ½c·dy²`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RowTerms {
    mx: f32,
    dy: f32,
    half_a: f32,
    b_dy: f32,
    half_c_dy2: f32,
}

impl RowTerms {
    #[inline(always)]
    pub(crate) fn new(s: &Splat2d, py: usize) -> Self {
        let dy = s.mean2d[1] - (py as f32 + 0.5);
        let [a, b, c] = s.conic;
        RowTerms { mx: s.mean2d[0], dy, half_a: 0.5 * a, b_dy: b * dy, half_c_dy2: 0.5 * c * dy * dy }
    }

    /// α at the pixel columns `x0 + k`, `k` in `first..end` (`end ≤ first + 16`, `first < 16`),
    /// into `out[k]` (`[32]`), lane by lane the arithmetic of [`Self::alpha`]; returns the mask
    /// of the columns that blend (bit k clear where [`Self::alpha`] gives `None`).
    #[inline(always)]
    pub(crate) fn alphas_row(
        &self,
        x0: usize,
        (first, end): (usize, usize),
        opacity: f32,
        settings: &RasterSettings,
        out: &mut [f32; 32],
    ) -> u32 {
        let mut keep = 0u32;
        for (k, slot) in out.iter_mut().enumerate().take(end).skip(first) {
            let dx = self.mx - ((x0 + k) as f32 + 0.5);
            let sigma = self.half_a * dx * dx + self.b_dy * dx + self.half_c_dy2;
            let alpha = (opacity * fast_exp(-sigma)).min(settings.alpha_max);
            *slot = alpha;
            keep |= (!(sigma < 0.0 || alpha < settings.alpha_min) as u32) << k;
        }
        keep
    }

    /// The arithmetic of [`Self::alpha`] on the 8 pixel columns `first_column + lane` with AVX2
    /// intrinsics: the same operations in the same order on every lane (no fused multiply-adds),
    /// so the same bits. The one home of the lane arithmetic of every AVX2 kernel.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn lanes_avx2(&self, first_column: usize, opacity: f32, alpha_max: f32) -> AlphaLanes {
        use std::arch::x86_64::*;
        let set = _mm256_set1_ps;
        // `(first_column + lane) as i32 as f32` is the same correctly rounded integer as `px as f32`.
        let columns = _mm256_add_epi32(
            _mm256_set1_epi32(first_column as i32),
            _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
        );
        let dx = _mm256_sub_ps(set(self.mx), _mm256_add_ps(_mm256_cvtepi32_ps(columns), set(0.5)));
        let sigma = _mm256_add_ps(
            _mm256_add_ps(
                _mm256_mul_ps(_mm256_mul_ps(set(self.half_a), dx), dx),
                _mm256_mul_ps(set(self.b_dy), dx),
            ),
            set(self.half_c_dy2),
        );
        let vis = fast_exp_avx2(_mm256_xor_ps(sigma, set(-0.0)));
        let raw = _mm256_mul_ps(set(opacity), vis);
        // `f32::min`: the other operand where `raw` is NaN, as `min_ps(raw, max)` gives.
        let alpha = _mm256_min_ps(raw, set(alpha_max));
        AlphaLanes { dx, sigma, vis, raw, alpha }
    }

    /// [`Self::alphas_row`] with AVX2 intrinsics, 8 columns at a time from `first` (one step
    /// when `end − first ≤ 8`, else two; the extra columns are computed too): the same operations
    /// in the same order on every lane (no fused multiply-adds), so the same bits.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn alphas_row_avx2(
        &self,
        x0: usize,
        (first, end): (usize, usize),
        opacity: f32,
        settings: &RasterSettings,
        out: &mut [f32; 32],
    ) -> u32 {
        use std::arch::x86_64::*;
        debug_assert!(first < 16 && end <= first + 16);
        let set = _mm256_set1_ps;
        let mut keep = 0u32;
        let steps = if end - first <= 8 { 1 } else { 2 };
        for step in 0..steps {
            let k = first + 8 * step;
            let AlphaLanes { sigma, alpha, .. } = self.lanes_avx2(x0 + k, opacity, settings.alpha_max);
            _mm256_storeu_ps(out.as_mut_ptr().add(k), alpha);
            let skip = _mm256_or_ps(
                _mm256_cmp_ps::<_CMP_LT_OQ>(sigma, _mm256_setzero_ps()),
                _mm256_cmp_ps::<_CMP_LT_OQ>(alpha, set(settings.alpha_min)),
            );
            keep |= (!(_mm256_movemask_ps(skip) as u32) & 0xff) << k;
        }
        keep
    }

    /// α at pixel column `px`, or `None` when the pixel skips the splat (σ < 0 or α < alpha_min).
    #[inline(always)]
    pub(crate) fn alpha(&self, px: usize, opacity: f32, settings: &RasterSettings) -> Option<PixelAlpha> {
        let dx = self.mx - (px as f32 + 0.5);
        let sigma = self.half_a * dx * dx + self.b_dy * dx + self.half_c_dy2;
        let vis = fast_exp(-sigma);
        let raw = opacity * vis;
        let alpha = raw.min(settings.alpha_max);
        if sigma < 0.0 || alpha < settings.alpha_min {
            return None;
        }
        Some(PixelAlpha { alpha, vis, dx, dy: self.dy, clamped: raw > settings.alpha_max })
    }
}

/// Per-pixel state of one tile in the forward pass.
struct TileState {
    t: Vec<f32>,
    /// 1 where the pixel has stopped, else 0.
    done: Vec<u32>,
    walked: Vec<u32>,
    best_w: Vec<f32>,
    best_id: Vec<i32>,
    /// Channel-major: `acc[ch * 256 + pixel]`.
    acc: Vec<f32>,
}

impl TileState {
    fn new(c: usize) -> Self {
        TileState {
            t: vec![1.0; TILE_PIXELS],
            done: vec![0; TILE_PIXELS],
            walked: vec![0; TILE_PIXELS],
            best_w: vec![0.0; TILE_PIXELS],
            best_id: vec![-1; TILE_PIXELS],
            acc: vec![0.0; TILE_PIXELS * c],
        }
    }

    fn reset(&mut self) {
        self.t.fill(1.0);
        self.done.fill(0);
        self.walked.fill(0);
        self.best_w.fill(0.0);
        self.best_id.fill(-1);
        self.acc.fill(0.0);
    }
}

/// Mutable views of one band of the outputs.
struct BandOut<'b> {
    channels: &'b mut [f32],
    final_t: &'b mut [f32],
    walked: &'b mut [u32],
    ids: &'b mut [i32],
}

/// Which tile kernels run: the AVX2 ones when the CPU has them (the same bits either way).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kernels {
    Portable,
    #[cfg(target_arch = "x86_64")]
    Avx2,
}

impl Kernels {
    pub(crate) fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            return Kernels::Avx2;
        }
        Kernels::Portable
    }
}

/// Blends one tile into `st`; returns the number of (pixel, splat) pairs blended.
fn rasterise_tile(
    inp: &RasterInputs,
    list: &[u32],
    tile: (usize, usize, usize, usize),
    st: &mut TileState,
    kernels: Kernels,
) -> u64 {
    #[cfg(target_arch = "x86_64")]
    if kernels == Kernels::Avx2 {
        // SAFETY: the CPU has the features `rasterise_tile_avx2` is compiled for.
        return unsafe { rasterise_tile_avx2(inp, list, tile, st) };
    }
    rasterise_tile_any::<false>(inp, list, tile, st)
}

/// [`rasterise_tile_any`] with the rows blended by AVX2 intrinsics ([`blend_row_avx2`]: the
/// same bits as the portable code).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn rasterise_tile_avx2(
    inp: &RasterInputs,
    list: &[u32],
    tile: (usize, usize, usize, usize),
    st: &mut TileState,
) -> u64 {
    rasterise_tile_any::<true>(inp, list, tile, st)
}

/// Dispatch on the channel count, so the common counts get unrolled loops (19 = RGB + the joint
/// stage's 16-channel identity map). `AVX2`: the caller is compiled for AVX2 and checked the CPU.
#[inline(always)]
fn rasterise_tile_any<const AVX2: bool>(
    inp: &RasterInputs,
    list: &[u32],
    tile: (usize, usize, usize, usize),
    st: &mut TileState,
) -> u64 {
    match inp.channel_count {
        1 => rasterise_tile_c::<1, AVX2>(inp, list, tile, st),
        3 => rasterise_tile_c::<3, AVX2>(inp, list, tile, st),
        4 => rasterise_tile_c::<4, AVX2>(inp, list, tile, st),
        19 => rasterise_tile_c::<19, AVX2>(inp, list, tile, st),
        _ => rasterise_tile_c::<0, AVX2>(inp, list, tile, st),
    }
}

/// [`rasterise_tile`] for `C` channels (`C = 0`: any number, read from the inputs).
#[inline(always)]
fn rasterise_tile_c<const C: usize, const AVX2: bool>(
    inp: &RasterInputs,
    list: &[u32],
    tile: (usize, usize, usize, usize),
    st: &mut TileState,
) -> u64 {
    let c_count = if C == 0 { inp.channel_count } else { C };
    let (x0, x1, y0, y1) = tile;
    let n_pix = (x1 - x0) * (y1 - y0);
    let mut n_done = 0;
    let mut blends = 0u64;
    for (k, &gid) in list.iter().enumerate() {
        if n_done == n_pix {
            break;
        }
        let s = &inp.splats[gid as usize];
        let Some(fp) = Footprint::new(s, inp.settings.alpha_min, tile) else {
            continue;
        };
        let colour = &inp.channels[gid as usize * c_count..][..c_count];
        let (_, _, by0, by1) = fp.bbox;
        for py in by0..by1 {
            let (bx0, bx1) = fp.row(py);
            if bx0 >= bx1 {
                continue;
            }
            let row = RowTerms::new(s, py);
            let li0 = (py - y0) * TILE_SIZE + bx0 - x0;
            let mut weights = [0.0f32; TILE_SIZE];
            let pixels = li0..li0 + (bx1 - bx0);
            let (walk, id) = (k as u32 + 1, gid as i32);
            #[cfg(target_arch = "x86_64")]
            if AVX2 {
                // SAFETY: `AVX2` is only set by `rasterise_tile_avx2`, called after the check.
                let (stops, blended) = unsafe {
                    let counts = blend_row_avx2(
                        &row,
                        s.opacity,
                        inp.settings,
                        bx0,
                        pixels,
                        walk,
                        id,
                        st,
                        &mut weights,
                    );
                    accumulate_row_avx2(colour, li0, bx1 - bx0, &weights, &mut st.acc);
                    counts
                };
                n_done += stops;
                blends += blended;
                continue;
            }
            let (stops, blended) =
                blend_row(&row, s.opacity, inp.settings, bx0, pixels, walk, id, st, &mut weights);
            n_done += stops;
            blends += blended;
            for (ch, &v) in colour.iter().enumerate() {
                let acc = &mut st.acc[ch * TILE_PIXELS + li0..][..bx1 - bx0];
                for (a, &w) in acc.iter_mut().zip(&weights) {
                    *a += w * v;
                }
            }
        }
    }
    blends
}

/// Blends one splat into the pixels `pixels` (tile-local indices, one row, first column `px0`)
/// without branches on pixel data, so the loop vectorises; writes each pixel's weight into
/// `weights` and returns `(pixels that stopped, pixels blended)`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn blend_row(
    row: &RowTerms,
    opacity: f32,
    settings: &RasterSettings,
    px0: usize,
    pixels: std::ops::Range<usize>,
    walk: u32,
    gid: i32,
    st: &mut TileState,
    weights: &mut [f32; TILE_SIZE],
) -> (usize, u64) {
    let n = pixels.len();
    let t_row = &mut st.t[pixels.clone()];
    let done_row = &mut st.done[pixels.clone()];
    let walked_row = &mut st.walked[pixels.clone()];
    let best_w_row = &mut st.best_w[pixels.clone()];
    let best_id_row = &mut st.best_id[pixels];
    let (a_min, a_max, t_min) = (settings.alpha_min, settings.alpha_max, settings.transmittance_min);
    let mut stops = 0usize;
    let mut blended = 0u64;
    let mut centre = px0 as f32 + 0.5;
    for j in 0..n.min(TILE_SIZE) {
        // Same arithmetic as `RowTerms::alpha` (used by the backward).
        let dx = row.mx - centre;
        centre += 1.0;
        let sigma = row.half_a * dx * dx + row.b_dy * dx + row.half_c_dy2;
        let alpha = (opacity * fast_exp(-sigma)).min(a_max);
        let t = t_row[j];
        let next_t = t * (1.0 - alpha);
        let live = (done_row[j] == 0) & (sigma >= 0.0) & (alpha >= a_min);
        let stop = live & (next_t <= t_min);
        let blend = live & !stop;
        let w = if blend { alpha * t } else { 0.0 };
        weights[j] = w;
        t_row[j] = if blend { next_t } else { t };
        done_row[j] |= stop as u32;
        walked_row[j] = if blend { walk } else { walked_row[j] };
        let better = w > best_w_row[j];
        best_w_row[j] = if better { w } else { best_w_row[j] };
        best_id_row[j] = if better { gid } else { best_id_row[j] };
        stops += stop as usize;
        blended += blend as u64;
    }
    (stops, blended)
}

/// [`blend_row`] on 8 pixels at a time with AVX2 intrinsics: every lane does the operations of
/// the portable loop in its order (no fused multiply-adds), so the same bits; lanes past the
/// row are masked off (neither read nor written).
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[allow(clippy::too_many_arguments)]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn blend_row_avx2(
    row: &RowTerms,
    opacity: f32,
    settings: &RasterSettings,
    px0: usize,
    pixels: std::ops::Range<usize>,
    walk: u32,
    gid: i32,
    st: &mut TileState,
    weights: &mut [f32; TILE_SIZE],
) -> (usize, u64) {
    use std::arch::x86_64::*;
    let set = _mm256_set1_ps;
    let n = pixels.len().min(TILE_SIZE);
    debug_assert!(pixels.end <= TILE_PIXELS);
    let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    let (mut stops, mut blended) = (0usize, 0u64);
    for step in (0..n).step_by(8) {
        let i = pixels.start + step;
        // Lanes `step + lane < n` are pixels of the row.
        let valid = _mm256_cmpgt_epi32(_mm256_set1_epi32((n - step) as i32), lane);
        let t_ptr = st.t.as_mut_ptr().add(i);
        let done_ptr = st.done.as_mut_ptr().add(i) as *mut i32;
        let walked_ptr = st.walked.as_mut_ptr().add(i) as *mut i32;
        let best_w_ptr = st.best_w.as_mut_ptr().add(i);
        let best_id_ptr = st.best_id.as_mut_ptr().add(i);
        // Column `px0 + step + lane` is the portable loop's `centre − 0.5` (exact integers).
        let AlphaLanes { sigma, alpha, .. } = row.lanes_avx2(px0 + step, opacity, settings.alpha_max);
        let t = _mm256_maskload_ps(t_ptr, valid);
        let next_t = _mm256_mul_ps(t, _mm256_sub_ps(set(1.0), alpha));
        let not_done = _mm256_castsi256_ps(_mm256_cmpeq_epi32(
            _mm256_maskload_epi32(done_ptr, valid),
            _mm256_setzero_si256(),
        ));
        let live = _mm256_and_ps(
            _mm256_and_ps(_mm256_castsi256_ps(valid), not_done),
            _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GE_OQ>(sigma, _mm256_setzero_ps()),
                _mm256_cmp_ps::<_CMP_GE_OQ>(alpha, set(settings.alpha_min)),
            ),
        );
        let stop = _mm256_and_ps(live, _mm256_cmp_ps::<_CMP_LE_OQ>(next_t, set(settings.transmittance_min)));
        let blend = _mm256_andnot_ps(stop, live);
        let w = _mm256_and_ps(blend, _mm256_mul_ps(alpha, t));
        _mm256_storeu_ps(weights.as_mut_ptr().add(step), w);
        _mm256_maskstore_ps(t_ptr, valid, _mm256_blendv_ps(t, next_t, blend));
        let stop_i = _mm256_castps_si256(stop);
        let done = _mm256_maskload_epi32(done_ptr, valid);
        _mm256_maskstore_epi32(done_ptr, valid, _mm256_or_si256(done, _mm256_srli_epi32::<31>(stop_i)));
        let walked = _mm256_castsi256_ps(_mm256_maskload_epi32(walked_ptr, valid));
        let walk_v = _mm256_castsi256_ps(_mm256_set1_epi32(walk as i32));
        _mm256_maskstore_epi32(
            walked_ptr,
            valid,
            _mm256_castps_si256(_mm256_blendv_ps(walked, walk_v, blend)),
        );
        let best_w = _mm256_maskload_ps(best_w_ptr, valid);
        let better = _mm256_cmp_ps::<_CMP_GT_OQ>(w, best_w);
        _mm256_maskstore_ps(best_w_ptr, valid, _mm256_blendv_ps(best_w, w, better));
        let best_id = _mm256_castsi256_ps(_mm256_maskload_epi32(best_id_ptr, valid));
        let id_v = _mm256_castsi256_ps(_mm256_set1_epi32(gid));
        _mm256_maskstore_epi32(
            best_id_ptr,
            valid,
            _mm256_castps_si256(_mm256_blendv_ps(best_id, id_v, better)),
        );
        stops += (_mm256_movemask_ps(stop) as u32).count_ones() as usize;
        blended += (_mm256_movemask_ps(blend) as u32).count_ones() as u64;
    }
    (stops, blended)
}

/// `acc[ch · 256 + li0 + j] += weights[j] · colour[ch]` for `j < n` (`n ≤ 16`), 8 pixels at a
/// time with AVX2 (a multiply then an add per lane: the portable loop's bits).
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn accumulate_row_avx2(
    colour: &[f32],
    li0: usize,
    n: usize,
    weights: &[f32; TILE_SIZE],
    acc: &mut [f32],
) {
    use std::arch::x86_64::*;
    debug_assert!(n <= TILE_SIZE && li0 + n <= TILE_PIXELS && acc.len() >= colour.len() * TILE_PIXELS);
    let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    for step in (0..n).step_by(8) {
        let valid = _mm256_cmpgt_epi32(_mm256_set1_epi32((n - step) as i32), lane);
        let w = _mm256_loadu_ps(weights.as_ptr().add(step));
        for (ch, &v) in colour.iter().enumerate() {
            let p = acc.as_mut_ptr().add(ch * TILE_PIXELS + li0 + step);
            let sum = _mm256_add_ps(_mm256_maskload_ps(p, valid), _mm256_mul_ps(w, _mm256_set1_ps(v)));
            _mm256_maskstore_ps(p, valid, sum);
        }
    }
}

fn rasterise_band(
    inp: &RasterInputs,
    bins: &TileBins,
    ty: usize,
    out: BandOut,
    st: &mut TileState,
    kernels: Kernels,
) -> u64 {
    let (w, c_count) = (inp.width, inp.channel_count);
    let mut blends = 0;
    for tx in 0..bins.tiles_x {
        let tile = tile_pixels(tx, ty, inp.width, inp.height);
        st.reset();
        blends += rasterise_tile(inp, bins.tile(ty * bins.tiles_x + tx), tile, st, kernels);
        let (x0, x1, y0, y1) = tile;
        for py in y0..y1 {
            for px in x0..x1 {
                let li = (py - y0) * TILE_SIZE + (px - x0);
                let pi = (py - y0) * w + px;
                let t = st.t[li];
                let dst = &mut out.channels[pi * c_count..(pi + 1) * c_count];
                for (ch, (d, &bg)) in dst.iter_mut().zip(inp.background).enumerate() {
                    *d = st.acc[ch * TILE_PIXELS + li] + t * bg;
                }
                out.final_t[pi] = t;
                out.walked[pi] = st.walked[li];
                out.ids[pi] = st.best_id[li];
            }
        }
    }
    blends
}

/// Blends the binned splats into an image.
pub fn rasterise(inp: &RasterInputs, bins: &TileBins) -> RasterOutput {
    rasterise_with(inp, bins, Kernels::detect())
}

/// [`rasterise`] with the given kernels.
pub(crate) fn rasterise_with(inp: &RasterInputs, bins: &TileBins, kernels: Kernels) -> RasterOutput {
    let (w, h, c) = (inp.width, inp.height, inp.channel_count);
    let mut out = RasterOutput {
        channels: vec![0.0; w * h * c],
        final_t: vec![1.0; w * h],
        walked: vec![0; w * h],
        max_weight_ids: vec![-1; w * h],
        blends: 0,
    };
    let band = TILE_SIZE * w;
    out.blends = out
        .channels
        .par_chunks_mut(band * c.max(1))
        .zip(out.final_t.par_chunks_mut(band))
        .zip(out.walked.par_chunks_mut(band))
        .zip(out.max_weight_ids.par_chunks_mut(band))
        .enumerate()
        .map_init(
            || TileState::new(c),
            |st, (ty, (((channels, final_t), walked), ids))| {
                rasterise_band(inp, bins, ty, BandOut { channels, final_t, walked, ids }, st, kernels)
            },
        )
        .sum();
    out
}

/// Gradients of the loss w.r.t. the rasteriser's outputs.
#[derive(Clone, Copy, Debug)]
pub struct RasterOutputGrads<'a> {
    /// `[H · W, C]` ∂L/∂channels (of the blended output, background term included).
    pub channels: &'a [f32],
    /// `[H · W]` ∂L/∂final transmittance (= −∂L/∂alpha), or `None` for zero.
    pub final_t: Option<&'a [f32]>,
}

/// Per-splat gradients from the rasteriser.
#[derive(Clone, Debug, Default)]
pub struct RasterGrads {
    /// `[N]` ∂L/∂mean2d, px⁻¹.
    pub mean2d: Vec<[f32; 2]>,
    /// `[N]` ∂L/∂conic `(a, b, c)`.
    pub conic: Vec<[f32; 3]>,
    /// `[N]` ∂L/∂opacity.
    pub opacity: Vec<f32>,
    /// `[N, C]` ∂L/∂channels.
    pub channels: Vec<f32>,
}

/// Number of floats in one (splat, tile) gradient record: mean2d 2, conic 3, opacity 1, C.
fn record_len(c: usize) -> usize {
    6 + c
}

/// Per-pixel state of one tile in the backward pass.
struct BwdState {
    /// Transmittance after the splat being processed.
    t: Vec<f32>,
    /// Colour blended behind the splat being processed, `[256, C]`.
    behind: Vec<f32>,
    /// ∂L/∂channels of the pixel, `[256, C]`.
    g_out: Vec<f32>,
    /// `T_final · ∂L/∂T_final` (background and alpha terms).
    g_t_final: Vec<f32>,
    /// Splats blended into the pixel (as [`RasterOutput::walked`]).
    walked: Vec<u32>,
}

impl BwdState {
    fn new(c: usize) -> Self {
        BwdState {
            t: vec![0.0; TILE_PIXELS],
            behind: vec![0.0; TILE_PIXELS * c],
            g_out: vec![0.0; TILE_PIXELS * c],
            g_t_final: vec![0.0; TILE_PIXELS],
            walked: vec![0; TILE_PIXELS],
        }
    }
}

/// Loads the tile's per-pixel state; returns the longest walk.
fn load_bwd_state(
    inp: &RasterInputs,
    fwd: &RasterOutput,
    grads: &RasterOutputGrads,
    tile: (usize, usize, usize, usize),
    st: &mut BwdState,
) -> usize {
    let (c, w) = (inp.channel_count, inp.width);
    let (x0, x1, y0, y1) = tile;
    let mut max_walked = 0usize;
    for py in y0..y1 {
        for px in x0..x1 {
            let (li, pi) = ((py - y0) * TILE_SIZE + (px - x0), py * w + px);
            let g_out = &grads.channels[pi * c..(pi + 1) * c];
            let mut g_t = grads.final_t.map_or(0.0, |g| g[pi]);
            for (g, bg) in g_out.iter().zip(inp.background) {
                g_t += g * bg;
            }
            st.t[li] = fwd.final_t[pi];
            st.g_t_final[li] = g_t * fwd.final_t[pi];
            st.behind[li * c..(li + 1) * c].fill(0.0);
            st.g_out[li * c..(li + 1) * c].copy_from_slice(g_out);
            st.walked[li] = fwd.walked[pi];
            max_walked = max_walked.max(fwd.walked[pi] as usize);
        }
    }
    max_walked
}

#[allow(clippy::too_many_arguments)]
fn rasterise_tile_bwd(
    inp: &RasterInputs,
    fwd: &RasterOutput,
    grads: &RasterOutputGrads,
    list: &[u32],
    tile: (usize, usize, usize, usize),
    records: &mut [f32],
    st: &mut BwdState,
    kernels: Kernels,
) {
    let max_walked = load_bwd_state(inp, fwd, grads, tile, st);
    #[cfg(target_arch = "x86_64")]
    if kernels == Kernels::Avx2 {
        // SAFETY: the CPU has the features `rasterise_tile_bwd_avx2` is compiled for.
        unsafe { rasterise_tile_bwd_avx2(inp, list, tile, records, st, max_walked) };
        return;
    }
    rasterise_tile_bwd_any::<false>(inp, list, tile, records, st, max_walked);
}

/// [`rasterise_tile_bwd_any`] with each row's α computed by AVX2 intrinsics ([`bwd_row_avx2`]:
/// the same bits as the portable code).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn rasterise_tile_bwd_avx2(
    inp: &RasterInputs,
    list: &[u32],
    tile: (usize, usize, usize, usize),
    records: &mut [f32],
    st: &mut BwdState,
    max_walked: usize,
) {
    rasterise_tile_bwd_any::<true>(inp, list, tile, records, st, max_walked);
}

/// Dispatch on the channel count. `AVX2`: the caller is compiled for AVX2 and checked the CPU.
#[inline(always)]
fn rasterise_tile_bwd_any<const AVX2: bool>(
    inp: &RasterInputs,
    list: &[u32],
    tile: (usize, usize, usize, usize),
    records: &mut [f32],
    st: &mut BwdState,
    max_walked: usize,
) {
    match inp.channel_count {
        1 => rasterise_tile_bwd_c::<1, AVX2>(inp, list, tile, records, st, max_walked),
        3 => rasterise_tile_bwd_c::<3, AVX2>(inp, list, tile, records, st, max_walked),
        4 => rasterise_tile_bwd_c::<4, AVX2>(inp, list, tile, records, st, max_walked),
        19 => rasterise_tile_bwd_c::<19, AVX2>(inp, list, tile, records, st, max_walked),
        _ => rasterise_tile_bwd_c::<0, AVX2>(inp, list, tile, records, st, max_walked),
    }
}

/// Back-to-front walk of one tile for `C` channels (`C = 0`: any number).
#[inline(always)]
fn rasterise_tile_bwd_c<const C: usize, const AVX2: bool>(
    inp: &RasterInputs,
    list: &[u32],
    tile: (usize, usize, usize, usize),
    records: &mut [f32],
    st: &mut BwdState,
    max_walked: usize,
) {
    let c_count = if C == 0 { inp.channel_count } else { C };
    let rl = record_len(c_count);
    let (x0, _, y0, _) = tile;
    for k in (0..max_walked).rev() {
        let gid = list[k] as usize;
        let s = &inp.splats[gid];
        let Some(fp) = Footprint::new(s, inp.settings.alpha_min, tile) else {
            continue;
        };
        let colour = &inp.channels[gid * c_count..][..c_count];
        let rec = &mut records[k * rl..(k + 1) * rl];
        let (rec_geo, rec_ch) = rec.split_at_mut(6);
        let mut geo = [0.0f32; 6];
        let [a, b, c] = s.conic;
        let (_, _, by0, by1) = fp.bbox;
        for py in by0..by1 {
            let (bx0, bx1) = fp.row(py);
            let row = RowTerms::new(s, py);
            let base = (py - y0) * TILE_SIZE;
            #[cfg(target_arch = "x86_64")]
            if AVX2 && C != 0 && bx0 < bx1 {
                let pixels = (base + bx0 - x0, bx1 - bx0);
                // SAFETY: `AVX2` is only set by `rasterise_tile_bwd_avx2`, called after the check.
                unsafe {
                    bwd_row_avx2::<C>(&row, s, inp.settings, bx0, pixels, k, colour, rec_ch, &mut geo, st)
                };
                continue;
            }
            for px in bx0..bx1 {
                let li = base + px - x0;
                if k >= st.walked[li] as usize {
                    continue;
                }
                let Some(pa) = row.alpha(px, s.opacity, inp.settings) else {
                    continue;
                };
                let inv_keep = 1.0 / (1.0 - pa.alpha);
                let t_before = st.t[li] * inv_keep;
                let weight = pa.alpha * t_before;
                let g_out = &st.g_out[li * c_count..][..c_count];
                let behind = &mut st.behind[li * c_count..][..c_count];
                let mut g_alpha = 0.0;
                for ch in 0..c_count {
                    g_alpha += g_out[ch] * (colour[ch] * t_before - behind[ch] * inv_keep);
                    rec_ch[ch] += weight * g_out[ch];
                    behind[ch] += colour[ch] * weight;
                }
                g_alpha -= st.g_t_final[li] * inv_keep;
                st.t[li] = t_before;
                if pa.clamped {
                    continue;
                }
                let (dx, dy) = (pa.dx, pa.dy);
                geo[5] += g_alpha * pa.vis;
                let g_sigma = -g_alpha * pa.alpha;
                geo[0] += g_sigma * (a * dx + b * dy);
                geo[1] += g_sigma * (b * dx + c * dy);
                geo[2] += g_sigma * 0.5 * dx * dx;
                geo[3] += g_sigma * dx * dy;
                geo[4] += g_sigma * 0.5 * dy * dy;
            }
        }
        for (r, g) in rec_geo.iter_mut().zip(geo) {
            *r += g;
        }
    }
}

/// One row of [`rasterise_tile_bwd_c`] for `C > 0` channels: α, `1/(1 − α)` and the
/// transmittances of 8 pixels at a time with AVX2 intrinsics (the operations of
/// [`RowTerms::alpha`] and of the portable loop, in their order: the same bits), then per
/// blended pixel, in column order, the channel terms (vectorised over channels, summed in
/// channel order) and the geometry sums. `pixels`: (tile-local index of column `px0`, count ≤ 16).
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[allow(clippy::too_many_arguments)]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn bwd_row_avx2<const C: usize>(
    row: &RowTerms,
    s: &Splat2d,
    settings: &RasterSettings,
    px0: usize,
    (li0, n): (usize, usize),
    k: usize,
    colour: &[f32],
    rec_ch: &mut [f32],
    geo: &mut [f32; 6],
    st: &mut BwdState,
) {
    use std::arch::x86_64::*;
    let set = _mm256_set1_ps;
    let n = n.min(TILE_SIZE);
    debug_assert!(li0 + n <= TILE_PIXELS && colour.len() == C && rec_ch.len() == C);
    let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    let (mut alpha_l, mut vis_l, mut dx_l) = ([0f32; TILE_SIZE], [0f32; TILE_SIZE], [0f32; TILE_SIZE]);
    let (mut inv_keep_l, mut t_before_l) = ([0f32; TILE_SIZE], [0f32; TILE_SIZE]);
    let (mut active, mut clamped) = (0u32, 0u32);
    for step in (0..n).step_by(8) {
        let i = li0 + step;
        let valid = _mm256_cmpgt_epi32(_mm256_set1_epi32((n - step) as i32), lane);
        // Pixels that blended this splat: `k < walked` (walks are below 2³¹).
        let walked = _mm256_maskload_epi32(st.walked.as_ptr().add(i) as *const i32, valid);
        let in_walk = _mm256_cmpgt_epi32(walked, _mm256_set1_epi32(k as i32));
        let AlphaLanes { dx, sigma, vis, raw, alpha } =
            row.lanes_avx2(px0 + step, s.opacity, settings.alpha_max);
        // `RowTerms::alpha` skips `σ < 0 || α < alpha_min` (so NaN σ is not skipped there).
        let keep = _mm256_and_ps(
            _mm256_and_ps(_mm256_castsi256_ps(valid), _mm256_castsi256_ps(in_walk)),
            _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_NLT_UQ>(sigma, _mm256_setzero_ps()),
                _mm256_cmp_ps::<_CMP_NLT_UQ>(alpha, set(settings.alpha_min)),
            ),
        );
        let inv_keep = _mm256_div_ps(set(1.0), _mm256_sub_ps(set(1.0), alpha));
        let t_ptr = st.t.as_mut_ptr().add(i);
        let t_before = _mm256_mul_ps(_mm256_maskload_ps(t_ptr, valid), inv_keep);
        _mm256_maskstore_ps(t_ptr, _mm256_castps_si256(keep), t_before);
        _mm256_storeu_ps(alpha_l.as_mut_ptr().add(step), alpha);
        _mm256_storeu_ps(vis_l.as_mut_ptr().add(step), vis);
        _mm256_storeu_ps(dx_l.as_mut_ptr().add(step), dx);
        _mm256_storeu_ps(inv_keep_l.as_mut_ptr().add(step), inv_keep);
        _mm256_storeu_ps(t_before_l.as_mut_ptr().add(step), t_before);
        active |= (_mm256_movemask_ps(keep) as u32) << step;
        let over = _mm256_cmp_ps::<_CMP_GT_OQ>(raw, set(settings.alpha_max));
        clamped |= (_mm256_movemask_ps(over) as u32) << step;
    }
    let [a, b, c] = s.conic;
    let dy = row.dy;
    let colour: &[f32; C] = colour.try_into().expect("C channels");
    let rec_ch: &mut [f32; C] = rec_ch.try_into().expect("C channels");
    while active != 0 {
        let j = active.trailing_zeros() as usize;
        active &= active - 1;
        let li = li0 + j;
        let (alpha, inv_keep, t_before) = (alpha_l[j], inv_keep_l[j], t_before_l[j]);
        let weight = alpha * t_before;
        let g_out: &[f32; C] = st.g_out[li * C..][..C].try_into().expect("C channels");
        let behind: &mut [f32; C] = (&mut st.behind[li * C..][..C]).try_into().expect("C channels");
        let mut terms = [0f32; C];
        for ch in 0..C {
            terms[ch] = g_out[ch] * (colour[ch] * t_before - behind[ch] * inv_keep);
        }
        for ch in 0..C {
            rec_ch[ch] += weight * g_out[ch];
            behind[ch] += colour[ch] * weight;
        }
        let mut g_alpha = 0.0;
        for term in terms {
            g_alpha += term;
        }
        g_alpha -= st.g_t_final[li] * inv_keep;
        if clamped & (1 << j) != 0 {
            continue;
        }
        let dx = dx_l[j];
        geo[5] += g_alpha * vis_l[j];
        let g_sigma = -g_alpha * alpha;
        geo[0] += g_sigma * (a * dx + b * dy);
        geo[1] += g_sigma * (b * dx + c * dy);
        geo[2] += g_sigma * 0.5 * dx * dx;
        geo[3] += g_sigma * dx * dy;
        geo[4] += g_sigma * 0.5 * dy * dy;
    }
}

/// Largest number of (splat, tile) records held at once by the backward.
const MAX_RECORDS_PER_GROUP: usize = 1 << 20;

/// Backward of [`rasterise`]: per-splat gradients given the output gradients.
pub fn rasterise_bwd(
    inp: &RasterInputs,
    bins: &TileBins,
    fwd: &RasterOutput,
    grads: &RasterOutputGrads,
) -> RasterGrads {
    rasterise_bwd_with(inp, bins, fwd, grads, Kernels::detect())
}

/// [`rasterise_bwd`] with the given kernels.
pub(crate) fn rasterise_bwd_with(
    inp: &RasterInputs,
    bins: &TileBins,
    fwd: &RasterOutput,
    grads: &RasterOutputGrads,
    kernels: Kernels,
) -> RasterGrads {
    let n = inp.splats.len();
    let c = inp.channel_count;
    let rl = record_len(c);
    let mut out = RasterGrads {
        mean2d: vec![[0.0; 2]; n],
        conic: vec![[0.0; 3]; n],
        opacity: vec![0.0; n],
        channels: vec![0.0; n * c],
    };
    let band_start = |ty: usize| bins.offsets[(ty * bins.tiles_x).min(bins.tiles_x * bins.tiles_y)];
    let mut records: Vec<f32> = Vec::new();
    let mut ty0 = 0;
    while ty0 < bins.tiles_y {
        let mut ty1 = ty0 + 1;
        while ty1 < bins.tiles_y && band_start(ty1 + 1) - band_start(ty0) <= MAX_RECORDS_PER_GROUP {
            ty1 += 1;
        }
        let (first, last) = (band_start(ty0), band_start(ty1));
        records.clear();
        records.resize((last - first) * rl, 0.0);
        let mut slices: Vec<(usize, &mut [f32])> = Vec::with_capacity(ty1 - ty0);
        let mut rest = records.as_mut_slice();
        for ty in ty0..ty1 {
            let (head, tail) = rest.split_at_mut((band_start(ty + 1) - band_start(ty)) * rl);
            slices.push((ty, head));
            rest = tail;
        }
        slices.into_par_iter().for_each_init(
            || BwdState::new(c),
            |st, (ty, band_records)| {
                let base = band_start(ty);
                for tx in 0..bins.tiles_x {
                    let t = ty * bins.tiles_x + tx;
                    let (lo, hi) = (bins.offsets[t] - base, bins.offsets[t + 1] - base);
                    let tile = tile_pixels(tx, ty, inp.width, inp.height);
                    let recs = &mut band_records[lo * rl..hi * rl];
                    rasterise_tile_bwd(inp, fwd, grads, bins.tile(t), tile, recs, st, kernels);
                }
            },
        );
        scatter_records(&bins.ids[first..last], &records, c, &mut out);
        ty0 = ty1;
    }
    out
}

/// Adds per-(splat, tile) records (`[len(ids), 6 + c]`) into the per-splat totals, each splat's
/// records in list order. Splat indices are split into one contiguous range per thread; every
/// thread scans all records and adds those of its range, so the sums do not depend on the
/// thread count.
fn scatter_records(ids: &[u32], records: &[f32], c: usize, out: &mut RasterGrads) {
    let rl = record_len(c);
    let n = out.opacity.len();
    let per = n.div_ceil(rayon::current_num_threads().max(1)).max(1);
    let add = |lo: usize, m2: &mut [[f32; 2]], con: &mut [[f32; 3]], op: &mut [f32], ch: &mut [f32]| {
        for (r, &gid) in ids.iter().enumerate() {
            let g = (gid as usize).wrapping_sub(lo);
            if g >= op.len() {
                continue;
            }
            let rec = &records[r * rl..(r + 1) * rl];
            m2[g][0] += rec[0];
            m2[g][1] += rec[1];
            for k in 0..3 {
                con[g][k] += rec[2 + k];
            }
            op[g] += rec[5];
            for (d, &v) in ch[g * c..(g + 1) * c].iter_mut().zip(&rec[6..]) {
                *d += v;
            }
        }
    };
    if c == 0 || per >= n {
        add(0, &mut out.mean2d, &mut out.conic, &mut out.opacity, &mut out.channels);
        return;
    }
    out.mean2d
        .par_chunks_mut(per)
        .zip(out.conic.par_chunks_mut(per))
        .zip(out.opacity.par_chunks_mut(per))
        .zip(out.channels.par_chunks_mut(per * c))
        .enumerate()
        .for_each(|(i, (((m2, con), op), ch))| add(i * per, m2, con, op, ch));
}

#[cfg(test)]
#[path = "rasterise_kernels_tests.rs"]
mod kernels_tests;
