//! The end-to-end pipeline behind `splatseg run` (and `demo`): cues → merge → match → lift →
//! (eval when ground truth is given), with per-stage caching in `OUT/cache/`. A library, so the
//! binary, the viewer's server or a binding can call it:
//!
//! - [`run_pipeline`] runs the whole pipeline ([`RunConfig`] → [`RunSummary`]);
//! - [`merge_views`] runs `run`'s per-view merge stage alone (`splatseg merge`), over every view
//!   or one [`Shard`] `K/N` of them (any number of shards at once, as separate processes), with
//!   `run`'s inputs and cache keys; a later [`run_pipeline`] on the same output folder reuses it;
//! - [`merge_view_arrays`] merges one view from cues held in memory (the step both of the
//!   above take per view; a binding's entry point);
//! - [`RunOutputs`] reads a finished run's results (summary, label maps, per-Gaussian ids);
//! - [`apply::apply_edits`] applies a run's `edits.json` to its outputs (`splatseg apply`);
//!   [`viewer_edits`] tells `splatseg view` the run it edits;
//! - [`scene_info`] (what a scene folder holds), [`demo`], [`render_views`], [`train_stage`]: the
//!   other commands' work;
//! - [`args`]: the arguments of the commands above (clap's `Args` with the `cli` feature) and
//!   the requests they make.
//!
//! Errors are [`PipelineError`]; [`PipelineError::report`] prints the chain of causes.
//!
//! ```text
//! OUT/masks/<stem>.png      final per-view label maps, 16-bit global ids, 0 = none
//! OUT/overlays/<stem>.png   the label maps over the images
//! OUT/gaussians.ply         the input PLY + `object_id` (+ fused `feat_*`), same Gaussian order
//! OUT/report.md             stage summary, warnings (what counted for less than given), metrics table
//! OUT/metrics.json          the same as data
//! OUT/cache/                per-stage results keyed by inputs + config (a rerun resumes)
//! ```
//!
//! The outputs above the cache are written into `OUT/.staging/` and moved in together when all
//! are complete, with `cache/run.json` (the manifest "up to date" checks) written last: a run
//! killed at any moment leaves the earlier outputs or none that count as up to date, and the
//! next run leaves no file of an earlier run it would not write (`commit.rs`).

pub mod apply;
mod apply_base;
mod apply_maps;
pub mod args;
mod cache;
mod commit;
pub mod config;
pub mod demo;
pub mod digest;
mod error;
mod eval_stage;
mod graph_record;
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
pub mod progress_log;
pub mod render_views;
mod results;
mod run_outputs;
mod sam_wholes;
pub mod scene_info;
pub mod shard;
#[cfg(test)]
mod tests;
pub mod train_stage;
mod view_data;
mod view_merge;
pub mod viewer_edits;
mod visible;

use cache::{read_json, write_json};
pub use config::PipelineConfig;
use error::bail;
pub use error::{Context, PipelineError, Result};
use indicatif::{ParallelProgressIterator, ProgressBar, ProgressStyle};
use inputs::RunInputs;
use lift_stage::ViewResult;
pub use mask_input::{mask_inputs, read_view_mask_inputs, ViewMaskInputs};
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
use splatseg_lift::{LiftStats, PosedCamera, PreparedGaussians};
use splatseg_match::{MatchStats, Matching};
use splatseg_scene::load::LoadOptions;
use splatseg_scene::Scene;
use std::path::{Path, PathBuf};
pub use view_merge::{merge_view_arrays, ViewArrays, ViewMerge};

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
    /// Resample `depth` maps of another size than their image (`--resize-depth`); without it
    /// such a map is an error naming the file and both shapes.
    pub resize_depth: bool,
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
    /// What made a view or a Gaussian count for less than the user gave, one sentence each with
    /// its count (also in `report.md`; left out of `metrics.json` when there is none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
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

