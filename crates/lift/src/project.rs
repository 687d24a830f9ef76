//! Gaussians prepared once for every view ([`PreparedGaussians`]) and their projection into one
//! view ([`project_view`]) by the renderer itself (`splatseg_render::ProjectedView`: EWA
//! splatting `Σ₂ = J W Σ₃ Wᵀ Jᵀ + 0.3·I`, 16×16 tiles sorted by depth, 3DGS's blending rules), so
//! the surface depth, the visibility test and the label maps rendered back composite exactly what
//! `splatseg render` draws. Lens distortion moves each footprint's centre (its shape stays the
//! pinhole's, as 3DGS renders undistorted images).

use crate::config::LiftConfig;
use crate::error::{LiftError, LiftResult};
use glam::{Mat3, Quat, Vec3};
use splatseg_render::bin::TileBins;
use splatseg_render::project::Splat2d;
use splatseg_render::project::ViewIndependent;
use splatseg_render::{ProjectedView, RasterSettings, RenderCamera};
use splatseg_scene::{Camera, Gaussians, Pose};

/// Gaussians closer to the camera than this (scene units) are skipped: 3DGS's `znear` (0.01).
pub const NEAR_PLANE: f32 = 0.01;

/// Per-Gaussian quantities every view needs, in world space.
#[derive(Clone, Debug, Default)]
pub struct PreparedGaussians {
    /// What the renderer projects: means, log-scales, rotations and raw opacities (`[N]` each;
    /// no colours).
    pub geometry: Gaussians,
    /// `[N]` covariances, upper triangle `xx, xy, xz, yy, yz, zz` (σ along a viewing ray).
    pub cov3d: Vec<[f32; 6]>,
    /// `[N]` unit normals: the axis of the smallest scale.
    pub normals: Vec<Vec3>,
    /// `[N]` flatness `1 − s_min / s_mid` in [0, 1] (0 = no preferred normal).
    pub flatness: Vec<f32>,
    /// The renderer's view-independent projection terms of `geometry` (covariances,
    /// opacities), so each view's projection only does the per-view part.
    pub projection: ViewIndependent,
}

impl PreparedGaussians {
    /// Prepares `gaussians`, rejecting non-finite parameters.
    pub fn new(gaussians: &Gaussians) -> LiftResult<Self> {
        let n = gaussians.len();
        let mut out = PreparedGaussians {
            geometry: Gaussians {
                means: gaussians.means.clone(),
                log_scales: gaussians.log_scales.clone(),
                rotations: gaussians.rotations.clone(),
                raw_opacities: gaussians.raw_opacities.clone(),
                ..Gaussians::default()
            },
            cov3d: Vec::with_capacity(n),
            normals: Vec::with_capacity(n),
            flatness: Vec::with_capacity(n),
            projection: ViewIndependent::default(),
        };
        for i in 0..n {
            let finite = |v: &[f32], what| {
                if v.iter().all(|x| x.is_finite()) {
                    Ok(())
                } else {
                    Err(LiftError::NonFinite { index: i, what })
                }
            };
            finite(&gaussians.means[i], "position")?;
            finite(&gaussians.log_scales[i], "scale")?;
            finite(&gaussians.rotations[i], "rotation")?;
            finite(&gaussians.raw_opacities[i..i + 1], "opacity")?;
            let [w, x, y, z] = gaussians.rotations[i];
            let q = Quat::from_xyzw(x, y, z, w);
            let q = if q.length_squared() > 1e-20 { q.normalize() } else { Quat::IDENTITY };
            let rot = Mat3::from_quat(q);
            let s = gaussians.scales(i);
            let m = rot * Mat3::from_diagonal(Vec3::from(s));
            let cov = m * m.transpose();
            out.cov3d.push([
                cov.x_axis.x,
                cov.y_axis.x,
                cov.z_axis.x,
                cov.y_axis.y,
                cov.z_axis.y,
                cov.z_axis.z,
            ]);
            let mut axes = [0usize, 1, 2];
            axes.sort_by(|&a, &b| s[a].total_cmp(&s[b]));
            out.normals.push(rot.col(axes[0]));
            out.flatness.push(if s[axes[1]] > 0.0 { 1.0 - s[axes[0]] / s[axes[1]] } else { 0.0 });
        }
        out.projection = ViewIndependent::new(&out.geometry);
        Ok(out)
    }

    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.geometry.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.geometry.is_empty()
    }

    /// Centre of Gaussian `i`.
    pub fn mean(&self, i: usize) -> Vec3 {
        Vec3::from(self.geometry.means[i])
    }

    /// Opacity of Gaussian `i` (sigmoid of the raw opacity).
    pub fn opacity(&self, i: usize) -> f32 {
        self.geometry.opacity(i)
    }

    /// Standard deviation of Gaussian `i` along the unit direction `ray`, in scene units.
    pub fn sigma_along(&self, i: usize, ray: Vec3) -> f32 {
        let c = self.cov3d[i];
        let cov = Mat3::from_cols(
            Vec3::new(c[0], c[1], c[2]),
            Vec3::new(c[1], c[3], c[4]),
            Vec3::new(c[2], c[4], c[5]),
        );
        ray.dot(cov * ray).max(0.0).sqrt()
    }
}

