//! 3D label accuracy: how many Gaussians carry the right object id.
//!
//! Predicted ids are arbitrary numbers, so they are first matched one-to-one to ground-truth ids
//! with the Hungarian algorithm on the Gaussian confusion matrix (maximising the number of
//! Gaussians on matched pairs). Accuracy is the share of Gaussians *with a ground-truth id*
//! whose predicted id is matched to that ground-truth id. Ground-truth ids ≤ 0 mean "no
//! object" (label maps use 0, PLY `object_id` uses −1) and those Gaussians are not scored.
//! Predicted ids ≤ 0 mean "no id" (the lifting's variance filter writes −1): such Gaussians
//! count as wrong, so withholding ids never raises accuracy.

use crate::error::EvalError;
use crate::hungarian::max_weight_matching_sparse;
use crate::metrics::LabelAccuracy3d;
use std::path::Path;

/// Reads ground-truth per-Gaussian ids from a `.npy` of shape `[N]` or `[N, 1]` holding
/// integers (an integer dtype, or floats with integral values).
pub fn read_gaussian_ids_npy(path: &Path) -> Result<Vec<i64>, EvalError> {
    let arr = splatseg_scene::npy::read_npy(path)?;
    let bad = |reason: String| EvalError::BadGaussianIds { reason, path: path.to_path_buf() };
    if !matches!(arr.shape[..], [_] | [_, 1]) {
        return Err(bad(format!("shape {:?}, expected [N] or [N, 1]", arr.shape)));
    }
    // Values are delivered as f32, exact for integers below 2^24 only.
    if arr.data.iter().any(|v| v.abs() >= (1u32 << 24) as f32) {
        return Err(bad(format!("ids of 2^24 or more are not supported ({:?} file)", arr.dtype)));
    }
    if let Some(i) = arr.data.iter().position(|v| !v.is_finite() || v.fract() != 0.0) {
        return Err(bad(format!("entry {i} is {}, not an integer id", arr.data[i])));
    }
    Ok(arr.data.iter().map(|v| *v as i64).collect())
}

/// 3D label accuracy of the `object_id`s of a labelled PLY against ground-truth ids in a
/// `.npy` (same Gaussian order).
pub fn label_accuracy_3d_files(gt_ids_npy: &Path, pred_ply: &Path) -> Result<LabelAccuracy3d, EvalError> {
    let gt = read_gaussian_ids_npy(gt_ids_npy)?;
    let g = splatseg_scene::ply::read_ply(pred_ply)?;
    let pred = g.object_ids.ok_or_else(|| EvalError::NoObjectIds { path: pred_ply.to_path_buf() })?;
    label_accuracy_3d(&gt, &pred).map_err(|e| match e {
        EvalError::GaussianCountMismatch { gt_len, pred_len, .. } => {
            EvalError::GaussianCountMismatch { gt_len, pred_len, path: Some(pred_ply.to_path_buf()) }
        }
        other => other,
    })
}

/// Scores predicted per-Gaussian ids against ground truth. `gt_ids`, `pred_ids`: `[N]`, same
/// Gaussian order. Fails on a length mismatch.
pub fn label_accuracy_3d(gt_ids: &[i64], pred_ids: &[i32]) -> Result<LabelAccuracy3d, EvalError> {
    if gt_ids.len() != pred_ids.len() {
        return Err(EvalError::GaussianCountMismatch {
            gt_len: gt_ids.len(),
            pred_len: pred_ids.len(),
            path: None,
        });
    }
    // Confusion counts over labelled Gaussians with a prediction, as sorted (gt, pred) pairs.
    let mut pairs: Vec<(i64, i32)> = Vec::new();
    let mut labelled = 0u64;
    let mut unpredicted = 0u64;
    let mut pred_objects: Vec<i32> = pred_ids.iter().copied().filter(|p| *p > 0).collect();
    for (&g, &p) in gt_ids.iter().zip(pred_ids) {
        if g <= 0 {
            continue;
        }
        labelled += 1;
        if p <= 0 {
            unpredicted += 1;
        } else {
            pairs.push((g, p));
        }
    }
    let mut gt_objects: Vec<i64> = gt_ids.iter().copied().filter(|g| *g > 0).collect();
    gt_objects.sort_unstable();
    gt_objects.dedup();
    pred_objects.sort_unstable();
    pred_objects.dedup();
    pairs.sort_unstable();

    // Sparse confusion counts over ground-truth ids × predicted ids.
    let mut cols: Vec<i32> = pairs.iter().map(|p| p.1).collect();
    cols.sort_unstable();
    cols.dedup();
    let mut entries: Vec<(usize, usize, f64)> = Vec::new();
    for (g, p) in &pairs {
        if let (Ok(r), Ok(c)) = (gt_objects.binary_search(g), cols.binary_search(p)) {
            match entries.last_mut() {
                Some(last) if (last.0, last.1) == (r, c) => last.2 += 1.0,
                _ => entries.push((r, c, 1.0)),
            }
        }
    }
    let assignment = max_weight_matching_sparse(&entries, gt_objects.len(), cols.len())?;
    let correct: f64 = assignment
        .iter()
        .enumerate()
        .filter_map(|(r, c)| c.map(|c| entries[entries.partition_point(|e| (e.0, e.1) < (r, c))].2))
        .sum();
    Ok(LabelAccuracy3d {
        accuracy: if labelled == 0 { 0.0 } else { correct / labelled as f64 },
        labelled_gaussians: labelled,
        unlabelled_predictions: unpredicted,
        gt_objects: gt_objects.len(),
        pred_objects: pred_objects.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relabelled_prediction_is_perfect() {
        let gt = [1, 1, 2, 2, 3, 0, -1];
        let pred = [7, 7, 4, 4, 9, 5, -1];
        let acc = label_accuracy_3d(&gt, &pred).unwrap();
        assert_eq!(acc.accuracy, 1.0);
        assert_eq!(acc.labelled_gaussians, 5);
        assert_eq!((acc.gt_objects, acc.pred_objects), (3, 4));
    }

    #[test]
    fn hungarian_beats_greedy_matching() {
        // Confusion: gt 1 → {5: 3, 6: 2}, gt 2 → {5: 2}. Greedy takes (1, 5) = 3 and leaves gt 2
        // with nothing: 3/7. The optimum (1, 6) + (2, 5) = 4 Gaussians: 4/7.
        let gt = [1, 1, 1, 1, 1, 2, 2];
        let pred = [5, 5, 5, 6, 6, 5, 5];
        let acc = label_accuracy_3d(&gt, &pred).unwrap();
        assert!((acc.accuracy - 4.0 / 7.0).abs() < 1e-12, "{acc:?}");
    }

    #[test]
    fn missing_predictions_count_as_wrong() {
        let gt = [1, 1, 2, 2];
        let pred = [3, -1, 4, -1];
        let acc = label_accuracy_3d(&gt, &pred).unwrap();
        assert_eq!(acc.accuracy, 0.5);
        assert_eq!(acc.unlabelled_predictions, 2);
    }

    #[test]
    fn length_mismatch_is_an_error() {
        let err = label_accuracy_3d(&[1, 2, 3], &[1, 2]).unwrap_err();
        assert!(err.to_string().contains("2 predicted Gaussian ids but 3 ground-truth ids"), "{err}");
    }
}
