//! Which Gaussians a view sees: a depth test against the surface depth of the composited
//! Gaussians (not the centres alone), on the renderer's own projection and compositor.
//!
//! The surface depth `D` of a pixel is the depth of the Gaussian at which the front-to-back
//! transmittance first drops below [`SURFACE_TRANSMITTANCE`] (0.5: the median depth), or +∞ where
//! it never does. A Gaussian is visible when its centre projects inside the image and
//! `z ≤ D · (1 + DEPTH_REL_TOL) + DEPTH_SIGMA_TOL · σ_ray` at its centre pixel (σ_ray: its own
//! extent along the ray, so a large Gaussian whose centre sits slightly behind the surface it
//! forms still counts). Callers may pass their own depth maps instead (e.g. from a renderer).
//!
//! Each visible Gaussian gets a fusion weight `w = frontal · f / z` (f: mean focal length in
//! pixels, so `f / z` is pixels per scene unit — near views weigh more) with
//! `frontal = max(MIN_FRONTAL, (1 − ρ) + ρ·|n̂ · r̂|)`, ρ the Gaussian's flatness and n̂ its
//! normal (flat Gaussians seen face-on weigh most; round ones ignore the angle).
//!
//! One projection serves both the surface depth and the test ([`view_visibility`], which also
//! hands back the view's tile lists for rendering the labels back).

use crate::config::LiftConfig;
use crate::project::{project_view, raster_settings, PreparedGaussians};
use glam::Vec3;
use splatseg_render::bin::TileBins;

/// The surface depth of a pixel is where front-to-back transmittance first drops below this:
/// 0.5 is the median depth of the composited footprints (the depth 3DGS renderers report).
pub const SURFACE_TRANSMITTANCE: f32 = 0.5;

/// Relative slack of the depth test (3 % of the surface depth): the surface depth is a median
/// over blended footprints, so a Gaussian that forms the surface can sit slightly behind it.
const DEPTH_REL_TOL: f32 = 0.03;

/// Slack of the depth test in the Gaussian's own standard deviations along the ray (1 σ): a
/// large Gaussian whose centre sits behind the surface it forms still counts.
const DEPTH_SIGMA_TOL: f32 = 1.0;

/// Floor of the frontal factor of the fusion weight, so grazing views still count a little.
const MIN_FRONTAL: f32 = 0.05;
use splatseg_render::{visit_contributions, Contribution, ContributionVisitor, ProjectedView};
use splatseg_scene::{Camera, Plane, Pose};

/// The Gaussians one view sees.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ViewVisibility {
    /// `[n_visible]` Gaussian indices, strictly increasing.
    pub gaussians: Vec<u32>,
    /// `[n_visible]` row-major index of the pixel each centre falls in.
    pub pixels: Vec<u32>,
    /// `[n_visible]` fusion weights.
    pub weights: Vec<f32>,
}

/// Surface depth and normal of one band of 16 rows: `[rows, width]`, the first pixel `first`.
struct DepthBand<'a> {
    view: &'a ProjectedView,
    /// `[N]` camera-space unit normal of each Gaussian turned towards the camera, scaled by its
    /// flatness (round Gaussians say nothing about the surface's orientation).
    normals: &'a [Vec3],
    first: usize,
    stop: f32,
    depth: Vec<f32>,
    /// `[rows · width]` blending-weighted sums of `normals` in front of the surface depth, and
    /// of the weights.
    normal_sums: Vec<Vec3>,
    weight_sums: Vec<f32>,
}

impl ContributionVisitor for DepthBand<'_> {
    #[inline(always)]
    fn contribution(&mut self, c: Contribution) -> bool {
        let p = c.pixel - self.first;
        self.normal_sums[p] += c.weight * self.normals[c.gaussian as usize];
        self.weight_sums[p] += c.weight;
        if c.t_after < self.stop {
            self.depth[p] = self.view.splats[c.gaussian as usize].depth;
            return false;
        }
        true
    }
}

/// Smallest length of a pixel's blended normal, as a fraction of the blended weight, for the
/// pixel to have a normal: the Gaussians in front of its surface depth must be mostly flat and
/// mostly agree (½, as for a side's normals in the merge's crease gate).
const MIN_NORMAL_AGREEMENT: f32 = 0.5;

/// Steps of the grid rendered normals are rounded to (per component; `i16` in a spilled pass,
/// so a pass read back equals the one computed).
pub const NORMAL_STEPS: f32 = 32767.0;

/// A pixel's rendered normal from its sums: unit, rounded to [`NORMAL_STEPS`], NaN when the
/// pixel has no surface or its Gaussians are round or disagree.
fn pixel_normal(sum: Vec3, weight: f32, depth: f32) -> [f32; 3] {
    let len = sum.length();
    if !depth.is_finite() || len.is_nan() || len <= 0.0 || len < MIN_NORMAL_AGREEMENT * weight {
        return [f32::NAN; 3];
    }
    (sum / len).to_array().map(|c| (c * NORMAL_STEPS).round() / NORMAL_STEPS)
}

/// `[N]` camera-space normals of the Gaussians for [`DepthBand`] (zero for culled ones).
fn camera_normals(gaussians: &PreparedGaussians, view: &ProjectedView, world_from_cam: &Pose) -> Vec<Vec3> {
    let cam_from_world = world_from_cam.rotation.transpose().as_mat3();
    let centre = world_from_cam.translation.as_vec3();
    (0..view.splats.len())
        .map(|i| {
            if view.splats[i].is_culled() {
                return Vec3::ZERO;
            }
            let n = gaussians.normals[i];
            let towards = if n.dot(gaussians.mean(i) - centre) > 0.0 { -n } else { n };
            gaussians.flatness[i] * (cam_from_world * towards)
        })
        .collect()
}

