//! What each view says about each Gaussian, measured by rendered contribution: for every pixel,
//! the Gaussians the renderer blends there and their weights `α·T`
//! ([`splatseg_render::visit_contributions`], the one compositor), summed per (Gaussian, label of
//! the pixel). A Gaussian hidden behind a surface gets `T ≈ 0` and so no weight: occlusion needs
//! no separate depth test, and a Gaussian's footprint, not only its centre, decides which masks
//! it lies in.
//!
//! Also the surface depth of a view (the depth where transmittance first falls below
//! `surface_transmittance`, the "median depth"), which the merge stage uses when no depth maps
//! are given.

use crate::config::LiftConfig;
use crate::error::{LiftError, LiftResult};
use crate::prepared::PreparedGaussians;
use splatseg_render::{
    visit_contributions, Contribution, ContributionVisitor, ProjectedView, RasterSettings, RenderCamera,
};
use splatseg_scene::{Camera, Plane, Pose};

/// Projects and bins the Gaussians for one view (the renderer's 3DGS rules; lens distortion is
/// ignored, as the renderer does).
pub fn project_view(
    gaussians: &PreparedGaussians,
    camera: &Camera,
    world_from_cam: &Pose,
    config: &LiftConfig,
) -> LiftResult<ProjectedView> {
    let mut cam = RenderCamera::from_scene(camera, world_from_cam);
    cam.near = config.near;
    ProjectedView::new(&gaussians.geometry, &cam, &RasterSettings::default())
        .map_err(|e| LiftError::Camera(e.to_string()))
}

/// Per view: the summed blending weight of each Gaussian over the pixels of each label.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ViewContributions {
    /// `[n]` Gaussian indices, non-decreasing (a Gaussian appears once per label it reaches).
    pub gaussians: Vec<u32>,
    /// `[n]` label of the pixels (0 = pixels in no mask), increasing within a Gaussian.
    pub labels: Vec<u32>,
    /// `[n]` `Σ α·T` of the Gaussian over the pixels of that label (in pixels: a fully visible,
    /// opaque Gaussian covering 3 pixels weighs about 3).
    pub weights: Vec<f32>,
    /// `[n]` `Σ α` over the same pixels: what the Gaussian would weigh with nothing in front.
    /// `Σ weights / Σ alphas` is the Gaussian's mean transmittance, its visibility in the view.
    pub alphas: Vec<f32>,
}

/// One Gaussian's verdict in one view: the label it contributes most to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DominantLabel {
    /// Gaussian index.
    pub gaussian: u32,
    /// The label with the largest summed weight (ties: the smaller label).
    pub label: u32,
    /// The Gaussian's total weight in the view, all labels.
    pub total: f32,
}

impl ViewContributions {
    /// Number of (Gaussian, label) entries.
    pub fn len(&self) -> usize {
        self.gaussians.len()
    }

    /// True when the view sees no Gaussian.
    pub fn is_empty(&self) -> bool {
        self.gaussians.is_empty()
    }

    /// Entries `[start, end)` of each Gaussian, in Gaussian order.
    pub fn per_gaussian(&self) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
        let mut start = 0;
        std::iter::from_fn(move || {
            if start >= self.gaussians.len() {
                return None;
            }
            let g = self.gaussians[start];
            let end = start + self.gaussians[start..].partition_point(|&x| x == g);
            let range = start..end;
            start = end;
            Some(range)
        })
    }

    /// Whether the view sees the Gaussian of entries `range`: its total weight reaches
    /// `config.min_view_weight` and its visibility (mean transmittance) `config.min_visibility`.
    pub fn sees(&self, range: std::ops::Range<usize>, config: &LiftConfig) -> bool {
        let total: f32 = self.weights[range.clone()].iter().sum();
        let alpha: f32 = self.alphas[range].iter().sum();
        total >= config.min_view_weight && total >= config.min_visibility * alpha
    }

    /// The dominant label of every Gaussian the view sees ([`Self::sees`]), in Gaussian order.
    pub fn dominant(&self, config: &LiftConfig) -> Vec<DominantLabel> {
        self.per_gaussian()
            .filter_map(|r| {
                let total: f32 = self.weights[r.clone()].iter().sum();
                let sees = self.sees(r.clone(), config);
                let best = r.max_by(|&a, &b| self.weights[a].total_cmp(&self.weights[b]).then(b.cmp(&a)))?;
                sees.then_some(DominantLabel {
                    gaussian: self.gaussians[best],
                    label: self.labels[best],
                    total,
                })
            })
            .collect()
    }
}

