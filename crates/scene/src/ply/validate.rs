//! [`Gaussians::validate`]: consistent array lengths, finite values, writable extras.

use super::layout::{role_of, Role};
use super::scalar::ScalarType;
use crate::gaussians::Gaussians;

/// Index and value of the first non-finite element of `values`, counted in groups of `width`.
fn first_non_finite(values: &[f32], width: usize) -> Option<(usize, usize, f32)> {
    let i = values.iter().position(|v| !v.is_finite())?;
    Some((i / width, i % width, values[i]))
}

/// Checks one flattened `[N, width]` float array; `names(k)` is the PLY name of column `k`.
fn check_finite(values: &[f32], width: usize, names: impl Fn(usize) -> String) -> Result<(), String> {
    match first_non_finite(values, width.max(1)) {
        Some((index, column, v)) => {
            Err(format!("non-finite value {v} in property '{}' at Gaussian {index}", names(column)))
        }
        None => Ok(()),
    }
}

/// The largest log-scale a Gaussian may have: a scale above `e^20` (≈ 4.9e8 scene units) makes
/// the rasteriser's 2D covariance and its determinant overflow `f32` for ordinary cameras, so such
/// a Gaussian is culled however it lies; a reconstruction has none (3DGS's are below `e^5`).
pub const MAX_LOG_SCALE: f32 = 20.0;

/// A rotation quaternion shorter than this has no direction (the renderer would not normalise it).
pub const MIN_QUATERNION_NORM: f32 = 1e-12;

/// Why a Gaussian of finite `log_scales` and `rotation` (w, x, y, z) has no usable shape, or
/// `None`: a zero quaternion ([`MIN_QUATERNION_NORM`]) or a log-scale above [`MAX_LOG_SCALE`].
pub fn degenerate_shape(log_scales: [f32; 3], rotation: [f32; 4]) -> Option<&'static str> {
    let norm = rotation.iter().map(|&q| f64::from(q) * f64::from(q)).sum::<f64>().sqrt();
    if norm < f64::from(MIN_QUATERNION_NORM) {
        Some("a zero rotation quaternion")
    } else if log_scales.iter().any(|&s| s > MAX_LOG_SCALE) {
        Some("a log-scale above 20 (a scale too large to have a covariance)")
    } else {
        None
    }
}

fn check_len(what: &str, len: usize, expected: usize) -> Result<(), String> {
    if len == expected {
        Ok(())
    } else {
        Err(format!("{what} has {len} entries but there are {expected} Gaussians"))
    }
}

impl Gaussians {
    /// Checks that the set can be written and used: every per-Gaussian array has length N
    /// (`sh_rest` N·3K, features N·D with D ≥ 1), `sh_degree ≤ 3`, every float of the known
    /// properties is finite (the error names the PLY property and the first bad index),
    /// extras have distinct, non-reserved, whitespace-free names, a known PLY type and values
    /// that type can hold. Called by [`crate::ply::read_ply`] and [`crate::ply::write_ply`].
    pub fn validate(&self) -> Result<(), String> {
        self.validate_structure()?;
        self.check_finite_values(3 * self.rest_per_channel())
    }

    /// [`Gaussians::validate`] without the finite-value check: what a set with some non-finite
    /// Gaussians ([`Gaussians::non_finite_rows`]) must still satisfy to be read or written.
    pub fn validate_structure(&self) -> Result<(), String> {
        let n = self.len();
        if self.sh_degree > 3 {
            return Err(format!("SH degree {} is not in 0..=3", self.sh_degree));
        }
        let k3 = 3 * self.rest_per_channel();
        if let Some(normals) = &self.normals {
            check_len("normals", normals.len(), n)?;
        }
        check_len("sh_dc", self.sh_dc.len(), n)?;
        if self.sh_rest.len() != n * k3 {
            return Err(format!(
                "sh_rest has {} values but SH degree {} needs {k3} per Gaussian × {n} Gaussians",
                self.sh_rest.len(),
                self.sh_degree
            ));
        }
        check_len("raw_opacities", self.raw_opacities.len(), n)?;
        check_len("log_scales", self.log_scales.len(), n)?;
        check_len("rotations", self.rotations.len(), n)?;
        if let Some(ids) = &self.object_ids {
            check_len("object_ids", ids.len(), n)?;
        }
        if let Some(f) = &self.features {
            if f.dim == 0 {
                return Err("features have dimension 0 (use None for no features)".to_string());
            }
            if f.values.len() != n * f.dim {
                return Err(format!(
                    "features have {} values but dimension {} × {n} Gaussians needs {}",
                    f.values.len(),
                    f.dim,
                    n * f.dim
                ));
            }
        }
        self.check_extras()
    }

