//! [`Gaussians`]: a 3D Gaussian Splatting scene as stored in the INRIA PLY layout, struct of arrays.
//!
//! Values are stored as the PLY stores them ("raw"): `log_scales` (actual scale = exp),
//! `raw_opacities` (actual opacity = sigmoid), `rotations` as unnormalised quaternions in
//! `w, x, y, z` order (PLY `rot_0..rot_3`), SH coefficients in the INRIA channel-major layout.

use serde::{Deserialize, Serialize};

/// Number of SH coefficients per colour channel for a degree (`(d + 1)²`).
pub fn sh_coeffs_for_degree(degree: u8) -> usize {
    (degree as usize + 1) * (degree as usize + 1)
}

/// The zeroth SH basis constant: colour = `SH_C0 * f_dc + 0.5`.
pub const SH_C0: f32 = 0.282_094_8;

/// A PLY property splatseg does not interpret, kept so it survives a round trip.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExtraProperty {
    /// Property name as in the header.
    pub name: String,
    /// PLY scalar type name as in the header (`float`, `uchar`, `int`, ...).
    pub ply_type: String,
    /// `[N]` values, converted to f64 (exact for every PLY scalar type but 64-bit ints).
    pub values: Vec<f64>,
}

/// A set of N 3D Gaussians. All per-Gaussian arrays have length N (or N × k as documented).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Gaussians {
    /// `[N]` centres in world coordinates.
    pub means: Vec<[f32; 3]>,
    /// `[N]` normals (`nx ny nz`), when the file has them (3DGS writes zeros).
    pub normals: Option<Vec<[f32; 3]>>,
    /// `[N]` degree-0 SH coefficients (`f_dc_0..2`), one per colour channel.
    pub sh_dc: Vec<[f32; 3]>,
    /// SH degree of `sh_rest` (0–3).
    pub sh_degree: u8,
    /// `[N, 3, K]` flattened, `K = (sh_degree + 1)² - 1`: the INRIA `f_rest_*` order, i.e.
    /// `sh_rest[n * 3 * K + c * K + k]` is coefficient `k + 1` of channel `c`.
    pub sh_rest: Vec<f32>,
    /// `[N]` opacities before the sigmoid.
    pub raw_opacities: Vec<f32>,
    /// `[N]` natural-log scales along the Gaussian's local axes.
    pub log_scales: Vec<[f32; 3]>,
    /// `[N]` rotations as quaternions `w, x, y, z` (not necessarily normalised).
    pub rotations: Vec<[f32; 4]>,
    /// `[N]` object ids (PLY `object_id`, int), `-1` = no object. Written by `lift`.
    pub object_ids: Option<Vec<i32>>,
    /// `[N, D]` flattened per-Gaussian feature vectors (PLY `feat_0..feat_{D-1}`).
    pub features: Option<FeatureBlock>,
    /// Properties the file had that splatseg does not interpret, in file order.
    pub extra: Vec<ExtraProperty>,
}

/// Per-Gaussian feature vectors, `[N, dim]` row-major.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FeatureBlock {
    /// Feature dimension D.
    pub dim: usize,
    /// `[N * dim]`, row-major.
    pub values: Vec<f32>,
}

impl Gaussians {
    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.means.len()
    }

    /// True when there are no Gaussians.
    pub fn is_empty(&self) -> bool {
        self.means.is_empty()
    }

    /// Number of `f_rest` coefficients per channel, `(degree + 1)² - 1`.
    pub fn rest_per_channel(&self) -> usize {
        sh_coeffs_for_degree(self.sh_degree) - 1
    }

    /// Opacity in (0, 1) of Gaussian `i`.
    pub fn opacity(&self, i: usize) -> f32 {
        1.0 / (1.0 + (-self.raw_opacities[i]).exp())
    }

    /// Scales (exp of the log-scales) of Gaussian `i`.
    pub fn scales(&self, i: usize) -> [f32; 3] {
        let s = self.log_scales[i];
        [s[0].exp(), s[1].exp(), s[2].exp()]
    }

    /// View-independent colour of Gaussian `i` (`SH_C0 * f_dc + 0.5`, clamped to [0, 1]).
    pub fn base_colour(&self, i: usize) -> [f32; 3] {
        let d = self.sh_dc[i];
        [0, 1, 2].map(|c| (SH_C0 * d[c] + 0.5).clamp(0.0, 1.0))
    }

    /// A new set holding the Gaussians at `indices`, in that order, with every per-Gaussian
    /// array (including extras, ids and features) subset consistently.
    pub fn select(&self, indices: &[usize]) -> Gaussians {
        let k3 = 3 * self.rest_per_channel();
        Gaussians {
            means: indices.iter().map(|&i| self.means[i]).collect(),
            normals: self.normals.as_ref().map(|n| indices.iter().map(|&i| n[i]).collect()),
            sh_dc: indices.iter().map(|&i| self.sh_dc[i]).collect(),
            sh_degree: self.sh_degree,
            sh_rest: indices
                .iter()
                .flat_map(|&i| self.sh_rest[i * k3..(i + 1) * k3].iter().copied())
                .collect(),
            raw_opacities: indices.iter().map(|&i| self.raw_opacities[i]).collect(),
            log_scales: indices.iter().map(|&i| self.log_scales[i]).collect(),
            rotations: indices.iter().map(|&i| self.rotations[i]).collect(),
            object_ids: self.object_ids.as_ref().map(|o| indices.iter().map(|&i| o[i]).collect()),
            features: self.features.as_ref().map(|f| FeatureBlock {
                dim: f.dim,
                values: indices
                    .iter()
                    .flat_map(|&i| f.values[i * f.dim..(i + 1) * f.dim].iter().copied())
                    .collect(),
            }),
            extra: self
                .extra
                .iter()
                .map(|e| ExtraProperty {
                    name: e.name.clone(),
                    ply_type: e.ply_type.clone(),
                    values: indices.iter().map(|&i| e.values[i]).collect(),
                })
                .collect(),
        }
    }
}
