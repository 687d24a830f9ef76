//! The per-view stages before matching: SAM masks → regions ("raw") → Multi-Cue merging
//! ("merged"), cached per view in `OUT/cache/merge/` (`<stem>.raw.png`, `<stem>.merged.png`,
//! `<stem>.json`; and `<stem>.log.json`, the merge's decisions, when [`MergeContext::keep_log`]).

use super::cache::{read_json, write_json, KeyHasher};
use super::{read_view_mask_inputs, ViewMaskInputs};
use crate::view_data::ViewImage;
use crate::view_merge::{merge_view_arrays_with_wholes, ViewArrays};
use serde::{Deserialize, Serialize};
use splatseg_cues::{DepthMap, DescriptorSource, RegionOptions, RegionSource};
use splatseg_merge::{MergeConfig, MergeLog, RegionSummary, ViewWholes, WholesEvidence};
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
    /// SAM masks of the view that are empty (all zeros): they select nothing and add no region.
    pub empty_masks: usize,
    /// SAM masks of the view whose file `area` / `bbox` disagreed with the mask (recomputed).
    pub recomputed_masks: usize,
    /// What the merge decided, when [`MergeContext::keep_log`] asked for it.
    pub log: Option<ViewMergeLog>,
}

/// What the merge of one view decided (`splatseg merge` writes it to `OUT/merge/<stem>.json`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ViewMergeLog {
    /// `[n]` input regions (SAM masks after overlaps were resolved), index = input label − 1.
    pub input_regions: Vec<RegionSource>,
    /// Every decision, and the final id of each input region.
    pub log: MergeLog,
}

/// What is cached next to the two label maps.
#[derive(Serialize, Deserialize)]
struct CacheEntry {
    key: String,
    regions: Vec<RegionSummary>,
    /// [`MergedView::empty_masks`] (left out when 0, so entries of other views are unchanged).
    #[serde(default, skip_serializing_if = "is_zero")]
    empty_masks: usize,
    /// [`MergedView::recomputed_masks`] (left out when 0, as `empty_masks`).
    #[serde(default, skip_serializing_if = "is_zero")]
    recomputed_masks: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// `<stem>.log.json`: the decisions, under the same key.
#[derive(Serialize, Deserialize)]
struct LogEntry {
    key: String,
    log: ViewMergeLog,
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
    /// Keep each view's decisions ([`MergedView::log`]) in the cache too; a cached view without
    /// them is merged again (to the same maps).
    pub keep_log: bool,
    /// Every view's SAM masks through the Gaussians, for the separate-wholes gate (`None`: the
    /// gate is off, or every view's merge is in the cache and it was not built).
    pub wholes: Option<&'a WholesEvidence>,
    /// [`crate::sam_wholes::wholes_key`] when the gate is on (then in every view's key), else empty.
    pub wholes_key: String,
}

/// The depth inputs of one view, and the other views' masks through the Gaussians it sees.
pub struct ViewDepth<'a> {
    /// Depth for the merge cues.
    pub depth: &'a DepthMap,
    /// Metric z for the crease gate's points, when known.
    pub metric: Option<&'a Plane<f32>>,
    /// Camera-space normals of that surface for the crease gate, when rendered.
    pub normals: Option<&'a Plane<[f32; 3]>>,
    /// Identifies where the depth came from, for the cache key.
    pub key: String,
    /// The separate-wholes gate's evidence for this view (its visible Gaussians), when built.
    pub wholes: Option<ViewWholes<'a>>,
}

/// The cache key of one view's merge.
fn view_key(ctx: &MergeContext, view: &View, depth_key: &str) -> crate::Result<String> {
    let mut h = KeyHasher::default();
    h.text("merge-v2").text(&view.stem).json(ctx.config).json(&ctx.region_options).text(depth_key);
    h.text(&ctx.wholes_key);
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
    let log = if ctx.keep_log {
        let logged: LogEntry = read_json(&ctx.cache_dir.join(format!("{stem}.log.json")))?;
        if logged.key != key {
            return None;
        }
        Some(logged.log)
    } else {
        None
    };
    let raw = read_label_png(&ctx.cache_dir.join(format!("{stem}.raw.png"))).ok()?;
    let merged = read_label_png(&ctx.cache_dir.join(format!("{stem}.merged.png"))).ok()?;
    (raw.size() == size && merged.size() == size).then_some(MergedView {
        raw,
        merged,
        regions: entry.regions,
        cached: true,
        empty_masks: entry.empty_masks,
        recomputed_masks: entry.recomputed_masks,
        log,
    })
}

