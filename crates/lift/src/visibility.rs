//! Which Gaussians a view sees: a depth test against the surface depth of the composited
//! Gaussian footprints (not the centres alone).
//!
//! The surface depth `D` of a pixel is the depth of the splat at which the front-to-back
//! transmittance first drops below `surface_transmittance` (0.5: the median depth), or +∞ where
//! it never does. A Gaussian is visible when its centre projects inside the image and
//! `z ≤ D · (1 + depth_rel_tol) + depth_sigma_tol · σ_ray` at its centre pixel (σ_ray: its own
//! extent along the ray, so a large Gaussian whose centre sits slightly behind the surface it
//! forms still counts). Callers may pass their own depth maps instead (e.g. from a renderer).
//!
//! Each visible Gaussian gets a fusion weight `w = frontal · f / z` (f: mean focal length in
//! pixels, so `f / z` is pixels per scene unit — near views weigh more) with
//! `frontal = max(min_frontal, (1 − ρ) + ρ·|n̂ · r̂|)`, ρ the Gaussian's flatness and n̂ its
//! normal (flat Gaussians seen face-on weigh most; round ones ignore the angle).

use crate::composite::{composite, sort_by_depth};
use crate::config::LiftConfig;
use crate::project::{project_view, PreparedGaussians, Splat};
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

impl ViewVisibility {
    /// Number of visible Gaussians.
    pub fn len(&self) -> usize {
        self.gaussians.len()
    }

    /// True when the view sees no Gaussian.
    pub fn is_empty(&self) -> bool {
        self.gaussians.is_empty()
    }
}

/// Surface depth per pixel (`[height * width]`, +∞ = no surface) of depth-sorted `splats`.
pub fn surface_depth(splats: &[Splat], width: usize, height: usize, config: &LiftConfig) -> Plane<f32> {
    let mut depth = Plane::filled(width, height, f32::INFINITY);
    let stop = config.surface_transmittance;
    composite(splats, width, height, stop, |p, k, _, t_after| {
        if t_after < stop {
            depth.data[p] = splats[k].depth;
        }
    });
    depth
}

/// The surface depth of one view from the Gaussians' own footprints: `[height, width]` metric z
/// (+∞ where transmittance never drops below `surface_transmittance`).
pub fn view_surface_depth(
    gaussians: &PreparedGaussians,
    camera: &Camera,
    world_from_cam: &Pose,
    config: &LiftConfig,
) -> Plane<f32> {
    let mut splats = project_view(gaussians, camera, world_from_cam, config);
    sort_by_depth(&mut splats);
    surface_depth(&splats, camera.width as usize, camera.height as usize, config)
}

/// Visibility of all Gaussians in one view, with the surface depth from their own footprints
/// (`depth: None`) or from a given map (`[height, width]` metric z, 0 / non-finite = none).
pub fn view_visibility(
    gaussians: &PreparedGaussians,
    camera: &Camera,
    world_from_cam: &Pose,
    depth: Option<&Plane<f32>>,
    config: &LiftConfig,
) -> ViewVisibility {
    let (width, height) = (camera.width as usize, camera.height as usize);
    let mut splats = project_view(gaussians, camera, world_from_cam, config);
    sort_by_depth(&mut splats);
    let own_depth;
    let depth = match depth {
        Some(d) => d,
        None => {
            own_depth = surface_depth(&splats, width, height, config);
            &own_depth
        }
    };
    let focal = 0.5 * (camera.fx + camera.fy) as f32;
    let mut visible: Vec<(u32, u32, f32)> = Vec::new();
    for s in &splats {
        let [u, v] = s.centre_px;
        if !(u >= 0.0 && v >= 0.0 && u < width as f32 && v < height as f32) {
            continue;
        }
        let p = v as usize * width + u as usize;
        let d = depth.data[p];
        let surface = if d.is_finite() && d > 0.0 { d } else { f32::INFINITY };
        if s.depth > surface * (1.0 + config.depth_rel_tol) + config.depth_sigma_tol * s.sigma_ray {
            continue;
        }
        let i = s.index as usize;
        let rho = gaussians.flatness[i];
        let frontal = ((1.0 - rho) + rho * gaussians.normals[i].dot(s.ray).abs()).max(config.min_frontal);
        visible.push((s.index, p as u32, frontal * focal / s.depth));
    }
    visible.sort_unstable_by_key(|v| v.0);
    ViewVisibility {
        gaussians: visible.iter().map(|v| v.0).collect(),
        pixels: visible.iter().map(|v| v.1).collect(),
        weights: visible.iter().map(|v| v.2).collect(),
    }
}
