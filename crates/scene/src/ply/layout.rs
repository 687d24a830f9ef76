//! Where each Gaussian attribute sits in a vertex row: the mapping from PLY property names to
//! [`Gaussians`] fields, with byte offsets precomputed once per file.

use super::header::PropertyDecl;
use super::scalar::ScalarType;
#[cfg(doc)]
use crate::gaussians::Gaussians;

/// What a vertex property name means to splatseg.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Role {
    /// `x`, `y`, `z`: component of the mean.
    Mean(usize),
    /// `nx`, `ny`, `nz`.
    Normal(usize),
    /// `f_dc_0..2`.
    ShDc(usize),
    /// `f_rest_<i>`.
    ShRest(usize),
    /// `opacity`.
    Opacity,
    /// `scale_0..2`.
    Scale(usize),
    /// `rot_0..3`.
    Rotation(usize),
    /// `object_id`.
    ObjectId,
    /// `feat_<i>`.
    Feature(usize),
    /// Anything else: kept verbatim.
    Extra,
}

/// Parses `<prefix><decimal index>` (no sign, no leading `+`).
fn indexed(name: &str, prefix: &str) -> Option<usize> {
    let digits = name.strip_prefix(prefix)?;
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    digits.parse().ok()
}

/// Classifies a vertex property name.
pub(crate) fn role_of(name: &str) -> Role {
    match name {
        "x" => return Role::Mean(0),
        "y" => return Role::Mean(1),
        "z" => return Role::Mean(2),
        "nx" => return Role::Normal(0),
        "ny" => return Role::Normal(1),
        "nz" => return Role::Normal(2),
        "opacity" => return Role::Opacity,
        "object_id" => return Role::ObjectId,
        _ => {}
    }
    if let Some(i) = indexed(name, "f_dc_").filter(|&i| i < 3) {
        return Role::ShDc(i);
    }
    if let Some(i) = indexed(name, "f_rest_") {
        return Role::ShRest(i);
    }
    if let Some(i) = indexed(name, "scale_").filter(|&i| i < 3) {
        return Role::Scale(i);
    }
    if let Some(i) = indexed(name, "rot_").filter(|&i| i < 4) {
        return Role::Rotation(i);
    }
    if let Some(i) = indexed(name, "feat_") {
        return Role::Feature(i);
    }
    Role::Extra
}

/// Where one value sits in a row.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Source {
    /// Byte offset within the row.
    pub offset: usize,
    /// Stored type.
    pub ty: ScalarType,
}

/// An uninterpreted property: its source and how to write it back.
#[derive(Clone, Debug)]
pub(crate) struct ExtraSource {
    pub name: String,
    pub type_name: String,
    pub source: Source,
}

/// The decoded meaning of a vertex element's properties.
#[derive(Clone, Debug)]
pub(crate) struct VertexLayout {
    /// Bytes per row.
    pub stride: usize,
    pub means: [Source; 3],
    pub normals: Option<[Source; 3]>,
    pub sh_dc: [Source; 3],
    pub sh_degree: u8,
    /// `[3K]` in `f_rest_<i>` order.
    pub sh_rest: Vec<Source>,
    pub opacity: Source,
    pub scales: [Source; 3],
    pub rotations: [Source; 4],
    pub object_id: Option<Source>,
    /// `[D]` in `feat_<i>` order.
    pub features: Vec<Source>,
    pub extras: Vec<ExtraSource>,
}

/// Collects the properties of one role family into an index-ordered list, or says which
/// index is missing.
fn gather<const K: usize>(slots: &[Option<Source>; K], names: [&str; K]) -> Result<[Source; K], String> {
    let mut out = [Source { offset: 0, ty: ScalarType::F32 }; K];
    for k in 0..K {
        out[k] = slots[k].ok_or_else(|| format!("vertex property '{}' is missing", names[k]))?;
    }
    Ok(out)
}

/// Turns an indexed family (`f_rest_*`, `feat_*`) into a dense list; indices must be `0..n`.
fn dense(mut found: Vec<(usize, Source)>, prefix: &str) -> Result<Vec<Source>, String> {
    found.sort_by_key(|&(i, _)| i);
    for (expected, &(i, _)) in found.iter().enumerate() {
        if i != expected {
            return Err(format!(
                "vertex properties {prefix}* must be numbered 0..{} without gaps, but \
                 {prefix}{expected} is missing",
                found.len() - 1
            ));
        }
    }
    Ok(found.into_iter().map(|(_, s)| s).collect())
}

