//! Projection of 3D Gaussians to screen-space splats (EWA splatting) and its backward.
//!
//! Work mapping: one Gaussian per rayon work item (`into_par_iter` over indices, output in index
//! order); every Gaussian is independent, so results do not depend on the thread count.
//!
//! Math (gsplat's `_fully_fused_projection` / `_persp_proj` / `_quat_scale_to_covar_preci`):
//! `Σ = R S Sᵀ Rᵀ` with `R` from the normalised quaternion `(w, x, y, z)` and `S = diag(exp
//! log_scales)`; `p_c = W p + t`, `Σ_c = W Σ Wᵀ` (`W, t` = cam_from_world); the Jacobian of the
//! pinhole at `(tx', ty', tz)` where `tx' = tz · clamp(tx / tz, −(cx/fx + 0.3·tanfov_x),
//! (w − cx)/fx + 0.3·tanfov_x)` (likewise y); `Σ_2d = J Σ_c Jᵀ + eps2d·I`; conic = `Σ_2d⁻¹`
//! (determinant clamped at 1e-10); mean `(fx·tx/tz + cx, fy·ty/tz + cy)` with the unclamped
//! `tx, ty`. Culled (radius 0): depth ≤ near or ≥ far, or a footprint entirely off-image.

use crate::camera::RenderCamera;
use crate::project_lanes::{splats_of_lanes_avx2, LANES};
use crate::settings::{Extent, RasterSettings};
use glam::{Mat3, Vec3};
use rayon::prelude::*;
use splatseg_scene::Gaussians;

/// One Gaussian as seen by a camera: what the rasteriser needs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Splat2d {
    /// Projected centre, px (pixel-corner origin).
    pub mean2d: [f32; 2],
    /// Inverse 2D covariance `(a, b, c)` = `[[a, b], [b, c]]`, 1/px².
    pub conic: [f32; 3],
    /// Opacity in (0, 1) (sigmoid of the raw opacity).
    pub opacity: f32,
    /// Camera-space z of the centre (metric depth).
    pub depth: f32,
    /// Footprint half-widths `(x, y)` in px; `[0, 0]` = culled.
    pub radii: [i32; 2],
}

impl Splat2d {
    /// True when the Gaussian is culled (not binned to any tile).
    pub fn is_culled(&self) -> bool {
        self.radii[0] <= 0 || self.radii[1] <= 0
    }
}

/// Camera constants shared by every Gaussian.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ProjCam {
    pub w: Mat3,
    pub t: Vec3,
    pub fx: f32,
    pub fy: f32,
    pub cx: f32,
    pub cy: f32,
    pub width: f32,
    pub height: f32,
    pub near: f32,
    pub far: f32,
    pub lim_x: (f32, f32),
    pub lim_y: (f32, f32),
}

impl ProjCam {
    pub fn new(camera: &RenderCamera) -> Self {
        let (r, t) = camera.cam_from_world_f32();
        let w = Mat3::from_cols(
            Vec3::new(r[0][0], r[1][0], r[2][0]),
            Vec3::new(r[0][1], r[1][1], r[2][1]),
            Vec3::new(r[0][2], r[1][2], r[2][2]),
        );
        let (width, height) = (camera.width as f32, camera.height as f32);
        let tan_x = 0.5 * width / camera.fx;
        let tan_y = 0.5 * height / camera.fy;
        ProjCam {
            w,
            t: Vec3::from(t),
            fx: camera.fx,
            fy: camera.fy,
            cx: camera.cx,
            cy: camera.cy,
            width,
            height,
            near: camera.near,
            far: camera.far,
            lim_x: (-(camera.cx / camera.fx + 0.3 * tan_x), (width - camera.cx) / camera.fx + 0.3 * tan_x),
            lim_y: (-(camera.cy / camera.fy + 0.3 * tan_y), (height - camera.cy) / camera.fy + 0.3 * tan_y),
        }
    }
}

