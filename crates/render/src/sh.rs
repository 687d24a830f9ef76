//! View-dependent colour from spherical harmonics (degree 0–3) and its backward.
//!
//! The real SH basis of 3DGS (Sloan, "Efficient Spherical Harmonic Evaluation", JCGT 2013),
//! evaluated at the unit view direction `(mean − camera centre) / |·|`; colour =
//! `Σ basis·coeff + 0.5`, clamped at 0 (gsplat's `clamp_min(colors + 0.5, 0)`; the gradient is zero where the
//! clamp is active). Coefficients use the INRIA PLY layout of [`splatseg_scene::Gaussians`]:
//! `sh_dc [3]` and `sh_rest [3, K]` channel-major.
//!
//! Called per Gaussian from the projection kernels; no threading here.

/// Basis constant of degree 0.
pub const SH_C0: f32 = 0.282_094_79;
const SH_C1: f32 = 0.488_602_51;
const C2_XY: f32 = 1.092_548_4;
const C2_ZZ: f32 = 0.946_174_7;
const C2_ZZ0: f32 = 0.315_391_57;
const C2_XXYY: f32 = 0.546_274_2;
const C3_A: f32 = -0.590_043_6;
const C3_B: f32 = 1.445_305_7;
const C3_C2: f32 = -2.285_229;
const C3_C0: f32 = 0.457_045_8;
const C3_Z3: f32 = 1.865_881_7;
const C3_Z1: f32 = 1.119_529;

/// Number of basis functions used for `degree` (`(degree + 1)²`).
pub fn basis_count(degree: u8) -> usize {
    (degree as usize + 1) * (degree as usize + 1)
}

/// Unit direction and the length it was normalised by (guarded like `F.normalize`, eps 1e-12).
pub fn normalise(dir: [f32; 3]) -> ([f32; 3], f32) {
    let len = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt().max(1e-12);
    ([dir[0] / len, dir[1] / len, dir[2] / len], len)
}

/// Basis values `[16]` (the first `basis_count(degree)` are set) at unit direction `u`.
pub fn eval_basis(u: [f32; 3], degree: u8) -> [f32; 16] {
    let [x, y, z] = u;
    let mut b = [0.0f32; 16];
    b[0] = SH_C0;
    if degree >= 1 {
        b[1] = -SH_C1 * y;
        b[2] = SH_C1 * z;
        b[3] = -SH_C1 * x;
    }
    if degree >= 2 {
        b[4] = C2_XY * x * y;
        b[5] = -C2_XY * y * z;
        b[6] = C2_ZZ * z * z - C2_ZZ0;
        b[7] = -C2_XY * x * z;
        b[8] = C2_XXYY * (x * x - y * y);
    }
    if degree >= 3 {
        let c = C3_C2 * z * z + C3_C0;
        b[9] = C3_A * (3.0 * x * x * y - y * y * y);
        b[10] = C3_B * z * 2.0 * x * y;
        b[11] = c * y;
        b[12] = z * (C3_Z3 * z * z - C3_Z1);
        b[13] = c * x;
        b[14] = C3_B * z * (x * x - y * y);
        b[15] = C3_A * (x * x * x - 3.0 * x * y * y);
    }
    b
}

/// `Σ_k g[k] · ∂basis_k/∂u` at unit direction `u` (`g: [16]`).
fn basis_vjp(u: [f32; 3], degree: u8, g: &[f32; 16]) -> [f32; 3] {
    let [x, y, z] = u;
    let mut d = [0.0f32; 3];
    let mut add = |k: usize, dx: f32, dy: f32, dz: f32| {
        d[0] += g[k] * dx;
        d[1] += g[k] * dy;
        d[2] += g[k] * dz;
    };
    if degree >= 1 {
        add(1, 0.0, -SH_C1, 0.0);
        add(2, 0.0, 0.0, SH_C1);
        add(3, -SH_C1, 0.0, 0.0);
    }
    if degree >= 2 {
        add(4, C2_XY * y, C2_XY * x, 0.0);
        add(5, 0.0, -C2_XY * z, -C2_XY * y);
        add(6, 0.0, 0.0, 2.0 * C2_ZZ * z);
        add(7, -C2_XY * z, 0.0, -C2_XY * x);
        add(8, 2.0 * C2_XXYY * x, -2.0 * C2_XXYY * y, 0.0);
    }
    if degree >= 3 {
        let c = C3_C2 * z * z + C3_C0;
        let dc_dz = 2.0 * C3_C2 * z;
        add(9, C3_A * 6.0 * x * y, C3_A * 3.0 * (x * x - y * y), 0.0);
        add(10, 2.0 * C3_B * y * z, 2.0 * C3_B * x * z, 2.0 * C3_B * x * y);
        add(11, 0.0, c, y * dc_dz);
        add(12, 0.0, 0.0, 3.0 * C3_Z3 * z * z - C3_Z1);
        add(13, c, 0.0, x * dc_dz);
        add(14, 2.0 * C3_B * z * x, -2.0 * C3_B * z * y, C3_B * (x * x - y * y));
        add(15, C3_A * 3.0 * (x * x - y * y), -C3_A * 6.0 * x * y, 0.0);
    }
    d
}