impl VertexLayout {
    /// Builds the layout from the vertex element's scalar properties (in row order).
    pub(crate) fn from_properties(props: &[PropertyDecl]) -> Result<VertexLayout, String> {
        Self::map_properties(props).map_err(|e| {
            let has_position = ["x", "y", "z"].iter().all(|n| props.iter().any(|p| p.name == *n));
            let has_splat = props.iter().any(|p| p.name.starts_with("scale_") || p.name == "opacity");
            if has_position && !has_splat {
                format!("{e} (this looks like a plain point cloud, not a 3D Gaussian Splatting PLY)")
            } else {
                e
            }
        })
    }

    fn map_properties(props: &[PropertyDecl]) -> Result<VertexLayout, String> {
        let mut means = [None; 3];
        let mut normals = [None; 3];
        let mut sh_dc = [None; 3];
        let mut scales = [None; 3];
        let mut rotations = [None; 4];
        let mut opacity = None;
        let mut object_id = None;
        let mut rest = Vec::new();
        let mut features = Vec::new();
        let mut extras = Vec::new();
        let mut offset = 0usize;
        for p in props {
            let source = Source { offset, ty: p.ty };
            offset += p.ty.size();
            let role = role_of(&p.name);
            let stored_as_float = matches!(
                role,
                Role::Mean(_)
                    | Role::ShDc(_)
                    | Role::ShRest(_)
                    | Role::Opacity
                    | Role::Scale(_)
                    | Role::Rotation(_)
                    | Role::Feature(_)
            );
            if stored_as_float && !matches!(p.ty, ScalarType::F32 | ScalarType::F64) {
                return Err(format!(
                    "property '{}' is {}, but a 3D Gaussian Splatting PLY stores it as float (opacity as \
                     a logit, scales as logs): this file follows another convention",
                    p.name, p.type_name
                ));
            }
            match role {
                Role::Mean(k) => means[k] = Some(source),
                Role::Normal(k) => normals[k] = Some(source),
                Role::ShDc(k) => sh_dc[k] = Some(source),
                Role::ShRest(i) => rest.push((i, source)),
                Role::Opacity => opacity = Some(source),
                Role::Scale(k) => scales[k] = Some(source),
                Role::Rotation(k) => rotations[k] = Some(source),
                Role::ObjectId => object_id = Some(source),
                Role::Feature(i) => features.push((i, source)),
                Role::Extra => {
                    extras.push(ExtraSource { name: p.name.clone(), type_name: p.type_name.clone(), source })
                }
            }
        }
        let normals = match normals.iter().filter(|n| n.is_some()).count() {
            0 => None,
            3 => Some(gather(&normals, ["nx", "ny", "nz"])?),
            _ => return Err("vertex has some of nx, ny, nz but not all three".to_string()),
        };
        let sh_rest = dense(rest, "f_rest_")?;
        let sh_degree = match sh_rest.len() {
            0 => 0,
            9 => 1,
            24 => 2,
            45 => 3,
            n => {
                return Err(format!(
                    "vertex has {n} f_rest_* properties; expected 0, 9, 24 or 45 (SH degree 0–3)"
                ))
            }
        };
        Ok(VertexLayout {
            stride: offset,
            means: gather(&means, ["x", "y", "z"])?,
            normals,
            sh_dc: gather(&sh_dc, ["f_dc_0", "f_dc_1", "f_dc_2"])?,
            sh_degree,
            sh_rest,
            opacity: opacity.ok_or_else(|| "vertex property 'opacity' is missing".to_string())?,
            scales: gather(&scales, ["scale_0", "scale_1", "scale_2"])?,
            rotations: gather(&rotations, ["rot_0", "rot_1", "rot_2", "rot_3"])?,
            object_id,
            features: dense(features, "feat_")?,
            extras,
        })
    }

    /// True when every float field (all but `object_id` and the extras) is stored as `float`,
    /// the usual case, which the decoder reads without per-value type dispatch.
    pub(crate) fn floats_are_f32(&self) -> bool {
        let f32 = |s: &Source| s.ty == ScalarType::F32;
        self.means.iter().all(f32)
            && self.normals.as_ref().is_none_or(|n| n.iter().all(f32))
            && self.sh_dc.iter().all(f32)
            && self.sh_rest.iter().all(f32)
            && f32(&self.opacity)
            && self.scales.iter().all(f32)
            && self.rotations.iter().all(f32)
            && self.features.iter().all(f32)
    }
}