/// Rotation matrix of the normalised quaternion `q = (w, x, y, z)`; also returns the norm.
pub(crate) fn quat_to_mat(q: [f32; 4]) -> (Mat3, [f32; 4], f32) {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt().max(1e-12);
    let [w, x, y, z] = q.map(|v| v / n);
    let m = Mat3::from_cols(
        Vec3::new(1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + w * z), 2.0 * (x * z - w * y)),
        Vec3::new(2.0 * (x * y - w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z + w * x)),
        Vec3::new(2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y)),
    );
    (m, [w, x, y, z], n)
}

/// Gradient w.r.t. the raw quaternion given `d_r = ∂L/∂R` (R = rotation of the normalised q).
pub(crate) fn quat_to_mat_bwd(qn: [f32; 4], norm: f32, d_r: Mat3) -> [f32; 4] {
    let [w, x, y, z] = qn;
    let g = |i: usize, j: usize| d_r.col(j)[i];
    let dw = 2.0 * (-z * g(0, 1) + y * g(0, 2) + z * g(1, 0) - x * g(1, 2) - y * g(2, 0) + x * g(2, 1));
    let dx = 2.0
        * (y * g(0, 1) + z * g(0, 2) + y * g(1, 0) - 2.0 * x * g(1, 1) - w * g(1, 2)
            + z * g(2, 0)
            + w * g(2, 1)
            - 2.0 * x * g(2, 2));
    let dy = 2.0
        * (-2.0 * y * g(0, 0) + x * g(0, 1) + w * g(0, 2) + x * g(1, 0) + z * g(1, 2) - w * g(2, 0)
            + z * g(2, 1)
            - 2.0 * y * g(2, 2));
    let dz = 2.0
        * (-2.0 * z * g(0, 0) - w * g(0, 1) + x * g(0, 2) + w * g(1, 0) - 2.0 * z * g(1, 1)
            + y * g(1, 2)
            + x * g(2, 0)
            + y * g(2, 1));
    let dqn = [dw, dx, dy, dz];
    let dot: f32 = (0..4).map(|i| dqn[i] * qn[i]).sum();
    [0, 1, 2, 3].map(|i| (dqn[i] - qn[i] * dot) / norm)
}

/// Intermediate values of one Gaussian's projection, kept for the backward.
struct Forward {
    rot: Mat3,
    qn: [f32; 4],
    qnorm: f32,
    scales: Vec3,
    m: Mat3,
    /// What depends on the view.
    view: ViewTerms,
}

/// The world-space covariance `Σ = (R S)(R S)ᵀ` of a Gaussian and what it is made of.
struct Covariance {
    rot: Mat3,
    qn: [f32; 4],
    qnorm: f32,
    scales: Vec3,
    m: Mat3,
    cov: Mat3,
}

fn covariance(log_scales: [f32; 3], quat: [f32; 4]) -> Covariance {
    let (rot, qn, qnorm) = quat_to_mat(quat);
    let scales = Vec3::from(log_scales.map(f32::exp));
    let m = Mat3::from_cols(rot.x_axis * scales.x, rot.y_axis * scales.y, rot.z_axis * scales.z);
    let cov = m * m.transpose();
    Covariance { rot, qn, qnorm, scales, m, cov }
}

/// Opacity from the raw (logit) opacity.
fn sigmoid(raw: f32) -> f32 {
    1.0 / (1.0 + (-raw).exp())
}

/// What does not change from view to view: each Gaussian's world-space covariance and
/// opacity, computed once by the same arithmetic [`project`] uses, so
/// [`project_prepared`] gives the same splats, bit for bit, without recomputing them per view.
#[derive(Clone, Debug, Default)]
pub struct ViewIndependent {
    /// `[N]` covariances `Σ`.
    cov: Vec<Mat3>,
    /// `[N]` opacities (sigmoid of the raw opacity).
    opacity: Vec<f32>,
}

