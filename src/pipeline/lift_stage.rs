//! The stages on the Gaussians: surface depth per view, each view's contributions (which
//! Gaussians render into which merged mask, by `α·T`), cross-view matching (with that 3D
//! evidence) and lifting with render-back.

use super::merge_stage::MergedView;
use super::progress;
use indicatif::ParallelProgressIterator;
use rayon::prelude::*;
use splatseg_lift::{
    covote_joins, drop_small_objects, lift_labels, render_label_map, render_votes, renumber, seen_apart,
    snap_to_regions, touching_joins, view_contributions, view_surface_depth, DominantLabel, FinalMaps,
    LiftConfig, LiftView, Lifted, ObjectFeatures, PosedCamera, PreparedGaussians, ViewContributions,
};
use splatseg_match::{match_masks, MatchConfig, MatchInput, Matching, ViewMasks, ViewObservations};
use splatseg_scene::Plane;

/// Surface depth of every view from the Gaussians (`[n_views]`, each `[H, W]` metric z).
pub fn surface_depths(
    prepared: &PreparedGaussians,
    cams: &[PosedCamera],
    config: &LiftConfig,
) -> anyhow::Result<Vec<Plane<f32>>> {
    let bar = progress(cams.len(), "depth from Gaussians");
    let out = cams
        .par_iter()
        .progress_with(bar.clone())
        .map(|c| view_surface_depth(prepared, c.camera, c.world_from_cam, config))
        .collect::<Result<_, _>>()?;
    bar.finish_and_clear();
    Ok(out)
}

/// Every view's contributions to its merged masks (empty for views without masks).
pub fn contributions(
    prepared: &PreparedGaussians,
    cams: &[PosedCamera],
    merged: &[Option<MergedView>],
    config: &LiftConfig,
) -> anyhow::Result<Vec<ViewContributions>> {
    let bar = progress(cams.len(), "contributions");
    let out = cams
        .par_iter()
        .zip(merged)
        .progress_with(bar.clone())
        .map(|(c, m)| match m {
            Some(m) => view_contributions(prepared, c.camera, c.world_from_cam, &m.merged, config),
            None => Ok(ViewContributions::default()),
        })
        .collect::<Result<_, _>>()?;
    bar.finish_and_clear();
    Ok(out)
}

/// Per view, the merged mask each Gaussian the view sees contributes most to.
pub fn dominant_labels(contributions: &[ViewContributions], config: &LiftConfig) -> Vec<Vec<DominantLabel>> {
    contributions.par_iter().map(|c| c.dominant(config)).collect()
}

