//! `run`'s last stage: every view's final map written (`masks/`, `overlays/`) and scored against
//! the ground truth one view at a time on each thread, while `gaussians.ply` is written beside.

use crate::error::Context;
use crate::eval_stage::{eval_views, evaluate, local_offsets, offset_map, view_counts};
use crate::inputs::RunInputs;
use crate::lift_stage::ViewResult;
use crate::{outputs, progress, RunConfig};
use indicatif::ParallelProgressIterator;
use rayon::prelude::*;
use splatseg_eval::{EvalReport, ViewCounts};
use splatseg_lift::LiftOutput;
use splatseg_match::Matching;
use splatseg_scene::load::LoadOptions;
use splatseg_scene::ply::PlyRows;
use splatseg_scene::Plane;
use std::collections::BTreeSet;

/// What the stages before gave the outputs.
pub struct StageResults<'a> {
    /// `[n_views]` per-view results (`None`: no masks).
    pub views: &'a [Option<ViewResult>],
    /// The matching of the merged masks.
    pub matching: &'a Matching,
    /// The lift stage's output, with Gaussians.
    pub lifted: Option<LiftOutput>,
}

/// What writing the outputs found.
pub struct Written {
    /// Distinct ids over the final maps.
    pub final_objects: usize,
    /// Metrics per stage, with ground truth.
    pub report: Option<EvalReport>,
    /// What lifting decided, with Gaussians.
    pub lift_stats: Option<splatseg_lift::LiftStats>,
    /// Results far from what the inputs promised, one sentence each.
    pub warnings: Vec<String>,
}

/// The Gaussians label less than this fraction of the pixels SAM's masks cover (over the views
/// with masks; the pixels the final maps take from the matched masks where the Gaussians say
/// nothing not counted): warned, as the Gaussians then say little about the scene (a poor or
/// partial reconstruction; on a real capture with a failed reconstruction `run` once labelled
/// 0.26 % of the pixels and said nothing).
const LOW_COVERAGE: f64 = 0.5;

/// The warning when the Gaussians label much less than the masks cover: `labelled` pixels of the
/// final maps, of which `filled` took the matched masks' ids, and `masked` pixels, summed over the
/// views with masks, out of `pixels`.
fn coverage_warning(labelled: usize, filled: usize, masked: usize, pixels: usize) -> Option<String> {
    let share = |n: usize| 100.0 * n as f64 / pixels.max(1) as f64;
    let own = labelled.saturating_sub(filled);
    ((own as f64) < LOW_COVERAGE * masked as f64).then(|| {
        format!(
            "the Gaussians label {:.1} % of the pixels of the views with masks, where SAM's masks cover \
             {:.1} % (the final label maps label {:.1} %, taking the matched masks' ids where the \
             Gaussians say nothing): the Gaussians may reconstruct the scene poorly (check the PLY's \
             held-out PSNR, e.g. with `splatseg train`)",
            share(own),
            share(masked),
            share(labelled)
        )
    })
}

/// What writing one view's outputs gives back: its distinct final ids, and its counts for the
/// scores (with ground truth).
type ViewOutputs = (Vec<u32>, Option<Vec<ViewCounts>>, Coverage);

/// Of a view with masks: pixels labelled in its final map, pixels SAM's masks cover, pixels.
type Coverage = Option<(usize, usize, usize)>;