impl ViewIndependent {
    /// The terms of `gaussians` (means, log-scales, rotations and raw opacities are read).
    pub fn new(gaussians: &Gaussians) -> Self {
        let cov = (0..gaussians.len())
            .into_par_iter()
            .map(|i| covariance(gaussians.log_scales[i], gaussians.rotations[i]).cov)
            .collect();
        let opacity = gaussians.raw_opacities.par_iter().map(|&o| sigmoid(o)).collect();
        ViewIndependent { cov, opacity }
    }

    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.opacity.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.opacity.is_empty()
    }
}

fn forward_one(cam: &ProjCam, mean: [f32; 3], log_scales: [f32; 3], quat: [f32; 4], eps2d: f32) -> Forward {
    let Covariance { rot, qn, qnorm, scales, m, cov } = covariance(log_scales, quat);
    Forward { rot, qn, qnorm, scales, m, view: view_terms(cam, mean, cov, eps2d) }
}

/// The view-dependent part of [`Forward`].
struct ViewTerms {
    p_c: Vec3,
    cov_c: Mat3,
    txc: f32,
    tyc: f32,
    clamped_x: bool,
    clamped_y: bool,
    j0: Vec3,
    j1: Vec3,
    cov2d: [f32; 3],
    det: f32,
    det_clamped: bool,
}

#[inline(always)]
fn view_terms(cam: &ProjCam, mean: [f32; 3], cov: Mat3, eps2d: f32) -> ViewTerms {
    view_terms_at(cam, camera_point(cam, mean), cov, eps2d)
}

/// The camera-space centre `W p + t` of a Gaussian at `mean`.
#[inline(always)]
fn camera_point(cam: &ProjCam, mean: [f32; 3]) -> Vec3 {
    cam.w * Vec3::from(mean) + cam.t
}

/// [`view_terms`] of a Gaussian whose camera-space centre is `p_c`.
#[inline(always)]
fn view_terms_at(cam: &ProjCam, p_c: Vec3, cov: Mat3, eps2d: f32) -> ViewTerms {
    let cov_c = cam.w * cov * cam.w.transpose();
    let tz = p_c.z;
    let (rx, ry) = (p_c.x / tz, p_c.y / tz);
    let clamped_x = !(rx >= cam.lim_x.0 && rx <= cam.lim_x.1);
    let clamped_y = !(ry >= cam.lim_y.0 && ry <= cam.lim_y.1);
    let txc = tz * rx.clamp(cam.lim_x.0, cam.lim_x.1);
    let tyc = tz * ry.clamp(cam.lim_y.0, cam.lim_y.1);
    let j0 = Vec3::new(cam.fx / tz, 0.0, -cam.fx * txc / (tz * tz));
    let j1 = Vec3::new(0.0, cam.fy / tz, -cam.fy * tyc / (tz * tz));
    let s0 = cov_c * j0;
    let s1 = cov_c * j1;
    let cov2d = [j0.dot(s0) + eps2d, j0.dot(s1), j1.dot(s1) + eps2d];
    let det_raw = cov2d[0] * cov2d[2] - cov2d[1] * cov2d[1];
    ViewTerms {
        p_c,
        cov_c,
        txc,
        tyc,
        clamped_x,
        clamped_y,
        j0,
        j1,
        cov2d,
        det: det_raw.max(1e-10),
        det_clamped: det_raw.is_nan() || det_raw < 1e-10,
    }
}

/// `v.ceil()`, bit for bit, without a libm call (`f32::ceil` is one without SSE4.1): below 2²³
/// in magnitude the truncation is exact and is raised by one when below `v`; zero keeps `v`'s
/// sign (`ceil(-0.3) = -0.0`); larger values, infinities and NaN are whole already.
#[inline(always)]
fn ceil_without_libm(v: f32) -> f32 {
    if v.is_nan() || v.abs() >= 8_388_608.0 {
        return v;
    }
    let t = v as i32 as f32;
    let c = if t < v { t + 1.0 } else { t };
    if c == 0.0 && v.is_sign_negative() {
        -0.0
    } else {
        c
    }
}