/// Accumulates one band's contributions as (Gaussian, label, weight, α) runs: a splat's pixels in
/// one tile come one after another, so consecutive blends of one (Gaussian, label) add up in
/// place.
struct LabelRuns<'a> {
    labels: &'a [u32],
    runs: Vec<(u32, u32, f32, f32)>,
}

impl ContributionVisitor for LabelRuns<'_> {
    fn contribution(&mut self, c: Contribution) {
        let label = self.labels[c.pixel];
        // w = α·T_before and t_after = T_before·(1 − α), so T_before = w + t_after.
        let alpha = c.weight / (c.weight + c.t_after).max(f32::MIN_POSITIVE);
        match self.runs.last_mut() {
            Some(last) if last.0 == c.gaussian && last.1 == label => {
                last.2 += c.weight;
                last.3 += alpha;
            }
            _ => self.runs.push((c.gaussian, label, c.weight, alpha)),
        }
    }
}

/// Sorts `(Gaussian, label, weight, α)` runs and sums equal keys (stable: equal keys add up in
/// their order in `runs`).
fn aggregate(mut runs: Vec<(u32, u32, f32, f32)>) -> ViewContributions {
    runs.sort_by_key(|r| (r.0, r.1));
    let mut out = ViewContributions::default();
    for (g, label, w, a) in runs {
        if out.gaussians.last() == Some(&g) && out.labels.last() == Some(&label) {
            if let (Some(lw), Some(la)) = (out.weights.last_mut(), out.alphas.last_mut()) {
                *lw += w;
                *la += a;
            }
        } else {
            out.gaussians.push(g);
            out.labels.push(label);
            out.weights.push(w);
            out.alphas.push(a);
        }
    }
    out
}

/// Label runs and the surface depth of one band together.
struct RunsAndDepth<'a> {
    runs: LabelRuns<'a>,
    depth: SurfaceDepth<'a>,
}

impl ContributionVisitor for RunsAndDepth<'_> {
    fn contribution(&mut self, c: Contribution) {
        self.runs.contribution(c);
        self.depth.contribution(c);
    }
}

/// The contributions of the Gaussians a view sees to the labels of `labels` (`[H, W]` of this
/// view, any label values, 0 = no mask).
///
/// A Gaussian counts as seen when its centre falls in the image and its depth passes the test
/// against the view's surface depth `D` at that pixel ([`view_surface_depth`], from the same
/// pass): `z ≤ D · (1 + depth_rel_tol) + depth_sigma_tol · σ` (σ its own size, so a large
/// Gaussian whose centre sits slightly behind the surface it forms still counts). Gaussians
/// behind a surface get little weight through it, but real surfaces of 3DGS scenes (and ours)
/// let some light through; the test keeps such leaks from voting.
pub fn view_contributions(
    gaussians: &PreparedGaussians,
    camera: &Camera,
    world_from_cam: &Pose,
    labels: &Plane<u32>,
    config: &LiftConfig,
) -> LiftResult<ViewContributions> {
    let (w, h) = (camera.width as usize, camera.height as usize);
    if labels.size() != (w, h) {
        return Err(LiftError::LabelMapSize {
            view: 0,
            got_w: labels.width,
            got_h: labels.height,
            want_w: w,
            want_h: h,
        });
    }
    let view = project_view(gaussians, camera, world_from_cam, config)?;
    let band_px = splatseg_render::bin::TILE_SIZE * w;
    let bands = visit_contributions(&view, &RasterSettings::default(), |band| RunsAndDepth {
        runs: LabelRuns { labels: &labels.data, runs: Vec::new() },
        depth: SurfaceDepth {
            splats: &view.splats,
            stop: config.surface_transmittance,
            first: band * band_px,
            depth: vec![f32::INFINITY; band_px.min(w * h - band * band_px)],
        },
    });
    let mut runs = Vec::new();
    let mut surface = Vec::with_capacity(w * h);
    for band in bands {
        runs.extend(band.runs.runs);
        surface.extend(band.depth.depth);
    }
    let seen = |g: u32| {
        let s = &view.splats[g as usize];
        let [u, v] = s.mean2d;
        if !(u >= 0.0 && v >= 0.0 && u < w as f32 && v < h as f32) {
            return false;
        }
        let d = surface[v as usize * w + u as usize];
        s.depth <= d * (1.0 + config.depth_rel_tol) + config.depth_sigma_tol * gaussians.sigmas[g as usize]
    };
    runs.retain(|r| seen(r.0));
    Ok(aggregate(runs))
}

