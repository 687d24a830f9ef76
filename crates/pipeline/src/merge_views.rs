//! `splatseg merge`: `run`'s per-view merge stage on its own, over every view or one shard `K/N`
//! of them, with `run`'s inputs, depth and cache keys ([`crate::per_view::MergeSources`]), so a
//! later `run` on the same output folder finds every view's merge in `OUT/cache/merge/`.
//! Unsharded, it also writes what a person looks at: per view `OUT/masks/<stem>.png` (16-bit
//! merged regions, 0 = none), `OUT/overlays/<stem>.png` and `OUT/merge/<stem>.json` (regions
//! before and after, and every merge decision with its score terms and the rule that decided it).

use crate::error::{bail, Context};
use crate::merge_stage::{MergedView, ViewMergeLog};
use crate::per_view::{finite_depth, ply_key, MergeSources};
use crate::sam_wholes::Wholes;
use crate::shard::{write_manifest, Shard, ShardManifest};
use crate::view_data::ViewImage;
use crate::visible::pass_or;
use crate::{inputs, lock, RunConfig};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use splatseg_lift::{view_visibility, PreparedGaussians};
use splatseg_merge::{MergeConfig, RegionSummary};
use splatseg_scene::load::LoadOptions;
use splatseg_scene::View;

/// What to merge besides `run`'s inputs.
#[derive(Clone, Debug, Default)]
pub struct MergeRequest {
    /// One shard of the views, recorded as finished in `OUT/cache/shards/` (a later `run` then
    /// reads every view's merge from the cache and names a missing shard); `None`: every view,
    /// and the per-view outputs above are written too.
    pub shard: Option<Shard>,
    /// How the scene is loaded (image resolution); `run` loads it with the defaults.
    pub load: LoadOptions,
}

/// What [`merge_views`] did.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ShardSummary {
    /// Which shard ([`Shard::ALL`] when unsharded).
    pub shard: Shard,
    /// Views of the scene.
    pub views: usize,
    /// Views of this shard that had masks (merged or found in the cache).
    pub merged: usize,
    /// Of those, from the cache.
    pub cached: usize,
    /// Regions before merging, summed over the merged views.
    pub regions_before: usize,
    /// Regions after merging, summed over the merged views.
    pub regions_after: usize,
}

/// Runs the per-view merge stage of `run` over the views of `request.shard` (every view when
/// `None`), into `OUT/cache/merge` (exactly what `run` computes for them). Any number of shards
/// may run at once on the same `OUT`; a later [`crate::run_pipeline`] on it finds every view's
/// merge there and does only the global steps.
pub fn merge_views(config: &RunConfig, request: &MergeRequest) -> crate::Result<ShardSummary> {
    let shard = request.shard.unwrap_or(Shard::ALL);
    let _lock = match request.shard {
        Some(_) => lock::lock_output_shared(&config.out, "merge")?,
        None => lock::lock_output(&config.out, "merge")?,
    };
    let load = &request.load;
    let scene = splatseg_scene::load_scene(&config.scene, load)?;
    splatseg_scene::load::check_image_sizes(&scene, load)?;
    let has_masks = inputs::views_with_masks(&scene, &config.masks)?;
    let ply_path = inputs::gaussians_path(&config.scene, config.gaussians.as_deref());
    let ply_rows =
        ply_path.as_deref().map(|p| inputs::read_gaussians(p, config.options.strict)).transpose()?;
    let gaussians = ply_rows.as_ref().map(inputs::finite_gaussians);
    if gaussians.is_none() && config.depth.is_none() {
        bail!("no depth: give --depth DIR or a PLY (--gaussians, or gaussians.ply in the scene folder)");
    }
    let prepared = gaussians.as_ref().map(|g| PreparedGaussians::new(g)).transpose()?;
    drop(gaussians);
    drop(ply_rows);
    let lift = &config.pipeline.lift;
    let ply_key = ply_key(ply_path.as_deref(), lift)?;
    let sources = MergeSources::new(config, &ply_key);
    let export = request.shard.is_none();
    let mine: Vec<usize> = (0..scene.views.len()).filter(|&v| shard.contains(v) && has_masks[v]).collect();
    // The separate-wholes gate reads every view's masks, not only this shard's (as `run` does).
    let wholes = match prepared.as_ref().filter(|_| config.pipeline.merge.separate_wholes) {
        Some(p) => {
            let stride = crate::visible::sample_stride(p.len(), scene.views.len());
            let request = crate::sam_wholes::WholesRequest {
                scene: &scene,
                prepared: p,
                masks_dir: &config.masks,
                has_masks: &has_masks,
                lift,
                stride,
                out: &config.out,
                for_lift: false,
                times: None,
            };
            let mut check = vec![false; scene.views.len()];
            mine.iter().for_each(|&v| check[v] = true);
            let mut probe = sources.context(&scene, load, config);
            probe.keep_log = export;
            crate::sam_wholes::prepare(&request, &sources, probe, &check, config.options)?
        }
        None => Wholes::off(scene.views.len()),
    };
    let mut ctx = sources.context(&scene, load, config);
    ctx.keep_log = export;
    ctx.wholes_key = wholes.key.clone();
    ctx.wholes = wholes.evidence.as_ref();
    let bar = crate::progress(mine.len(), if export { "merge" } else { "merge shard" }, config.options);
    let counts = mine
        .par_iter()
        .map(|&v| -> crate::Result<(bool, usize, usize, usize, usize)> {
            let view = &scene.views[v];
            let (metric, normals, visible) = match prepared.as_ref() {
                Some(p) => {
                    let pass = pass_or(&config.out, &view.stem, wholes.spilled[v], || {
                        view_visibility(p, scene.camera(view), &view.world_from_cam, None, lift)
                    })?;
                    (pass.surface_depth.as_ref().map(finite_depth), pass.surface_normals, Some(pass.visible))
                }
                None => (None, None, None),
            };
            let visible = visible.as_ref();
            let image = ViewImage::new(&scene, view, load);
            let merged = match request.shard {
                Some(shard) => sources
                    .merge(&ctx, v, metric, normals, visible, &image)
                    .with_context(|| format!("shard {shard}"))?,
                None => sources.merge(&ctx, v, metric, normals, visible, &image)?,
            };
            let before = match &merged.log {
                Some(log) => log.log.regions_before,
                None => merged.raw.data.iter().copied().max().unwrap_or(0) as usize,
            };
            if export {
                write_view(view, &image, &config.out, &config.pipeline.merge, &merged)?;
            }
            bar.inc(1);
            Ok((merged.cached, before, merged.regions.len(), merged.empty_masks, merged.recomputed_masks))
        })
        .collect::<Vec<crate::Result<_>>>()
        .into_iter()
        .collect::<crate::Result<Vec<_>>>()?; // the first error in view order
    bar.finish_and_clear();
    let empty: usize = counts.iter().map(|c| c.3).sum();
    if empty > 0 {
        tracing::warn!(
            "{empty} SAM masks in {} of {} views merged are empty (all zeros) and select nothing: {}",
            counts.iter().filter(|c| c.3 > 0).count(),
            counts.len(),
            config.masks.display()
        );
    }
    let recomputed: usize = counts.iter().map(|c| c.4).sum();
    if recomputed > 0 {
        tracing::warn!(
            "{recomputed} SAM masks in {} of {} views merged have an area or bbox that disagrees with the mask \
             itself; the values recomputed from the masks are used: {}",
            counts.iter().filter(|c| c.4 > 0).count(),
            counts.len(),
            config.masks.display()
        );
    }
    if let Some(shard) = request.shard {
        let views = mine.iter().map(|&v| scene.views[v].stem.clone()).collect();
        write_manifest(&config.out, &ShardManifest { stage: "merge".into(), shard, views })?;
    }
    Ok(ShardSummary {
        shard,
        views: scene.views.len(),
        merged: mine.len(),
        cached: counts.iter().filter(|c| c.0).count(),
        regions_before: counts.iter().map(|c| c.1).sum(),
        regions_after: counts.iter().map(|c| c.2).sum(),
    })
}

