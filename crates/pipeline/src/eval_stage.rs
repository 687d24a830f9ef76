//! Scoring every stage's per-view label maps against the ground truth (raw → merged → matched
//! → lifted), in memory with the eval crate.

use super::inputs::GroundTruth;
use crate::error::{bail, Context};
use rayon::prelude::*;
use splatseg_eval::{label_accuracy_3d, EvalConfig, EvalReport, Metrics, NamedMetrics, ViewCounts};
use splatseg_scene::{Plane, Scene};

/// One stage's label maps: `[n_views]`, `None` = the stage has no map for that view.
pub struct StageMaps<'a> {
    /// Name in the report.
    pub name: &'a str,
    /// The maps, in scene view order.
    pub maps: &'a [Option<Plane<u32>>],
}

/// Scores `stages` against the ground truth; `object_ids` (`[N]`) of the last stage, when the
/// ground truth has per-Gaussian ids, adds the 3D label accuracy to it.
pub fn evaluate(
    scene: &Scene,
    gt: &GroundTruth,
    stages: &[StageMaps],
    object_ids: Option<&[i32]>,
    config: &EvalConfig,
) -> crate::Result<EvalReport> {
    let gt_files = splatseg_eval::list_label_maps(&gt.maps_dir)?;
    if let Some(stem) = gt_files.keys().find(|s| scene.view_by_stem(s).is_none()) {
        bail!(
            "ground truth for a view the scene does not have: `{stem}`: {}",
            gt.maps_dir.join(format!("{stem}.png")).display()
        );
    }
    let views: Vec<usize> =
        (0..scene.views.len()).filter(|&v| gt_files.contains_key(&scene.views[v].stem)).collect();
    if views.is_empty() {
        bail!("no ground-truth label map matches a view of the scene: {}", gt.maps_dir.display());
    }
    // counts[view][stage]
    let counts: Vec<Vec<ViewCounts>> = views
        .par_iter()
        .map(|&v| {
            let stem = &scene.views[v].stem;
            let path = &gt_files[stem];
            let gt_map = splatseg_scene::labels::read_label_png(path)?;
            stages
                .iter()
                .map(|s| match &s.maps[v] {
                    Some(pred) => ViewCounts::compute(stem, &gt_map, pred, config)
                        .with_context(|| format!("ground truth {}", path.display())),
                    None => Ok(ViewCounts::without_prediction(stem, &gt_map, config)),
                })
                .collect::<crate::Result<Vec<_>>>()
        })
        .collect::<crate::Result<_>>()?;
    let mut sets = Vec::new();
    for (k, stage) in stages.iter().enumerate() {
        let per_view: Vec<ViewCounts> = counts.iter().map(|c| c[k].clone()).collect();
        let mut metrics = Metrics::from_views(&per_view, config)?;
        if k + 1 == stages.len() {
            if let (Some(gt_ids), Some(ids)) = (&gt.gaussian_ids, object_ids) {
                metrics.label_accuracy_3d = Some(label_accuracy_3d(gt_ids, ids)?);
            }
        }
        sets.push(NamedMetrics { name: stage.name.to_string(), metrics });
    }
    Ok(EvalReport { sets })
}

/// View-local label maps made globally distinct (view `v`'s labels offset by the number of
/// labels of the views before it), as the per-view baselines are scored: every mask of every
/// view counts as its own object.
pub fn offset_local_maps(maps: &[Option<Plane<u32>>]) -> Vec<Option<Plane<u32>>> {
    let mut offset = 0u32;
    maps.iter()
        .map(|m| {
            m.as_ref().map(|m| {
                let base = offset;
                offset += m.data.iter().copied().max().unwrap_or(0);
                m.map(|&l| if l == 0 { 0 } else { l + base })
            })
        })
        .collect()
}
