//! The per-view merge as `run` and `splatseg merge` (sharded or not, [`crate::merge_views`])
//! share it: one view's depth (from `--depth`, or the surface depth rendered from the Gaussians),
//! its cache key, and the merge itself.

use crate::cache::KeyHasher;
use crate::error::bail;
use crate::lift_stage::ViewResult;
use crate::merge_stage::{is_cached, merge_cached, merge_one, MergeContext, MergedView, ViewDepth};
use crate::profile::PartTimes;
use crate::shard::Shard;
use crate::view_data::{self, ViewImage};
use crate::{visible, RunConfig};
use splatseg_cues::{
    ColourTextureDescriptors, DenseFeatureDescriptors, DepthKind, DepthMap, DepthSource, DescriptorSource,
    FeatureGrids, NpyDepthSource,
};
use splatseg_lift::{view_visibility, LiftConfig, PosedCamera, PreparedGaussians, ViewVisibility};
use splatseg_merge::ViewWholes;
use splatseg_scene::load::LoadOptions;
use splatseg_scene::{Plane, Scene};
use std::path::Path;

/// The key of what rendered depth depends on (the PLY's contents and the surface settings), so
/// lift-only changes keep the merge cache; empty without a PLY.
pub fn ply_key(ply: Option<&Path>, _lift: &LiftConfig) -> crate::Result<String> {
    Ok(match ply {
        Some(p) => KeyHasher::default()
            .file(p)?
            .json(&(splatseg_lift::visibility::SURFACE_TRANSMITTANCE, splatseg_lift::project::NEAR_PLANE))
            .finish(),
        None => String::new(),
    })
}

/// `[H, W]` metric z with non-finite values (no surface) as 0.
pub fn finite_depth(z: &Plane<f32>) -> Plane<f32> {
    z.map(|&z| if z.is_finite() { z } else { 0.0 })
}

/// Where each view's descriptors and depth come from.
pub struct MergeSources {
    npy_depth: Option<NpyDepthSource>,
    dense: Option<DenseFeatureDescriptors>,
    ply_key: String,
}

impl MergeSources {
    /// The sources `config` names; `ply_key` from [`ply_key`].
    pub fn new(config: &RunConfig, ply_key: &str) -> Self {
        MergeSources {
            npy_depth: config.depth.as_ref().map(|dir| NpyDepthSource {
                dir: dir.clone(),
                kind: config.depth_kind,
                resize: config.resize_depth,
            }),
            dense: config
                .features
                .as_ref()
                .map(|dir| DenseFeatureDescriptors { grids: FeatureGrids::Folder(dir.clone()) }),
            ply_key: ply_key.to_string(),
        }
    }

