//! The end-to-end pipeline behind `splatseg run` (and `demo`): cues → merge → match → lift →
//! (eval when ground truth is given), with per-stage caching in `OUT/cache/`. A library, so the
//! binary, the viewer's server or a binding can call it:
//!
//! - [`run_pipeline`] runs the whole pipeline ([`RunConfig`] → [`RunSummary`]);
//! - [`merge_views`] runs `run`'s per-view merge stage alone (`splatseg merge`), over every view
//!   or one [`Shard`] `K/N` of them (any number of shards at once, as separate processes), with
//!   `run`'s inputs and cache keys; a later [`run_pipeline`] on the same output folder reuses it;
//! - [`RunOutputs`] reads a finished run's results (summary, label maps, per-Gaussian ids);
//! - [`scene_info`] (what a scene folder holds), [`demo`], [`render_views`], [`train_stage`]: the
//!   other commands' work.
//!
//! Errors are [`PipelineError`]; [`PipelineError::report`] prints the chain of causes.
//!
//! ```text
//! OUT/masks/<stem>.png      final per-view label maps, 16-bit global ids, 0 = none
//! OUT/overlays/<stem>.png   the label maps over the images
//! OUT/gaussians.ply         the input PLY + `object_id` (+ fused `feat_*`), same Gaussian order
//! OUT/report.md             stage summary, metrics table (raw → merged → matched → lifted)
//! OUT/metrics.json          the same as data
//! OUT/cache/                per-stage results keyed by inputs + config (a rerun resumes)
//! ```

mod cache;
pub mod config;
pub mod demo;
pub mod digest;
mod error;
mod eval_stage;
pub mod identity_study;
mod inputs;
mod lift_stage;
pub mod lock;
mod mask_input;
mod merge_stage;
mod merge_views;
mod options;
mod outputs;
mod per_view;
pub mod ply_input;
pub mod profile;
pub mod render_views;
mod results;
pub mod scene_info;
pub mod shard;
#[cfg(test)]
mod tests;
pub mod train_stage;
mod visible;

use crate::error::bail;
use cache::{read_json, write_json, KeyHasher};
pub use config::PipelineConfig;
pub use error::{Context, PipelineError, Result};
use eval_stage::{eval_views, evaluate, local_offsets, offset_map, view_counts};
use indicatif::{ParallelProgressIterator, ProgressBar, ProgressStyle};
use lift_stage::ViewResult;
pub use mask_input::{mask_inputs, read_view_mask_inputs};
pub use merge_views::{merge_shard, merge_views, MergeRequest, ShardSummary};
pub use options::RunOptions;
use profile::Profiler;
pub use profile::{peak_rss_bytes, PartTimes, StageProfile};
use rayon::prelude::*;
pub use results::RunOutputs;
use serde::{Deserialize, Serialize};
pub use shard::Shard;
use splatseg_cues::DepthKind;
use splatseg_eval::EvalReport;
use splatseg_eval::ViewCounts;
use splatseg_lift::{LiftStats, PosedCamera, PreparedGaussians};
use splatseg_match::MatchStats;
use splatseg_scene::load::LoadOptions;
use splatseg_scene::Plane;
use std::path::{Path, PathBuf};

/// What to run on.
#[derive(Clone, Debug)]
pub struct RunConfig {
    /// Scene folder (COLMAP or transforms.json).
    pub scene: PathBuf,
    /// SAM masks folder (`<stem>.json` per image).
    pub masks: PathBuf,
    /// Dense feature maps (`<stem>.npy`, `[h, w, C]`); colour/texture descriptors when absent.
    pub features: Option<PathBuf>,
    /// Depth maps (`<stem>.npy`); rendered from the Gaussians when absent.
    pub depth: Option<PathBuf>,
    /// What the `depth` maps hold.
    pub depth_kind: DepthKind,
    /// 3DGS PLY; `SCENE/gaussians.ply` when absent and present.
    pub gaussians: Option<PathBuf>,
    /// Ground truth: a folder of `<stem>.png` instance maps, or a synthetic `gt/` folder.
    pub gt: Option<PathBuf>,
    /// Stage settings.
    pub pipeline: PipelineConfig,
    /// Output folder.
    pub out: PathBuf,
    /// `--strict` and `--quiet`.
    pub options: RunOptions,
}

