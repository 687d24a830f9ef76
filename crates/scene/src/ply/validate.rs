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