/// The SAM masks of `view` as merge inputs (none when it has no masks), each checked against
/// the `width × height` image before it is decoded and turned into row runs straight from its
/// COCO counts (see [`super::read_view_mask_inputs`]).
fn read_masks(ctx: &MergeContext, view: &View, width: u32, height: u32) -> crate::Result<ViewMaskInputs> {
    let masks = read_view_mask_inputs(ctx.masks_dir, &view.stem, width as usize, height as usize)?;
    Ok(masks.unwrap_or_default())
}

/// True when the cache holds view `view`'s merge made from the same inputs and settings
/// (`depth_key` as [`ViewDepth::key`]); reads the small entry only, not the maps.
pub fn is_cached(ctx: &MergeContext, view: &View, depth_key: &str) -> crate::Result<bool> {
    let key = view_key(ctx, view, depth_key)?;
    let entry: Option<CacheEntry> = read_json(&ctx.cache_dir.join(format!("{}.json", view.stem)));
    let logged = || {
        let log: Option<LogEntry> = read_json(&ctx.cache_dir.join(format!("{}.log.json", view.stem)));
        log.is_some_and(|l| l.key == key)
    };
    Ok(entry.is_some_and(|e| e.key == key) && (!ctx.keep_log || logged()))
}

/// The merge of one view from the cache, when an entry made from the same inputs and settings
/// is there.
pub fn merge_cached(ctx: &MergeContext, view: &View, depth: &ViewDepth) -> crate::Result<Option<MergedView>> {
    let camera = ctx.scene.camera(view);
    let size = (camera.width as usize, camera.height as usize);
    let key = view_key(ctx, view, &depth.key)?;
    Ok(read_cached(ctx, &view.stem, &key, size))
}

/// Merges one view (or reads it from the cache); `image` is decoded only when the view is merged.
pub fn merge_one(
    ctx: &MergeContext,
    view: &View,
    depth: &ViewDepth,
    image: &ViewImage,
) -> crate::Result<MergedView> {
    let camera = ctx.scene.camera(view);
    let size = (camera.width as usize, camera.height as usize);
    let key = view_key(ctx, view, &depth.key)?;
    if let Some(hit) = read_cached(ctx, &view.stem, &key, size) {
        return Ok(hit);
    }
    let image = image.rgb()?;
    let ViewMaskInputs { masks, recomputed: recomputed_masks } =
        read_masks(ctx, view, camera.width, camera.height)?;
    let empty_masks = masks.iter().filter(|m| m.runs.is_empty()).count();
    let result = merge_view_arrays_with_wholes(
        &ViewArrays {
            stem: &view.stem,
            rgb: &image.data,
            width: size.0,
            height: size.1,
            masks: &masks,
            depth: depth.depth,
            metric: depth.metric,
            normals: depth.normals,
            descriptors: ctx.descriptors,
            config: ctx.config,
            region_options: ctx.region_options,
            intrinsics: Some(splatseg_cues::Intrinsics::of_camera(camera, size.0, size.1)),
        },
        depth.wholes.as_ref(),
    )?;
    let log = ctx.keep_log.then_some(ViewMergeLog { input_regions: result.input_regions, log: result.log });
    let merged = MergedView {
        raw: result.raw,
        merged: result.merged,
        regions: result.regions,
        cached: false,
        empty_masks,
        recomputed_masks,
        log,
    };
    write_label_png(&ctx.cache_dir.join(format!("{}.raw.png", view.stem)), &merged.raw)?;
    write_label_png(&ctx.cache_dir.join(format!("{}.merged.png", view.stem)), &merged.merged)?;
    write_json(
        &ctx.cache_dir.join(format!("{}.json", view.stem)),
        &CacheEntry { key: key.clone(), regions: merged.regions.clone(), empty_masks, recomputed_masks },
    )?;
    if let Some(log) = &merged.log {
        write_json(
            &ctx.cache_dir.join(format!("{}.log.json", view.stem)),
            &LogEntry { key, log: log.clone() },
        )?;
    }
    Ok(merged)
}

