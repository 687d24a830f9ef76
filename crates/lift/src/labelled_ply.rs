//! The labelled PLY (`gaussians.ply`): the input's rows, every one of them in file order, with
//! the lifted `object_id` and the fused features `feat_*` (made row by row while writing).
//! Rows the readers skip (a non-finite value, a degenerate shape) take no part in lifting: they
//! get id −1 and zero features.

use crate::error::LiftResult;
use crate::lifting::FusedFeatures;
use splatseg_scene::ply::{FeatureRows, PlyRows};
use splatseg_scene::Gaussians;
use std::path::Path;

/// `[N]` object ids of every row of the input PLY: `finite_ids` (`[N - k]`, one per usable row,
/// in order) spread back, and -1 for the `k` rows the stages skipped ([`PlyRows::usable_rows`]).
pub fn ids_of_every_row(rows: &PlyRows, finite_ids: &[i32]) -> Vec<i32> {
    let mut ids = vec![-1; rows.gaussians.len()];
    for (&row, &id) in rows.usable_rows().iter().zip(finite_ids) {
        ids[row] = id;
    }
    ids
}

/// The input rows with `object_id` = `ids` (`[N]`). With `fused` features (lifting fused them),
/// the input's own `feat_*` are dropped (the fused ones are written instead, see
/// [`FusedRows`]); otherwise they stay.
fn labelled_rows(rows: PlyRows, ids: &[i32], fused: bool) -> Gaussians {
    let mut g = rows.gaussians;
    g.object_ids = Some(ids.to_vec());
    if fused {
        g.features = None;
    }
    g
}

/// The fused features of every input row, made row by row while `gaussians.ply` is written:
/// the finite rows' fused features (one per finite row, in order), zeros for the skipped rows.
struct FusedRows {
    fused: FusedFeatures,
    /// `[N]` index among the finite rows, `u32::MAX` for a skipped row (empty: every row finite).
    finite_index: Vec<u32>,
}

impl FusedRows {
    /// `fused` (`[N − k]` rows) spread over the `n_rows` input rows; `finite_rows`: the input rows
    /// that are finite, in order.
    fn new(fused: FusedFeatures, finite_rows: &[usize], n_rows: usize) -> Self {
        let finite_index = if finite_rows.len() == n_rows {
            Vec::new()
        } else {
            let mut index = vec![u32::MAX; n_rows];
            for (k, &row) in finite_rows.iter().enumerate() {
                index[row] = k as u32;
            }
            index
        };
        FusedRows { fused, finite_index }
    }
}

impl FeatureRows for FusedRows {
    fn dim(&self) -> usize {
        self.fused.dim
    }

    fn row(&self, i: usize, out: &mut [f32]) {
        match self.finite_index.get(i) {
            None => self.fused.row(i, out),
            Some(&u32::MAX) => out.iter_mut().for_each(|x| *x = 0.0),
            Some(&k) => self.fused.row(k as usize, out),
        }
    }
}

/// Writes `rows` (the input PLY's) to `path` with `object_id` = `ids` (`[N]`, from
/// [`ids_of_every_row`]) and, with `fused` features (one row per finite input row), those as
/// `feat_*` in place of the input's own.
pub fn write_labelled_ply(
    path: &Path,
    rows: PlyRows,
    ids: &[i32],
    fused: Option<FusedFeatures>,
) -> LiftResult<()> {
    let (finite, n_rows) = (rows.usable_rows(), rows.gaussians.len());
    let g = labelled_rows(rows, ids, fused.is_some());
    let fused = fused.map(|f| FusedRows::new(f, &finite, n_rows));
    let feature_rows: Option<&dyn FeatureRows> = fused.as_ref().map(|f| f as _);
    splatseg_scene::ply::write_ply_rows_with_features(path, &g, feature_rows)?;
    Ok(())
}
