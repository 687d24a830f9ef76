//! Decoding vertex rows into [`Gaussians`] arrays: per-field readers, output slices that split
//! by row range, and the parallel row loop.

use super::layout::{Source, VertexLayout};
use super::scalar::ScalarType;
use crate::gaussians::{ExtraProperty, FeatureBlock, Gaussians};

/// Rows decoded by one task; larger inputs are split in halves with `rayon::join`.
const ROWS_PER_TASK: usize = 8 * 1024;

/// Output arrays being filled, as mutable slices over a range of rows.
pub(crate) struct ColumnsMut<'a> {
    means: &'a mut [[f32; 3]],
    normals: Option<&'a mut [[f32; 3]]>,
    sh_dc: &'a mut [[f32; 3]],
    /// `[rows, 3K]`.
    sh_rest: &'a mut [f32],
    raw_opacities: &'a mut [f32],
    log_scales: &'a mut [[f32; 3]],
    rotations: &'a mut [[f32; 4]],
    object_ids: Option<&'a mut [i32]>,
    /// `[rows, D]`.
    features: &'a mut [f32],
    /// One `[rows]` slice per extra property.
    extras: Vec<&'a mut [f64]>,
}

impl<'a> ColumnsMut<'a> {
    pub(crate) fn rows(&self) -> usize {
        self.means.len()
    }

    /// Splits into rows `[0, mid)` and `[mid, rows)`.
    pub(crate) fn split_at(self, mid: usize, rest_width: usize, feat_width: usize) -> (Self, Self) {
        fn opt<T>(s: Option<&mut [T]>, mid: usize) -> (Option<&mut [T]>, Option<&mut [T]>) {
            match s {
                Some(s) => {
                    let (a, b) = s.split_at_mut(mid);
                    (Some(a), Some(b))
                }
                None => (None, None),
            }
        }
        let (means_a, means_b) = self.means.split_at_mut(mid);
        let (normals_a, normals_b) = opt(self.normals, mid);
        let (dc_a, dc_b) = self.sh_dc.split_at_mut(mid);
        let (rest_a, rest_b) = self.sh_rest.split_at_mut(mid * rest_width);
        let (op_a, op_b) = self.raw_opacities.split_at_mut(mid);
        let (sc_a, sc_b) = self.log_scales.split_at_mut(mid);
        let (rot_a, rot_b) = self.rotations.split_at_mut(mid);
        let (id_a, id_b) = opt(self.object_ids, mid);
        let (feat_a, feat_b) = self.features.split_at_mut(mid * feat_width);
        let (extras_a, extras_b) = self.extras.into_iter().map(|e| e.split_at_mut(mid)).unzip();
        (
            ColumnsMut {
                means: means_a,
                normals: normals_a,
                sh_dc: dc_a,
                sh_rest: rest_a,
                raw_opacities: op_a,
                log_scales: sc_a,
                rotations: rot_a,
                object_ids: id_a,
                features: feat_a,
                extras: extras_a,
            },
            ColumnsMut {
                means: means_b,
                normals: normals_b,
                sh_dc: dc_b,
                sh_rest: rest_b,
                raw_opacities: op_b,
                log_scales: sc_b,
                rotations: rot_b,
                object_ids: id_b,
                features: feat_b,
                extras: extras_b,
            },
        )
    }
}

/// How the float fields of a row are read: any PLY type, or `float` only (no type dispatch).
trait FloatReader {
    fn read(row: &[u8], s: &Source) -> f32;
}

/// Reads any scalar type, converting to f32.
struct AnyType<const BIG: bool>;

impl<const BIG: bool> FloatReader for AnyType<BIG> {
    #[inline(always)]
    fn read(row: &[u8], s: &Source) -> f32 {
        s.ty.read_f32::<BIG>(row, s.offset)
    }
}

/// Reads `float` properties only (checked by [`VertexLayout::floats_are_f32`]).
struct Float32<const BIG: bool>;

impl<const BIG: bool> FloatReader for Float32<BIG> {
    #[inline(always)]
    fn read(row: &[u8], s: &Source) -> f32 {
        let mut b = [0u8; 4];
        b.copy_from_slice(&row[s.offset..s.offset + 4]);
        if BIG {
            f32::from_be_bytes(b)
        } else {
            f32::from_le_bytes(b)
        }
    }
}

#[inline(always)]
fn read_n<R: FloatReader, const K: usize>(row: &[u8], sources: &[Source; K]) -> [f32; K] {
    sources.map(|s| R::read(row, &s))
}

#[inline(always)]
fn read_into<R: FloatReader>(row: &[u8], sources: &[Source], out: &mut [f32]) {
    for (dst, s) in out.iter_mut().zip(sources) {
        *dst = R::read(row, s);
    }
}