    /// What every view's merge shares.
    pub fn context<'a>(
        &'a self,
        scene: &'a Scene,
        load: &'a LoadOptions,
        config: &'a RunConfig,
    ) -> MergeContext<'a> {
        let descriptors: &dyn DescriptorSource = match &self.dense {
            Some(d) => d,
            None => &ColourTextureDescriptors,
        };
        MergeContext {
            scene,
            load_options: load,
            masks_dir: &config.masks,
            features_dir: config.features.as_deref(),
            descriptors,
            config: &config.pipeline.merge,
            region_options: config.pipeline.regions,
            cache_dir: config.out.join("cache").join("merge"),
            keep_log: false,
            wholes: None,
            wholes_key: String::new(),
        }
    }

    /// [`ViewDepth::key`] of every view: from `--depth`, or rendered when `metric` (there are
    /// Gaussians); `None` without either.
    fn depth_key(&self, metric: bool) -> Option<String> {
        match (&self.npy_depth, metric) {
            (Some(src), _) => Some(format!("npy:{:?}:{}", src.kind, self.ply_key)),
            (None, true) => Some(format!("rendered:{}", self.ply_key)),
            (None, false) => None,
        }
    }

    /// True when the cache holds the merge of every view with masks (`has_masks: [n_views]`)
    /// made from the same inputs and settings; `metric`: depth is rendered from Gaussians.
    pub fn all_cached(&self, ctx: &MergeContext, has_masks: &[bool], metric: bool) -> crate::Result<bool> {
        let Some(key) = self.depth_key(metric) else { return Ok(false) };
        for (view, _) in ctx.scene.views.iter().zip(has_masks).filter(|(_, &m)| m) {
            if !is_cached(ctx, view, &key)? {
                return Ok(false);
            }
        }
        Ok(true)
    }

    /// The depth of view `v` for its merge, with its cache key; `metric`: `[H, W]` z rendered
    /// from the Gaussians, when there are some.
    fn depth(
        &self,
        ctx: &MergeContext,
        v: usize,
        metric: Option<&Plane<f32>>,
    ) -> crate::Result<(DepthMap, String)> {
        let view = &ctx.scene.views[v];
        let camera = ctx.scene.camera(view);
        let Some(key) = self.depth_key(metric.is_some()) else { bail!("no depth for view `{}`", view.stem) };
        Ok(match (&self.npy_depth, metric) {
            (Some(src), _) => (src.depth(&view.stem, camera.width as usize, camera.height as usize)?, key),
            (None, Some(m)) => (DepthMap { values: m.clone(), kind: DepthKind::MetricZ }, key),
            (None, None) => bail!("no depth for view `{}`", view.stem),
        })
    }

    /// Merges view `v` (or reads it from the cache); `image` is its image, decoded if needed;
    /// `visible`: the Gaussians it sees (for the separate-wholes gate, when `ctx` has its evidence).
    pub fn merge(
        &self,
        ctx: &MergeContext,
        v: usize,
        metric: Option<Plane<f32>>,
        normals: Option<Plane<[f32; 3]>>,
        visible: Option<&ViewVisibility>,
        image: &ViewImage,
    ) -> crate::Result<MergedView> {
        let (depth, key) = self.depth(ctx, v, metric.as_ref())?;
        let camera = ctx.scene.camera(&ctx.scene.views[v]);
        let size = (camera.width as usize, camera.height as usize);
        let wholes = ctx
            .wholes
            .zip(visible)
            .map(|(evidence, vis)| ViewWholes::new(evidence, v, (&vis.gaussians, &vis.pixels), size));
        let depth =
            ViewDepth { depth: &depth, metric: metric.as_ref(), normals: normals.as_ref(), key, wholes };
        merge_one(ctx, &ctx.scene.views[v], &depth, image)
    }

    /// The merge of view `v` that `shard` wrote; an error naming the shard when it is missing or
    /// was made from other inputs or settings.
    pub fn cached(
        &self,
        ctx: &MergeContext,
        v: usize,
        metric: Option<Plane<f32>>,
        shard: Shard,
    ) -> crate::Result<MergedView> {
        let (depth, key) = self.depth(ctx, v, metric.as_ref())?;
        let view = &ctx.scene.views[v];
        match merge_cached(
            ctx,
            view,
            &ViewDepth { depth: &depth, metric: metric.as_ref(), normals: None, key, wholes: None },
        )? {
            Some(hit) => Ok(hit),
            None => bail!(
                "view `{}` has no merge results from shard {shard} made with these inputs and settings: \
                 rerun `splatseg merge --shard {shard}` with the same arguments as this run: {}",
                view.stem,
                ctx.cache_dir.display()
            ),
        }
    }
}

