//! Scoring folders of label maps: `<stem>.png` files (8- or 16-bit, 0 = unlabelled) matched
//! by file stem between the ground-truth folder and each prediction folder.
//!
//! - Files that are not `.png` are ignored (ground-truth folders also hold e.g. `.npy` files).
//! - A ground-truth view without a prediction is scored as an all-zero prediction and reported
//!   in [`Metrics::warnings`].
//! - A prediction for a view the ground truth lacks is an error naming it; so is a prediction
//!   whose size differs from its ground truth.
//!
//! Views are read and counted in parallel (each reading its ground truth once for all
//! prediction sets) and combined in stem order.

use crate::config::{EvalConfig, IdScope};
use crate::error::EvalError;
use crate::metrics::Metrics;
use crate::view::ViewCounts;
use rayon::prelude::*;
use splatseg_scene::labels::read_label_png;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The `.png` files of `dir` by stem, sorted by stem. Other files and folders are ignored.
pub fn list_label_maps(dir: &Path) -> Result<BTreeMap<String, PathBuf>, EvalError> {
    let entries =
        std::fs::read_dir(dir).map_err(|source| EvalError::Io { path: dir.to_path_buf(), source })?;
    let mut out = BTreeMap::new();
    for entry in entries {
        let path = entry.map_err(|source| EvalError::Io { path: dir.to_path_buf(), source })?.path();
        let is_png = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("png"));
        if !is_png || !path.is_file() {
            continue;
        }
        if let Some(stem) = path.file_stem().and_then(|s| s.to_str()) {
            out.insert(stem.to_string(), path.clone());
        }
    }
    Ok(out)
}

/// Scores one prediction folder against a ground-truth folder.
pub fn evaluate_folders(gt_dir: &Path, pred_dir: &Path, cfg: &EvalConfig) -> Result<Metrics, EvalError> {
    let set = PredictionSet { dir: pred_dir, id_scope: cfg.pred_id_scope };
    let mut sets = evaluate_prediction_sets(gt_dir, &[set], cfg)?;
    Ok(sets.remove(0))
}

/// One folder of predicted label maps and the scope of its ids.
#[derive(Clone, Copy, Debug)]
pub struct PredictionSet<'a> {
    /// The folder of `<stem>.png` label maps.
    pub dir: &'a Path,
    /// Whether its ids are global or numbered per view (overrides `cfg.pred_id_scope`).
    pub id_scope: IdScope,
}

/// Scores several prediction folders (e.g. raw, merged, matched, lifted) against one
/// ground-truth folder. Returns one [`Metrics`] per set, in the given order.
pub fn evaluate_prediction_sets(
    gt_dir: &Path,
    sets: &[PredictionSet<'_>],
    cfg: &EvalConfig,
) -> Result<Vec<Metrics>, EvalError> {
    let pred_dirs: Vec<&Path> = sets.iter().map(|s| s.dir).collect();
    let gt_maps = list_label_maps(gt_dir)?;
    if gt_maps.is_empty() {
        return Err(EvalError::NoLabelMaps { path: gt_dir.to_path_buf() });
    }
    let mut pred_maps = Vec::with_capacity(pred_dirs.len());
    for dir in &pred_dirs {
        let maps = list_label_maps(dir)?;
        if maps.is_empty() {
            return Err(EvalError::NoLabelMaps { path: dir.to_path_buf() });
        }
        if let Some((stem, path)) = maps.iter().find(|(stem, _)| !gt_maps.contains_key(*stem)) {
            return Err(EvalError::UnknownView {
                view: stem.clone(),
                gt_dir: gt_dir.to_path_buf(),
                path: path.clone(),
            });
        }
        pred_maps.push(maps);
    }
    let views: Vec<(&String, &PathBuf)> = gt_maps.iter().collect();
    // counts[view][set]
    let counts: Vec<Vec<ViewCounts>> = views
        .par_iter()
        .map(|(stem, gt_path)| {
            let gt = read_label_png(gt_path)?;
            pred_maps
                .iter()
                .map(|maps| match maps.get(*stem) {
                    Some(pred_path) => {
                        let pred = read_label_png(pred_path)?;
                        ViewCounts::compute(stem, &gt, &pred, cfg).map_err(|e| with_file(e, pred_path))
                    }
                    None => Ok(ViewCounts::without_prediction(stem, &gt, cfg)),
                })
                .collect()
        })
        .collect::<Result<_, EvalError>>()?;
    pred_dirs
        .iter()
        .enumerate()
        .map(|(set, dir)| {
            let set_counts: Vec<ViewCounts> = counts.iter().map(|v| v[set].clone()).collect();
            let set_cfg = EvalConfig { pred_id_scope: sets[set].id_scope, ..cfg.clone() };
            let mut m = Metrics::from_views(&set_counts, &set_cfg).map_err(|e| match e {
                EvalError::NoGroundTruth { .. } => {
                    EvalError::NoGroundTruth { path: Some(gt_dir.to_path_buf()) }
                }
                other => other,
            })?;
            let missing: Vec<&str> = views
                .iter()
                .filter(|(stem, _)| !pred_maps[set].contains_key(*stem))
                .map(|(s, _)| s.as_str())
                .collect();
            if !missing.is_empty() {
                m.warnings.push(format!(
                    "{} ground-truth view(s) have no prediction in {} and were scored as all-unlabelled: {}",
                    missing.len(),
                    dir.display(),
                    missing.join(", ")
                ));
            }
            Ok(m)
        })
        .collect()
}

/// Names the prediction file in a size-mismatch error.
fn with_file(e: EvalError, file: &Path) -> EvalError {
    match e {
        EvalError::SizeMismatch { path: None, view, gt_width, gt_height, pred_width, pred_height } => {
            EvalError::SizeMismatch {
                view,
                gt_width,
                gt_height,
                pred_width,
                pred_height,
                path: Some(file.to_path_buf()),
            }
        }
        other => other,
    }
}
