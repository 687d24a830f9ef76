//! The global stages on compact per-view results: cross-view matching (with 3D evidence),
//! lifting, and the label maps rendered back, numbered and written view by view.
//!
//! No stage here holds an `[H, W]` map per view: each view keeps its region descriptors, its
//! visible Gaussians and the merged (view-local) label at each visible Gaussian's pixel
//! ([`ViewResult`]). Lifting and the touching-objects join only ever read a map at the visible
//! Gaussians' pixels, so they are given those labels as `[1, n_visible]` maps with the pixel
//! indices renumbered `0..n_visible` — the same lookups, the same results. The maps rendered back
//! are kept as runs ([`RunLengths`]) until the speck filter and the numbering (which need every
//! view) are decided, then decoded one view at a time.

use super::progress;
use indicatif::ParallelProgressIterator;
use rayon::prelude::*;
use splatseg_lift::{
    join_touching_objects, lift_labels, render_label_map, render_votes, renumber, snap_to_regions, FinalMaps,
    LiftConfig, Lifted, ObjectFeatures, PosedCamera, PreparedGaussians, ViewVisibility,
};
use splatseg_match::{match_masks, MatchConfig, MatchInput, Matching, ViewMasks, ViewObservations};
use splatseg_merge::RegionSummary;
use splatseg_scene::Plane;
use std::collections::BTreeMap;

/// What the global stages keep of one view with masks.
#[derive(Clone, Debug)]
pub struct ViewResult {
    /// `[k]` merged regions (descriptor, area, …), `regions[i].id == i + 1`.
    pub regions: Vec<RegionSummary>,
    /// Largest raw (SAM region) label of the view.
    pub raw_max: u32,
    /// Largest merged label of the view.
    pub merged_max: u32,
    /// True when the merge came from the cache.
    pub cached: bool,
    /// The visible Gaussians (with Gaussians), pixel indices renumbered `0..n_visible`: entry `k`
    /// reads `[1, n_visible]` maps at `k`.
    pub visibility: Option<ViewVisibility>,
    /// `[n_visible]` merged label at each visible Gaussian's pixel.
    pub local_labels: Vec<u32>,
}

impl ViewResult {
    /// `visibility` (with its real pixel indices into the `[H, W]` `merged` map) made compact.
    pub fn compact(
        visibility: Option<ViewVisibility>,
        merged: &Plane<u32>,
    ) -> (Option<ViewVisibility>, Vec<u32>) {
        match visibility {
            Some(mut vis) => {
                let labels = vis.pixels.iter().map(|&p| merged.data[p as usize]).collect();
                vis.pixels = (0..vis.pixels.len() as u32).collect();
                (Some(vis), labels)
            }
            None => (None, Vec::new()),
        }
    }
}

/// `labels` as a `[1, n]` map.
fn row_map(labels: Vec<u32>) -> Plane<u32> {
    Plane { width: labels.len(), height: 1, data: labels }
}

/// Matches the merged masks of all views. Views without masks (`None`) take no part; with
/// `with_3d`, the Gaussians each mask sees are the 3D evidence (moved into the matcher's input
/// and back, not copied).
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
        .iter()
        .map(|m| match m {
            Some(m) => ViewMasks {
                features: m.regions.iter().flat_map(|r| r.descriptor.iter().copied()).collect(),
                areas_px: m.regions.iter().map(|r| r.area).collect(),
            },
            None => ViewMasks::default(),
        })
        .collect();
    let observations = with_3d.then(|| {
        views
            .iter_mut()
            .map(|m| match m.as_mut().and_then(|m| m.visibility.as_mut().map(|v| (v, &mut m.local_labels))) {
                Some((v, labels)) => ViewObservations {
                    gaussians: std::mem::take(&mut v.gaussians),
                    labels: std::mem::take(labels),
                },
                None => ViewObservations::default(),
            })
            .collect::<Vec<_>>()
    });
    let input = MatchInput { dim, views: masks, observations };
    let matching = match_masks(&input, config);
    for (m, obs) in views.iter_mut().zip(input.observations.into_iter().flatten()) {
        if let Some((v, labels)) =
            m.as_mut().and_then(|m| m.visibility.as_mut().map(|v| (v, &mut m.local_labels)))
        {
            v.gaussians = obs.gaussians;
            *labels = obs.labels;
        }
    }
    Ok(matching?)
}

