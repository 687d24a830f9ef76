//! Scoring every stage's per-view label maps against the ground truth (raw → merged → matched
//! → lifted), in memory with the eval crate.

use super::inputs::GroundTruth;
use crate::error::{bail, Context};
use splatseg_eval::{label_accuracy_3d, EvalConfig, EvalReport, Metrics, NamedMetrics, ViewCounts};
use splatseg_scene::{Plane, Scene};

/// The views scored against the ground truth: those with a ground-truth label map.
pub struct EvalViews {
    gt_files: std::collections::BTreeMap<String, std::path::PathBuf>,
}

/// Lists the ground-truth maps; an error for ground truth of a view the scene does not have, or
/// when no view has any.
pub fn eval_views(scene: &Scene, gt: &GroundTruth) -> crate::Result<EvalViews> {
    let gt_files = splatseg_eval::list_label_maps(&gt.maps_dir)?;
    if let Some(stem) = gt_files.keys().find(|s| scene.view_by_stem(s).is_none()) {
        bail!(
            "ground truth for a view the scene does not have: `{stem}`: {}",
            gt.maps_dir.join(format!("{stem}.png")).display()
        );
    }
    if !scene.views.iter().any(|v| gt_files.contains_key(&v.stem)) {
        bail!("no ground-truth label map matches a view of the scene: {}", gt.maps_dir.display());
    }
    Ok(EvalViews { gt_files })
}

/// Scores view `v`'s maps of every stage (`[n_stages]`, `None` = the stage has no map for it)
/// against its ground truth; `None` when the view has no ground truth.
pub fn view_counts(
    scene: &Scene,
    eval: &EvalViews,
    v: usize,
    maps: &[Option<Plane<u32>>],
    config: &EvalConfig,
) -> crate::Result<Option<Vec<ViewCounts>>> {
    let stem = &scene.views[v].stem;
    let Some(path) = eval.gt_files.get(stem) else { return Ok(None) };
    let gt_map = splatseg_scene::labels::read_label_png(path)?;
    maps.iter()
        .map(|m| match m {
            Some(pred) => ViewCounts::compute(stem, &gt_map, pred, config)
                .with_context(|| format!("ground truth {}", path.display())),
            None => Ok(ViewCounts::without_prediction(stem, &gt_map, config)),
        })
        .collect::<crate::Result<Vec<_>>>()
        .map(Some)
}

/// The metrics of every stage (`names`) from the per-view counts (`counts[view][stage]`, views
/// in scene order); `object_ids` (`[N]`) of the last stage, when the ground truth has
/// per-Gaussian ids, adds the 3D label accuracy to it.
pub fn evaluate(
    names: &[&str],
    counts: &[Vec<ViewCounts>],
    gt: &GroundTruth,
    object_ids: Option<&[i32]>,
    config: &EvalConfig,
) -> crate::Result<EvalReport> {
    let mut sets = Vec::new();
    for (k, name) in names.iter().enumerate() {
        let per_view: Vec<ViewCounts> = counts.iter().map(|c| c[k].clone()).collect();
        let mut metrics = Metrics::from_views(&per_view, config)?;
        if k + 1 == names.len() {
            if let (Some(gt_ids), Some(ids)) = (&gt.gaussian_ids, object_ids) {
                metrics.label_accuracy_3d = Some(label_accuracy_3d(gt_ids, ids)?);
            }
        }
        sets.push(NamedMetrics { name: name.to_string(), metrics });
    }
    Ok(EvalReport { sets })
}

/// Per view, the offset that makes its view-local labels globally distinct: the sum of the
/// largest labels of the views before it (`max_labels`, `[n_views]`, 0 for views without a
/// map), as the per-view baselines are scored: every mask of every view counts as its own object.
pub fn local_offsets(max_labels: &[u32]) -> Vec<u32> {
    let mut offset = 0u32;
    max_labels
        .iter()
        .map(|&m| {
            let base = offset;
            offset += m;
            base
        })
        .collect()
}

/// A view-local label map with its labels offset by `base` (0 stays 0).
pub fn offset_map(map: &Plane<u32>, base: u32) -> Plane<u32> {
    map.map(|&l| if l == 0 { 0 } else { l + base })
}