/// Writes, per pixel of one band, the depth of the splat at which transmittance first falls
/// below the threshold.
struct SurfaceDepth<'a> {
    splats: &'a [splatseg_render::project::Splat2d],
    stop: f32,
    /// Pixel index of the band's first pixel.
    first: usize,
    depth: Vec<f32>,
}

impl ContributionVisitor for SurfaceDepth<'_> {
    fn contribution(&mut self, c: Contribution) {
        let slot = &mut self.depth[c.pixel - self.first];
        if c.t_after < self.stop && !slot.is_finite() {
            *slot = self.splats[c.gaussian as usize].depth;
        }
    }
}

/// The surface depth of one view: `[height, width]` metric z of the Gaussian at which the
/// front-to-back transmittance first drops below `config.surface_transmittance`, +∞ where it
/// never does.
pub fn view_surface_depth(
    gaussians: &PreparedGaussians,
    camera: &Camera,
    world_from_cam: &Pose,
    config: &LiftConfig,
) -> LiftResult<Plane<f32>> {
    let view = project_view(gaussians, camera, world_from_cam, config)?;
    let (w, h) = (view.width, view.height);
    let band_px = splatseg_render::bin::TILE_SIZE * w;
    let bands = visit_contributions(&view, &RasterSettings::default(), |band| SurfaceDepth {
        splats: &view.splats,
        stop: config.surface_transmittance,
        first: band * band_px,
        depth: vec![f32::INFINITY; band_px.min(w * h - band * band_px)],
    });
    let data = bands.into_iter().flat_map(|b| b.depth).collect();
    Ok(Plane { width: w, height: h, data })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aggregation_sums_equal_keys_and_sorts() {
        let runs =
            vec![(3, 1, 0.5, 0.5), (1, 2, 1.0, 1.0), (3, 1, 0.25, 0.5), (1, 0, 2.0, 2.0), (3, 0, 1.0, 1.0)];
        let c = aggregate(runs);
        assert_eq!(c.gaussians, vec![1, 1, 3, 3]);
        assert_eq!(c.labels, vec![0, 2, 0, 1]);
        assert_eq!(c.weights, vec![2.0, 1.0, 1.0, 0.75]);
        assert_eq!(c.alphas, vec![2.0, 1.0, 1.0, 1.0]);
        let config = |min_view_weight, min_visibility| LiftConfig {
            min_view_weight,
            min_visibility,
            ..LiftConfig::default()
        };
        let d = c.dominant(&config(2.0, 0.0));
        assert_eq!(d, vec![DominantLabel { gaussian: 1, label: 0, total: 3.0 }]);
        let d = c.dominant(&config(0.0, 0.0));
        assert_eq!(d[1], DominantLabel { gaussian: 3, label: 0, total: 1.75 });
        // Gaussian 3 has weight 1.75 of α 2.0: visibility 0.875.
        assert_eq!(c.dominant(&config(0.0, 0.9)).len(), 1);
    }
}