/// A label map as runs of equal values in row-major order: `[n_runs]` (value, length).
#[derive(Clone, Debug, Default)]
pub struct RunLengths {
    /// Width of the map.
    pub width: usize,
    /// Height of the map.
    pub height: usize,
    /// `[n_runs]` (value, length), lengths summing to `width · height`.
    pub runs: Vec<(u32, u32)>,
}

impl RunLengths {
    /// The runs of `map`.
    pub fn encode(map: &Plane<u32>) -> RunLengths {
        let mut runs: Vec<(u32, u32)> = Vec::new();
        for &v in &map.data {
            match runs.last_mut() {
                Some((last, n)) if *last == v && *n < u32::MAX => *n += 1,
                _ => runs.push((v, 1)),
            }
        }
        RunLengths { width: map.width, height: map.height, runs }
    }

    /// The map, each value passed through `f`.
    pub fn decode(&self, f: impl Fn(u32) -> u32) -> Plane<u32> {
        let mut data = Vec::with_capacity(self.width * self.height);
        for &(v, n) in &self.runs {
            data.extend(std::iter::repeat_n(f(v), n as usize));
        }
        Plane { width: self.width, height: self.height, data }
    }

    /// Ids (> 0) in order of first appearance.
    fn first_appearance(&self, skip: impl Fn(u32) -> bool) -> Vec<u32> {
        let mut seen = std::collections::BTreeSet::new();
        self.runs.iter().map(|&(v, _)| v).filter(|&v| v > 0 && !skip(v) && seen.insert(v)).collect()
    }
}

/// What lifting produced.
pub struct LiftOutput {
    /// Per-Gaussian results (ids renumbered to the final numbering).
    pub lifted: Lifted,
    /// `[n_views]` label maps rendered back from the labelled Gaussians (snapped onto the
    /// merged regions with `final_maps = "snapped"`) as runs, *before* the final numbering.
    pub maps: Vec<RunLengths>,
    /// `new_of_old[id]`: final id of a rendered id (0 for the dropped specks).
    pub new_of_old: Vec<u32>,
}

impl LiftOutput {
    /// `[H, W]` final label map of view `v`.
    pub fn final_map(&self, v: usize) -> Plane<u32> {
        self.maps[v].decode(|id| self.new_of_old.get(id as usize).copied().unwrap_or(0))
    }
}

/// Lifts the matched labels of the views with masks onto the Gaussians, renders every view back
/// (snapping the rendered ids onto the regions read back by `snap_map(v)`: the SAM regions with
/// `final_maps = "snapped-raw"`, the merged ones with `"snapped"`), drops specks and numbers the ids by first appearance. The views'
/// visible Gaussians and labels are consumed (moved, not copied).
pub fn lift_and_render(
    prepared: &PreparedGaussians,
    cams: &[PosedCamera],
    views: &mut [Option<ViewResult>],
    matching: &Matching,
    snap_map: &(dyn Fn(usize) -> crate::Result<Plane<u32>> + Sync),
    config: &LiftConfig,
) -> crate::Result<LiftOutput> {
    let mut vis: Vec<ViewVisibility> = Vec::new();
    let mut labels: Vec<Vec<u32>> = Vec::new();
    let mut tables: Vec<&[u32]> = Vec::new();
    for (m, table) in views.iter_mut().zip(&matching.global_of_label) {
        if let Some(m) = m.as_mut() {
            if let Some(v) = m.visibility.take() {
                vis.push(v);
                labels.push(std::mem::take(&mut m.local_labels));
                tables.push(table);
            }
        }
    }
    let matched: Vec<Plane<u32>> = labels
        .iter()
        .zip(&tables)
        .map(|(l, table)| row_map(l.iter().map(|&l| table.get(l as usize).copied().unwrap_or(0)).collect()))
        .collect();
    let features = ObjectFeatures { dim: matching.dim, values: &matching.object_features };
    let mut lifted = lift_labels(prepared.len(), &vis, &matched, features, config)?;
    drop(matched);
    let local_maps: Vec<Plane<u32>> = labels.into_iter().map(row_map).collect();
    let local: Vec<(&ViewVisibility, &Plane<u32>)> = vis.iter().zip(&local_maps).collect();
    let joins = join_touching_objects(prepared, &mut lifted, features, &local, config);
    drop(local);
    drop((vis, local_maps));
    tracing::info!("joined {joins} pairs of touching look-alike objects");
    let votes = render_votes(&lifted, config);
    let bar = progress(cams.len(), "render label maps");
    let maps: Vec<RunLengths> = cams
        .par_iter()
        .enumerate()
        .progress_with(bar.clone())
        .map(|(v, c)| -> crate::Result<RunLengths> {
            let map = render_label_map(prepared, &votes, c.camera, c.world_from_cam, config);
            let map = match (&config.final_maps, &views[v]) {
                (FinalMaps::Snapped | FinalMaps::SnappedRaw, Some(_)) => snap_to_regions(&snap_map(v)?, &map),
                _ => map,
            };
            Ok(RunLengths::encode(&map))
        })
        .collect::<crate::Result<_>>()?;
    bar.finish_and_clear();
    let new_of_old = drop_specks_and_number(&maps, &mut lifted.object_ids, config.min_object_px);
    Ok(LiftOutput { lifted, maps, new_of_old })
}

