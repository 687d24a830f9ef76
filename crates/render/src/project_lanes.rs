//! The projection of [`crate::project::project_prepared`], eight Gaussians at a time.
//!
//! Every lane does the operations of the one-Gaussian projection (`splat_of` in `project.rs`:
//! glam's `Mat3 · Mat3`, `Mat3 · Vec3` and `dot` as glam evaluates them, the same clamps, the same
//! `max` with positive constants, IEEE division and square root, `ceil`), in the same order and
//! without fused multiply-adds, so each lane's splat is the one-Gaussian splat bit for bit (test
//! `prepared_projection_equals_the_direct_one_bit_for_bit`). Written over fixed-size arrays so the
//! compiler vectorises it; compiled for AVX2 and used when the CPU has it.

use crate::project::{ProjCam, Splat2d};
use crate::settings::{Extent, RasterSettings};
use glam::Mat3;

/// Gaussians per batch.
pub(crate) const LANES: usize = 8;

/// Whether [`splats_of_lanes_avx2`] may run on this CPU.
pub(crate) fn lanes_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// [`splats_of_lanes`] compiled for AVX2.
///
/// # Safety
/// The CPU must have AVX2 ([`lanes_available`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn splats_of_lanes_avx2(
    cam: &ProjCam,
    means: &[[f32; 3]],
    covs: &[Mat3],
    opacities: &[f32],
    settings: &RasterSettings,
    out: &mut [Splat2d],
) {
    splats_of_lanes(cam, means, covs, opacities, settings, out)
}

/// Stand-in where there is no AVX2 build ([`lanes_available`] is false there).
///
/// # Safety
/// None needed; `unsafe` only to match the x86-64 signature.
#[cfg(not(target_arch = "x86_64"))]
pub(crate) unsafe fn splats_of_lanes_avx2(
    cam: &ProjCam,
    means: &[[f32; 3]],
    covs: &[Mat3],
    opacities: &[f32],
    settings: &RasterSettings,
    out: &mut [Splat2d],
) {
    splats_of_lanes(cam, means, covs, opacities, settings, out)
}

