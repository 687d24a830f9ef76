//! antimatter15's `.splat`: no header, 32 bytes per Gaussian: position f32 × 3, scale f32 × 3
//! (linear, not log), colour and opacity u8 × 4 (`(0.5 + SH_C0 · f_dc) · 255`, `sigmoid(opacity) ·
//! 255`), rotation u8 × 4 (`w x y z` of the normalised quaternion as `q · 128 + 128`),
//! little-endian. No SH rest (degree 0), no normals, no other properties.

use super::quantise::{logit_of_byte, sigmoid, to_u8};
use crate::gaussians::{Gaussians, SH_C0};

/// Format name used in error messages.
pub(crate) const FORMAT: &str = ".splat";

/// Bytes per Gaussian.
pub(crate) const ROW_BYTES: usize = 32;

/// Decodes a whole `.splat` file. A scale of 0 or below gives a non-finite log-scale, which the
/// caller skips or refuses as it does a PLY's non-finite values.
pub(crate) fn parse_splat(file: &[u8]) -> Result<Gaussians, String> {
    if !file.len().is_multiple_of(ROW_BYTES) {
        return Err(format!(
            "{} bytes is not a multiple of the 32 bytes of a Gaussian ({} whole Gaussians and {} \
             bytes over): truncated, or not a .splat file",
            file.len(),
            file.len() / ROW_BYTES,
            file.len() % ROW_BYTES
        ));
    }
    let n = file.len() / ROW_BYTES;
    crate::limits::check_gaussians(n as u64)?;
    let f32_at = |row: &[u8], o: usize| f32::from_le_bytes([row[o], row[o + 1], row[o + 2], row[o + 3]]);
    let mut g = Gaussians {
        means: Vec::with_capacity(n),
        sh_dc: Vec::with_capacity(n),
        raw_opacities: Vec::with_capacity(n),
        log_scales: Vec::with_capacity(n),
        rotations: Vec::with_capacity(n),
        ..Gaussians::default()
    };
    for row in file.chunks_exact(ROW_BYTES) {
        g.means.push([0, 1, 2].map(|a| f32_at(row, 4 * a)));
        g.log_scales.push([0, 1, 2].map(|a| f32_at(row, 12 + 4 * a).ln()));
        g.sh_dc.push([0, 1, 2].map(|c| (row[24 + c] as f32 / 255.0 - 0.5) / SH_C0));
        g.raw_opacities.push(logit_of_byte(row[27]));
        g.rotations.push([0, 1, 2, 3].map(|i| (row[28 + i] as f32 - 128.0) / 128.0));
    }
    Ok(g)
}

/// The bytes of a `.splat` file holding `g` (which the caller validated: finite values). SH rest,
/// normals, ids, features and extras are not written; colours outside [0, 1] are clamped.
pub(crate) fn to_splat_bytes(g: &Gaussians) -> Vec<u8> {
    let mut out = Vec::with_capacity(g.len() * ROW_BYTES);
    for i in 0..g.len() {
        for v in g.means[i] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in g.scales(i) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend(g.sh_dc[i].map(|dc| to_u8((0.5 + SH_C0 * dc) * 255.0)));
        out.push(to_u8(sigmoid(g.raw_opacities[i]) * 255.0));
        let q = g.rotations[i];
        let norm = q.iter().map(|v| v * v).sum::<f32>().sqrt();
        let unit = if norm > 0.0 { q.map(|v| v / norm) } else { [1.0, 0.0, 0.0, 0.0] };
        out.extend(unit.map(|v| to_u8(v * 128.0 + 128.0)));
    }
    out
}