/// The speck filter and the numbering of `splatseg_lift::{drop_small_objects, renumber}` over
/// maps kept as runs: ids with fewer than `min_px` pixels over all maps become 0 (and −1 in
/// `object_ids`), then ids are numbered by first appearance (view order, row-major), by
/// [`renumber`] itself on each view's ids in order of first appearance. Returns `new_of_old`.
fn drop_specks_and_number(maps: &[RunLengths], object_ids: &mut [i32], min_px: u64) -> Vec<u32> {
    let mut area: BTreeMap<u32, u64> = BTreeMap::new();
    for map in maps {
        for &(id, n) in map.runs.iter().filter(|(id, _)| *id > 0) {
            *area.entry(id).or_insert(0) += n as u64;
        }
    }
    let small: std::collections::BTreeSet<u32> =
        area.iter().filter(|&(_, &px)| px < min_px).map(|(&id, _)| id).collect();
    for id in object_ids.iter_mut().filter(|id| **id > 0 && small.contains(&(**id as u32))) {
        *id = -1;
    }
    tracing::info!("dropped {} speck objects under {min_px} px", small.len());
    let mut order: Vec<Plane<u32>> =
        maps.iter().map(|m| row_map(m.first_appearance(|id| small.contains(&id)))).collect();
    let old_of_new = renumber(&mut order, object_ids);
    let max_old =
        area.keys().next_back().copied().unwrap_or(0).max(old_of_new.iter().copied().max().unwrap_or(0));
    let mut new_of_old = vec![0u32; max_old as usize + 1];
    for (new, &old) in old_of_new.iter().enumerate().skip(1) {
        new_of_old[old as usize] = new as u32;
    }
    new_of_old
}

#[cfg(test)]
mod tests {
    use super::*;
    use splatseg_lift::drop_small_objects;

    /// The run-length path numbers and filters exactly as the lift crate does on whole maps.
    #[test]
    fn specks_and_numbering_on_runs_equal_the_whole_map_functions() {
        let maps: Vec<Plane<u32>> = vec![
            Plane { width: 4, height: 3, data: vec![0, 7, 7, 3, 3, 3, 9, 0, 5, 5, 5, 5] },
            Plane { width: 3, height: 2, data: vec![9, 9, 2, 0, 11, 11] },
            Plane { width: 2, height: 2, data: vec![0, 0, 0, 0] },
        ];
        let ids: Vec<i32> = vec![-1, 3, 7, 2, 11, 4, 9, 5, 12];
        let (mut whole, mut whole_ids) = (maps.clone(), ids.clone());
        drop_small_objects(&mut whole, &mut whole_ids, 2);
        renumber(&mut whole, &mut whole_ids);
        let runs: Vec<RunLengths> = maps.iter().map(RunLengths::encode).collect();
        let mut run_ids = ids.clone();
        let new_of_old = drop_specks_and_number(&runs, &mut run_ids, 2);
        assert_eq!(run_ids, whole_ids);
        for (r, w) in runs.iter().zip(&whole) {
            assert_eq!(r.decode(|id| new_of_old.get(id as usize).copied().unwrap_or(0)).data, w.data);
        }
        assert_eq!(runs[0].decode(|id| id).data, maps[0].data, "runs decode to the map");
    }
}