    /// `[k]` ascending indices of the Gaussians holding a non-finite value (NaN, ±Inf) in a
    /// property splatseg interprets (position, normal, colour, opacity, scale, rotation,
    /// feature); extras are not looked at. Needs [`Gaussians::validate_structure`] to hold.
    pub fn non_finite_rows(&self) -> Vec<usize> {
        let k3 = 3 * self.rest_per_channel();
        let finite = |v: &[f32]| v.iter().all(|x| x.is_finite());
        (0..self.len())
            .filter(|&i| {
                !(finite(&self.means[i])
                    && self.normals.as_ref().is_none_or(|n| finite(&n[i]))
                    && finite(&self.sh_dc[i])
                    && finite(&self.sh_rest[i * k3..(i + 1) * k3])
                    && self.raw_opacities[i].is_finite()
                    && finite(&self.log_scales[i])
                    && finite(&self.rotations[i])
                    && self.features.as_ref().is_none_or(|f| finite(&f.values[i * f.dim..(i + 1) * f.dim])))
            })
            .collect()
    }

    /// `[k]` ascending indices of the Gaussians that hold only finite values but have no usable
    /// shape ([`degenerate_shape`]): a zero rotation quaternion or a scale too large to have a
    /// covariance. The renderer culls or mis-draws them; readers skip them as they skip
    /// non-finite rows. Needs [`Gaussians::validate_structure`] to hold.
    pub fn degenerate_rows(&self) -> Vec<usize> {
        (0..self.len())
            .filter(|&i| degenerate_shape(self.log_scales[i], self.rotations[i]).is_some())
            .collect()
    }

    /// The first non-finite value as [`Gaussians::validate`] reports it (property and
    /// Gaussian index), or `None` when every value is finite.
    pub fn first_non_finite(&self) -> Option<String> {
        self.check_finite_values(3 * self.rest_per_channel()).err()
    }

    fn check_finite_values(&self, k3: usize) -> Result<(), String> {
        let xyz = ["x", "y", "z"];
        check_finite(self.means.as_flattened(), 3, |k| xyz[k].to_string())?;
        if let Some(normals) = &self.normals {
            check_finite(normals.as_flattened(), 3, |k| format!("n{}", xyz[k]))?;
        }
        check_finite(self.sh_dc.as_flattened(), 3, |k| format!("f_dc_{k}"))?;
        check_finite(&self.sh_rest, k3, |k| format!("f_rest_{k}"))?;
        check_finite(&self.raw_opacities, 1, |_| "opacity".to_string())?;
        check_finite(self.log_scales.as_flattened(), 3, |k| format!("scale_{k}"))?;
        check_finite(self.rotations.as_flattened(), 4, |k| format!("rot_{k}"))?;
        if let Some(f) = &self.features {
            check_finite(&f.values, f.dim, |k| format!("feat_{k}"))?;
        }
        Ok(())
    }

    fn check_extras(&self) -> Result<(), String> {
        let n = self.len();
        for (j, e) in self.extra.iter().enumerate() {
            let name = &e.name;
            if name.is_empty() || !name.bytes().all(|b| b.is_ascii_graphic()) {
                return Err(format!(
                    "extra property name '{name}' must be non-empty printable ASCII without spaces"
                ));
            }
            if role_of(name) != Role::Extra {
                return Err(format!(
                    "extra property '{name}' has the name of a property splatseg interprets"
                ));
            }
            if self.extra[..j].iter().any(|o| &o.name == name) {
                return Err(format!("extra property '{name}' appears twice"));
            }
            let ty = ScalarType::from_name(&e.ply_type)
                .ok_or_else(|| format!("extra property '{name}' has unknown PLY type '{}'", e.ply_type))?;
            check_len(&format!("extra property '{name}'"), e.values.len(), n)?;
            if let Some(i) = e.values.iter().position(|&v| !ty.can_store(v)) {
                return Err(format!(
                    "extra property '{name}' ({}) cannot store value {} at Gaussian {i}",
                    e.ply_type, e.values[i]
                ));
            }
        }
        Ok(())
    }
}
