//! The global stages on compact per-view results: cross-view matching (with 3D evidence), and
//! the lift stage's access to the views ([`SpilledViews`]; the stage itself is
//! `splatseg_lift::LiftStage`).
//!
//! No stage here holds an `[H, W]` map per view, nor every view's visible Gaussians: each view
//! keeps its region descriptors and a bounded sample of its visible Gaussians with their merged
//! labels for matching ([`ViewResult`], [`crate::visible::sample_stride`]); its full list is
//! spilled to `OUT/cache/visible/` by the per-view pass and read back one view at a time, in view
//! order, to accumulate the votes and the touching-objects counts, its tile lists once to render
//! its labels back.

use crate::error::{bail, PipelineError};
use crate::merge_stage::MergeContext;
use crate::profile::PartTimes;
use crate::view_data::{self, ViewData};
use crate::visible;
use crate::RunConfig;
use indicatif::ProgressBar;
use rayon::prelude::*;
use splatseg_lift::{
    LiftError, LiftOutput, LiftStage, MatchedViews, ObjectFeatures, PosedCamera, PreparedGaussians,
    ViewRegions, ViewStore, VisibleGaussians,
};
use splatseg_match::{match_masks_owned, MatchConfig, MatchInput, Matching, ViewMasks, ViewObservations};
use splatseg_merge::RegionSummary;
use splatseg_render::bin::TileBins;
use std::path::{Path, PathBuf};

/// What the global stages keep of one view with masks.
#[derive(Clone, Debug)]
pub struct ViewResult {
    /// `[k]` merged regions (descriptor, area, …), `regions[i].id == i + 1`; moved into the matcher
    /// by [`match_views`].
    pub regions: Vec<RegionSummary>,
    /// Largest raw (SAM region) label of the view.
    pub raw_max: u32,
    /// Largest merged label of the view.
    pub merged_max: u32,
    /// True when the merge came from the cache.
    pub cached: bool,
    /// SAM masks of the view that are empty (all zeros) ([`crate::merge_stage::MergedView::empty_masks`]).
    pub empty_masks: usize,
    /// SAM masks of the view whose file `area` / `bbox` disagreed with the mask
    /// ([`crate::merge_stage::MergedView::recomputed_masks`]).
    pub recomputed_masks: usize,
    /// With Gaussians: the sampled visible Gaussians and their merged labels (matching's 3D
    /// evidence; moved into the matcher).
    pub observations: Option<ViewObservations>,
    /// With Gaussians: the file holding every visible Gaussian ([`crate::visible`]).
    pub spill: Option<PathBuf>,
    /// The file holding the view's image and raw and merged maps ([`crate::view_data`]).
    pub data: PathBuf,
}

impl ViewResult {
    /// The view's image and raw and merged maps, as the per-view pass decoded them.
    pub fn data(&self) -> crate::Result<ViewData> {
        view_data::read_spill(&self.data)
    }
}

/// Matches the merged masks of all views. Views without masks (`None`) take no part; with
/// `with_3d`, the sampled Gaussians each mask sees are the 3D evidence. The regions' descriptors
/// and the observations are moved into the matcher (and dropped there once used), not copied;
/// `views[_].regions` are empty afterwards.
pub fn match_views(
    views: &mut [Option<ViewResult>],
    with_3d: bool,
    config: &MatchConfig,
) -> crate::Result<Matching> {
    let dim = views
        .iter()
        .flatten()
        .flat_map(|m| m.regions.first())
        .map(|r| r.descriptor.len())
        .next()
        .unwrap_or(0);
    let masks = views
        .iter_mut()
        .map(|m| match m {
            Some(m) => {
                let regions = std::mem::take(&mut m.regions);
                // `[n_masks, dim]`, allocated once at its size (no growth slack held while matching).
                let mut features = Vec::with_capacity(regions.len() * dim);
                for r in &regions {
                    features.extend_from_slice(&r.descriptor);
                }
                ViewMasks { features, areas_px: regions.iter().map(|r| r.area).collect() }
            }
            None => ViewMasks::default(),
        })
        .collect();
    let observations = with_3d.then(|| {
        views.iter_mut().map(|m| m.as_mut().and_then(|m| m.observations.take()).unwrap_or_default()).collect()
    });
    let input = MatchInput { dim, views: masks, observations };
    Ok(match_masks_owned(input, config)?)
}