/// Matches the merged masks of all views. Views without masks (`None`) take no part.
/// `seen`: per view, [`dominant_labels`], when Gaussians are available.
pub fn match_views(
    merged: &[Option<MergedView>],
    seen: Option<&[Vec<DominantLabel>]>,
    config: &MatchConfig,
) -> anyhow::Result<Matching> {
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
    let observations = seen.map(|seen| {
        seen.iter()
            .zip(merged)
            .map(|(s, m)| match m {
                Some(_) => ViewObservations {
                    gaussians: s.iter().map(|d| d.gaussian).collect(),
                    labels: s.iter().map(|d| d.label).collect(),
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

/// Lifts the matched ids of the views with masks onto the Gaussians by their contributions,
/// renders every view back (snapping the rendered ids onto the merged regions with
/// `final_maps = "snapped"`), drops specks and renumbers the ids by first appearance.
#[allow(clippy::too_many_arguments)]
pub fn lift_and_render(
    prepared: &PreparedGaussians,
    cams: &[PosedCamera],
    contributions: &[ViewContributions],
    seen: &[Vec<DominantLabel>],
    merged: &[Option<MergedView>],
    matching: &Matching,
    config: &LiftConfig,
) -> anyhow::Result<LiftOutput> {
    let views: Vec<LiftView> = contributions
        .iter()
        .zip(merged)
        .zip(&matching.global_of_label)
        .filter(|((_, m), _)| m.is_some())
        .map(|((c, _), table)| LiftView { contributions: c, global_of_label: table })
        .collect();
    let features = ObjectFeatures { dim: matching.dim, values: &matching.object_features };
    let first = lift_labels(prepared.len(), &views, features, config)?;
    let local: Vec<Vec<DominantLabel>> =
        seen.iter().zip(merged).filter(|(_, m)| m.is_some()).map(|(s, _)| s.clone()).collect();
    // Touching look-alikes become one object; lifting again with the joined ids lets the
    // variance filter see the pieces of one object as one id.
    let touching = touching_joins(prepared, &first, features, &local, config);
    let local_tables: Vec<&[u32]> = merged
        .iter()
        .zip(&matching.global_of_label)
        .filter(|(m, _)| m.is_some())
        .map(|(_, t)| t.as_slice())
        .collect();
    let apart = seen_apart(&local, &local_tables, config.covote_min_gaussians, 2);
    let covoted = covote_joins(&first, features, matching.n_objects, &apart, config);
    let joined = union_tables(&touching, &covoted);
    let count = |t: &[u32]| t.iter().enumerate().filter(|&(id, &to)| id as u32 != to).count();
    let joins = count(&joined);
    tracing::info!(
        "joined {joins} ids into others ({} as touching look-alikes, {} by shared Gaussians)",
        count(&touching),
        count(&covoted)
    );
    let tables: Vec<Vec<u32>> = matching
        .global_of_label
        .iter()
        .map(|t| t.iter().map(|&id| joined.get(id as usize).copied().unwrap_or(id)).collect())
        .collect();
    let views: Vec<LiftView> = contributions
        .iter()
        .zip(merged)
        .zip(&tables)
        .filter(|((_, m), _)| m.is_some())
        .map(|((c, _), table)| LiftView { contributions: c, global_of_label: table })
        .collect();
    let mut lifted = if joins > 0 { lift_labels(prepared.len(), &views, features, config)? } else { first };
    let votes = render_votes(&lifted, config);
    let bar = progress(cams.len(), "render label maps");
    let mut back: Vec<Plane<u32>> = cams
        .par_iter()
        .progress_with(bar.clone())
        .map(|c| render_label_map(prepared, &votes, c.camera, c.world_from_cam, config))
        .collect::<Result<_, _>>()?;
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
    if config.relift_final_maps {
        lifted = relift(prepared, cams, &back, features, config)?;
    }
    renumber(&mut back, &mut lifted.object_ids);
    Ok(LiftOutput { lifted, maps: back })
}

/// Lifts the final label maps (`[n_views]`, global ids) back onto the Gaussians, so the PLY's
/// ids are the ones the maps show: objects the maps dropped or merged are gone in 3D too.
fn relift(
    prepared: &PreparedGaussians,
    cams: &[PosedCamera],
    maps: &[Plane<u32>],
    features: ObjectFeatures,
    config: &LiftConfig,
) -> anyhow::Result<Lifted> {
    let bar = progress(cams.len(), "lift the final maps");
    let contributions: Vec<ViewContributions> = cams
        .par_iter()
        .zip(maps)
        .progress_with(bar.clone())
        .map(|(c, m)| view_contributions(prepared, c.camera, c.world_from_cam, m, config))
        .collect::<Result<_, _>>()?;
    bar.finish_and_clear();
    let max_id = maps.iter().flat_map(|m| m.data.iter().copied()).max().unwrap_or(0);
    let identity: Vec<u32> = (0..=max_id).collect();
    let views: Vec<LiftView> =
        contributions.iter().map(|c| LiftView { contributions: c, global_of_label: &identity }).collect();
    Ok(lift_labels(prepared.len(), &views, features, config)?)
}

/// The union of two join tables (`[n + 1]` each, id → the id it becomes): ids joined by either
/// end up together, each group under its smallest id.
fn union_tables(a: &[u32], b: &[u32]) -> Vec<u32> {
    let n = a.len().max(b.len());
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            parent[x as usize] = parent[parent[x as usize] as usize];
            x = parent[x as usize];
        }
        x
    }
    for table in [a, b] {
        for (id, &to) in table.iter().enumerate() {
            let (ra, rb) = (find(&mut parent, id as u32), find(&mut parent, to.min(n as u32 - 1)));
            if ra != rb {
                parent[ra.max(rb) as usize] = ra.min(rb);
            }
        }
    }
    (0..n as u32).map(|id| find(&mut parent, id)).collect()
}