/// Allocates the arrays of `n` Gaussians, lets `fill` decode the rows into them, and
/// assembles the result.
pub(crate) fn decode_with<E>(
    layout: &VertexLayout,
    n: usize,
    fill: impl FnOnce(ColumnsMut<'_>) -> Result<(), E>,
) -> Result<Gaussians, E> {
    let rest_width = layout.sh_rest.len();
    let feat_width = layout.features.len();
    let mut means = vec![[0f32; 3]; n];
    let mut normals = layout.normals.map(|_| vec![[0f32; 3]; n]);
    let mut sh_dc = vec![[0f32; 3]; n];
    let mut sh_rest = vec![0f32; n * rest_width];
    let mut raw_opacities = vec![0f32; n];
    let mut log_scales = vec![[0f32; 3]; n];
    let mut rotations = vec![[0f32; 4]; n];
    let mut object_ids = layout.object_id.map(|_| vec![0i32; n]);
    let mut features = vec![0f32; n * feat_width];
    let mut extras: Vec<Vec<f64>> = layout.extras.iter().map(|_| vec![0f64; n]).collect();
    let columns = ColumnsMut {
        means: &mut means,
        normals: normals.as_deref_mut(),
        sh_dc: &mut sh_dc,
        sh_rest: &mut sh_rest,
        raw_opacities: &mut raw_opacities,
        log_scales: &mut log_scales,
        rotations: &mut rotations,
        object_ids: object_ids.as_deref_mut(),
        features: &mut features,
        extras: extras.iter_mut().map(|e| e.as_mut_slice()).collect(),
    };
    fill(columns)?;
    Ok(Gaussians {
        means,
        normals,
        sh_dc,
        sh_degree: layout.sh_degree,
        sh_rest,
        raw_opacities,
        log_scales,
        rotations,
        object_ids,
        features: (feat_width > 0).then_some(FeatureBlock { dim: feat_width, values: features }),
        extra: layout
            .extras
            .iter()
            .zip(extras)
            .map(|(e, values)| ExtraProperty { name: e.name.clone(), ply_type: e.type_name.clone(), values })
            .collect(),
    })
}

/// Decodes the rows into `out`, splitting large ranges in parallel halves. `first` is the
/// index of the first row (for error messages); the error of the lowest row wins.
pub(crate) fn decode_range<const BIG: bool>(
    layout: &VertexLayout,
    rows: &[u8],
    out: ColumnsMut<'_>,
    first: usize,
) -> Result<(), String> {
    let n = out.rows();
    if n > ROWS_PER_TASK {
        let mid = n / 2;
        let (rows_a, rows_b) = rows.split_at(mid * layout.stride);
        let (out_a, out_b) = out.split_at(mid, layout.sh_rest.len(), layout.features.len());
        let (a, b) = rayon::join(
            || decode_range::<BIG>(layout, rows_a, out_a, first),
            || decode_range::<BIG>(layout, rows_b, out_b, first + mid),
        );
        return a.and(b);
    }
    if layout.floats_are_f32() {
        decode_rows_with::<BIG, Float32<BIG>>(layout, rows, out, first)
    } else {
        decode_rows_with::<BIG, AnyType<BIG>>(layout, rows, out, first)
    }
}

/// The row loop, with float fields read by `R`.
fn decode_rows_with<const BIG: bool, R: FloatReader>(
    layout: &VertexLayout,
    rows: &[u8],
    mut out: ColumnsMut<'_>,
    first: usize,
) -> Result<(), String> {
    let rest_width = layout.sh_rest.len();
    let feat_width = layout.features.len();
    for (i, row) in rows.chunks_exact(layout.stride).enumerate() {
        out.means[i] = read_n::<R, 3>(row, &layout.means);
        if let (Some(normals), Some(src)) = (out.normals.as_deref_mut(), &layout.normals) {
            normals[i] = read_n::<R, 3>(row, src);
        }
        out.sh_dc[i] = read_n::<R, 3>(row, &layout.sh_dc);
        read_into::<R>(row, &layout.sh_rest, &mut out.sh_rest[i * rest_width..(i + 1) * rest_width]);
        out.raw_opacities[i] = R::read(row, &layout.opacity);
        out.log_scales[i] = read_n::<R, 3>(row, &layout.scales);
        out.rotations[i] = read_n::<R, 4>(row, &layout.rotations);
        if let (Some(ids), Some(src)) = (out.object_ids.as_deref_mut(), &layout.object_id) {
            let v = src.ty.read_f64::<BIG>(row, src.offset);
            if !ScalarType::I32.can_store(v) {
                return Err(format!("object_id {v} of vertex {} is not a 32-bit signed integer", first + i));
            }
            ids[i] = v as i32;
        }
        read_into::<R>(row, &layout.features, &mut out.features[i * feat_width..(i + 1) * feat_width]);
        for (dst, e) in out.extras.iter_mut().zip(&layout.extras) {
            dst[i] = e.source.ty.read_f64::<BIG>(row, e.source.offset);
        }
    }
    Ok(())
}