/// An error naming the first view whose region descriptors are not as long as the first view's
/// (`views`: `[n_views]`, `stems` their image stems): feature files of different channel counts,
/// e.g. from two models, reach here as descriptors of different lengths. `features`: the
/// `--features` folder, named in the message.
pub fn check_descriptor_lengths(
    views: &[Option<ViewResult>],
    stems: &[&str],
    features: Option<&Path>,
) -> crate::Result<()> {
    let mut first: Option<(usize, usize)> = None;
    for (v, view) in views.iter().enumerate() {
        let Some(len) = view.as_ref().and_then(|m| m.regions.first()).map(|r| r.descriptor.len()) else {
            continue;
        };
        match first {
            None => first = Some((v, len)),
            Some((f, expected)) if len != expected => {
                let source = features.map_or_else(
                    || "the model-free descriptors".to_string(),
                    |dir| format!("the features in {}", dir.display()),
                );
                bail!(
                    "view `{}` has region descriptors of {len} values where view `{}` has {expected}: \
                     {source} must have one channel count for every view (one model, one layer)",
                    stems[v],
                    stems[f]
                );
            }
            Some(_) => {}
        }
    }
    Ok(())
}

/// The lift stage on `run`'s per-view results (views with masks vote and are snapped; every
/// view is rendered back): the Gaussians labelled and every view's final map. With model-free
/// descriptors (no `features`), the lift settings for them. `ctx.wholes`: the separate-wholes
/// evidence, which vetoes touching joins (`None`: the gate is off).
pub fn lift_views(
    prepared: &PreparedGaussians,
    cams: &[PosedCamera],
    views: &[Option<ViewResult>],
    matching: &Matching,
    ctx: &MergeContext,
    config: &RunConfig,
    times: &PartTimes,
) -> crate::Result<LiftOutput> {
    let lift = &config.pipeline.lift;
    let scene = ctx.scene;
    let snap_kind = lift.final_maps.snapped_onto().unwrap_or("merged");
    // A view with masks: its spill from the per-view pass (decoded there once); a view without
    // them (rendered and refined, never snapped) has its image decoded here.
    let spilled = |v: usize| views.get(v).and_then(|m| m.as_ref());
    let regions = |v: usize| -> crate::Result<ViewRegions> {
        match spilled(v) {
            Some(m) => m.data()?.into_regions(snap_kind),
            None => bail!("view {v} has no masks to snap onto"),
        }
    };
    let image_rgb = |v: usize| -> crate::Result<Vec<u8>> {
        match spilled(v) {
            Some(m) => Ok(m.data()?.rgb),
            None => {
                Ok(splatseg_scene::images::load_image_rgb(scene, &scene.views[v], ctx.load_options)?.data)
            }
        }
    };
    let store = SpilledViews {
        views,
        regions: &regions,
        image_rgb: &image_rgb,
        times,
        bar: crate::progress(cams.len(), "render label maps", config.options),
    };
    let matched = MatchedViews {
        global_of_label: views
            .iter()
            .zip(&matching.global_of_label)
            .map(|(m, t)| m.as_ref().map(|_| &t[..]))
            .collect(),
        objects: ObjectFeatures { dim: matching.dim, values: &matching.object_features },
    };
    let wholes = ctx.wholes.map(ObjectWholes);
    let stage = LiftStage {
        gaussians: prepared,
        cams,
        matched,
        config: lift,
        wholes: wholes.as_ref().map(|w| w as &dyn splatseg_lift::SeparateWholes),
    };
    let output = stage.run(&store)?;
    store.bar.finish_and_clear();
    Ok(output)
}