/// Writes every view's maps and `gaussians.ply` (with Gaussians) into `dest` (the staging
/// folder), and scores the stages (with ground truth). `ply_rows`: the input PLY's rows (taken
/// out of `inputs`), moved into the PLY.
pub fn write_outputs(
    config: &RunConfig,
    dest: &std::path::Path,
    inputs: &RunInputs,
    ply_rows: Option<PlyRows>,
    load: &LoadOptions,
    mut results: StageResults,
) -> crate::Result<Written> {
    let (scene, views) = (&inputs.scene, results.views);
    let pc = &config.pipeline;
    let eval = inputs.gt.as_ref().map(|g| eval_views(scene, g)).transpose()?;
    let raw_offsets =
        local_offsets(&views.iter().map(|m| m.as_ref().map_or(0, |m| m.raw_max)).collect::<Vec<_>>());
    let merged_offsets =
        local_offsets(&views.iter().map(|m| m.as_ref().map_or(0, |m| m.merged_max)).collect::<Vec<_>>());
    let lifted = &mut results.lifted;
    let stage_names: &[&str] = if lifted.is_some() {
        &["raw", "merged", "matched", "lifted"]
    } else {
        &["raw", "merged", "matched"]
    };
    // `[N]` ids of every input row (-1 for the non-finite rows that were skipped).
    let row_ids = match (&ply_rows, &*lifted) {
        (Some(rows), Some(l)) => Some(splatseg_lift::ids_of_every_row(rows, &l.lifted.object_ids)),
        _ => None,
    };
    let fused = lifted.as_mut().and_then(|l| l.lifted.fused_features.take());
    let lifted = &*lifted;
    // `gaussians.ply` is written while the views' maps are (its writing is mostly the kernel
    // copying bytes, on one thread).
    let write_ply = || -> crate::Result<()> {
        if let (Some(rows), Some(ids), Some(_), Some(p)) = (ply_rows, &row_ids, lifted, &inputs.ply_path) {
            let out_ply = dest.join("gaussians.ply");
            splatseg_lift::write_labelled_ply(&out_ply, rows, ids, fused)
                .with_context(|| format!("writing the labelled Gaussians of {}", p.display()))?;
        }
        Ok(())
    };
    let matched_map = |v: usize, merged: &Plane<u32>| -> Plane<u32> {
        let table = &results.matching.global_of_label[v];
        merged.map(|&l| table.get(l as usize).copied().unwrap_or(0))
    };
    let bar = progress(scene.views.len(), "write label maps", config.options);
    let write_maps = || -> crate::Result<Vec<ViewOutputs>> {
        (0..scene.views.len())
            .into_par_iter()
            .progress_with(bar.clone())
            .map(|v| -> crate::Result<ViewOutputs> {
                // What the per-view pass decoded (a view with masks), read back once.
                let data = views[v].as_ref().map(|m| m.data()).transpose()?;
                let matched = data.as_ref().map(|d| matched_map(v, &d.merged));
                let final_map = match lifted {
                    Some(l) => l.final_map(v),
                    None => matched.clone().unwrap_or_else(|| {
                        let c = scene.camera(&scene.views[v]);
                        Plane::filled(c.width as usize, c.height as usize, 0)
                    }),
                };
                let (rgb, maps) = match data {
                    Some(d) => (Some(d.rgb), Some((d.raw, d.merged))),
                    None => (None, None),
                };
                outputs::write_view_maps(dest, scene, load, v, &final_map, rgb)?;
                let ids = distinct_ids(&final_map);
                let coverage = maps.as_ref().map(|(raw, _)| {
                    let nonzero = |m: &Plane<u32>| m.data.iter().filter(|&&l| l != 0).count();
                    (nonzero(&final_map), nonzero(raw), raw.data.len())
                });
                let counts = match &eval {
                    Some(e) => {
                        let (raw, merged) = match &maps {
                            Some((raw, merged)) => (
                                Some(offset_map(raw, raw_offsets[v])),
                                Some(offset_map(merged, merged_offsets[v])),
                            ),
                            None => (None, None),
                        };
                        let mut maps = vec![raw, merged, matched];
                        if lifted.is_some() {
                            maps.push(Some(final_map));
                        }
                        view_counts(scene, e, v, &maps, &pc.eval)?
                    }
                    None => None,
                };
                Ok((ids, counts, coverage))
            })
            .collect::<crate::Result<_>>()
    };
    let (per_view, ply_written) = rayon::join(write_maps, write_ply);
    let per_view = per_view?;
    ply_written?;
    bar.finish_and_clear();
    let final_ids: BTreeSet<u32> = per_view.iter().flat_map(|(ids, _, _)| ids.iter().copied()).collect();
    let (labelled, masked, pixels) = per_view
        .iter()
        .filter_map(|(_, _, c)| *c)
        .fold((0, 0, 0), |(a, b, c), (l, m, p)| (a + l, b + m, c + p));
    let filled = lifted.as_ref().map_or(0, |l| l.filled_px as usize);
    let warnings: Vec<String> = coverage_warning(labelled, filled, masked, pixels).into_iter().collect();
    let report = match &inputs.gt {
        Some(gt) => {
            let counts: Vec<Vec<ViewCounts>> = per_view.into_iter().filter_map(|(_, c, _)| c).collect();
            Some(evaluate(stage_names, &counts, gt, row_ids.as_deref(), &pc.eval)?)
        }
        None => None,
    };
    let lift_stats = lifted.as_ref().map(|l| l.lifted.stats.clone());
    for w in &warnings {
        tracing::warn!("{w}");
    }
    Ok(Written { final_objects: final_ids.len(), report, lift_stats, warnings })
}

/// The distinct ids (> 0) of a map (kept for every view: a few, not a pixel's worth each); a
/// pixel equal to the one before adds nothing new.
fn distinct_ids(map: &Plane<u32>) -> Vec<u32> {
    let mut distinct = BTreeSet::new();
    let mut last = 0u32;
    for &x in &map.data {
        if x != last {
            if x > 0 {
                distinct.insert(x);
            }
            last = x;
        }
    }
    distinct.into_iter().collect()
}

#[cfg(test)]
mod coverage_tests {
    use super::coverage_warning;

    #[test]
    fn final_maps_labelling_under_half_of_what_the_masks_cover_are_warned() {
        assert!(coverage_warning(90, 0, 100, 200).is_none());
        assert!(coverage_warning(50, 0, 100, 200).is_none());
        assert!(coverage_warning(90, 41, 100, 200).is_some(), "filled pixels are not the Gaussians'");
        let w = coverage_warning(1, 0, 100, 400).expect("a warning");
        assert!(w.contains("0.2 %") && w.contains("25.0 %"), "{w}");
        assert!(coverage_warning(0, 0, 0, 0).is_none(), "no masks: nothing promised");
    }
}