/// SH coefficients of one Gaussian.
#[derive(Clone, Copy, Debug)]
pub struct ShCoeffs<'a> {
    /// Degree-0 coefficients `[3]` (one per channel).
    pub dc: [f32; 3],
    /// Higher coefficients `[3, k_per_channel]`, channel-major (INRIA `f_rest` order).
    pub rest: &'a [f32],
    /// Coefficients per channel in `rest` (`(stored degree + 1)² − 1`).
    pub k_per_channel: usize,
}

/// Colour before the clamp (`Σ basis·coeff + 0.5`) for view direction `dir` (unnormalised,
/// `mean − camera centre`), using SH up to `degree`.
pub fn colour_unclamped(coeffs: &ShCoeffs, degree: u8, dir: [f32; 3]) -> [f32; 3] {
    let (u, _) = normalise(dir);
    let b = eval_basis(u, degree);
    let n = basis_count(degree);
    [0, 1, 2].map(|c| {
        let rest = &coeffs.rest[c * coeffs.k_per_channel..];
        let mut v = SH_C0 * coeffs.dc[c];
        for k in 1..n {
            v += b[k] * rest[k - 1];
        }
        v + 0.5
    })
}

/// Colour, clamped at 0 (gsplat's convention; values above 1 are kept).
pub fn colour(coeffs: &ShCoeffs, degree: u8, dir: [f32; 3]) -> [f32; 3] {
    colour_unclamped(coeffs, degree, dir).map(|v| v.max(0.0))
}

/// Backward of [`colour`]: given `d_colour [3]`, adds the coefficient gradients into `d_dc [3]`
/// and `d_rest [3, k_per_channel]` and returns the gradient w.r.t. the unnormalised `dir`.
pub fn colour_bwd(
    coeffs: &ShCoeffs,
    degree: u8,
    dir: [f32; 3],
    d_colour: [f32; 3],
    d_dc: &mut [f32; 3],
    d_rest: &mut [f32],
) -> [f32; 3] {
    let raw = colour_unclamped(coeffs, degree, dir);
    let (u, len) = normalise(dir);
    let b = eval_basis(u, degree);
    let n = basis_count(degree);
    let mut g_basis = [0.0f32; 16];
    for c in 0..3 {
        // torch.clamp_min passes the gradient where the input is >= the bound.
        let g = if raw[c] >= 0.0 { d_colour[c] } else { 0.0 };
        if g == 0.0 {
            continue;
        }
        d_dc[c] += SH_C0 * g;
        let rest = &coeffs.rest[c * coeffs.k_per_channel..];
        let d_rest_c = &mut d_rest[c * coeffs.k_per_channel..];
        for k in 1..n {
            d_rest_c[k - 1] += b[k] * g;
            g_basis[k] += rest[k - 1] * g;
        }
    }
    if n == 1 {
        return [0.0; 3];
    }
    let g_u = basis_vjp(u, degree, &g_basis);
    let radial = g_u[0] * u[0] + g_u[1] * u[1] + g_u[2] * u[2];
    [0, 1, 2].map(|i| (g_u[i] - u[i] * radial) / len)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_gradient_matches_finite_differences() {
        let u = normalise([0.3, -0.5, 0.8]).0;
        for k in 1..16 {
            let mut g = [0.0f32; 16];
            g[k] = 1.0;
            let d = basis_vjp(u, 3, &g);
            for i in 0..3 {
                let h = 1e-3f32;
                let mut up = u;
                let mut dn = u;
                up[i] += h;
                dn[i] -= h;
                let fd = (eval_basis(up, 3)[k] - eval_basis(dn, 3)[k]) / (2.0 * h);
                assert!((fd - d[i]).abs() < 2e-3, "basis {k} axis {i}: fd {fd} analytic {}", d[i]);
            }
        }
    }

    #[test]
    fn basis_is_orthonormal_on_the_sphere() {
        // Monte-Carlo-free check: integrate over a Fibonacci sphere; ∫ b_i b_j = δ_ij.
        let n = 20000;
        let mut gram = [[0.0f64; 16]; 16];
        for s in 0..n {
            let z = 1.0 - 2.0 * (s as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = s as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
            let b = eval_basis([(r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32], 3);
            for i in 0..16 {
                for j in 0..16 {
                    gram[i][j] += b[i] as f64 * b[j] as f64 * 4.0 * std::f64::consts::PI / n as f64;
                }
            }
        }
        for (i, row) in gram.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((v - want).abs() < 1e-3, "gram[{i}][{j}] = {v}");
            }
        }
    }
}