fn footprint(extent: Extent, cov2d: [f32; 3], det: f32) -> [f32; 2] {
    match extent {
        Extent::MaxEigen { sigmas } => {
            let b = 0.5 * (cov2d[0] + cov2d[2]);
            let v1 = b + (b * b - det).max(0.1).sqrt();
            let r = ceil_without_libm(sigmas * v1.sqrt());
            [r, r]
        }
        Extent::PerAxis { sigmas } => {
            [ceil_without_libm(sigmas * cov2d[0].sqrt()), ceil_without_libm(sigmas * cov2d[2].sqrt())]
        }
    }
}

/// Projects Gaussian `i` (no colour).
pub(crate) fn project_one(cam: &ProjCam, g: &Gaussians, i: usize, settings: &RasterSettings) -> Splat2d {
    let cov = covariance(g.log_scales[i], g.rotations[i]).cov;
    splat_of(cam, g.means[i], cov, sigmoid(g.raw_opacities[i]), settings)
}

/// The splat of a Gaussian at `mean` with covariance `cov` and opacity `opacity`.
#[inline(always)]
fn splat_of(cam: &ProjCam, mean: [f32; 3], cov: Mat3, opacity: f32, settings: &RasterSettings) -> Splat2d {
    let p_c = camera_point(cam, mean);
    if !(p_c.z > cam.near && p_c.z < cam.far) {
        // Culled by depth whatever its footprint (most Gaussians behind a camera inside a room):
        // no covariance, conic or footprint is computed; only `radii` matters for a culled splat.
        return Splat2d { opacity, depth: p_c.z, ..Splat2d::default() };
    }
    splat_of_terms(cam, view_terms_at(cam, p_c, cov, settings.eps2d), opacity, settings)
}

/// The splat of a Gaussian of opacity `opacity` from its view terms `f`.
#[inline(always)]
fn splat_of_terms(cam: &ProjCam, f: ViewTerms, opacity: f32, settings: &RasterSettings) -> Splat2d {
    let depth = f.p_c.z;
    let mean2d = [cam.fx * f.p_c.x / depth + cam.cx, cam.fy * f.p_c.y / depth + cam.cy];
    let conic = [f.cov2d[2] / f.det, -f.cov2d[1] / f.det, f.cov2d[0] / f.det];
    let mut r = footprint(settings.extent, f.cov2d, f.det);
    let valid = depth > cam.near && depth < cam.far;
    let inside = mean2d[0] + r[0] > 0.0
        && mean2d[0] - r[0] < cam.width
        && mean2d[1] + r[1] > 0.0
        && mean2d[1] - r[1] < cam.height;
    let finite = mean2d.iter().chain(conic.iter()).all(|v| v.is_finite()) && r.iter().all(|v| v.is_finite());
    if !valid || !inside || !finite {
        r = [0.0, 0.0];
    }
    Splat2d { mean2d, conic, opacity, depth, radii: [r[0] as i32, r[1] as i32] }
}

/// Projects every Gaussian: `[N]` splats in input order.
pub fn project(gaussians: &Gaussians, camera: &RenderCamera, settings: &RasterSettings) -> Vec<Splat2d> {
    let cam = ProjCam::new(camera);
    (0..gaussians.len()).into_par_iter().map(|i| project_one(&cam, gaussians, i, settings)).collect()
}

/// [`project`] with the view-independent terms computed once (`prepared`, from the same
/// `gaussians`; only their means are read here): the same splats, bit for bit.
///
/// # Panics
/// If `prepared` was made from another number of Gaussians.
pub fn project_prepared(
    gaussians: &Gaussians,
    prepared: &ViewIndependent,
    camera: &RenderCamera,
    settings: &RasterSettings,
) -> Vec<Splat2d> {
    assert_eq!(prepared.len(), gaussians.len(), "view-independent terms of another set of Gaussians");
    let cam = ProjCam::new(camera);
    let lanes = crate::project_lanes::lanes_available();
    let mut out = vec![Splat2d::default(); gaussians.len()];
    out.par_chunks_mut(PROJECT_CHUNK).enumerate().for_each(|(k, chunk)| {
        let first = k * PROJECT_CHUNK;
        let (means, covs, opacities) =
            (&gaussians.means[first..], &prepared.cov[first..], &prepared.opacity[first..]);
        let batched = if lanes { chunk.len() / LANES * LANES } else { 0 };
        for b in (0..batched).step_by(LANES) {
            // SAFETY: `lanes` says the CPU has AVX2; every slice holds LANES items from `b`.
            unsafe {
                splats_of_lanes_avx2(
                    &cam,
                    &means[b..],
                    &covs[b..],
                    &opacities[b..],
                    settings,
                    &mut chunk[b..],
                )
            };
        }
        for i in batched..chunk.len() {
            chunk[i] = splat_of(&cam, means[i], covs[i], opacities[i], settings);
        }
    });
    out
}

