//! The stages on the Gaussians: surface depth and visibility per view, cross-view matching
//! (with 3D evidence) and lifting with render-back.

use super::merge_stage::MergedView;
use super::progress;
use indicatif::ParallelProgressIterator;
use rayon::prelude::*;
use splatseg_lift::{
    drop_small_objects, join_touching_objects, lift_labels, render_label_map, render_votes, renumber,
    snap_to_regions, view_surface_depth, view_visibility, FinalMaps, LiftConfig, Lifted, ObjectFeatures,
    PosedCamera, PreparedGaussians, ViewVisibility,
};
use splatseg_match::{match_masks, MatchConfig, MatchInput, Matching, ViewMasks, ViewObservations};
use splatseg_scene::Plane;

/// Surface depth of every view from the Gaussians (`[n_views]`, each `[H, W]` metric z).
pub fn surface_depths(
    prepared: &PreparedGaussians,
    cams: &[PosedCamera],
    config: &LiftConfig,
) -> Vec<Plane<f32>> {
    let bar = progress(cams.len(), "depth from Gaussians");
    let out = cams
        .par_iter()
        .progress_with(bar.clone())
        .map(|c| view_surface_depth(prepared, c.camera, c.world_from_cam, config))
        .collect();
    bar.finish_and_clear();
    out
}

/// Visibility of every view against its surface depth.
pub fn visibilities(
    prepared: &PreparedGaussians,
    cams: &[PosedCamera],
    depths: &[Plane<f32>],
    config: &LiftConfig,
) -> Vec<ViewVisibility> {
    let bar = progress(cams.len(), "visibility");
    let out = cams
        .par_iter()
        .zip(depths)
        .progress_with(bar.clone())
        .map(|(c, d)| view_visibility(prepared, c.camera, c.world_from_cam, Some(d), config))
        .collect();
    bar.finish_and_clear();
    out
}

/// Matches the merged masks of all views. Views without masks (`None`) take no part.
/// `visibility`: per view, when Gaussians are available.
pub fn match_views(
    merged: &[Option<MergedView>],
    visibility: Option<&[ViewVisibility]>,
    config: &MatchConfig,
) -> crate::Result<Matching> {
    let dim = merged
        .iter()
        .flatten()
        .flat_map(|m| m.regions.first())
        .map(|r| r.descriptor.len())
        .next()
        .unwrap_or(0);
    let views = merged
        .iter()
        .map(|m| match m {
            Some(m) => ViewMasks {
                features: m.regions.iter().flat_map(|r| r.descriptor.iter().copied()).collect(),
                areas_px: m.regions.iter().map(|r| r.area).collect(),
            },
            None => ViewMasks::default(),
        })
        .collect();
    let observations = visibility.map(|vis| {
        vis.iter()
            .zip(merged)
            .map(|(v, m)| match m {
                Some(m) => ViewObservations {
                    gaussians: v.gaussians.clone(),
                    labels: v.pixels.iter().map(|&p| m.merged.data[p as usize]).collect(),
                },
                None => ViewObservations::default(),
            })
            .collect()
    });
    Ok(match_masks(&MatchInput { dim, views, observations }, config)?)
}

/// Per view, the merged labels mapped to global ids (`None` for views without masks).
pub fn matched_maps(merged: &[Option<MergedView>], matching: &Matching) -> Vec<Option<Plane<u32>>> {
    merged
        .iter()
        .zip(&matching.global_of_label)
        .map(|(m, table)| m.as_ref().map(|m| m.merged.map(|&l| table.get(l as usize).copied().unwrap_or(0))))
        .collect()
}

/// What lifting produced.
pub struct LiftOutput {
    /// Per-Gaussian results (ids renumbered to match `maps`).
    pub lifted: Lifted,
    /// `[n_views]` label maps rendered back from the labelled Gaussians (snapped onto the
    /// merged regions with `final_maps = "snapped"`), final ids.
    pub maps: Vec<Plane<u32>>,
}

/// Lifts the matched maps of the views with masks onto the Gaussians, renders every view back
/// (snapping the rendered ids onto the merged regions with `final_maps = "snapped"`), drops
/// specks and renumbers the ids by first appearance.
pub fn lift_and_render(
    prepared: &PreparedGaussians,
    cams: &[PosedCamera],
    visibility: &[ViewVisibility],
    merged: &[Option<MergedView>],
    matched: &[Option<Plane<u32>>],
    matching: &Matching,
    config: &LiftConfig,
) -> crate::Result<LiftOutput> {
    let (vis, maps): (Vec<ViewVisibility>, Vec<Plane<u32>>) = visibility
        .iter()
        .zip(matched)
        .filter_map(|(v, m)| m.as_ref().map(|m| (v.clone(), m.clone())))
        .unzip();
    let features = ObjectFeatures { dim: matching.dim, values: &matching.object_features };
    let mut lifted = lift_labels(prepared.len(), &vis, &maps, features, config)?;
    let local: Vec<(&ViewVisibility, &Plane<u32>)> =
        visibility.iter().zip(merged).filter_map(|(v, m)| m.as_ref().map(|m| (v, &m.merged))).collect();
    let joins = join_touching_objects(prepared, &mut lifted, features, &local, config);
    tracing::info!("joined {joins} pairs of touching look-alike objects");
    let votes = render_votes(&lifted, config);
    let bar = progress(cams.len(), "render label maps");
    let mut back: Vec<Plane<u32>> = cams
        .par_iter()
        .progress_with(bar.clone())
        .map(|c| render_label_map(prepared, &votes, c.camera, c.world_from_cam, config))
        .collect();
    bar.finish_and_clear();
    if config.final_maps == FinalMaps::Snapped {
        for (map, m) in back.iter_mut().zip(merged) {
            if let Some(m) = m {
                *map = snap_to_regions(&m.merged, map);
            }
        }
    }
    let specks = drop_small_objects(&mut back, &mut lifted.object_ids, config.min_object_px);
    tracing::info!("dropped {specks} speck objects under {} px", config.min_object_px);
    renumber(&mut back, &mut lifted.object_ids);
    Ok(LiftOutput { lifted, maps: back })
}