/// `run`'s merge stage over the views of `shard` only, with the scene loaded as `run` loads it
/// (see [`merge_views`]).
pub fn merge_shard(config: &RunConfig, shard: Shard) -> crate::Result<ShardSummary> {
    merge_views(config, &MergeRequest { shard: Some(shard), load: LoadOptions::default() })
}

/// `OUT/merge/<stem>.json`.
#[derive(Serialize)]
struct ViewLog<'a> {
    stem: &'a str,
    config: &'a MergeConfig,
    regions_before: usize,
    regions_after: usize,
    merges: usize,
    /// Input regions (SAM masks after overlaps were resolved), index = input label − 1.
    input_regions: &'a [splatseg_cues::RegionSource],
    /// Final id of each input region.
    final_id_of_input: &'a [u32],
    /// Final regions (descriptor omitted).
    regions: Vec<RegionBrief<'a>>,
    decisions: &'a [splatseg_merge::Decision],
}

#[derive(Serialize)]
struct RegionBrief<'a> {
    id: u32,
    area: u64,
    mean_depth: f32,
    bbox_px: [u32; 4],
    merged_from: &'a [u32],
}

fn brief(r: &RegionSummary) -> RegionBrief<'_> {
    RegionBrief {
        id: r.id,
        area: r.area,
        mean_depth: r.mean_depth,
        bbox_px: r.bbox_px,
        merged_from: &r.merged_from,
    }
}

/// Writes the merged regions of `view` as a label map, over its image, and its decisions.
fn write_view(
    view: &View,
    image: &ViewImage,
    out: &std::path::Path,
    config: &MergeConfig,
    merged: &MergedView,
) -> crate::Result<()> {
    let stem = &view.stem;
    let Some(ViewMergeLog { input_regions, log }) = &merged.log else {
        bail!("the merge of view `{stem}` kept no decisions");
    };
    splatseg_scene::labels::write_label_png(&out.join("masks").join(format!("{stem}.png")), &merged.merged)?;
    let overlay = splatseg_scene::labels::overlay(image.rgb()?, &merged.merged, 0.5);
    splatseg_scene::image_io::write_png_rgb8(&out.join("overlays").join(format!("{stem}.png")), &overlay)?;
    let entry = ViewLog {
        stem,
        config,
        regions_before: log.regions_before,
        regions_after: log.regions_after,
        merges: log.merges,
        input_regions,
        final_id_of_input: &log.final_id_of_input,
        regions: merged.regions.iter().map(brief).collect(),
        decisions: &log.decisions,
    };
    let json = serde_json::to_vec_pretty(&entry)?;
    splatseg_scene::atomic::write_bytes_atomic(&out.join("merge").join(format!("{stem}.json")), &json)?;
    Ok(())
}