/// Gaussians per parallel work item of [`project_prepared`].
const PROJECT_CHUNK: usize = 4096;

/// Gradients reaching one splat from the rasteriser and the depth channel.
#[derive(Clone, Copy, Debug, Default)]
pub struct SplatGrad {
    /// ∂L/∂mean2d, px⁻¹.
    pub mean2d: [f32; 2],
    /// ∂L/∂conic `(a, b, c)`, `b` counted once.
    pub conic: [f32; 3],
    /// ∂L/∂opacity (after the sigmoid).
    pub opacity: f32,
    /// ∂L/∂depth (camera z), e.g. from rendered depth.
    pub depth: f32,
}

/// Gradients of one Gaussian's raw parameters.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ParamGrad {
    /// ∂L/∂mean `[3]`.
    pub mean: [f32; 3],
    /// ∂L/∂log_scales `[3]`.
    pub log_scales: [f32; 3],
    /// ∂L/∂rotation `[4]` (w, x, y, z; raw, unnormalised quaternion).
    pub rotation: [f32; 4],
    /// ∂L/∂raw_opacity.
    pub raw_opacity: f32,
}

/// Backward of [`project`] for Gaussian `i` (not culled).
pub(crate) fn project_one_bwd(
    cam: &ProjCam,
    g: &Gaussians,
    i: usize,
    settings: &RasterSettings,
    grad: &SplatGrad,
) -> ParamGrad {
    let f = forward_one(cam, g.means[i], g.log_scales[i], g.rotations[i], settings.eps2d);
    let tz = f.view.p_c.z;
    // conic = [c11, -c01, c00] / det
    let [a, b, c] =
        [f.view.cov2d[2] / f.view.det, -f.view.cov2d[1] / f.view.det, f.view.cov2d[0] / f.view.det];
    let [ga, gb, gc] = grad.conic;
    let g_det = if f.view.det_clamped { 0.0 } else { -(ga * a + gb * b + gc * c) / f.view.det };
    let g00 = gc / f.view.det + g_det * f.view.cov2d[2];
    let g11 = ga / f.view.det + g_det * f.view.cov2d[0];
    let g01 = -gb / f.view.det - 2.0 * g_det * f.view.cov2d[1];
    // cov2d = J Σc Jᵀ with rows j0, j1.
    let outer = |u: Vec3, v: Vec3| Mat3::from_cols(u * v.x, u * v.y, u * v.z);
    let g_cov_c = outer(f.view.j0, f.view.j0) * g00
        + outer(f.view.j0, f.view.j1) * g01
        + outer(f.view.j1, f.view.j1) * g11;
    let g_j0 = f.view.cov_c * f.view.j0 * (2.0 * g00) + f.view.cov_c * f.view.j1 * g01;
    let g_j1 = f.view.cov_c * f.view.j1 * (2.0 * g11) + f.view.cov_c * f.view.j0 * g01;
    let (fx, fy) = (cam.fx, cam.fy);
    let tz2 = tz * tz;
    let tz3 = tz2 * tz;
    let mut g_p_c = Vec3::ZERO;
    g_p_c.z += -fx / tz2 * g_j0.x + 2.0 * fx * f.view.txc / tz3 * g_j0.z - fy / tz2 * g_j1.y
        + 2.0 * fy * f.view.tyc / tz3 * g_j1.z;
    let g_txc = -fx / tz2 * g_j0.z;
    let g_tyc = -fy / tz2 * g_j1.z;
    if f.view.clamped_x {
        g_p_c.z += g_txc * f.view.txc / tz;
    } else {
        g_p_c.x += g_txc;
    }
    if f.view.clamped_y {
        g_p_c.z += g_tyc * f.view.tyc / tz;
    } else {
        g_p_c.y += g_tyc;
    }
    let [gmx, gmy] = grad.mean2d;
    g_p_c.x += fx / tz * gmx;
    g_p_c.y += fy / tz * gmy;
    g_p_c.z += -fx * f.view.p_c.x / tz2 * gmx - fy * f.view.p_c.y / tz2 * gmy + grad.depth;
    let g_mean = cam.w.transpose() * g_p_c;
    // Σc = W Σ Wᵀ; Σ = M Mᵀ; M = R diag(s).
    let g_cov = cam.w.transpose() * g_cov_c * cam.w;
    let g_m = (g_cov + g_cov.transpose()) * f.m;
    let s = f.scales;
    let g_rot = Mat3::from_cols(g_m.x_axis * s.x, g_m.y_axis * s.y, g_m.z_axis * s.z);
    let g_s =
        Vec3::new(g_m.x_axis.dot(f.rot.x_axis), g_m.y_axis.dot(f.rot.y_axis), g_m.z_axis.dot(f.rot.z_axis));
    let o = 1.0 / (1.0 + (-g.raw_opacities[i]).exp());
    ParamGrad {
        mean: g_mean.to_array(),
        log_scales: (g_s * s).to_array(),
        rotation: quat_to_mat_bwd(f.qn, f.qnorm, g_rot),
        raw_opacity: grad.opacity * o * (1.0 - o),
    }
}