/// The rules every lift pass composites by: the renderer's defaults (3DGS: α ≤ 0.99, skipped
/// below 1/255, a pixel stops before its transmittance falls to 1e-4, 3σ footprints).
pub fn raster_settings() -> RasterSettings {
    RasterSettings::default()
}

/// The Gaussians projected and binned for one view (`[N]` splats in Gaussian order, culled ones
/// with zero radii): the renderer's projection with [`NEAR_PLANE`] as the near plane, each
/// centre moved by the camera's lens distortion when it has one.
pub fn project_view(
    gaussians: &PreparedGaussians,
    camera: &Camera,
    world_from_cam: &Pose,
    config: &LiftConfig,
) -> ProjectedView {
    let splats = project_splats(gaussians, camera, world_from_cam, config);
    ProjectedView::from_splats(splats, camera.width as usize, camera.height as usize)
}

/// [`project_view`] with the tile lists a [`project_view`] of the same Gaussians, camera and
/// config made before (e.g. kept on disk between two passes over the view), not sorted again.
/// Lists that cannot index these splats or this image are an error.
pub fn project_view_binned(
    gaussians: &PreparedGaussians,
    camera: &Camera,
    world_from_cam: &Pose,
    config: &LiftConfig,
    bins: TileBins,
) -> LiftResult<ProjectedView> {
    let splats = project_splats(gaussians, camera, world_from_cam, config);
    Ok(ProjectedView::from_binned(splats, bins, camera.width as usize, camera.height as usize)?)
}

/// The splats of [`project_view`] (centres moved by the camera's distortion), not binned.
fn project_splats(
    gaussians: &PreparedGaussians,
    camera: &Camera,
    world_from_cam: &Pose,
    _config: &LiftConfig,
) -> Vec<Splat2d> {
    let mut render_camera = RenderCamera::from_scene(camera, world_from_cam);
    render_camera.near = NEAR_PLANE;
    let mut splats = splatseg_render::project::project_prepared(
        &gaussians.geometry,
        &gaussians.projection,
        &render_camera,
        &raster_settings(),
    );
    if !camera.distortion.is_zero() {
        let cam_from_world = world_from_cam.inverse();
        for (i, s) in splats.iter_mut().enumerate() {
            if s.is_culled() {
                continue;
            }
            let p = cam_from_world.transform_point(Vec3::from(gaussians.geometry.means[i]).as_dvec3());
            match camera.project(p) {
                Some(uv) => s.mean2d = [uv.x as f32, uv.y as f32],
                None => s.radii = [0, 0],
            }
        }
    }
    splats
}
