//! Per-pixel contributions: which Gaussians a pixel blends, front to back, and with what weight
//! `w = α·T` (T the transmittance before the Gaussian) — the same splats, tiles, α arithmetic
//! and stopping rule as the forward rasteriser ([`crate::rasterise`]), so `Σ w_i c_i` over a
//! pixel's contributions is exactly what [`crate::render()`] blends. Label lifting, label
//! rendering and surface depth are all built on this one compositor.
//!
//! Work mapping: one rayon work item per row of tiles (a 16-pixel band), tiles left to right;
//! inside a tile the loop runs over the tile's splats (outer) and the pixels of each splat's
//! footprint (inner). Each band gets its own visitor, made by the caller, and the visitors come
//! back in band order, so a caller that folds them in that order gets a result independent of
//! the thread count. Within one pixel, contributions arrive front to back.

use crate::bin::{bin, TileBins, TILE_SIZE};
use crate::camera::RenderCamera;
use crate::error::{RenderError, RenderResult};
use crate::footprint::{Footprint, Reach};
use crate::project::{project, Splat2d};
use crate::rasterise::{tile_pixels, RowTerms};
use crate::settings::RasterSettings;
use rayon::prelude::*;
use splatseg_scene::Gaussians;

/// Gaussians projected and binned for one camera: what contribution passes iterate over.
#[derive(Clone, Debug)]
pub struct ProjectedView {
    /// `[N]` projected splats, in Gaussian order (culled ones have zero radii).
    pub splats: Vec<Splat2d>,
    /// Tile lists, front to back.
    pub bins: TileBins,
    /// Image width, px.
    pub width: usize,
    /// Image height, px.
    pub height: usize,
}

impl ProjectedView {
    /// Projects and bins `gaussians` (only their means, log-scales, rotations and raw
    /// opacities are read) for `camera` under `settings`.
    pub fn new(
        gaussians: &Gaussians,
        camera: &RenderCamera,
        settings: &RasterSettings,
    ) -> RenderResult<Self> {
        camera.validate()?;
        let (width, height) = (camera.width as usize, camera.height as usize);
        let splats = project(gaussians, camera, settings);
        Ok(Self::from_splats(splats, width, height))
    }

    /// Bins splats made by [`crate::project::project`] (a caller may move their centres first,
    /// e.g. by a lens distortion the pinhole projection ignores) for a `width × height` image.
    pub fn from_splats(splats: Vec<Splat2d>, width: usize, height: usize) -> Self {
        let bins = bin(&splats, width, height);
        ProjectedView { splats, bins, width, height }
    }

    /// The view of `splats` with tile lists `bins` that [`crate::bin::bin`] made of the same
    /// splats before (kept, e.g. on disk, between two passes over one view), so they are not
    /// sorted again. Lists that cannot index these splats or this image are an error
    /// ([`TileBins::check`]); lists of other splats that pass the check give other contributions.
    pub fn from_binned(
        splats: Vec<Splat2d>,
        bins: TileBins,
        width: usize,
        height: usize,
    ) -> RenderResult<Self> {
        bins.check(splats.len(), width, height).map_err(RenderError::Bins)?;
        Ok(ProjectedView { splats, bins, width, height })
    }
}

/// One blended (pixel, Gaussian) pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contribution {
    /// Row-major pixel index `y · width + x`.
    pub pixel: usize,
    /// Gaussian index (into the splats / the Gaussians).
    pub gaussian: u32,
    /// Blending weight `α·T_before`.
    pub weight: f32,
    /// Transmittance after this Gaussian, `T_before · (1 − α)`.
    pub t_after: f32,
}