/// Backward of [`project`]: per-Gaussian raw-parameter gradients (`[N]`) from per-splat
/// gradients (`grads: [N]`); culled Gaussians get zeros. (SH colour gradients are separate:
/// [`crate::sh::colour_bwd`].)
pub fn project_bwd(
    gaussians: &Gaussians,
    camera: &RenderCamera,
    settings: &RasterSettings,
    splats: &[Splat2d],
    grads: &[SplatGrad],
) -> Vec<ParamGrad> {
    let cam = ProjCam::new(camera);
    (0..gaussians.len())
        .into_par_iter()
        .map(|i| {
            if splats[i].is_culled() {
                ParamGrad::default()
            } else {
                project_one_bwd(&cam, gaussians, i, settings, &grads[i])
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use splatseg_scene::{Camera, Pose};

    /// Projecting with the view-independent terms computed once gives the splats of `project`,
    /// bit for bit, culled ones included, under both footprint rules.
    #[test]
    fn prepared_projection_equals_the_direct_one_bit_for_bit() {
        let mut seed = 5u32;
        let mut unit = move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let mut g = Gaussians::default();
        // More than two parallel chunks and a remainder beside the 8-lane batches; some
        // Gaussians far beside the view (clamped Jacobian), some needle-thin (clamped
        // determinant), some at the camera's plane.
        for k in 0..10_003 {
            let z = match k % 16 {
                0 => 1e-7 * (unit() - 0.5),
                _ => 12.0 * unit() - 2.0,
            };
            let lateral = if k % 5 == 0 { 6.0 } else { 1.0 };
            g.means.push([(unit() - 0.5) * 2.0 * lateral * z.abs(), (unit() - 0.5) * 1.5 * z.abs(), z]);
            let thin = if k % 7 == 0 { -14.0 } else { 0.0 };
            g.log_scales.push([4.0 * unit() - 5.0 + thin, 4.0 * unit() - 5.0, 4.0 * unit() - 5.0 + thin]);
            g.rotations.push([unit() - 0.5, unit() - 0.5, unit() - 0.5, unit() - 0.5]);
            g.raw_opacities.push(12.0 * unit() - 6.0);
        }
        let prepared = ViewIndependent::new(&g);
        let pose = Pose { translation: glam::DVec3::new(0.2, -0.1, -0.5), ..Pose::IDENTITY };
        let camera = RenderCamera::from_scene(&Camera::pinhole(1, 96, 72, 80.0, 82.0, 47.0, 37.0), &pose);
        let bits = |s: &Splat2d| {
            let f = [s.mean2d[0], s.mean2d[1], s.conic[0], s.conic[1], s.conic[2], s.opacity, s.depth];
            (f.map(f32::to_bits), s.radii)
        };
        for settings in [RasterSettings::default(), RasterSettings::gsplat_1_5()] {
            let direct = project(&g, &camera, &settings);
            let culled = direct.iter().filter(|s| s.is_culled()).count();
            assert!(culled > 500 && culled < 9500, "{culled} culled: both kinds are compared");
            let again = project_prepared(&g, &prepared, &camera, &settings);
            for (i, (a, b)) in direct.iter().zip(&again).enumerate() {
                assert_eq!(bits(a), bits(b), "Gaussian {i}");
            }
        }
    }

    /// Culling by depth before the covariance is projected culls exactly the Gaussians the full
    /// computation culls, and leaves every other splat bit for bit as the full computation makes
    /// it: Gaussians behind the camera, at the near and far planes, beside and in front of it.
    #[test]
    fn early_depth_cull_changes_nothing_but_culled_fields() {
        let mut seed = 11u32;
        let mut unit = move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let pose = Pose { translation: glam::DVec3::new(0.1, 0.2, -0.3), ..Pose::IDENTITY };
        let mut camera = RenderCamera::from_scene(&Camera::pinhole(1, 80, 60, 70.0, 70.0, 40.0, 30.0), &pose);
        camera.far = 8.0;
        let cam = ProjCam::new(&camera);
        let (mut early_culled, mut kept) = (0, 0);
        for settings in [RasterSettings::default(), RasterSettings::gsplat_1_5()] {
            for k in 0..4000 {
                // Depths on both sides of the near and far planes, some exactly on them.
                let z = match k % 8 {
                    0 => camera.near - 0.3,
                    1 => camera.far - 0.3,
                    _ => 14.0 * unit() - 4.0,
                };
                let mean = [(unit() - 0.5) * 3.0 * z.abs(), (unit() - 0.5) * 2.0 * z.abs(), z];
                let cov = covariance(
                    [3.0 * unit() - 4.0, 3.0 * unit() - 4.0, 3.0 * unit() - 4.0],
                    [unit() - 0.5, unit() - 0.5, unit() - 0.5, unit() - 0.5],
                )
                .cov;
                let full = splat_of_terms(&cam, view_terms(&cam, mean, cov, settings.eps2d), 0.7, &settings);
                let fast = splat_of(&cam, mean, cov, 0.7, &settings);
                assert_eq!(fast.radii, full.radii, "Gaussian {k} at z {z}");
                if full.is_culled() {
                    let p_c = camera_point(&cam, mean);
                    early_culled += usize::from(!(p_c.z > cam.near && p_c.z < cam.far));
                } else {
                    assert_eq!(fast, full, "Gaussian {k} at z {z}");
                    assert_eq!(fast.conic.map(f32::to_bits), full.conic.map(f32::to_bits));
                    kept += 1;
                }
            }
        }
        assert!(early_culled > 1000 && kept > 1000, "{early_culled} culled by depth, {kept} kept");
    }

    /// The libm-free ceiling equals `f32::ceil` bit for bit: every float from a sweep of bit
    /// patterns (both signs, all exponents), halves, zeros, infinities and NaN.
    #[test]
    fn ceil_without_libm_equals_ceil() {
        let mut values: Vec<f32> = (0..=u32::MAX).step_by(997).map(f32::from_bits).collect();
        values.extend((-40_000..40_000).map(|i| i as f32 * 0.25));
        values.extend([0.0, -0.0, 8_388_607.5, -8_388_607.5, 8_388_608.0, f32::INFINITY, f32::NEG_INFINITY]);
        for v in values {
            let (got, want) = (ceil_without_libm(v), v.ceil());
            assert!(
                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "{v}: {got} vs {want}"
            );
        }
    }

    /// d(conic·w + mean2d·v + depth·u)/d(params) against central differences.
    #[test]
    fn projection_backward_matches_finite_differences() {
        let g = Gaussians {
            means: vec![[0.3, -0.2, 3.0]],
            log_scales: vec![[-1.0, -1.6, -1.3]],
            rotations: vec![[0.9, 0.2, -0.3, 0.1]],
            raw_opacities: vec![0.4],
            ..Default::default()
        };
        let camera =
            RenderCamera::from_scene(&Camera::pinhole(1, 64, 48, 60.0, 61.0, 32.0, 24.0), &Pose::IDENTITY);
        let settings = RasterSettings::default();
        let grad = SplatGrad { mean2d: [0.7, -0.4], conic: [2.0, -1.5, 3.0], opacity: 0.6, depth: 0.3 };
        let loss = |g: &Gaussians| {
            let s = project(g, &camera, &settings)[0];
            let c: f64 = (0..3).map(|k| s.conic[k] as f64 * grad.conic[k] as f64).sum();
            c + s.mean2d[0] as f64 * 0.7 - s.mean2d[1] as f64 * 0.4
                + s.opacity as f64 * 0.6
                + s.depth as f64 * 0.3
        };
        let splats = project(&g, &camera, &settings);
        let an = project_bwd(&g, &camera, &settings, &splats, &[grad])[0];
        let h = 1e-3f32;
        let fd = |f: &dyn Fn(&mut Gaussians, f32)| {
            let (mut up, mut dn) = (g.clone(), g.clone());
            f(&mut up, h);
            f(&mut dn, -h);
            ((loss(&up) - loss(&dn)) / (2.0 * h as f64)) as f32
        };
        for k in 0..3 {
            let d = fd(&|g, h| g.means[0][k] += h);
            assert!((d - an.mean[k]).abs() < 2e-2 * (1.0 + d.abs()), "mean[{k}]: fd {d} vs {}", an.mean[k]);
            let d = fd(&|g, h| g.log_scales[0][k] += h);
            assert!(
                (d - an.log_scales[k]).abs() < 2e-2 * (1.0 + d.abs()),
                "log_scale[{k}]: fd {d} vs {}",
                an.log_scales[k]
            );
        }
        for k in 0..4 {
            let d = fd(&|g, h| g.rotations[0][k] += h);
            assert!(
                (d - an.rotation[k]).abs() < 2e-2 * (1.0 + d.abs()),
                "rotation[{k}]: fd {d} vs {}",
                an.rotation[k]
            );
        }
        let d = fd(&|g, h| g.raw_opacities[0] += h);
        assert!((d - an.raw_opacity).abs() < 1e-3, "raw opacity: fd {d} vs {}", an.raw_opacity);
    }

    #[test]
    fn quaternion_backward_matches_finite_differences() {
        let q = [0.8f32, -0.3, 0.5, 0.2];
        let weights = Mat3::from_cols_array(&[0.3, -1.2, 0.7, 0.4, 0.9, -0.5, 1.1, 0.2, -0.8]);
        let loss = |q: [f32; 4]| {
            let (m, _, _) = quat_to_mat(q);
            (0..3).map(|j| m.col(j).dot(weights.col(j))).sum::<f32>()
        };
        let (_, qn, n) = quat_to_mat(q);
        let g = quat_to_mat_bwd(qn, n, weights);
        for k in 0..4 {
            let h = 1e-3;
            let (mut up, mut dn) = (q, q);
            up[k] += h;
            dn[k] -= h;
            let fd = (loss(up) - loss(dn)) / (2.0 * h);
            assert!((fd - g[k]).abs() < 1e-3, "component {k}: fd {fd} analytic {}", g[k]);
        }
    }
}
