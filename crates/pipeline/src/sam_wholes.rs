//! The other views' SAM masks, through the Gaussians, for the merge's separate-wholes gate
//! ([`splatseg_merge::wholes`]): before any view is merged, one visibility pass over every view
//! with masks records which of its masks (all of them, overlapping: parts and wholes) hold each
//! sampled visible Gaussian's centre pixel. The merge of a view then asks, for a pair of its
//! regions, what the other views' masks say about the Gaussians either side of their contact,
//! and the lift stage asks it about two touching objects before joining them
//! ([`splatseg_lift::SeparateWholes`]); the evidence lives until the lift stage is done.
//!
//! This pass is each view's visibility pass, made before the merges rather than in them (the
//! merge of a view needs the other views' evidence, so every view's pass comes first): what the
//! merge of each view the caller merges next reads of it is spilled to `OUT/cache/visible/`
//! ([`crate::visible::write_pass`]) and read back instead of projecting the Gaussians again, and
//! for `run` its tile lists go straight to the file rendering the labels back reads
//! ([`crate::visible::write_bins`]): a view's visibility is computed once per run, and each part
//! of it written once.

use crate::cache::KeyHasher;
use crate::merge_stage::MergeContext;
use crate::per_view::MergeSources;
use crate::profile::PartTimes;
use crate::{read_view_mask_inputs, RunOptions};
use rayon::prelude::*;
use splatseg_lift::{view_visibility, LiftConfig, PreparedGaussians};
use splatseg_merge::{ViewMaskSets, WholesEvidence};
use splatseg_scene::Scene;
use std::path::Path;

/// The part of every view's merge key that the gate's evidence adds: every view's masks (the
/// Gaussians and the visibility settings are in the depth key already) and the sampling stride.
/// Empty when the gate is off.
pub fn wholes_key(scene: &Scene, masks_dir: &Path, has_masks: &[bool], stride: u32) -> crate::Result<String> {
    let mut h = KeyHasher::default();
    h.text("sam-wholes-v1").text(&stride.to_string());
    for (view, _) in scene.views.iter().zip(has_masks).filter(|(_, &m)| m) {
        h.text(&view.stem).folder_entry(masks_dir, &view.stem)?;
    }
    Ok(h.finish())
}

/// What [`wholes_evidence`] reads.
pub struct WholesRequest<'a> {
    /// The scene (cameras, views).
    pub scene: &'a Scene,
    /// Its Gaussians.
    pub prepared: &'a PreparedGaussians,
    /// The SAM masks folder.
    pub masks_dir: &'a Path,
    /// `[n_views]` which views have masks.
    pub has_masks: &'a [bool],
    /// Visibility settings (as the per-view pass).
    pub lift: &'a LiftConfig,
    /// Every `stride`-th Gaussian is kept ([`crate::visible::sample_stride`]).
    pub stride: u32,
    /// The output folder, whose `cache/visible/` receives the spilled passes.
    pub out: &'a Path,
    /// The lift stage follows (`run`): the spilled views' tile lists are written to their file
    /// beside the visible Gaussians ([`crate::visible::bins_path`]); without it they are dropped.
    pub for_lift: bool,
    /// Thread time of the pass's parts.
    pub times: Option<&'a PartTimes>,
}

/// What [`prepare`] gives the merges.
pub struct Wholes {
    /// The gate's part of every view's merge key ([`wholes_key`]).
    pub key: String,
    /// The evidence, when a view to merge was not in the cache.
    pub evidence: Option<WholesEvidence>,
    /// `[n_views]` the views whose visibility pass was spilled to `OUT/cache/visible/` for their
    /// merge to read back ([`crate::visible::pass_or`]).
    pub spilled: Vec<bool>,
}

impl Wholes {
    /// The gate off (or no Gaussians): no key, no evidence, no spilled pass, for `n_views` views.
    pub fn off(n_views: usize) -> Self {
        Wholes { key: String::new(), evidence: None, spilled: vec![false; n_views] }
    }
}

/// Every view's mask sets at its sampled visible Gaussians, grouped by Gaussian; a view without
/// masks contributes nothing. One visibility pass per view (the one its merge needs), views in
/// parallel, with a progress bar; the passes of the views of `spill` (`[n_views]`) are spilled.
pub fn wholes_evidence(
    request: &WholesRequest,
    spill: &[bool],
    options: RunOptions,
) -> crate::Result<WholesEvidence> {
    let WholesRequest { scene, prepared, masks_dir, has_masks, lift, stride, out, for_lift, times } =
        *request;
    let own = PartTimes::default();
    let times = times.unwrap_or(&own);
    let bar = crate::progress(scene.views.len(), "visibility, SAM masks", options);
    let views: Vec<crate::Result<ViewMaskSets>> = (0..scene.views.len())
        .into_par_iter()
        .map(|v| {
            let view = &scene.views[v];
            let sets = if has_masks[v] {
                let camera = scene.camera(view);
                let (w, h) = (camera.width as usize, camera.height as usize);
                // The merge's own read of the masks reports what was recomputed, once per run.
                let masks = times
                    .time("read the SAM masks", || read_view_mask_inputs(masks_dir, &view.stem, w, h))?;
                let masks = masks.unwrap_or_default().masks;
                let pass = times.time("surface depth and visibility", || {
                    view_visibility(prepared, camera, &view.world_from_cam, None, lift)
                });
                let sets = times.time("mask sets of the sampled Gaussians", || {
                    ViewMaskSets::new(&masks, &pass.visible.gaussians, &pass.visible.pixels, stride)
                });
                if spill[v] {
                    times.time("spill the pass and tile lists", || -> crate::Result<()> {
                        crate::visible::write_pass(&crate::visible::pass_path(out, &view.stem), &pass)?;
                        if for_lift {
                            let spill = crate::visible::spill_path(out, &view.stem);
                            crate::visible::write_bins(&crate::visible::bins_path(&spill), &pass.tile_lists)?;
                        }
                        Ok(())
                    })?;
                }
                sets
            } else {
                ViewMaskSets::default()
            };
            bar.inc(1);
            Ok(sets)
        })
        .collect();
    bar.finish_and_clear();
    let views = views.into_iter().collect::<crate::Result<Vec<_>>>()?;
    Ok(WholesEvidence::new(prepared.len(), stride, views))
}

/// The gate's key (for every view's merge key) and its evidence, which is built when the lift
/// stage follows (`request.for_lift`: it vetoes the touching joins with it) or a view of `check`
/// (`[n_views]`, the views this call will merge or pass over) is not in the cache: merges from the
/// cache or from shards already hold it in their keys. When it is built, the passes of the views
/// of `check` with masks are spilled. `probe`: the merges' context (without the gate), which checks
/// the cache.
pub fn prepare(
    request: &WholesRequest,
    sources: &MergeSources,
    mut probe: MergeContext,
    check: &[bool],
    options: RunOptions,
) -> crate::Result<Wholes> {
    let key = wholes_key(request.scene, request.masks_dir, request.has_masks, request.stride)?;
    probe.wholes_key = key.clone();
    let spilled: Vec<bool> = check.iter().zip(request.has_masks).map(|(&c, &m)| c && m).collect();
    if !request.for_lift && sources.all_cached(&probe, check, true)? {
        return Ok(Wholes { key, ..Wholes::off(spilled.len()) });
    }
    let evidence = wholes_evidence(request, &spilled, options)?;
    Ok(Wholes { key, evidence: Some(evidence), spilled })
}
