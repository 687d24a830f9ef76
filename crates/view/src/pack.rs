//! The compact binary layout the server sends the page: 48 bytes (12 little-endian 32-bit words)
//! per Gaussian, the same layout the page uploads as-is into its `RGBA32UI` data texture (three
//! texels per Gaussian), so the browser does no per-Gaussian conversion.
//!
//! | words | content |
//! | --- | --- |
//! | 0–2 | centre x, y, z (f32, world) |
//! | 3 | object slot (u32): index into the manifest's `objects` |
//! | 4–9 | 3D covariance `Σ = R S Sᵀ Rᵀ`: xx, xy, xz, yy, yz, zz (f32) |
//! | 10 | colour: r, g, b, 0 as bytes (SH degree 0: `clamp(0.282095 · f_dc + 0.5)`) |
//! | 11 | opacity (f32, sigmoid of the raw opacity) |
//!
//! `R` is the rotation of the normalised quaternion `(w, x, y, z)` and `S = diag(exp log_scales)`,
//! computed as `splatseg-render`'s projection does, so the page's EWA projection starts from the
//! same covariance.

use splatseg_scene::gaussians::SH_C0;
use splatseg_scene::Gaussians;

/// Bytes per Gaussian in the wire layout.
pub const BYTES_PER_GAUSSIAN: usize = 48;

/// Gaussians per chunk the page fetches (64 texture rows of 1024 Gaussians).
pub const CHUNK_GAUSSIANS: usize = 64 * 1024;

/// `Σ` of one Gaussian as `[xx, xy, xz, yy, yz, zz]`.
pub fn covariance(log_scales: [f32; 3], quat_wxyz: [f32; 4]) -> [f32; 6] {
    let q = quat_wxyz;
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt().max(1e-12);
    let [w, x, y, z] = q.map(|v| v / n);
    // Rows of R.
    let r = [
        [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
        [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
        [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)],
    ];
    let s = log_scales.map(f32::exp);
    // M = R S; Σ = M Mᵀ.
    let m = r.map(|row| [row[0] * s[0], row[1] * s[1], row[2] * s[2]]);
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    [dot(m[0], m[0]), dot(m[0], m[1]), dot(m[0], m[2]), dot(m[1], m[1]), dot(m[1], m[2]), dot(m[2], m[2])]
}

/// Packs every Gaussian (`slots`: `[N]` object slot of each) into the wire layout, `[N × 48]` bytes.
pub fn pack(g: &Gaussians, slots: &[u32]) -> Vec<u8> {
    let mut out = Vec::with_capacity(g.len() * BYTES_PER_GAUSSIAN);
    for (i, &slot) in slots.iter().enumerate().take(g.len()) {
        let mut words = [0u32; 12];
        for (k, v) in g.means[i].iter().enumerate() {
            words[k] = v.to_bits();
        }
        words[3] = slot;
        for (k, v) in covariance(g.log_scales[i], g.rotations[i]).iter().enumerate() {
            words[4 + k] = v.to_bits();
        }
        let rgb = g.sh_dc[i].map(|c| ((SH_C0 * c + 0.5).clamp(0.0, 1.0) * 255.0).round() as u32);
        words[10] = rgb[0] | (rgb[1] << 8) | (rgb[2] << 16);
        words[11] = (1.0 / (1.0 + (-g.raw_opacities[i]).exp())).to_bits();
        for w in words {
            out.extend_from_slice(&w.to_le_bytes());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn covariance_of_an_axis_aligned_gaussian_is_diagonal_scales_squared() {
        let c = covariance([0.0, 1.0f32.ln(), 2.0f32.ln()], [2.0, 0.0, 0.0, 0.0]);
        let expect = [1.0, 0.0, 0.0, 1.0, 0.0, 4.0];
        for (a, b) in c.iter().zip(expect) {
            assert!((a - b).abs() < 1e-6, "{c:?}");
        }
    }

    #[test]
    fn a_quarter_turn_about_z_swaps_x_and_y_variances() {
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let c = covariance([2.0f32.ln(), 0.0, 0.0], [h, 0.0, 0.0, h]);
        assert!((c[0] - 1.0).abs() < 1e-5 && (c[3] - 4.0).abs() < 1e-5 && c[1].abs() < 1e-5, "{c:?}");
    }

    #[test]
    fn packed_words_hold_centre_slot_colour_and_opacity() {
        let g = Gaussians {
            means: vec![[1.0, -2.0, 3.5]],
            sh_dc: vec![[0.0, 10.0, -10.0]],
            raw_opacities: vec![0.0],
            log_scales: vec![[0.0; 3]],
            rotations: vec![[1.0, 0.0, 0.0, 0.0]],
            ..Gaussians::default()
        };
        let bytes = pack(&g, &[7]);
        assert_eq!(bytes.len(), BYTES_PER_GAUSSIAN);
        let word = |k: usize| u32::from_le_bytes(bytes[4 * k..4 * k + 4].try_into().unwrap());
        assert_eq!(f32::from_bits(word(1)), -2.0);
        assert_eq!(word(3), 7);
        assert_eq!(word(10), 128 | (255 << 8));
        assert_eq!(f32::from_bits(word(11)), 0.5);
    }
}
