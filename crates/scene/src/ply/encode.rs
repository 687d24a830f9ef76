//! Writing: validation, the header in the INRIA property order, rows encoded in parallel
//! chunks, then one atomic write.

use super::scalar::ScalarType;
use super::FORMAT;
use crate::atomic::write_atomic;
use crate::error::{SceneError, SceneResult};
use crate::gaussians::Gaussians;
use rayon::prelude::*;
use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

/// Rows encoded by one parallel task.
const ROWS_PER_TASK: usize = 8 * 1024;

/// Rows encoded and written at a time by [`write_ply`] (≈ 16 MB for 62-float rows).
const ROWS_PER_WRITE: usize = 64 * 1024;

/// Writes `g` as a binary little-endian 3DGS PLY, atomically (temp file + rename), encoding
/// and writing in chunks. Property order: `x y z [nx ny nz] f_dc_0..2 f_rest_* opacity
/// scale_0..2 rot_0..3 [object_id] [feat_*]` then the extras in their order with their types.
/// Fails (naming the file, writing nothing) if [`Gaussians::validate`] does.
pub fn write_ply(path: &Path, g: &Gaussians) -> SceneResult<()> {
    g.validate().map_err(|reason| SceneError::invalid(FORMAT, path, reason))?;
    write_ply_rows(path, g)
}

/// [`write_ply`] for a set that may hold non-finite Gaussians (what [`super::read_ply_rows`]
/// read): they are written as they are, so the output keeps every row of its input. Every
/// other check of [`Gaussians::validate`] still applies.
pub fn write_ply_rows(path: &Path, g: &Gaussians) -> SceneResult<()> {
    write_ply_rows_with_features(path, g, None)
}

/// Per-Gaussian feature rows made on demand while a PLY is written (`feat_*`), so a caller need
/// not hold the whole `[N, dim]` block.
pub trait FeatureRows: Sync {
    /// Feature dimension D.
    fn dim(&self) -> usize;
    /// Writes row `i` (`[dim]`) into `out`.
    fn row(&self, i: usize, out: &mut [f32]);
}

/// [`write_ply_rows`] with the `feat_*` columns from `features` (made row by row as the file is
/// written) instead of `g.features`, which must then be `None`.
pub fn write_ply_rows_with_features(
    path: &Path,
    g: &Gaussians,
    features: Option<&dyn FeatureRows>,
) -> SceneResult<()> {
    if features.is_some() && g.features.is_some() {
        return Err(SceneError::invalid(FORMAT, path, "features given twice (in the Gaussians and as rows)"));
    }
    let plan = RowPlan::new(g, features.map(|f| f.dim()))
        .map_err(|reason| SceneError::invalid(FORMAT, path, reason))?;
    write_atomic(path, |w| write_planned(w, g, features, &plan))
}

/// [`write_ply`] into a folder of the user's (what `extract`, `remove`, `recolor` and the viewer's
/// exports write): through [`crate::atomic::write_atomic_sweeping`], so the temporary file a killed
/// write leaves (hundreds of MB for a large scene) is removed by the next such write there.
pub fn write_ply_swept(path: &Path, g: &Gaussians) -> SceneResult<()> {
    g.validate().map_err(|reason| SceneError::invalid(FORMAT, path, reason))?;
    let plan = RowPlan::new(g, None).map_err(|reason| SceneError::invalid(FORMAT, path, reason))?;
    crate::atomic::write_atomic_sweeping(path, |w| write_planned(w, g, None, &plan))
}

/// The header and every row of `g`, in pieces of [`ROWS_PER_WRITE`] rows.
fn write_planned(
    w: &mut dyn Write,
    g: &Gaussians,
    features: Option<&dyn FeatureRows>,
    plan: &RowPlan,
) -> std::io::Result<()> {
    w.write_all(plan.header.as_bytes())?;
    let mut buffer = vec![0u8; ROWS_PER_WRITE.min(g.len()) * plan.stride];
    for first in (0..g.len()).step_by(ROWS_PER_WRITE) {
        let rows = ROWS_PER_WRITE.min(g.len() - first);
        let chunk = &mut buffer[..rows * plan.stride];
        encode_rows(g, features, plan, first, chunk);
        w.write_all(chunk)?;
    }
    Ok(())
}

/// The bytes of the file [`write_ply`] writes. The error says what is wrong with `g`.
pub fn to_ply_bytes(g: &Gaussians) -> Result<Vec<u8>, String> {
    g.validate()?;
    let plan = RowPlan::new(g, None)?;
    let mut bytes = vec![0u8; plan.header.len() + g.len() * plan.stride];
    let (head, body) = bytes.split_at_mut(plan.header.len());
    head.copy_from_slice(plan.header.as_bytes());
    encode_rows(g, None, &plan, 0, body);
    Ok(bytes)
}

/// What every row needs: the header, the row size and the extras' types.
struct RowPlan {
    header: String,
    stride: usize,
    extra_types: Vec<ScalarType>,
}