/// The merge's separate-wholes evidence, asked about two objects' Gaussians (the touching joins'
/// veto, [`splatseg_lift::SeparateWholes`]).
struct ObjectWholes<'a>(&'a splatseg_merge::WholesEvidence);

impl splatseg_lift::SeparateWholes for ObjectWholes<'_> {
    fn separate(&self, a: &[u32], b: &[u32]) -> bool {
        self.0.count_gaussians([a, b]).separate()
    }

    fn count_pairs(&self, sets: &[&[u32]], pairs: &[(usize, usize)]) -> Vec<splatseg_lift::SamViews> {
        let observed: Vec<splatseg_merge::Observed> = sets.par_iter().map(|s| self.0.observe(s)).collect();
        pairs
            .par_iter()
            .map(|&(a, b)| {
                let c = self.0.count_observed([&observed[a], &observed[b]]);
                splatseg_lift::SamViews { together: c.together, apart: c.apart, seen: c.seen }
            })
            .collect()
    }
}

/// The lift stage's [`ViewStore`] over `run`'s per-view results: the visible Gaussians and tile
/// lists spilled by the per-view pass ([`crate::visible`]), the region maps in the merge cache
/// and the images, each read when the stage asks for it.
pub struct SpilledViews<'a> {
    /// `[n_views]` per-view results (`None`: no masks).
    pub views: &'a [Option<ViewResult>],
    /// The regions of view `v` to snap onto and its merged regions.
    pub regions: &'a (dyn Fn(usize) -> crate::Result<ViewRegions> + Sync),
    /// `[H, W, 3]` 8-bit row-major colours of view `v`'s image.
    pub image_rgb: &'a (dyn Fn(usize) -> crate::Result<Vec<u8>> + Sync),
    /// Thread time of the stage's parts.
    pub times: &'a PartTimes,
    /// Progress over the views rendered back.
    pub bar: ProgressBar,
}

impl SpilledViews<'_> {
    /// The spill file of view `v`; an error for a view the per-view pass did not spill.
    fn spill(&self, v: usize) -> crate::Result<&Path> {
        match self.views.get(v).and_then(|m| m.as_ref()).and_then(|m| m.spill.as_deref()) {
            Some(path) => Ok(path),
            None => bail!("view {v} has no visible Gaussians spilled"),
        }
    }

    /// The tile lists' file of view `v`, when the per-view pass kept them.
    fn bins(&self, v: usize) -> Option<PathBuf> {
        let spill = self.views.get(v)?.as_ref()?.spill.as_deref()?;
        Some(visible::bins_path(spill)).filter(|p| p.is_file())
    }
}

impl ViewStore for SpilledViews<'_> {
    type Error = PipelineError;

    fn visible(&self, v: usize) -> crate::Result<VisibleGaussians> {
        visible::read(self.spill(v)?)
    }

    fn tile_lists(&self, v: usize) -> crate::Result<Option<TileBins>> {
        self.bins(v).map(|p| visible::read_bins(&p)).transpose()
    }

    fn regions(&self, v: usize) -> crate::Result<ViewRegions> {
        (self.regions)(v)
    }

    fn image_rgb(&self, v: usize) -> crate::Result<Vec<u8>> {
        (self.image_rgb)(v)
    }

    fn unfit_tile_lists(&self, v: usize, error: LiftError) -> PipelineError {
        let path = self.bins(v).unwrap_or_default();
        PipelineError::Context {
            context: format!("rendering the labels back with {}", path.display()),
            source: Box::new(error.into()),
        }
    }

    fn time<T>(&self, part: &'static str, f: impl FnOnce() -> T) -> T {
        self.times.time(part, f)
    }

    fn view_rendered(&self) {
        self.bar.inc(1);
    }
}