/// A progress bar over `len` items: drawn on a terminal; when stderr is not one, a log line at
/// least every 30 s while it runs ([`progress_log`]); nothing with `--quiet`.
pub(crate) fn progress(len: usize, what: &str, options: RunOptions) -> ProgressBar {
    let bar = ProgressBar::new(len as u64);
    if options.quiet {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    } else {
        progress_log::log_when_piped(&bar);
    }
    if let Ok(style) = ProgressStyle::with_template("{msg:>24} [{bar:30}] {pos}/{len} {elapsed}") {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(what.to_string());
    bar
}

#[derive(Serialize, Deserialize)]
struct RunCache {
    key: String,
    summary: RunSummary,
}

/// Runs the whole pipeline (see the module docs for the outputs).
pub fn run_pipeline(config: &RunConfig) -> crate::Result<RunSummary> {
    // `metrics.json` and the cache record the output folder as text: refused before anything is
    // written rather than failing once the outputs are staged.
    if config.out.to_str().is_none() {
        bail!("the output folder's path is not valid UTF-8 (choose another --out): {}", config.out.display());
    }
    let _lock = lock::lock_output(&config.out, "run")?;
    commit::remove_leftover_staging(&config.out)?;
    let mut profiler = Profiler::start("load inputs");
    let load = LoadOptions::default();
    let mut inputs = RunInputs::load(config, &load)?;
    let cache_dir = config.out.join("cache");
    let run_key = inputs.key(config)?;
    if let Some(hit) = read_json::<RunCache>(&cache_dir.join("run.json")) {
        let here = same_folder(&hit.summary.out, &config.out);
        if hit.key == run_key && inputs.outputs_present(&config.out) && here {
            tracing::info!("outputs are up to date with the inputs and settings: nothing to do");
            apply::record_run_scene(&config.out, &run_key, &config.scene)?;
            return Ok(RunSummary { resumed: true, out: config.out.clone(), ..hit.summary });
        }
        if hit.key == run_key && !here {
            tracing::info!(
                "the outputs here were written for {} (a copy or a moved folder): writing them for {}",
                hit.summary.out.display(),
                config.out.display()
            );
        }
    }

    profiler.next("prepare Gaussians");
    let prepared = inputs.prepared_gaussians()?;
    let scene = &inputs.scene;
    let poses: Vec<_> = scene.views.iter().map(|v| v.world_from_cam).collect();
    let cams: Vec<PosedCamera> = scene
        .views
        .iter()
        .zip(&poses)
        .map(|(v, p)| PosedCamera { camera: scene.camera(v), world_from_cam: p })
        .collect();

    profiler.next("per view: visibility, SAM masks");
    let sources = per_view::MergeSources::new(
        config,
        &per_view::ply_key(inputs.ply_path.as_deref(), &config.pipeline.lift)?,
    );
    let sharded = shard::expected_shards(&config.out, "merge")?;
    let sample_stride = prepared.as_ref().map_or(1, |p| visible::sample_stride(p.len(), scene.views.len()));
    let times = PartTimes::default();
    let wholes = match prepared.as_ref().filter(|_| config.pipeline.merge.separate_wholes) {
        Some(p) => {
            let request = sam_wholes::WholesRequest {
                scene,
                prepared: p,
                masks_dir: &config.masks,
                has_masks: &inputs.has_masks,
                lift: &config.pipeline.lift,
                stride: sample_stride,
                out: &config.out,
                for_lift: true,
                times: Some(&times),
            };
            // Built in every run: the lift stage's touching joins read it (every view with masks
            // takes its pass over the Gaussians, so each view's spilled pass is read back).
            let probe = sources.context(scene, &load, config);
            sam_wholes::prepare(&request, &sources, probe, &inputs.has_masks, config.options)?
        }
        None => sam_wholes::Wholes::off(scene.views.len()),
    };
    profiler.parts(times.take());

    profiler.next("per view: depth, merge, visibility");
    let mut views = {
        let mut ctx = sources.context(scene, &load, config);
        ctx.wholes_key = wholes.key.clone();
        ctx.wholes = wholes.evidence.as_ref();
        let per_view = per_view::PerView {
            prepared: prepared.as_ref(),
            cams: &cams,
            sources: &sources,
            ctx: &ctx,
            sharded,
            lift: &config.pipeline.lift,
            out: &config.out,
            sample_stride,
            spilled: &wholes.spilled,
            times: &times,
        };
        every_view(&per_view, &inputs.has_masks, config.options)?
    };
    let regions = RegionCounts::of(&views);
    let mask_warnings = mask_warnings(&views, scene, &config.masks);
    for w in &mask_warnings {
        tracing::warn!("{w}");
    }
    profiler.parts(times.take());

    profiler.next("match");
    let stems: Vec<&str> = scene.views.iter().map(|v| v.stem.as_str()).collect();
    lift_stage::check_descriptor_lengths(&views, &stems, config.features.as_deref())?;
    let matching = lift_stage::match_views(&mut views, prepared.is_some(), &config.pipeline.matching)?;
    tracing::info!("matched into {} global objects ({:?})", matching.n_objects, matching.stats);

    profiler.next("lift and render back");
    let mut ctx = sources.context(scene, &load, config);
    ctx.wholes = wholes.evidence.as_ref();
    let lifted = prepared
        .as_ref()
        .map(|p| lift_stage::lift_views(p, &cams, &views, &matching, &ctx, config, &times))
        .transpose()?;
    drop(wholes);
    if let Some(l) = &lifted {
        let truth = inputs.gt.as_ref().and_then(|g| g.gaussian_ids.as_deref());
        let truth = truth.and_then(|t| graph_record::node_truth(inputs.ply_rows.as_ref(), &l.voted_ids, t));
        graph_record::write_graph(&cache_dir, l, truth.as_ref())?;
    }
    profiler.parts(times.take());
    remove_spills(&cache_dir.join("visible"))?;

    profiler.next("outputs and eval");
    let results = run_outputs::StageResults { views: &views, matching: &matching, lifted };
    let ply_rows = inputs.ply_rows.take();
    let staging = commit::Staging::begin(&config.out)?;
    let written = run_outputs::write_outputs(config, staging.dir(), &inputs, ply_rows, &load, results)?;
    remove_spills(&cache_dir.join("views"))?;
    inputs.warnings.extend(mask_warnings);
    let summary = summary(config, &inputs, prepared.as_ref(), regions, &matching, written);
    write_json(&staging.dir().join("metrics.json"), &summary)?;
    outputs::write_report(staging.dir(), &inputs.scene, &summary)?;
    let manifest = cache_dir.join("run.json");
    staging.commit(&manifest)?;
    write_json(&manifest, &RunCache { key: run_key.clone(), summary: summary.clone() })?;
    apply::record_run_scene(&config.out, &run_key, &config.scene)?;
    Ok(RunSummary { stages: profiler.finish(), ..summary })
}

/// Whether `recorded` (the output folder a finished run recorded) is `out`, by their resolved paths: a
/// copy of an output folder, or one moved, is not (its `metrics.json` and report name the other), and
/// is written again rather than called up to date.
fn same_folder(recorded: &Path, out: &Path) -> bool {
    match (std::fs::canonicalize(recorded), std::fs::canonicalize(out)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

/// The per-view pass over every view with masks, one view at a time on each thread (bounded
/// memory): every view's result, then the first error in view order (which view an error names
/// does not depend on the thread count or on which thread failed first).
fn every_view(
    per_view: &per_view::PerView,
    has_masks: &[bool],
    options: RunOptions,
) -> crate::Result<Vec<Option<ViewResult>>> {
    let bar = progress(has_masks.len(), "merge", options);
    let results: Vec<crate::Result<Option<ViewResult>>> = (0..has_masks.len())
        .into_par_iter()
        .progress_with(bar.clone())
        .map(|v| has_masks[v].then(|| per_view.result(v)).transpose())
        .collect();
    let views: Vec<Option<ViewResult>> = results.into_iter().collect::<crate::Result<_>>()?;
    bar.finish_and_clear();
    let c = RegionCounts::of(&views);
    tracing::info!("merged {} regions into {} ({} views from the cache)", c.raw, c.merged, c.cached_views);
    Ok(views)
}

/// What the views' SAM files held that the run went on without, one sentence each with the count
/// and the views (none when all is well): empty masks (all zeros: they select nothing), and masks
/// whose `area` / `bbox` disagreed with the mask (the values recomputed from the masks are used).
/// Said once for the run, not once per file or per pass over the files.
fn mask_warnings(views: &[Option<ViewResult>], scene: &Scene, dir: &Path) -> Vec<String> {
    let sentence = |count: fn(&ViewResult) -> usize, said: &str, then: &str| -> Option<String> {
        let per_view: Vec<(&str, usize)> = views
            .iter()
            .zip(&scene.views)
            .filter_map(|(r, v)| r.as_ref().map(|r| (v.stem.as_str(), count(r))).filter(|&(_, n)| n > 0))
            .collect();
        let total: usize = per_view.iter().map(|(_, n)| n).sum();
        (total > 0).then(|| {
            let shown: Vec<String> = per_view.iter().take(5).map(|(s, n)| format!("{s} ({n})")).collect();
            let more =
                if per_view.len() > 5 { format!(" and {} more", per_view.len() - 5) } else { String::new() };
            format!(
                "{total} SAM masks in {} of {} views {said}: {}{more}; {then}: {}",
                per_view.len(),
                scene.views.len(),
                shown.join(", "),
                dir.display()
            )
        })
    };
    let empty = sentence(
        |r| r.empty_masks,
        "are empty (all zeros) and select nothing",
        "each view is segmented by its other masks only",
    );
    let recomputed = sentence(
        |r| r.recomputed_masks,
        "have an area or bbox that disagrees with the mask itself",
        "the values recomputed from the masks are used",
    );
    empty.into_iter().chain(recomputed).collect()
}

/// What the per-view pass found over all views (before matching takes the regions).
struct RegionCounts {
    /// SAM regions.
    raw: usize,
    /// Merged regions.
    merged: usize,
    /// Views whose merge came from the cache.
    cached_views: usize,
}

impl RegionCounts {
    fn of(views: &[Option<ViewResult>]) -> Self {
        RegionCounts {
            raw: views.iter().flatten().map(|m| m.raw_max as usize).sum::<usize>(),
            merged: views.iter().flatten().map(|m| m.regions.len()).sum::<usize>(),
            cached_views: views.iter().flatten().filter(|m| m.cached).count(),
        }
    }
}

/// Removes a folder the per-view pass spilled into once its last reader is done: `visible/` after
/// the lift stage, `views/` after the outputs.
fn remove_spills(spill_dir: &Path) -> crate::Result<()> {
    if spill_dir.is_dir() {
        std::fs::remove_dir_all(spill_dir).with_context(|| format!("removing {}", spill_dir.display()))?;
    }
    Ok(())
}

/// The run's summary.
fn summary(
    config: &RunConfig,
    inputs: &RunInputs,
    prepared: Option<&PreparedGaussians>,
    regions: RegionCounts,
    matching: &Matching,
    written: run_outputs::Written,
) -> RunSummary {
    RunSummary {
        out: config.out.clone(),
        views: inputs.scene.views.len(),
        views_with_masks: inputs.has_masks.iter().filter(|&&m| m).count(),
        gaussians: prepared.map(|p| p.len()),
        raw_masks: regions.raw,
        merged_masks: regions.merged,
        matched_objects: matching.n_objects,
        final_objects: written.final_objects,
        match_stats: matching.stats.clone(),
        lift_stats: written.lift_stats,
        report: written.report,
        warnings: inputs.warnings.iter().chain(&written.warnings).cloned().collect(),
        cached_views: regions.cached_views,
        resumed: false,
        stages: Vec::new(),
    }
}
