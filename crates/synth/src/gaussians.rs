//! Gaussians on the visible surfaces: every shape is sampled on a jittered grid, samples no view
//! sees are dropped, and each remaining sample becomes a flat disc (two in-plane scales, one
//! tiny scale along the normal) with the surface's shaded colour as SH degree 0 and a high
//! opacity. Each Gaussian's ground-truth id is the id of the surface it was sampled on.
//! [`CueConfig`]'s `gaussian_*` knobs make them less exact, as a trained 3DGS's are: discs
//! tilted off the surface, thicker, moved off it along their normals, of spread sizes, and a
//! share of them floaters in free space.

use crate::config::CueConfig;
use crate::geometry::SurfacePoint;
use crate::layout::SceneObject;
use crate::noise::{hash, normal, rng_for, stream, unit};
use crate::render::{shade, RenderedView};
use glam::{DMat3, DQuat, DVec3};
use rayon::prelude::*;
use splatseg_scene::gaussians::SH_C0;
use splatseg_scene::{Camera, Gaussians, Pose};

/// Opacity of every Gaussian (stored as its logit).
const OPACITY: f32 = 0.95;
/// In-plane standard deviation as a fraction of the sample spacing.
const DISC_SIGMA_FRACTION: f64 = 0.6;

/// A sample is visible in a view when its depth matches the ground-truth depth of the pixel it
/// projects to within `VISIBILITY_ABS_M + VISIBILITY_REL · z`.
pub const VISIBILITY_ABS_M: f64 = 0.01;
/// Relative part of the visibility tolerance (see [`VISIBILITY_ABS_M`]).
pub const VISIBILITY_REL: f64 = 0.01;

/// Gaussians with their ground-truth instance ids.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceGaussians {
    /// The Gaussians (SH degree 0, normals set to the surface normals).
    pub gaussians: Gaussians,
    /// `[N]` ground-truth instance id of each Gaussian.
    pub ids: Vec<u32>,
}

/// True when the point `p_world` is seen at its pixel in the view (`gt_depth`: `[H, W]` metric z).
pub fn visible_in(
    p_world: DVec3,
    camera: &Camera,
    cam_from_world: &Pose,
    gt_depth: &splatseg_scene::Plane<f32>,
) -> bool {
    let p_cam = cam_from_world.transform_point(p_world);
    let Some(uv) = camera.project(p_cam) else { return false };
    if uv.x < 0.0 || uv.y < 0.0 || uv.x >= camera.width as f64 || uv.y >= camera.height as f64 {
        return false;
    }
    let z = *gt_depth.get(uv.x as usize, uv.y as usize) as f64;
    z > 0.0 && (z - p_cam.z).abs() <= VISIBILITY_ABS_M + VISIBILITY_REL * p_cam.z
}

