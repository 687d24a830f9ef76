//! Prediction sets named as on `splatseg eval`'s command line (`NAME=DIR`, or a bare `DIR` named
//! by its folder), scored together into one [`EvalReport`], with the 3D label accuracy of a
//! labelled PLY attached to one of them.

use crate::{
    evaluate_prediction_sets, label_accuracy_3d_files, EvalConfig, EvalError, EvalReport, IdScope,
    NamedMetrics, PredictionSet,
};
use std::path::{Path, PathBuf};

/// What to score.
#[derive(Clone, Debug)]
pub struct NamedSets {
    /// Folder of ground-truth label maps.
    pub gt: PathBuf,
    /// Prediction folders as `[NAME=]DIR`.
    pub pred: Vec<String>,
    /// Names of the sets whose ids are numbered per view.
    pub view_local: Vec<String>,
    /// Ground-truth object id per Gaussian (`.npy`) and the labelled PLY scored against it, as
    /// `[NAME=]PLY` (a bare PLY is attached to the last set).
    pub gaussian_ids: Option<(PathBuf, String)>,
}

/// Splits `NAME=VALUE`; a bare value is named by `default_name`.
pub fn split_named(text: &str, default_name: impl FnOnce(&Path) -> String) -> (String, PathBuf) {
    match text.split_once('=') {
        Some((name, value)) if !name.is_empty() && !value.is_empty() => {
            (name.to_string(), PathBuf::from(value))
        }
        _ => {
            let path = PathBuf::from(text);
            (default_name(&path), path)
        }
    }
}

/// Scores every set of `sets` against the ground truth.
pub fn evaluate_named_sets(sets: &NamedSets, config: &EvalConfig) -> Result<EvalReport, EvalError> {
    let named: Vec<(String, PathBuf)> = sets
        .pred
        .iter()
        .map(|p| {
            split_named(p, |path| {
                path.file_name()
                    .map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned())
            })
        })
        .collect();
    if let Some(name) = sets.view_local.iter().find(|n| !named.iter().any(|(s, _)| s == *n)) {
        return Err(EvalError::UnknownSet { option: "--view-local", name: name.clone() });
    }
    let pred_sets: Vec<PredictionSet> = named
        .iter()
        .map(|(name, dir)| PredictionSet {
            dir,
            id_scope: if sets.view_local.contains(name) { IdScope::PerView } else { IdScope::Global },
        })
        .collect();
    let metrics = evaluate_prediction_sets(&sets.gt, &pred_sets, config)?;
    let mut report = EvalReport {
        sets: named
            .iter()
            .zip(metrics)
            .map(|((name, _), metrics)| NamedMetrics { name: name.clone(), metrics })
            .collect(),
    };
    if let Some((gt_ids, pred_ply)) = &sets.gaussian_ids {
        let last = report.sets.len().saturating_sub(1);
        let (name, ply) =
            split_named(pred_ply, |_| report.sets.get(last).map_or_else(String::new, |s| s.name.clone()));
        let set = report
            .sets
            .iter_mut()
            .find(|s| s.name == name)
            .ok_or(EvalError::UnknownSet { option: "--pred-ply", name })?;
        set.metrics.label_accuracy_3d = Some(label_accuracy_3d_files(gt_ids, &ply)?);
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_come_from_the_text_or_the_folder() {
        let (name, path) = split_named("raw=out/raw", |_| "unused".into());
        assert_eq!((name.as_str(), path), ("raw", PathBuf::from("out/raw")));
        let (name, path) = split_named("out/masks", |p| p.display().to_string());
        assert_eq!((name.as_str(), path), ("out/masks", PathBuf::from("out/masks")));
        let (name, _) = split_named("=x", |_| "default".into());
        assert_eq!(name, "default");
    }

    #[test]
    fn a_view_local_set_must_be_one_of_the_predictions() {
        let sets = NamedSets {
            gt: PathBuf::from("no/such/gt"),
            pred: vec!["a=no/such/pred".into()],
            view_local: vec!["b".into()],
            gaussian_ids: None,
        };
        let err = evaluate_named_sets(&sets, &EvalConfig::default()).expect_err("unknown set");
        assert_eq!(err.to_string(), "--view-local names set `b` but no --pred set has that name");
    }
}