/// What a run produced (also cached as `OUT/cache/run.json`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RunSummary {
    /// Output folder.
    pub out: PathBuf,
    /// Views of the scene.
    pub views: usize,
    /// Views that had SAM masks.
    pub views_with_masks: usize,
    /// Gaussians, when a PLY was used.
    pub gaussians: Option<usize>,
    /// SAM regions over all views.
    pub raw_masks: usize,
    /// Merged regions over all views.
    pub merged_masks: usize,
    /// Global objects after matching.
    pub matched_objects: usize,
    /// Distinct ids in the final label maps.
    pub final_objects: usize,
    /// What matching decided.
    pub match_stats: MatchStats,
    /// What lifting decided (with Gaussians).
    pub lift_stats: Option<LiftStats>,
    /// Metrics per stage (with ground truth).
    pub report: Option<EvalReport>,
    /// Views whose merge came from the cache. Not written to `metrics.json`: it describes this
    /// invocation, not the outputs, which are byte-identical however often a run was resumed.
    #[serde(skip)]
    pub cached_views: usize,
    /// The whole run came from the cache (not written either).
    #[serde(skip)]
    pub resumed: bool,
    /// Wall time and peak memory per stage of this invocation (not written either).
    #[serde(skip)]
    pub stages: Vec<StageProfile>,
}

impl RunSummary {
    /// The raw → merged → matched → lifted metrics table (Markdown), with ground truth.
    pub fn table(&self) -> Option<String> {
        self.report.as_ref().map(|r| {
            let rows: Vec<(&str, &splatseg_eval::Metrics)> =
                r.sets.iter().map(|s| (s.name.as_str(), &s.metrics)).collect();
            splatseg_eval::summary_table(&rows)
        })
    }
}