/// What `run` does per view, one view at a time on each thread: surface depth from the
/// Gaussians and the visibility test against it (one projection, or the one the separate-wholes
/// gate's evidence pass spilled), the merge (computed, from the
/// cache, or — after `merge --shard` — from the shard that made it); only the compact [`ViewResult`] is kept, the merged maps stay in
/// `OUT/cache/merge/`, the visible Gaussians are spilled to `OUT/cache/visible/`.
pub struct PerView<'a> {
    /// The Gaussians, when there are some.
    pub prepared: Option<&'a PreparedGaussians>,
    /// `[n_views]` cameras.
    pub cams: &'a [PosedCamera<'a>],
    /// Depth and descriptor sources.
    pub sources: &'a MergeSources,
    /// What every view's merge shares.
    pub ctx: &'a MergeContext<'a>,
    /// The shard count, when the merges come from shards.
    pub sharded: Option<usize>,
    /// Lift settings (surface depth, visibility).
    pub lift: &'a LiftConfig,
    /// Output folder (the visible Gaussians are spilled to `OUT/cache/visible/`).
    pub out: &'a Path,
    /// Matching samples every `sample_stride`-th Gaussian ([`visible::sample_stride`]).
    pub sample_stride: u32,
    /// `[n_views]` the views whose visibility pass the gate's evidence spilled
    /// ([`crate::sam_wholes::Wholes::spilled`]).
    pub spilled: &'a [bool],
    /// Thread time of the parts of the per-view pass.
    pub times: &'a PartTimes,
}

impl PerView<'_> {
    /// The compact result of view `v` (which has masks).
    pub fn result(&self, v: usize) -> crate::Result<ViewResult> {
        let c = &self.cams[v];
        let view = &self.ctx.scene.views[v];
        // One projection of the Gaussians: the surface depth and the visibility test against it.
        let (depth, normals, visibility, bins) = match self.prepared {
            Some(p) => {
                let pass = self.times.time("surface depth and visibility", || {
                    visible::pass_or(self.out, &view.stem, self.spilled[v], || {
                        view_visibility(p, c.camera, c.world_from_cam, None, self.lift)
                    })
                })?;
                (pass.surface_depth, pass.surface_normals, Some(pass.visible), pass.tile_lists)
            }
            None => (None, None, None, None),
        };
        let metric = depth.as_ref().map(finite_depth);
        drop(depth);
        // The view's image, decoded once for this run: the merge, the lift stage and the outputs
        // all take it from here (the latter two from the view's spill).
        let image = ViewImage::new(self.ctx.scene, view, self.ctx.load_options);
        self.times.time("decode the image", || image.rgb().map(|_| ()))?;
        let merged =
            self.times.time("merge (inputs, cues, merging; or the cache)", || match self.sharded {
                Some(count) => self.sources.cached(self.ctx, v, metric, Shard { index: v % count, count }),
                None => self.sources.merge(self.ctx, v, metric, normals, visibility.as_ref(), &image),
            })?;
        let data = view_data::spill_path(self.out, &view.stem);
        self.times.time("spill the view's image and maps", || {
            view_data::write_spill(&data, &image.rgb()?.data, &merged.raw, &merged.merged)
        })?;
        drop(image);
        // Every visible Gaussian to disk, a bounded sample of them kept for matching.
        let (observations, spill) = match visibility {
            Some(vis) => {
                let labels: Vec<u32> = vis.pixels.iter().map(|&p| merged.merged.data[p as usize]).collect();
                let path = visible::spill_path(self.out, &view.stem);
                self.times.time("spill the visible Gaussians", || -> crate::Result<()> {
                    visible::write(&path, &vis, &labels)?;
                    // The tile lists too, unless the evidence pass wrote them: rendering the
                    // labels back reuses them.
                    match &bins {
                        Some(bins) => visible::write_bins(&visible::bins_path(&path), bins),
                        None => Ok(()),
                    }
                })?;
                (Some(visible::sampled(&vis, &labels, self.sample_stride)), Some(path))
            }
            None => (None, None),
        };
        Ok(ViewResult {
            raw_max: merged.raw.data.iter().copied().max().unwrap_or(0),
            merged_max: merged.merged.data.iter().copied().max().unwrap_or(0),
            regions: merged.regions,
            cached: merged.cached,
            empty_masks: merged.empty_masks,
            recomputed_masks: merged.recomputed_masks,
            observations,
            spill,
            data,
        })
    }
}