/// Surface depth and normals per pixel of a projected view: `[height, width]` metric z (+∞
/// where transmittance never drops below [`SURFACE_TRANSMITTANCE`]) and camera-space unit
/// normals facing the camera (blended from the Gaussians' shortest axes in front of the
/// surface depth, weighted by flatness; NaN where there is none, see [`pixel_normal`]).
pub(crate) fn surface(
    gaussians: &PreparedGaussians,
    view: &ProjectedView,
    world_from_cam: &Pose,
) -> (Plane<f32>, Plane<[f32; 3]>) {
    let (width, height) = (view.width, view.height);
    let normals = camera_normals(gaussians, view, world_from_cam);
    let band_rows = splatseg_render::bin::TILE_SIZE;
    let bands = visit_contributions(view, &raster_settings(), |b| {
        let rows = band_rows.min(height - b * band_rows);
        DepthBand {
            view,
            normals: &normals,
            first: b * band_rows * width,
            stop: SURFACE_TRANSMITTANCE,
            depth: vec![f32::INFINITY; rows * width],
            normal_sums: vec![Vec3::ZERO; rows * width],
            weight_sums: vec![0.0; rows * width],
        }
    });
    let mut depth = Vec::with_capacity(width * height);
    let mut normal = Vec::with_capacity(width * height);
    for band in bands {
        for ((&d, &sum), &weight) in band.depth.iter().zip(&band.normal_sums).zip(&band.weight_sums) {
            normal.push(pixel_normal(sum, weight, d));
        }
        depth.extend(band.depth);
    }
    (Plane { width, height, data: depth }, Plane { width, height, data: normal })
}

/// The visibility test of a projected view against `depth` (`[height, width]` metric z,
/// 0 / non-finite = no surface).
pub(crate) fn visible_gaussians(
    gaussians: &PreparedGaussians,
    view: &ProjectedView,
    camera: &Camera,
    world_from_cam: &Pose,
    depth: &Plane<f32>,
    _config: &LiftConfig,
) -> ViewVisibility {
    let (width, height) = (view.width, view.height);
    let focal = 0.5 * (camera.fx + camera.fy) as f32;
    let centre = world_from_cam.translation.as_vec3();
    let alpha_min = raster_settings().alpha_min;
    let mut out = ViewVisibility::default();
    for (i, s) in view.splats.iter().enumerate() {
        if s.is_culled() || s.opacity < alpha_min {
            continue;
        }
        let [u, v] = s.mean2d;
        if !(u >= 0.0 && v >= 0.0 && u < width as f32 && v < height as f32) {
            continue;
        }
        let p = v as usize * width + u as usize;
        let d = depth.data[p];
        let surface = if d.is_finite() && d > 0.0 { d } else { f32::INFINITY };
        let ray = (gaussians.mean(i) - centre).normalize_or_zero();
        let sigma_ray = gaussians.sigma_along(i, ray);
        if s.depth > surface * (1.0 + DEPTH_REL_TOL) + DEPTH_SIGMA_TOL * sigma_ray {
            continue;
        }
        let rho = gaussians.flatness[i];
        let frontal = ((1.0 - rho) + rho * gaussians.normals[i].dot(ray).abs()).max(MIN_FRONTAL);
        out.gaussians.push(i as u32);
        out.pixels.push(p as u32);
        out.weights.push(frontal * focal / s.depth);
    }
    out
}

/// What one visibility pass over a view gives.
#[derive(Clone, Debug)]
pub struct VisibilityPass {
    /// `[height, width]` surface depth from the Gaussians' own footprints, metric z (+∞ where
    /// transmittance never drops below `surface_transmittance`); `None` when a depth map was given.
    pub surface_depth: Option<Plane<f32>>,
    /// `[height, width]` camera-space unit normals of that surface facing the camera (NaN where
    /// there is none); `None` when a depth map was given.
    pub surface_normals: Option<Plane<[f32; 3]>>,
    /// The Gaussians the view sees, tested against that depth (or the given one).
    pub visible: ViewVisibility,
    /// The view's tile lists, which a later pass over the same view may reuse instead of sorting
    /// the splats again ([`crate::render_label_map`]).
    pub tile_lists: TileBins,
}

/// The visibility of every Gaussian in one view, from one projection: the depth test against
/// the surface depth of the Gaussians' own footprints (`depth: None`, the depth is returned too)
/// or against a given map (`[height, width]` metric z, 0 / non-finite = no surface).
pub fn view_visibility(
    gaussians: &PreparedGaussians,
    camera: &Camera,
    world_from_cam: &Pose,
    depth: Option<&Plane<f32>>,
    config: &LiftConfig,
) -> VisibilityPass {
    let view = project_view(gaussians, camera, world_from_cam, config);
    let test =
        |depth: &Plane<f32>| visible_gaussians(gaussians, &view, camera, world_from_cam, depth, config);
    let (surface_depth, surface_normals, visible) = match depth {
        Some(given) => (None, None, test(given)),
        None => {
            let (own, normals) = surface(gaussians, &view, world_from_cam);
            let visible = test(&own);
            (Some(own), Some(normals), visible)
        }
    };
    VisibilityPass { surface_depth, surface_normals, visible, tile_lists: view.bins }
}