/// What a contribution pass calls. One visitor serves one band of tiles.
pub trait ContributionVisitor {
    /// A Gaussian blended into a pixel (per pixel, front to back). Returns whether the visitor
    /// wants the pixel's further contributions: `false` finishes the pixel here (a surface-depth
    /// pass stops at the first Gaussian that brings transmittance below its threshold), and its
    /// `pixel_done` then reports the transmittance after this contribution.
    fn contribution(&mut self, c: Contribution) -> bool;
    /// A pixel is finished: `t_final` is the light left for the background.
    fn pixel_done(&mut self, _pixel: usize, _t_final: f32) {}
    /// Gaussian `gaussian` comes a few splats later in this tile: a visitor that reads per-Gaussian
    /// data may [`prefetch`] it (a hint only).
    #[inline(always)]
    fn prefetch(&self, _gaussian: u32) {}
}

/// Runs every (pixel, Gaussian) blend of `view` through visitors: `make(band)` builds the
/// visitor of band `band` (rows `16·band .. 16·band + 16`); the visitors are returned in band
/// order. A pixel stops where the rasteriser stops (before transmittance would fall to
/// `settings.transmittance_min`).
pub fn visit_contributions<V: ContributionVisitor + Send>(
    view: &ProjectedView,
    settings: &RasterSettings,
    make: impl Fn(usize) -> V + Sync,
) -> Vec<V> {
    visit_contributions_with(
        view,
        settings,
        make,
        Build { avx2: avx2_available(), trim_rows: true, reach: true },
    )
}

/// How the tile loop runs; every choice gives the same contributions, bit for bit and in the
/// same order (test `every_build_gives_the_same_contributions`).
#[derive(Clone, Copy, Debug)]
struct Build {
    /// With AVX2 (the CPU must have it: [`avx2_available`]).
    avx2: bool,
    /// Skip a footprint box's top and bottom rows that no pixel can blend in
    /// ([`Footprint::reaching_rows`]) instead of computing their α.
    trim_rows: bool,
    /// Each splat's [`Reach`] made once per pass and clipped to each of its tiles
    /// ([`Footprint::in_tile`]) instead of [`Footprint::new`] per (splat, tile).
    reach: bool,
}

/// Whether the AVX2 build of the tile loop can run here.
fn avx2_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// [`visit_contributions`] with the tile loop compiled for AVX2 (`build.avx2`, which the caller
/// has checked the CPU has) or for the baseline: the same arithmetic, lane by lane, so the same
/// contributions bit for bit (test `every_build_gives_the_same_contributions`).
fn visit_contributions_with<V: ContributionVisitor + Send>(
    view: &ProjectedView,
    settings: &RasterSettings,
    make: impl Fn(usize) -> V + Sync,
    build: Build,
) -> Vec<V> {
    let Build { avx2, trim_rows, reach } = build;
    // `[N]` reach of every splat (empty: made per tile instead).
    let reaches: Vec<Reach> =
        if reach { crate::reach_lanes::reaches(&view.splats, settings.alpha_min) } else { Vec::new() };
    let pass = Pass { view, settings, reaches: &reaches, trim_rows };
    (0..view.bins.tiles_y)
        .into_par_iter()
        .map(|ty| {
            let mut visitor = make(ty);
            let mut t = [1.0f32; TILE_SIZE * TILE_SIZE];
            for tx in 0..view.bins.tiles_x {
                let tile = tile_pixels(tx, ty, view.width, view.height);
                t.fill(1.0);
                let list = view.bins.tile(ty * view.bins.tiles_x + tx);
                #[cfg(target_arch = "x86_64")]
                if avx2 {
                    // SAFETY: `avx2` is only true when the CPU has AVX2 (`avx2_available`).
                    unsafe { visit_tile_avx2(&pass, list, tile, &mut t, &mut visitor) };
                } else {
                    visit_tile::<V, false>(&pass, list, tile, &mut t, &mut visitor);
                }
                #[cfg(not(target_arch = "x86_64"))]
                {
                    let _ = avx2;
                    visit_tile::<V, false>(&pass, list, tile, &mut t, &mut visitor);
                }
                let (x0, x1, y0, y1) = tile;
                for py in y0..y1 {
                    for px in x0..x1 {
                        visitor.pixel_done(py * view.width + px, t[(py - y0) * TILE_SIZE + px - x0]);
                    }
                }
            }
            visitor
        })
        .collect()
}