impl RowPlan {
    /// Validates `g`'s structure (not its values) and plans its rows; `feature_rows`: the
    /// dimension of features given as rows instead of `g.features`.
    fn new(g: &Gaussians, feature_rows: Option<usize>) -> Result<RowPlan, String> {
        g.validate_structure()?;
        let extra_types: Vec<ScalarType> = g
            .extra
            .iter()
            .map(|e| {
                ScalarType::from_name(&e.ply_type).ok_or_else(|| format!("unknown type '{}'", e.ply_type))
            })
            .collect::<Result<_, _>>()?;
        let dim = feature_rows.or(g.features.as_ref().map(|f| f.dim));
        Ok(RowPlan { header: header_text(g, dim), stride: row_bytes(g, dim, &extra_types), extra_types })
    }
}

/// Encodes Gaussians `first..first + rows` into `out` (`[rows * stride]` bytes), in parallel
/// tasks.
fn encode_rows(
    g: &Gaussians,
    features: Option<&dyn FeatureRows>,
    plan: &RowPlan,
    first: usize,
    out: &mut [u8],
) {
    if plan.stride == 0 {
        return;
    }
    out.par_chunks_mut(ROWS_PER_TASK * plan.stride).enumerate().for_each(|(task, rows)| {
        let start = first + task * ROWS_PER_TASK;
        let mut scratch = vec![0f32; features.map_or(0, |f| f.dim())];
        for (k, row) in rows.chunks_exact_mut(plan.stride).enumerate() {
            let made = features.map(|f| {
                f.row(start + k, &mut scratch);
                &scratch[..]
            });
            encode_row(g, start + k, made, &plan.extra_types, row);
        }
    });
}

/// The header text, ending with `end_header\n`.
fn header_text(g: &Gaussians, feature_dim: Option<usize>) -> String {
    let mut h = String::new();
    let mut prop = |ty: &str, name: &str| {
        // Writing into a String cannot fail.
        let _ = writeln!(h, "property {ty} {name}");
    };
    for name in ["x", "y", "z"] {
        prop("float", name);
    }
    if g.normals.is_some() {
        for name in ["nx", "ny", "nz"] {
            prop("float", name);
        }
    }
    for c in 0..3 {
        prop("float", &format!("f_dc_{c}"));
    }
    for k in 0..3 * g.rest_per_channel() {
        prop("float", &format!("f_rest_{k}"));
    }
    prop("float", "opacity");
    for k in 0..3 {
        prop("float", &format!("scale_{k}"));
    }
    for k in 0..4 {
        prop("float", &format!("rot_{k}"));
    }
    if g.object_ids.is_some() {
        prop("int", "object_id");
    }
    for d in 0..feature_dim.unwrap_or(0) {
        prop("float", &format!("feat_{d}"));
    }
    for e in &g.extra {
        prop(&e.ply_type, &e.name);
    }
    format!("ply\nformat binary_little_endian 1.0\nelement vertex {}\n{h}end_header\n", g.len())
}

/// Bytes per vertex row.
fn row_bytes(g: &Gaussians, feature_dim: Option<usize>, extra_types: &[ScalarType]) -> usize {
    let floats = 3
        + if g.normals.is_some() { 3 } else { 0 }
        + 3
        + 3 * g.rest_per_channel()
        + 1
        + 3
        + 4
        + feature_dim.unwrap_or(0);
    let ids = if g.object_ids.is_some() { 4 } else { 0 };
    4 * floats + ids + extra_types.iter().map(|t| t.size()).sum::<usize>()
}

/// Appends little-endian values to a row.
struct RowWriter<'a> {
    row: &'a mut [u8],
    pos: usize,
}

impl RowWriter<'_> {
    #[inline(always)]
    fn bytes(&mut self, b: &[u8]) {
        self.row[self.pos..self.pos + b.len()].copy_from_slice(b);
        self.pos += b.len();
    }

    #[inline(always)]
    fn floats(&mut self, values: &[f32]) {
        for v in values {
            self.bytes(&v.to_le_bytes());
        }
    }
}

/// Encodes Gaussian `i` into `row` (`[stride]` bytes); `made`: its features, when they come as
/// rows rather than from `g.features`.
fn encode_row(g: &Gaussians, i: usize, made: Option<&[f32]>, extra_types: &[ScalarType], row: &mut [u8]) {
    let k3 = 3 * g.rest_per_channel();
    let mut w = RowWriter { row, pos: 0 };
    w.floats(&g.means[i]);
    if let Some(normals) = &g.normals {
        w.floats(&normals[i]);
    }
    w.floats(&g.sh_dc[i]);
    w.floats(&g.sh_rest[i * k3..(i + 1) * k3]);
    w.floats(&[g.raw_opacities[i]]);
    w.floats(&g.log_scales[i]);
    w.floats(&g.rotations[i]);
    if let Some(ids) = &g.object_ids {
        w.bytes(&ids[i].to_le_bytes());
    }
    if let Some(f) = made {
        w.floats(f);
    } else if let Some(f) = &g.features {
        w.floats(&f.values[i * f.dim..(i + 1) * f.dim]);
    }
    for (e, ty) in g.extra.iter().zip(extra_types) {
        ty.write_le(e.values[i], &mut w.row[w.pos..]);
        w.pos += ty.size();
    }
}
