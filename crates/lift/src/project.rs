//! Gaussians prepared once for projection ([`PreparedGaussians`]) and their 2D footprints in one
//! view ([`project_view`]): the EWA splatting approximation 3DGS uses,
//! `Σ₂ = J W Σ₃ Wᵀ Jᵀ + 0.3·I` with `J` the pinhole Jacobian at the centre (lens distortion moves
//! the centre but is ignored for the footprint's shape).

use crate::config::LiftConfig;
use crate::error::{LiftError, LiftResult};
use glam::{Mat3, Quat, Vec3};
use splatseg_scene::{Camera, Gaussians, Pose};

/// Per-Gaussian quantities every view needs, in world space.
#[derive(Clone, Debug, Default)]
pub struct PreparedGaussians {
    /// `[N]` centres.
    pub means: Vec<Vec3>,
    /// `[N]` covariances, upper triangle `xx, xy, xz, yy, yz, zz`.
    pub cov3d: Vec<[f32; 6]>,
    /// `[N]` opacities in (0, 1).
    pub opacities: Vec<f32>,
    /// `[N]` unit normals: the axis of the smallest scale.
    pub normals: Vec<Vec3>,
    /// `[N]` flatness `1 − s_min / s_mid` in [0, 1] (0 = no preferred normal).
    pub flatness: Vec<f32>,
}

impl PreparedGaussians {
    /// Prepares `gaussians`, rejecting non-finite parameters.
    pub fn new(gaussians: &Gaussians) -> LiftResult<Self> {
        let n = gaussians.len();
        let mut out = PreparedGaussians {
            means: Vec::with_capacity(n),
            cov3d: Vec::with_capacity(n),
            opacities: Vec::with_capacity(n),
            normals: Vec::with_capacity(n),
            flatness: Vec::with_capacity(n),
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
            out.means.push(Vec3::from(gaussians.means[i]));
            out.opacities.push(gaussians.opacity(i));
        }
        Ok(out)
    }

    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.means.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.means.is_empty()
    }

    fn cov(&self, i: usize) -> Mat3 {
        let c = self.cov3d[i];
        Mat3::from_cols(Vec3::new(c[0], c[1], c[2]), Vec3::new(c[1], c[3], c[4]), Vec3::new(c[2], c[4], c[5]))
    }
}

/// One Gaussian's footprint in one view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Splat {
    /// Index of the Gaussian.
    pub index: u32,
    /// Centre in pixels (pixel-corner origin).
    pub centre_px: [f32; 2],
    /// Inverse 2D covariance `a, b, c` of `[[a, b], [b, c]]`.
    pub conic: [f32; 3],
    /// Opacity.
    pub opacity: f32,
    /// Camera-space depth of the centre.
    pub depth: f32,
    /// Standard deviation along the viewing ray, in scene units.
    pub sigma_ray: f32,
    /// Unit ray from the camera centre to the Gaussian, world frame.
    pub ray: Vec3,
    /// Pixel bounding box `[x0, y0, x1, y1)` clipped to the image.
    pub bbox: [u32; 4],
}

/// Footprints of the Gaussians that fall in `camera`'s image, in increasing index order.
pub fn project_view(
    gaussians: &PreparedGaussians,
    camera: &Camera,
    world_from_cam: &Pose,
    config: &LiftConfig,
) -> Vec<Splat> {
    let cam_from_world = world_from_cam.inverse();
    let w = cam_from_world.rotation.as_mat3();
    let t = cam_from_world.translation.as_vec3();
    let centre = world_from_cam.translation.as_vec3();
    let (fx, fy) = (camera.fx as f32, camera.fy as f32);
    let (width, height) = (camera.width as f32, camera.height as f32);
    let lim_x = 1.3 * 0.5 * width / fx;
    let lim_y = 1.3 * 0.5 * height / fy;
    let mut out = Vec::new();
    for i in 0..gaussians.len() {
        let p = w * gaussians.means[i] + t;
        if p.z < config.near {
            continue;
        }
        let Some(uv) = camera.project(p.as_dvec3()) else { continue };
        let (u, v) = (uv.x as f32, uv.y as f32);
        let tx = (p.x / p.z).clamp(-lim_x, lim_x) * p.z;
        let ty = (p.y / p.z).clamp(-lim_y, lim_y) * p.z;
        let j0 = Vec3::new(fx / p.z, 0.0, -fx * tx / (p.z * p.z));
        let j1 = Vec3::new(0.0, fy / p.z, -fy * ty / (p.z * p.z));
        let cov_cam = w * gaussians.cov(i) * w.transpose();
        let (c0, c1) = (cov_cam * j0, cov_cam * j1);
        let a = j0.dot(c0) + 0.3;
        let b = j0.dot(c1);
        let c = j1.dot(c1) + 0.3;
        let det = a * c - b * b;
        let opacity = gaussians.opacities[i];
        if det <= 0.0 || opacity < 1.0 / 255.0 {
            continue;
        }
        // Extent where opacity · exp(−½ d²) ≥ 1/255 along the major axis.
        let mid = 0.5 * (a + c);
        let lambda_max = mid + (mid * mid - det).max(0.0).sqrt();
        let d2 = 2.0 * (255.0 * opacity).ln();
        let radius = (lambda_max * d2).sqrt().ceil();
        let x0 = (u - radius).floor().max(0.0);
        let y0 = (v - radius).floor().max(0.0);
        let x1 = (u + radius + 1.0).ceil().min(width);
        let y1 = (v + radius + 1.0).ceil().min(height);
        if x0 >= x1 || y0 >= y1 {
            continue;
        }
        let ray = (gaussians.means[i] - centre).normalize_or_zero();
        let sigma_ray = ray.dot(gaussians.cov(i) * ray).max(0.0).sqrt();
        out.push(Splat {
            index: i as u32,
            centre_px: [u, v],
            conic: [c / det, -b / det, a / det],
            opacity,
            depth: p.z,
            sigma_ray,
            ray,
            bbox: [x0 as u32, y0 as u32, x1 as u32, y1 as u32],
        });
    }
    out
}
