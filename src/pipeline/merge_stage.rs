//! The per-view stages before matching: SAM masks → regions ("raw") → Multi-Cue merging
//! ("merged"), cached per view in `OUT/cache/merge/`.

use super::cache::{read_json, write_json, KeyHasher};
use anyhow::{anyhow, Context};
use serde::{Deserialize, Serialize};
use splatseg_cues::{DepthMap, DescriptorSource, MaskInput, RegionOptions};
use splatseg_merge::{build_view_inputs, merge_view, CueRequest, MergeConfig, RegionSummary};
use splatseg_scene::labels::{read_label_png, write_label_png};
use splatseg_scene::load::LoadOptions;
use splatseg_scene::{Plane, Scene, View};
use std::path::{Path, PathBuf};

/// One view after merging.
#[derive(Clone, Debug)]
pub struct MergedView {
    /// `[H, W]` SAM masks resolved into regions, 0 = none (the "raw" baseline).
    pub raw: Plane<u32>,
    /// `[H, W]` merged regions, 0 = none, local ids `1..=regions.len()`.
    pub merged: Plane<u32>,
    /// `[k]` merged regions (descriptor, area, …), `regions[i].id == i + 1`.
    pub regions: Vec<RegionSummary>,
    /// True when read from the cache.
    pub cached: bool,
}

/// What is cached next to the two label maps.
#[derive(Serialize, Deserialize)]
struct CacheEntry {
    key: String,
    regions: Vec<RegionSummary>,
}

/// Everything every view's merge shares.
pub struct MergeContext<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// How the scene was loaded (image resolution).
    pub load_options: &'a LoadOptions,
    /// SAM mask folder.
    pub masks_dir: &'a Path,
    /// Feature folder (hashed into the key), when features are used.
    pub features_dir: Option<&'a Path>,
    /// Descriptor source.
    pub descriptors: &'a dyn DescriptorSource,
    /// Merge settings.
    pub config: &'a MergeConfig,
    /// Masks → regions settings.
    pub region_options: RegionOptions,
    /// `OUT/cache/merge`.
    pub cache_dir: PathBuf,
}

/// The depth inputs of one view.
pub struct ViewDepth<'a> {
    /// Depth for the merge cues.
    pub depth: &'a DepthMap,
    /// Metric z for the relative gate, when known.
    pub metric: Option<&'a Plane<f32>>,
    /// Identifies where the depth came from, for the cache key.
    pub key: String,
}

/// The cache key of one view's merge.
fn view_key(ctx: &MergeContext, view: &View, depth_key: &str) -> anyhow::Result<String> {
    let mut h = KeyHasher::default();
    h.text("merge-v1").text(&view.stem).json(ctx.config).json(&ctx.region_options).text(depth_key);
    h.folder_entry(ctx.masks_dir, &view.stem)?;
    h.file(&view.image_path)?;
    if let Some(dir) = ctx.features_dir {
        h.folder_entry(dir, &view.stem)?;
    }
    Ok(h.finish())
}

fn read_cached(ctx: &MergeContext, stem: &str, key: &str, size: (usize, usize)) -> Option<MergedView> {
    let entry: CacheEntry = read_json(&ctx.cache_dir.join(format!("{stem}.json")))?;
    if entry.key != key {
        return None;
    }
    let raw = read_label_png(&ctx.cache_dir.join(format!("{stem}.raw.png"))).ok()?;
    let merged = read_label_png(&ctx.cache_dir.join(format!("{stem}.merged.png"))).ok()?;
    (raw.size() == size && merged.size() == size).then_some(MergedView {
        raw,
        merged,
        regions: entry.regions,
        cached: true,
    })
}

/// The SAM masks of `view` as merge inputs (checked against the image size).
fn read_masks(ctx: &MergeContext, view: &View, width: u32, height: u32) -> anyhow::Result<Vec<MaskInput>> {
    let masks = splatseg_scene::sam::read_view_masks(ctx.masks_dir, &view.stem)?.unwrap_or_default();
    let path = ctx.masks_dir.join(format!("{}.json", view.stem));
    splatseg_scene::sam::check_mask_sizes(&masks, width, height, &path)?;
    masks
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let plane = m
                .segmentation
                .decode()
                .map_err(|e| anyhow!("mask {i} of view `{}`: {e}: {}", view.stem, path.display()))?;
            Ok(MaskInput::from_plane(&plane, m.predicted_iou as f32, m.stability_score as f32))
        })
        .collect()
}

/// Merges one view (or reads it from the cache).
pub fn merge_one(ctx: &MergeContext, view: &View, depth: &ViewDepth) -> anyhow::Result<MergedView> {
    let camera = ctx.scene.camera(view);
    let size = (camera.width as usize, camera.height as usize);
    let key = view_key(ctx, view, &depth.key)?;
    if let Some(hit) = read_cached(ctx, &view.stem, &key, size) {
        return Ok(hit);
    }
    let image = splatseg_scene::images::load_image_rgb(ctx.scene, view, ctx.load_options)?;
    let rgb = Plane {
        width: size.0,
        height: size.1,
        data: image.as_raw().chunks_exact(3).map(|p| [0, 1, 2].map(|c| p[c] as f32 / 255.0)).collect(),
    };
    let masks = read_masks(ctx, view, camera.width, camera.height)?;
    let inputs = build_view_inputs(&CueRequest {
        stem: &view.stem,
        rgb: &rgb,
        masks: &masks,
        depth: depth.depth,
        metric_depth: depth.metric,
        descriptors: ctx.descriptors,
        region_options: ctx.region_options,
    })
    .with_context(|| format!("preparing the merge cues of view `{}`", view.stem))?;
    let result = merge_view(&inputs, ctx.config).with_context(|| format!("merging view `{}`", view.stem))?;
    let merged = MergedView {
        raw: inputs.regions.labels,
        merged: result.labels,
        regions: result.regions,
        cached: false,
    };
    write_label_png(&ctx.cache_dir.join(format!("{}.raw.png", view.stem)), &merged.raw)?;
    write_label_png(&ctx.cache_dir.join(format!("{}.merged.png", view.stem)), &merged.merged)?;
    write_json(
        &ctx.cache_dir.join(format!("{}.json", view.stem)),
        &CacheEntry { key, regions: merged.regions.clone() },
    )?;
    Ok(merged)
}