/// Samples all surfaces at `spacing_m` and keeps what at least one view sees, each Gaussian as
/// exact as `fit`'s `gaussian_*` knobs say.
///
/// `poses`: `[V]` `world_from_cam`; `rendered`: `[V]` the rendered views (for their depth).
pub fn surface_gaussians(
    objects: &[SceneObject],
    camera: &Camera,
    poses: &[Pose],
    rendered: &[RenderedView],
    (spacing_m, fit): (f64, &CueConfig),
    seed: u64,
) -> SurfaceGaussians {
    let cam_from_world: Vec<Pose> = poses.iter().map(Pose::inverse).collect();
    let per_object: Vec<Vec<(SurfacePoint, u32, [f64; 3])>> = objects
        .par_iter()
        .map(|o| {
            let mut rng = rng_for(seed, stream::GAUSSIANS, o.id as u64);
            o.shape
                .sample_surface(spacing_m, &mut rng)
                .into_iter()
                .filter(|sp| {
                    cam_from_world
                        .iter()
                        .zip(rendered)
                        .any(|(cfw, r)| visible_in(sp.position, camera, cfw, &r.depth_z))
                })
                .map(|sp| {
                    let colour = shade(o.texture.evaluate(&sp).0, sp.normal);
                    (sp, o.id, colour)
                })
                .collect()
        })
        .collect();
    let samples: Vec<_> = per_object.into_iter().flatten().collect();
    let n = samples.len();
    let log_in_plane = (DISC_SIGMA_FRACTION * spacing_m).ln() as f32;
    let log_thin = (fit.gaussian_thickness * spacing_m).ln() as f32;
    let raw_opacity = (OPACITY / (1.0 - OPACITY)).ln();
    let mut g = Gaussians {
        means: Vec::with_capacity(n),
        normals: Some(Vec::with_capacity(n)),
        sh_dc: Vec::with_capacity(n),
        sh_degree: 0,
        sh_rest: Vec::new(),
        raw_opacities: vec![raw_opacity; n],
        log_scales: vec![[log_in_plane, log_in_plane, log_thin]; n],
        rotations: Vec::with_capacity(n),
        object_ids: None,
        features: None,
        extra: Vec::new(),
    };
    let mut ids = Vec::with_capacity(n);
    for (i, (sp, id, colour)) in samples.into_iter().enumerate() {
        let draw = |k: u64| normal(hash(seed, &[stream::GAUSSIAN_FIT, i as u64, k]));
        let mut disc_normal = sp.normal;
        if fit.gaussian_tilt_deg > 0.0 {
            let (t1, t2) = tangents(sp.normal);
            let sigma = fit.gaussian_tilt_deg.to_radians();
            let tilt = sigma * (draw(0) * t1 + draw(1) * t2);
            let angle = tilt.length();
            if angle > 0.0 {
                disc_normal = (sp.normal * angle.cos() + tilt / angle * angle.sin()).normalize();
            }
        }
        let mut position = sp.position;
        if fit.gaussian_offset > 0.0 {
            position += sp.normal * (fit.gaussian_offset * spacing_m * draw(2));
        }
        let uniform = |k: u64| unit(hash(seed, &[stream::GAUSSIAN_FIT, i as u64, k]));
        if fit.gaussian_scale_spread > 0.0 {
            let spread = fit.gaussian_scale_spread;
            let scales = &mut g.log_scales[i];
            scales[0] = log_in_plane + (spread * draw(3)) as f32;
            scales[1] = log_in_plane + (spread * draw(4)) as f32;
        }
        if fit.gaussian_floaters > 0.0 && !poses.is_empty() && uniform(5) < fit.gaussian_floaters {
            // Towards one camera's centre, 2–8 spacings off the surface, faint.
            let view = ((uniform(6) * poses.len() as f64) as usize).min(poses.len() - 1);
            let towards = (poses[view].centre() - position).normalize_or_zero();
            position += towards * (spacing_m * (2.0 + 6.0 * uniform(7)));
            let opacity = 0.1 + 0.3 * uniform(8);
            g.raw_opacities[i] = (opacity / (1.0 - opacity)).ln() as f32;
        }
        g.means.push(position.as_vec3().to_array());
        if let Some(normals) = g.normals.as_mut() {
            normals.push(disc_normal.as_vec3().to_array());
        }
        g.sh_dc.push(colour.map(|c| ((c - 0.5) / SH_C0 as f64) as f32));
        g.rotations.push(disc_rotation(disc_normal));
        ids.push(id);
    }
    SurfaceGaussians { gaussians: g, ids }
}

/// Two unit axes in the plane of unit `normal`, completing a right-handed frame with it.
fn tangents(normal: DVec3) -> (DVec3, DVec3) {
    let helper = if normal.z.abs() < 0.9 { DVec3::Z } else { DVec3::X };
    let t1 = helper.cross(normal).normalize();
    (t1, normal.cross(t1))
}

/// Quaternion `w, x, y, z` turning the local z axis onto `normal` (local x, y in the plane).
fn disc_rotation(normal: DVec3) -> [f32; 4] {
    let (t1, t2) = tangents(normal);
    let q = DQuat::from_mat3(&DMat3::from_cols(t1, t2, normal)).normalize();
    [q.w as f32, q.x as f32, q.y as f32, q.z as f32]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disc_rotation_maps_local_z_to_the_normal() {
        for n in [DVec3::Z, DVec3::X, DVec3::new(0.3, -0.5, 0.8).normalize(), -DVec3::Y] {
            let [w, x, y, z] = disc_rotation(n);
            let q = DQuat::from_xyzw(x as f64, y as f64, z as f64, w as f64);
            assert!((q * DVec3::Z - n).length() < 1e-6, "{n:?}");
        }
    }
}