/// What every tile of one pass reads.
struct Pass<'a> {
    view: &'a ProjectedView,
    settings: &'a RasterSettings,
    /// `[N]` each splat's reach, or empty (footprints made per tile).
    reaches: &'a [Reach],
    /// [`Build::trim_rows`].
    trim_rows: bool,
}

/// How many entries of a tile list ahead the splat (and the visitor's data) is prefetched: the
/// lists index the splats in depth order, far apart in memory, so each splat is otherwise a
/// cache miss.
const PREFETCH_AHEAD: usize = 8;

/// Asks the CPU to start loading `value`'s cache line (a hint: no effect on results).
#[inline(always)]
pub fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint that never faults; the pointer comes from a reference.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(value as *const T as *const i8)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}

/// Bits `lo..hi` of a tile row's pixel mask (`hi - lo ≤ 16`).
#[inline(always)]
fn span_bits(lo: usize, hi: usize) -> u32 {
    ((1u32 << (hi - lo)) - 1) << lo
}

/// [`visit_tile`] compiled with AVX2 (a row's α in one or two 8-lane steps).
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn visit_tile_avx2<V: ContributionVisitor>(
    pass: &Pass,
    list: &[u32],
    tile: (usize, usize, usize, usize),
    t: &mut [f32; TILE_SIZE * TILE_SIZE],
    visitor: &mut V,
) {
    visit_tile::<V, true>(pass, list, tile, t, visitor)
}