#[cfg(test)]
mod tests {
    use crate::{mask_inputs, read_view_mask_inputs};
    use splatseg_cues::{regions_from_sam_masks, MaskInput, RegionOptions};
    use splatseg_scene::sam::{write_sam_json, write_sam_png_folder, SamMask};
    use splatseg_synth::SynthConfig;

    /// The former path: every mask decoded to a full `[H, W]` boolean image, then scanned.
    fn decoded_inputs(masks: &[SamMask]) -> Vec<MaskInput> {
        masks
            .iter()
            .map(|m| {
                let plane = m.segmentation.decode().expect("valid synthetic mask");
                MaskInput::from_plane(&plane, m.predicted_iou as f32, m.stability_score as f32)
            })
            .collect()
    }

    fn scene() -> splatseg_synth::SynthScene {
        let config = SynthConfig { seed: 5, views: 3, width: 160, height: 120, ..SynthConfig::default() };
        splatseg_synth::generate(&config).expect("synthetic scene")
    }

    /// Runs built from the COCO counts equal those of the decoded masks, mask by mask, so the
    /// regions (and everything merged from them) are unchanged; also through both file forms.
    #[test]
    fn mask_inputs_from_counts_equal_the_decoded_masks_on_synthetic_views() {
        let scene = scene();
        let tmp = tempfile::tempdir().expect("temp dir");
        let mut masks_seen = 0;
        for (v, view) in scene.views.iter().enumerate() {
            let (w, h) = (160, 120);
            let before = decoded_inputs(&view.sam_masks);
            let after = mask_inputs(&view.sam_masks, w, h).expect("valid masks");
            assert_eq!(after.len(), view.sam_masks.len());
            for (i, (a, b)) in after.iter().zip(&before).enumerate() {
                assert_eq!(a, b, "mask {i} of {}", view.stem);
            }
            masks_seen += after.len();
            let options = RegionOptions::default();
            let regions_before = regions_from_sam_masks(&before, w, h, &options).expect("regions");
            let regions_after = regions_from_sam_masks(&after, w, h, &options).expect("regions");
            assert!(regions_before.count() > 1, "{}: a real partition", view.stem);
            assert_eq!(regions_after.labels.data, regions_before.labels.data, "{}", view.stem);
            // Read back from SAM JSON (even views) or a SAM PNG folder (odd views).
            if v % 2 == 0 {
                write_sam_json(&tmp.path().join(format!("{}.json", view.stem)), &view.sam_masks)
                    .expect("json");
            } else {
                write_sam_png_folder(&tmp.path().join(&view.stem), &view.sam_masks).expect("png folder");
            }
            let read = read_view_mask_inputs(tmp.path(), &view.stem, w, h).expect("readable");
            assert_eq!(
                read.map(|r| r.masks).as_deref(),
                Some(&before[..]),
                "{} read from its files",
                view.stem
            );
        }
        assert!(masks_seen >= 20, "only {masks_seen} masks: the comparison would prove little");
        assert_eq!(read_view_mask_inputs(tmp.path(), "no_such_view", 160, 120).expect("no error"), None);
    }

    /// A mask PNG of another size than the image is refused with an error naming that PNG (not
    /// `<stem>.json`); a JSON mask of another size names the JSON file.
    #[test]
    fn a_wrong_size_mask_names_its_own_file() {
        let scene = scene();
        let tmp = tempfile::tempdir().expect("temp dir");
        let view = &scene.views[0];
        let folder = tmp.path().join(&view.stem);
        write_sam_png_folder(&folder, &view.sam_masks).expect("png folder");
        let bad = folder.join("2.png");
        splatseg_scene::image_io::write_png_luma8(&bad, &splatseg_scene::Plane::filled(80, 60, 0))
            .expect("small png");
        let err = read_view_mask_inputs(tmp.path(), &view.stem, 160, 120).unwrap_err().report();
        assert!(err.contains(&bad.display().to_string()), "{err}");
        assert!(err.contains("80") && err.contains("160"), "both sizes: {err}");
        assert!(!err.contains(".json"), "{err}");

        let json = tmp.path().join("other.json");
        write_sam_json(&json, &view.sam_masks).expect("json");
        let err = read_view_mask_inputs(tmp.path(), "other", 160, 121).unwrap_err().report();
        assert!(err.contains(&json.display().to_string()), "{err}");
    }
}
