//! The merge of one view from its cues in memory: the step `run` and `splatseg merge` take for
//! every view they merge (after reading the view's files, [`crate::merge_stage::merge_one`]), and
//! the one a binding calls on arrays it holds (`splatseg.merge_view` in Python).

use crate::error::{bail, Context};
use splatseg_cues::{DepthMap, DescriptorSource, Intrinsics, MaskInput, RegionOptions, RegionSource};
use splatseg_merge::{
    build_view_inputs, merge_view_with_wholes, CueRequest, MergeConfig, MergeLog, RegionSummary, ViewWholes,
};
use splatseg_scene::Plane;

/// One view's cues, held in memory.
#[derive(Clone, Copy)]
pub struct ViewArrays<'a> {
    /// The view's name: in error messages, and the key a per-view descriptor source looks up
    /// (e.g. [`splatseg_cues::FeatureGrids::InMemory`]).
    pub stem: &'a str,
    /// `[H, W, 3]` 8-bit RGB, row-major (`H · W · 3` bytes).
    pub rgb: &'a [u8],
    /// Image width `W`, px.
    pub width: usize,
    /// Image height `H`, px.
    pub height: usize,
    /// `[K]` SAM masks over the `W × H` image ([`crate::mask_inputs`], [`MaskInput::from_row_major`]).
    pub masks: &'a [MaskInput],
    /// `[H, W]` depth for the normalised gate, the affinity and `∇D`
    /// ([`DepthMap::at_image_size`] for a map of another size).
    pub depth: &'a DepthMap,
    /// `[H, W]` metric z for the crease gate, when known (`run` renders it
    /// from the Gaussians); `None`: `depth` when it is metric.
    pub metric: Option<&'a Plane<f32>>,
    /// `[H, W]` camera-space unit normals of that surface facing the camera (NaN = none), when
    /// known (`run` renders them from the Gaussians): the crease gate reads them.
    pub normals: Option<&'a Plane<[f32; 3]>>,
    /// Where the regions' descriptors come from (dense features or the colour/texture fallback).
    pub descriptors: &'a dyn DescriptorSource,
    /// `[merge]` settings.
    pub config: &'a MergeConfig,
    /// How masks become regions (`PipelineConfig::regions`).
    pub region_options: RegionOptions,
    /// Pinhole intrinsics of the `W × H` image: with metric depth they turn on the crease gate.
    pub intrinsics: Option<Intrinsics>,
}

/// What the merge of one view made.
#[derive(Clone, Debug)]
pub struct ViewMerge {
    /// `[H, W]` SAM masks resolved into regions, 0 = none (the "raw" baseline).
    pub raw: Plane<u32>,
    /// `[H, W]` merged regions, 0 = none, local ids `1..=regions.len()`.
    pub merged: Plane<u32>,
    /// `[k]` merged regions (descriptor, area, …), `regions[i].id == i + 1`.
    pub regions: Vec<RegionSummary>,
    /// `[n]` input regions (SAM masks after overlaps were resolved), index = raw label − 1.
    pub input_regions: Vec<RegionSource>,
    /// Every decision of the merge, and the final id of each input region.
    pub log: MergeLog,
}

/// Merges one view's SAM masks with its cues (Multi-Cue-Guided Mask Merging, paper §4.2): the
/// masks become regions, the cues are computed (descriptors, normalised depth, `∇D`, LoG
/// edges) and the regions merged. Errors name the view.
pub fn merge_view_arrays(view: &ViewArrays) -> crate::Result<ViewMerge> {
    merge_view_arrays_with_wholes(view, None)
}

/// [`merge_view_arrays`] with the other views' SAM masks through the Gaussians this view sees
/// (the merge's separate-wholes gate, [`splatseg_merge::wholes`]).
pub fn merge_view_arrays_with_wholes(
    view: &ViewArrays,
    wholes: Option<&ViewWholes>,
) -> crate::Result<ViewMerge> {
    let (w, h) = (view.width, view.height);
    if view.rgb.len() != w * h * 3 {
        bail!("image of view `{}` holds {} bytes, expected {h}×{w}×3", view.stem, view.rgb.len());
    }
    let rgb = Plane {
        width: w,
        height: h,
        data: view.rgb.chunks_exact(3).map(|p| [0, 1, 2].map(|c| p[c] as f32 / 255.0)).collect(),
    };
    let inputs = build_view_inputs(&CueRequest {
        stem: view.stem,
        rgb: &rgb,
        masks: view.masks,
        depth: view.depth,
        metric_depth: view.metric,
        normals: view.normals,
        descriptors: view.descriptors,
        region_options: view.region_options,
        intrinsics: view.intrinsics,
    })
    .with_context(|| format!("preparing the merge cues of view `{}`", view.stem))?;
    let result = merge_view_with_wholes(&inputs, view.config, wholes)
        .with_context(|| format!("merging view `{}`", view.stem))?;
    Ok(ViewMerge {
        raw: inputs.regions.labels,
        merged: result.labels,
        regions: result.regions,
        input_regions: inputs.regions.sources,
        log: result.log,
    })
}