/// The blends of one tile (`tile = (x0, x1, y0, y1)`, half-open); `t`: `[256]` per-pixel
/// transmittance, tile-local row-major.
///
/// The pixels still open (not stopped) are kept as one bit mask per tile row, so a splat's rows
/// whose pixels are all finished are skipped, and only open pixels are visited. The α of a
/// row's columns from its first open pixel in the footprint box to its last are computed
/// together (8 lanes at a time with AVX2); the open pixels whose α blends are then walked left
/// to right. The rasteriser narrows each row to the
/// footprint's exact span first; that span holds every pixel whose α reaches `alpha_min` (with a
/// 1 px margin, [`Footprint`]), so testing α over the whole box row keeps exactly the same
/// pixels, in the same order, without the span's square root. `AVX2`: with AVX2 intrinsics
/// (only inside [`visit_tile_avx2`]).
#[inline(always)]
fn visit_tile<V: ContributionVisitor, const AVX2: bool>(
    pass: &Pass,
    list: &[u32],
    tile: (usize, usize, usize, usize),
    t: &mut [f32; TILE_SIZE * TILE_SIZE],
    visitor: &mut V,
) {
    let Pass { view, settings, reaches, trim_rows } = *pass;
    let (x0, x1, y0, y1) = tile;
    let mut open = [0u32; TILE_SIZE];
    for mask in &mut open[..y1 - y0] {
        *mask = span_bits(0, x1 - x0);
    }
    let mut n_open = (x1 - x0) * (y1 - y0);
    // Per tile row: the α of the current splat's columns and the mask of those that blend.
    let mut alpha_rows = [[0f32; 32]; TILE_SIZE];
    let mut keeps = [0u32; TILE_SIZE];
    for (i, &gid) in list.iter().enumerate() {
        if n_open == 0 {
            break;
        }
        if let Some(&ahead) = list.get(i + PREFETCH_AHEAD) {
            prefetch(&view.splats[ahead as usize]);
            if let Some(r) = reaches.get(ahead as usize) {
                prefetch(r);
            }
            visitor.prefetch(ahead);
        }
        let s = &view.splats[gid as usize];
        let fp = match reaches.get(gid as usize) {
            Some(reach) => Footprint::in_tile(s, reach, tile),
            None => Footprint::new(s, settings.alpha_min, tile),
        };
        let Some(fp) = fp else { continue };
        let (bx0, bx1, mut by0, mut by1) = fp.bbox;
        if trim_rows {
            (by0, by1) = fp.reaching_rows();
        }
        let box_bits = span_bits(bx0 - x0, bx1 - x0);
        // First the α of every row (independent of one another, so the CPU overlaps their
        // arithmetic), then the blends row by row; a row's blends change only its own open
        // pixels, so every row sees the open pixels it would see row after row.
        for py in by0..by1 {
            let ty = py - y0;
            let todo = open[ty] & box_bits;
            if todo == 0 {
                keeps[ty] = 0;
                continue;
            }
            // α of the columns from the first open pixel to the last.
            let span = (todo.trailing_zeros() as usize, 32 - todo.leading_zeros() as usize);
            let row = RowTerms::new(s, py);
            let alphas = &mut alpha_rows[ty];
            #[cfg(target_arch = "x86_64")]
            let keep = if AVX2 {
                // SAFETY: `AVX2` is only set inside `visit_tile_avx2`, which needs AVX2.
                unsafe { row.alphas_row_avx2(x0, span, s.opacity, settings, alphas) }
            } else {
                row.alphas_row(x0, span, s.opacity, settings, alphas)
            };
            #[cfg(not(target_arch = "x86_64"))]
            let keep = row.alphas_row(x0, span, s.opacity, settings, alphas);
            keeps[ty] = todo & keep;
        }
        for py in by0..by1 {
            let ty = py - y0;
            let mut todo = keeps[ty];
            let alphas = &alpha_rows[ty];
            while todo != 0 {
                let k = todo.trailing_zeros() as usize;
                todo &= todo - 1;
                let px = x0 + k;
                let li = ty * TILE_SIZE + k;
                let alpha = alphas[k];
                let next_t = t[li] * (1.0 - alpha);
                if next_t <= settings.transmittance_min {
                    open[ty] &= !(1 << k);
                    n_open -= 1;
                    continue;
                }
                let more = visitor.contribution(Contribution {
                    pixel: py * view.width + px,
                    gaussian: gid,
                    weight: alpha * t[li],
                    t_after: next_t,
                });
                t[li] = next_t;
                if !more {
                    open[ty] &= !(1 << k);
                    n_open -= 1;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::request::RenderRequest;
    use splatseg_scene::{Camera, Pose};

    /// A few overlapping Gaussians in front of a 40×36 camera (two bands of tiles, a partial
    /// tile on each edge).
    fn scene() -> (Gaussians, RenderCamera) {
        let mut g = Gaussians::default();
        let spots = [
            ([0.0, 0.0, 3.0], -1.6, 2.0),
            ([0.3, -0.2, 3.5], -1.2, 0.5),
            ([-0.4, 0.3, 2.5], -1.9, 3.0),
            ([0.1, 0.45, 4.0], -1.0, 1.0),
            ([0.6, 0.6, 2.0], -2.2, 6.0),
        ];
        for (i, (m, s, o)) in spots.into_iter().enumerate() {
            g.means.push(m);
            g.log_scales.push([s, s + 0.3, s - 0.2]);
            g.rotations.push([1.0, 0.1 * i as f32, 0.0, 0.05]);
            g.raw_opacities.push(o);
            g.sh_dc.push([i as f32, 1.0, 0.0]);
        }
        let camera =
            RenderCamera::from_scene(&Camera::pinhole(1, 40, 36, 30.0, 30.0, 20.0, 18.0), &Pose::IDENTITY);
        (g, camera)
    }

    /// Collects every visit.
    #[derive(Default)]
    struct Record {
        blends: Vec<Contribution>,
        finals: Vec<(usize, f32)>,
    }

    impl ContributionVisitor for Record {
        fn contribution(&mut self, c: Contribution) -> bool {
            self.blends.push(c);
            true
        }
        fn pixel_done(&mut self, pixel: usize, t_final: f32) {
            self.finals.push((pixel, t_final));
        }
    }

    /// Σ w·feature and the final transmittance agree with the rasteriser's blend of the same
    /// feature (a one-hot of the Gaussian index), pixel by pixel.
    #[test]
    fn contributions_reproduce_the_rasterised_blend() {
        let (g, camera) = scene();
        let settings = RasterSettings::default();
        let n = g.len();
        let one_hot: Vec<f32> = (0..n * n).map(|k| if k / n == k % n { 1.0 } else { 0.0 }).collect();
        let request = RenderRequest {
            rgb: false,
            alpha: true,
            features: Some(crate::request::FeatureInput { values: &one_hot, dim: n }),
            ..RenderRequest::default()
        };
        let out = crate::render(&g, &camera, &request).expect("renders");
        let features = out.features.expect("features");
        let alpha = out.alpha.expect("alpha");
        let view = ProjectedView::new(&g, &camera, &settings).expect("valid camera");
        let bands = visit_contributions(&view, &settings, |_| Record::default());
        let pixels = view.width * view.height;
        let mut sums = vec![0.0f32; pixels * n];
        let mut t_final = vec![f32::NAN; pixels];
        let mut blended = 0;
        for band in &bands {
            for c in &band.blends {
                sums[c.pixel * n + c.gaussian as usize] += c.weight;
                blended += 1;
            }
            for &(p, t) in &band.finals {
                assert!(t_final[p].is_nan(), "pixel {p} finished twice");
                t_final[p] = t;
            }
        }
        assert!(blended > 500, "only {blended} blends: the scene proves little");
        for p in 0..pixels {
            for k in 0..n {
                let (ours, theirs) = (sums[p * n + k], features[p * n + k]);
                assert!((ours - theirs).abs() <= 1e-5, "pixel {p}, Gaussian {k}: {ours} vs {theirs}");
            }
            let a = 1.0 - t_final[p];
            assert!((a - alpha.data[p]).abs() <= 1e-6, "pixel {p}: alpha {a} vs {}", alpha.data[p]);
        }
    }

    /// Per pixel the weights come front to back and each `t_after` is the next `T_before`.
    #[test]
    fn contributions_come_front_to_back_per_pixel() {
        let (g, camera) = scene();
        let settings = RasterSettings::default();
        let view = ProjectedView::new(&g, &camera, &settings).expect("valid camera");
        let bands = visit_contributions(&view, &settings, |_| Record::default());
        let mut last: std::collections::HashMap<usize, (f32, f32)> = Default::default();
        for c in bands.iter().flat_map(|b| &b.blends) {
            let depth = view.splats[c.gaussian as usize].depth;
            let (prev_depth, t_before) = last.get(&c.pixel).copied().unwrap_or((f32::NEG_INFINITY, 1.0));
            assert!(depth >= prev_depth, "pixel {}: depth {depth} after {prev_depth}", c.pixel);
            let alpha = c.weight / t_before;
            assert!((c.t_after - t_before * (1.0 - alpha)).abs() < 1e-6);
            last.insert(c.pixel, (depth, c.t_after));
        }
    }

    /// The AVX2 build of the tile loop (when the CPU has it), with and without the trimmed box
    /// rows and the precomputed reaches, gives the contributions of the baseline build
    /// (portable, every box row, footprints made per tile), bit for bit and in the same order.
    #[test]
    fn every_build_gives_the_same_contributions() {
        for (g, camera) in [scene(), crowded_scene(7, 600), crowded_scene(8, 3000)] {
            compare_builds(&g, &camera);
        }
    }

    /// `n` overlapping Gaussians of mixed sizes (σ from about half a pixel to seven), shapes
    /// and opacities before a 70×50 camera.
    fn crowded_scene(mut seed: u32, n: usize) -> (Gaussians, RenderCamera) {
        let mut unit = move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let mut g = Gaussians::default();
        for _ in 0..n {
            let z = 2.0 + 4.0 * unit();
            g.means.push([(unit() - 0.5) * 1.4 * z, (unit() - 0.5) * 1.0 * z, z]);
            let s = -3.5 + 2.0 * unit();
            g.log_scales.push([s, s + unit() - 0.5, s + 1.5 * unit() - 0.75]);
            g.rotations.push([1.0, unit() - 0.5, unit() - 0.5, unit() - 0.5]);
            g.raw_opacities.push(8.0 * unit() - 3.0);
            g.sh_dc.push([0.0; 3]);
        }
        let camera =
            RenderCamera::from_scene(&Camera::pinhole(1, 70, 50, 60.0, 60.0, 35.0, 25.0), &Pose::IDENTITY);
        (g, camera)
    }

    fn compare_builds(g: &Gaussians, camera: &RenderCamera) {
        let settings = RasterSettings::default();
        let view = ProjectedView::new(g, camera, &settings).expect("valid camera");
        let run = |avx2, trim_rows, reach| {
            visit_contributions_with(
                &view,
                &settings,
                |_| Record::default(),
                Build { avx2, trim_rows, reach },
            )
        };
        let base = run(false, false, false);
        let blends: usize = base.iter().map(|b| b.blends.len()).sum();
        assert!(blends > 500, "only {blends} blends: the scene proves little");
        let mut builds = vec![run(false, true, false), run(false, false, true), run(false, true, true)];
        if avx2_available() {
            builds.extend([run(true, false, false), run(true, true, false), run(true, true, true)]);
        } else {
            eprintln!("no AVX2 on this CPU: only the portable builds run");
        }
        for (a, b) in builds.iter().flat_map(|other| base.iter().zip(other)) {
            assert_eq!(a.blends.len(), b.blends.len());
            for (x, y) in a.blends.iter().zip(&b.blends) {
                assert_eq!((x.pixel, x.gaussian), (y.pixel, y.gaussian));
                assert_eq!(
                    (x.weight.to_bits(), x.t_after.to_bits()),
                    (y.weight.to_bits(), y.t_after.to_bits())
                );
            }
            let bits = |f: &[(usize, f32)]| f.iter().map(|&(p, t)| (p, t.to_bits())).collect::<Vec<_>>();
            assert_eq!(bits(&a.finals), bits(&b.finals));
        }
    }

    /// Stops each pixel at the first contribution that brings transmittance below 0.5.
    #[derive(Default)]
    struct StopAtHalf(Record);

    impl ContributionVisitor for StopAtHalf {
        fn contribution(&mut self, c: Contribution) -> bool {
            self.0.blends.push(c);
            c.t_after >= 0.5
        }
        fn pixel_done(&mut self, pixel: usize, t_final: f32) {
            self.0.finals.push((pixel, t_final));
        }
    }

    /// A visitor that declines a pixel's further contributions gets the full pass's
    /// contributions up to and including that one, and nothing after it.
    #[test]
    fn a_visitor_can_finish_a_pixel_early() {
        let (g, camera) = scene();
        let settings = RasterSettings::default();
        let view = ProjectedView::new(&g, &camera, &settings).expect("valid camera");
        let full = visit_contributions(&view, &settings, |_| Record::default());
        let early = visit_contributions(&view, &settings, |_| StopAtHalf::default());
        let per_pixel = |blends: &mut dyn Iterator<Item = Contribution>| {
            let mut m: std::collections::BTreeMap<usize, Vec<Contribution>> = Default::default();
            for c in blends {
                m.entry(c.pixel).or_default().push(c);
            }
            m
        };
        let full_px = per_pixel(&mut full.iter().flat_map(|b| b.blends.iter().copied()));
        let early_px = per_pixel(&mut early.iter().flat_map(|b| b.0.blends.iter().copied()));
        let finals: std::collections::HashMap<usize, f32> =
            early.iter().flat_map(|b| b.0.finals.iter().copied()).collect();
        let mut stopped = 0;
        for (p, all) in &full_px {
            let cut = all.iter().position(|c| c.t_after < 0.5).map_or(all.len(), |k| k + 1);
            assert_eq!(early_px.get(p).map_or(&[][..], |v| &v[..]), &all[..cut], "pixel {p}");
            if cut < all.len() {
                stopped += 1;
                assert_eq!(finals[p], all[cut - 1].t_after, "pixel {p}");
            }
        }
        assert!(stopped > 20, "only {stopped} pixels stopped early: the scene proves little");
    }
}