/// Projects `LANES` Gaussians: `means`, `covs` (world covariances), `opacities` and `out`, `[LANES]`
/// each (longer slices are cut to `LANES`).
#[inline(always)]
fn splats_of_lanes(
    cam: &ProjCam,
    means: &[[f32; 3]],
    covs: &[Mat3],
    opacities: &[f32],
    settings: &RasterSettings,
    out: &mut [Splat2d],
) {
    const L: usize = LANES;
    let (means, covs, opacities, out) = (&means[..L], &covs[..L], &opacities[..L], &mut out[..L]);
    // Inputs as structure of arrays: `m[k][l]`, `c[j][r][l]` = column j, row r of lane l's Σ.
    let mut m = [[0f32; L]; 3];
    let mut c = [[[0f32; L]; 3]; 3];
    for l in 0..L {
        for k in 0..3 {
            m[k][l] = means[l][k];
        }
        for (j, column) in c.iter_mut().enumerate() {
            let col = covs[l].col(j);
            for r in 0..3 {
                column[r][l] = col[r];
            }
        }
    }
    // Camera constants: `w[j][r]` = column j, row r of W; `wt` of Wᵀ.
    let w = [cam.w.x_axis.to_array(), cam.w.y_axis.to_array(), cam.w.z_axis.to_array()];
    let wtm = cam.w.transpose();
    let wt = [wtm.x_axis.to_array(), wtm.y_axis.to_array(), wtm.z_axis.to_array()];
    let t = cam.t.to_array();
    let (fx, fy, cx, cy) = (cam.fx, cam.fy, cam.cx, cam.cy);
    let eps2d = settings.eps2d;
    let (max_eigen, sigmas) = match settings.extent {
        Extent::MaxEigen { sigmas } => (true, sigmas),
        Extent::PerAxis { sigmas } => (false, sigmas),
    };
    let mut o = [[0f32; L]; 9]; // mean x, y, conic a, b, c, depth, r x, r y, in-depth-range
    for l in 0..L {
        // p_c = W·mean + t (glam's Mat3 · Vec3: columns times components, summed left to right).
        let p = |r: usize| ((w[0][r] * m[0][l] + w[1][r] * m[1][l]) + w[2][r] * m[2][l]) + t[r];
        let (px, py, pz) = (p(0), p(1), p(2));
        // Σ_c = (W Σ) Wᵀ.
        let mut a = [[0f32; 3]; 3];
        for j in 0..3 {
            for r in 0..3 {
                a[j][r] = (w[0][r] * c[j][0][l] + w[1][r] * c[j][1][l]) + w[2][r] * c[j][2][l];
            }
        }
        let mut cc = [[0f32; 3]; 3];
        for j in 0..3 {
            for r in 0..3 {
                cc[j][r] = (a[0][r] * wt[j][0] + a[1][r] * wt[j][1]) + a[2][r] * wt[j][2];
            }
        }
        let tz = pz;
        let (rx, ry) = (px / tz, py / tz);
        let txc = tz * rx.clamp(cam.lim_x.0, cam.lim_x.1);
        let tyc = tz * ry.clamp(cam.lim_y.0, cam.lim_y.1);
        let j0 = [fx / tz, 0.0, -fx * txc / (tz * tz)];
        let j1 = [0.0, fy / tz, -fy * tyc / (tz * tz)];
        let mat_vec = |v: [f32; 3], r: usize| (cc[0][r] * v[0] + cc[1][r] * v[1]) + cc[2][r] * v[2];
        let s0 = [mat_vec(j0, 0), mat_vec(j0, 1), mat_vec(j0, 2)];
        let s1 = [mat_vec(j1, 0), mat_vec(j1, 1), mat_vec(j1, 2)];
        let dot = |u: [f32; 3], v: [f32; 3]| (u[0] * v[0] + u[1] * v[1]) + u[2] * v[2];
        let cov2d = [dot(j0, s0) + eps2d, dot(j0, s1), dot(j1, s1) + eps2d];
        let det = (cov2d[0] * cov2d[2] - cov2d[1] * cov2d[1]).max(1e-10);
        let depth = pz;
        let mean2d = [fx * px / depth + cx, fy * py / depth + cy];
        let conic = [cov2d[2] / det, -cov2d[1] / det, cov2d[0] / det];
        let radius = if max_eigen {
            let b = 0.5 * (cov2d[0] + cov2d[2]);
            let v1 = b + (b * b - det).max(0.1).sqrt();
            let r = (sigmas * v1.sqrt()).ceil();
            [r, r]
        } else {
            [(sigmas * cov2d[0].sqrt()).ceil(), (sigmas * cov2d[2].sqrt()).ceil()]
        };
        let in_range = pz > cam.near && pz < cam.far;
        let inside = mean2d[0] + radius[0] > 0.0
            && mean2d[0] - radius[0] < cam.width
            && mean2d[1] + radius[1] > 0.0
            && mean2d[1] - radius[1] < cam.height;
        let finite = mean2d[0].is_finite()
            && mean2d[1].is_finite()
            && conic[0].is_finite()
            && conic[1].is_finite()
            && conic[2].is_finite()
            && radius[0].is_finite()
            && radius[1].is_finite();
        let keep = inside && finite;
        o[0][l] = mean2d[0];
        o[1][l] = mean2d[1];
        o[2][l] = conic[0];
        o[3][l] = conic[1];
        o[4][l] = conic[2];
        o[5][l] = depth;
        o[6][l] = if keep { radius[0] } else { 0.0 };
        o[7][l] = if keep { radius[1] } else { 0.0 };
        o[8][l] = if in_range { 1.0 } else { 0.0 };
    }
    for l in 0..L {
        out[l] = if o[8][l] == 1.0 {
            Splat2d {
                mean2d: [o[0][l], o[1][l]],
                conic: [o[2][l], o[3][l], o[4][l]],
                opacity: opacities[l],
                depth: o[5][l],
                radii: [o[6][l] as i32, o[7][l] as i32],
            }
        } else {
            // As the one-Gaussian projection culls by depth before anything else.
            Splat2d { opacity: opacities[l], depth: o[5][l], ..Splat2d::default() }
        };
    }
}