/// A progress bar over `len` items (hidden when stderr is not a terminal, and with `--quiet`).
pub(crate) fn progress(len: usize, what: &str, options: RunOptions) -> ProgressBar {
    let bar = ProgressBar::new(len as u64);
    if options.quiet {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    if let Ok(style) = ProgressStyle::with_template("{msg:>24} [{bar:30}] {pos}/{len} {elapsed}") {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(what.to_string());
    bar
}

/// Output files a cached run must still find to be reused.
fn outputs_present(out: &Path, stems: &[&str], with_ply: bool) -> bool {
    let files = ["report.md", "metrics.json"];
    files.iter().all(|f| out.join(f).is_file())
        && (!with_ply || out.join("gaussians.ply").is_file())
        && stems.iter().all(|s| out.join("masks").join(format!("{s}.png")).is_file())
}

#[derive(Serialize, Deserialize)]
struct RunCache {
    key: String,
    summary: RunSummary,
}

/// What writing one view's outputs gives back: its distinct final ids, and its counts for the
/// scores (with ground truth).
type ViewOutputs = (Vec<u32>, Option<Vec<ViewCounts>>);

/// Runs the whole pipeline (see the module docs for the outputs).
pub fn run_pipeline(config: &RunConfig) -> crate::Result<RunSummary> {
    let _lock = lock::lock_output(&config.out, "run")?;
    let mut profiler = Profiler::start("load inputs");
    let load = LoadOptions::default();
    let scene = splatseg_scene::load_scene(&config.scene, &load)?;
    for w in &scene.warnings {
        tracing::warn!("{w}");
    }
    // Every camera against its image on disk, before anything of a camera's size is allocated.
    splatseg_scene::load::check_image_sizes(&scene, &load)?;
    let has_masks = inputs::views_with_masks(&scene, &config.masks)?;
    let ply_path = inputs::gaussians_path(&config.scene, config.gaussians.as_deref());
    let ply_rows = match &ply_path {
        Some(p) => {
            tracing::info!("reading Gaussians from {}", p.display());
            Some(inputs::read_gaussians(p, config.options.strict)?)
        }
        None => None,
    };
    // Every stage works on the finite Gaussians; gaussians.ply keeps every input row.
    let gaussians = ply_rows.as_ref().map(inputs::finite_gaussians);
    if gaussians.is_none() && config.depth.is_none() {
        bail!("no depth: give --depth DIR or a PLY (--gaussians, or gaussians.ply in the scene folder)");
    }
    let gt = match &config.gt {
        Some(dir) => Some(inputs::ground_truth(
            dir,
            ply_rows.as_ref().map(|r| r.gaussians.len()),
            ply_path.as_deref(),
        )?),
        None => None,
    };
    let cache_dir = config.out.join("cache");
    let pc = &config.pipeline;

    // Whole-run key: every input file and every setting.
    let mut run_key = KeyHasher::default();
    run_key.text("run-v1").json(pc).text(&format!("{:?}", config.depth_kind));
    for (view, &masked) in scene.views.iter().zip(&has_masks) {
        run_key.text(&view.stem).file(&view.image_path)?;
        if masked {
            run_key.folder_entry(&config.masks, &view.stem)?;
        }
        for dir in [&config.features, &config.depth].into_iter().flatten() {
            run_key.folder_entry(dir, &view.stem)?;
        }
    }
    if let Some(p) = &ply_path {
        run_key.file(p)?;
    }
    if let Some(dir) = &config.gt {
        run_key.file(&dir.join("gaussian_ids.npy"))?;
        for view in &scene.views {
            run_key.file(&dir.join("instance").join(format!("{}.png", view.stem)))?;
            run_key.file(&dir.join(format!("{}.png", view.stem)))?;
        }
    }
    let run_key = run_key.finish();
    tracing::debug!("inputs and settings key {run_key}");
    let stems: Vec<&str> = scene.views.iter().map(|v| v.stem.as_str()).collect();
    if let Some(hit) = read_json::<RunCache>(&cache_dir.join("run.json")) {
        if hit.key == run_key && outputs_present(&config.out, &stems, ply_path.is_some()) {
            tracing::info!("outputs are up to date with the inputs and settings: nothing to do");
            return Ok(RunSummary { resumed: true, ..hit.summary });
        }
    }

    // Per view, one view at a time on each thread (bounded memory), see `per_view::PerView`.
    profiler.next("prepare Gaussians");
    let prepared = gaussians.as_ref().map(|g| PreparedGaussians::new(g)).transpose()?;
    drop(gaussians);
    let poses: Vec<_> = scene.views.iter().map(|v| v.world_from_cam).collect();
    let cams: Vec<PosedCamera> = scene
        .views
        .iter()
        .zip(&poses)
        .map(|(v, p)| PosedCamera { camera: scene.camera(v), world_from_cam: p })
        .collect();
    let ply_key = per_view::ply_key(ply_path.as_deref(), &pc.lift)?;
    profiler.next("per view: depth, merge, visibility");
    let times = profile::PartTimes::default();
    let sources = per_view::MergeSources::new(config, &ply_key);
    let ctx = sources.context(&scene, &load, config);
    let sharded = shard::expected_shards(&config.out, "merge")?;
    let per_view = per_view::PerView {
        prepared: prepared.as_ref(),
        cams: &cams,
        sources: &sources,
        ctx: &ctx,
        sharded,
        lift: &pc.lift,
        out: &config.out,
        sample_stride: prepared.as_ref().map_or(1, |p| visible::sample_stride(p.len(), scene.views.len())),
        times: &times,
    };
    let bar = progress(scene.views.len(), "merge", config.options);
    // Every view's result, then the first error in view order: which view an error names does
    // not depend on the thread count or on which thread failed first.
    let results: Vec<crate::Result<Option<ViewResult>>> = (0..scene.views.len())
        .into_par_iter()
        .progress_with(bar.clone())
        .map(|v| has_masks[v].then(|| per_view.result(v)).transpose())
        .collect();
    let mut views: Vec<Option<ViewResult>> = results.into_iter().collect::<crate::Result<_>>()?;
    bar.finish_and_clear();
    let cached_views = views.iter().flatten().filter(|m| m.cached).count();
    let raw_masks = views.iter().flatten().map(|m| m.raw_max as usize).sum::<usize>();
    let merged_masks = views.iter().flatten().map(|m| m.regions.len()).sum::<usize>();
    tracing::info!("merged {raw_masks} regions into {merged_masks} ({cached_views} views from the cache)");
    let cached_map = |v: usize, kind: &str| ctx.cached_map(&scene.views[v].stem, kind);
    let merged_map = |v: usize| cached_map(v, "merged");

    // Match, lift, render back.
    profiler.parts(times.take());
    profiler.next("match");
    let matching = lift_stage::match_views(&mut views, prepared.is_some(), &pc.matching)?;
    tracing::info!("matched into {} global objects ({:?})", matching.n_objects, matching.stats);
    profiler.next("lift and render back");
    let mut lifted = match &prepared {
        Some(p) => {
            let snap_kind = pc.lift.final_maps.snapped_onto().unwrap_or("merged");
            let snap_map = |v: usize| cached_map(v, snap_kind);
            let lift_config = match config.features {
                Some(_) => pc.lift.clone(),
                None => pc.lift.for_model_free_descriptors(),
            };
            let image_rgb = |v: usize| -> Result<Vec<u8>> {
                Ok(splatseg_scene::images::load_image_rgb(&scene, &scene.views[v], &load)?.into_raw())
            };
            let inputs = lift_stage::FinalMapInputs {
                snap_map: &snap_map,
                image_rgb: &image_rgb,
                options: config.options,
            };
            Some(lift_stage::lift_and_render(p, &cams, &views, &matching, &inputs, &lift_config, &times)?)
        }
        None => None,
    };
    profiler.parts(times.take());
    let spill_dir = cache_dir.join("visible");
    if spill_dir.is_dir() {
        std::fs::remove_dir_all(&spill_dir).with_context(|| format!("removing {}", spill_dir.display()))?;
    }
    let matched_map = |v: usize| -> crate::Result<Option<Plane<u32>>> {
        if views[v].is_none() {
            return Ok(None);
        }
        let table = &matching.global_of_label[v];
        Ok(Some(merged_map(v)?.map(|&l| table.get(l as usize).copied().unwrap_or(0))))
    };

    // Outputs and scores, one view at a time on each thread.
    profiler.next("outputs and eval");
    let eval = gt.as_ref().map(|g| eval_views(&scene, g)).transpose()?;
    let raw_offsets =
        local_offsets(&views.iter().map(|m| m.as_ref().map_or(0, |m| m.raw_max)).collect::<Vec<_>>());
    let merged_offsets =
        local_offsets(&views.iter().map(|m| m.as_ref().map_or(0, |m| m.merged_max)).collect::<Vec<_>>());
    let stage_names: &[&str] = if lifted.is_some() {
        &["raw", "merged", "matched", "lifted"]
    } else {
        &["raw", "merged", "matched"]
    };
    // `[N]` ids of every input row (-1 for the non-finite rows that were skipped).
    let row_ids = match (&ply_rows, &lifted) {
        (Some(rows), Some(l)) => Some(outputs::ids_of_every_row(rows, &l.lifted.object_ids)),
        _ => None,
    };
    let fused = lifted.as_mut().and_then(|l| l.lifted.fused_features.take());
    // `gaussians.ply` is written while the views' maps are (its writing is mostly the kernel
    // copying bytes, on one thread).
    let write_ply = || -> crate::Result<()> {
        if let (Some(rows), Some(ids), Some(_), Some(p)) = (ply_rows, &row_ids, &lifted, &ply_path) {
            let (finite, n_rows) = (rows.finite_rows(), rows.gaussians.len());
            let g = outputs::labelled_rows(rows, ids, fused.is_some());
            let fused = fused.map(|f| outputs::FusedRows::new(f, &finite, n_rows));
            let out_ply = config.out.join("gaussians.ply");
            let rows: Option<&dyn splatseg_scene::ply::FeatureRows> = fused.as_ref().map(|f| f as _);
            splatseg_scene::ply::write_ply_rows_with_features(&out_ply, &g, rows)
                .with_context(|| format!("writing the labelled Gaussians of {}", p.display()))?;
        }
        Ok(())
    };
    let bar = progress(scene.views.len(), "write label maps", config.options);
    let write_maps = || -> crate::Result<Vec<ViewOutputs>> {
        (0..scene.views.len())
            .into_par_iter()
            .progress_with(bar.clone())
            .map(|v| -> crate::Result<ViewOutputs> {
                let view = &scene.views[v];
                let matched = matched_map(v)?;
                let final_map = match &lifted {
                    Some(l) => l.final_map(v),
                    None => matched.clone().unwrap_or_else(|| {
                        let c = scene.camera(view);
                        Plane::filled(c.width as usize, c.height as usize, 0)
                    }),
                };
                outputs::write_view_maps(&config.out, &scene, &load, v, &final_map)?;
                // The view's distinct ids (kept for every view: a few, not a pixel's worth each);
                // a pixel equal to the one before adds nothing new.
                let mut distinct = std::collections::BTreeSet::new();
                let mut last = 0u32;
                for &x in &final_map.data {
                    if x != last {
                        if x > 0 {
                            distinct.insert(x);
                        }
                        last = x;
                    }
                }
                let ids: Vec<u32> = distinct.into_iter().collect();
                let counts = match &eval {
                    Some(e) => {
                        let local = |kind: &str, base: u32| -> crate::Result<Option<Plane<u32>>> {
                            Ok(match views[v] {
                                Some(_) => Some(offset_map(&cached_map(v, kind)?, base)),
                                None => None,
                            })
                        };
                        let mut maps =
                            vec![local("raw", raw_offsets[v])?, local("merged", merged_offsets[v])?, matched];
                        if lifted.is_some() {
                            maps.push(Some(final_map));
                        }
                        view_counts(&scene, e, v, &maps, &pc.eval)?
                    }
                    None => None,
                };
                Ok((ids, counts))
            })
            .collect::<crate::Result<_>>()
    };
    let (per_view, ply_written) = rayon::join(write_maps, write_ply);
    let per_view = per_view?;
    ply_written?;
    bar.finish_and_clear();
    let final_ids: std::collections::BTreeSet<u32> =
        per_view.iter().flat_map(|(ids, _)| ids.iter().copied()).collect();
    let report = match &gt {
        Some(gt) => {
            let counts: Vec<Vec<ViewCounts>> = per_view.into_iter().filter_map(|(_, c)| c).collect();
            Some(evaluate(stage_names, &counts, gt, row_ids.as_deref(), &pc.eval)?)
        }
        None => None,
    };
    let summary = RunSummary {
        out: config.out.clone(),
        views: scene.views.len(),
        views_with_masks: has_masks.iter().filter(|&&m| m).count(),
        gaussians: prepared.as_ref().map(|p| p.len()),
        raw_masks,
        merged_masks,
        matched_objects: matching.n_objects,
        final_objects: final_ids.len(),
        match_stats: matching.stats.clone(),
        lift_stats: lifted.as_ref().map(|l| l.lifted.stats.clone()),
        report,
        cached_views,
        resumed: false,
        stages: Vec::new(),
    };
    write_json(&config.out.join("metrics.json"), &summary)?;
    outputs::write_report(&config.out, &scene, &summary)?;
    write_json(&cache_dir.join("run.json"), &RunCache { key: run_key, summary: summary.clone() })?;
    Ok(RunSummary { stages: profiler.finish(), ..summary })
}
