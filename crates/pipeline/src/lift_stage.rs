//! The global stages on compact per-view results: cross-view matching (with 3D evidence),
//! lifting, and the label maps rendered back, numbered and written view by view.
//!
//! No stage here holds an `[H, W]` map per view, nor every view's visible Gaussians: each view
//! keeps its region descriptors and a bounded sample of its visible Gaussians with their merged
//! labels for matching ([`ViewResult`], [`crate::visible::sample_stride`]); its full list is
//! spilled to `OUT/cache/visible/` by the per-view pass and read back one view at a time, in view
//! order, to accumulate the votes ([`VoteAccumulator`]) and the touching-objects counts. The maps
//! rendered back are kept as runs ([`RunLengths`]) until the speck filter and the numbering
//! (which need every view) are decided, then decoded one view at a time.

use super::progress;
use crate::error::Context;
use crate::profile::PartTimes;
use crate::visible;
use indicatif::ParallelProgressIterator;
use rayon::prelude::*;
use splatseg_lift::{
    join_touching_counted, refine_boundaries, render_label_map, render_label_map_binned, render_votes,
    renumber, snap_view, split_disconnected_objects, Facing, FinalMaps, LiftConfig, Lifted, ObjectFeatures,
    PosedCamera, PreparedGaussians, ViewCounts, VoteAccumulator,
};
use splatseg_match::{match_masks_owned, MatchConfig, MatchInput, Matching, ViewMasks, ViewObservations};
use splatseg_merge::RegionSummary;
use splatseg_scene::Plane;
use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

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
    /// With Gaussians: the sampled visible Gaussians and their merged labels (matching's 3D
    /// evidence; moved into the matcher).
    pub observations: Option<ViewObservations>,
    /// With Gaussians: the file holding every visible Gaussian ([`crate::visible`]).
    pub spill: Option<PathBuf>,
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

/// `labels` as a `[1, n]` map.
fn row_map(labels: Vec<u32>) -> Plane<u32> {
    Plane { width: labels.len(), height: 1, data: labels }
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

/// What the final maps of a view are made from besides the rendered labels, read back one view
/// at a time.
pub struct FinalMapInputs<'a> {
    /// `[H, W]` regions of view `v` to snap onto.
    pub snap_map: &'a (dyn Fn(usize) -> crate::Result<Plane<u32>> + Sync),
    /// `[H, W, 3]` 8-bit row-major colours of view `v`'s image, for the boundary refinement.
    pub image_rgb: &'a (dyn Fn(usize) -> crate::Result<Vec<u8>> + Sync),
    /// `--quiet` hides the progress bar.
    pub options: crate::RunOptions,
}

/// Lifts the matched labels of the views with masks onto the Gaussians, renders every view back
/// (snapping the rendered ids onto the regions read back by `view_inputs.snap_map(v)`: the SAM regions with
/// `final_maps = "snapped-raw"`, the merged ones with `"snapped"`; then refining the boundaries
/// by the colours of `view_inputs.image_rgb(v)`), drops specks and numbers the
/// ids by first appearance. The views' visible Gaussians are read back from their spill files one
/// view at a time, in view order.
pub fn lift_and_render(
    prepared: &PreparedGaussians,
    cams: &[PosedCamera],
    views: &[Option<ViewResult>],
    matching: &Matching,
    view_inputs: &FinalMapInputs,
    config: &LiftConfig,
    times: &PartTimes,
) -> crate::Result<LiftOutput> {
    let spilled: Vec<(usize, &PathBuf, &[u32])> = views
        .iter()
        .zip(&matching.global_of_label)
        .enumerate()
        .filter_map(|(v, (m, table))| m.as_ref().and_then(|m| m.spill.as_ref()).map(|p| (v, p, &table[..])))
        .collect();
    let features = ObjectFeatures { dim: matching.dim, values: &matching.object_features };
    let mut facing = Facing::new(prepared.len());
    let mut lifted = times.time("votes, fusion, variance filter", || -> crate::Result<Lifted> {
        let mut votes = VoteAccumulator::new(prepared.len());
        // A few views' spill files are read at once, the next few while these are added; the
        // views add their votes and their facing in view order (the two accumulators side by
        // side), as one view at a time would.
        let read_chunk = |chunk: &[(usize, &PathBuf, &[u32])]| -> Vec<crate::Result<visible::Spilled>> {
            chunk.par_iter().map(|&(_, path, _)| visible::read(path)).collect()
        };
        let chunks: Vec<_> = spilled.chunks(SPILLS_READ_AT_ONCE).collect();
        let mut read = chunks.first().map(|c| read_chunk(c)).unwrap_or_default();
        for (k, chunk) in chunks.iter().enumerate() {
            let mut add_chunk = |read: Vec<crate::Result<visible::Spilled>>| -> crate::Result<()> {
                for (&(v, _, table), spill) in chunk.iter().zip(read) {
                    let (gaussians, weights, labels) = spill?;
                    let ids: Vec<u32> =
                        labels.iter().map(|&l| table.get(l as usize).copied().unwrap_or(0)).collect();
                    let centre = cams[v].world_from_cam.centre().as_vec3();
                    let (added, ()) = rayon::join(
                        || votes.add_view(&gaussians, &weights, &ids),
                        || facing.add_view(prepared, &gaussians, centre),
                    );
                    added?;
                }
                Ok(())
            };
            let next = chunks.get(k + 1);
            let (added, next_read) =
                rayon::join(|| add_chunk(std::mem::take(&mut read)), || next.map(|c| read_chunk(c)));
            added?;
            read = next_read.unwrap_or_default();
        }
        Ok(votes.finish(features, config)?)
    })?;
    let joins = times.time("touching objects", || -> crate::Result<usize> {
        let counts: Vec<ViewCounts> = spilled
            .par_iter()
            .map(|&(_, path, _)| -> crate::Result<ViewCounts> {
                let (gaussians, _, labels) = visible::read(path)?;
                Ok(ViewCounts::new(&gaussians, &labels, &lifted.object_ids))
            })
            .collect::<crate::Result<_>>()?;
        Ok(join_touching_counted(prepared, &mut lifted, features, &counts, Some(&facing), config))
    })?;
    tracing::info!("joined {joins} pairs of touching objects");
    let split = times.time("split objects apart in 3D", || {
        let reserved = matching.object_features.len().checked_div(matching.dim).unwrap_or(0) as u32;
        split_disconnected_objects(prepared, &mut lifted, reserved, config)
    });
    tracing::info!(
        "split {} objects into {} more, whose Gaussians lie apart in 3D",
        split.objects_split,
        split.parents.len()
    );
    let votes = render_votes(&lifted, config);
    let refine = |v: usize, labels: &Plane<u32>| -> crate::Result<Plane<u32>> {
        let rule = config.refine_rule_for((labels.width * labels.height) as u64);
        if rule.window_px == 0 || rule.passes == 0 {
            return Ok(labels.clone());
        }
        let rgb = times.time("read the image back", || (view_inputs.image_rgb)(v))?;
        Ok(times.time("refine boundaries by colour", || refine_boundaries(labels, &rgb, &rule)))
    };
    let bar = progress(cams.len(), "render label maps", view_inputs.options);
    let snapped: Vec<SnappedRuns> = cams
        .par_iter()
        .enumerate()
        .progress_with(bar.clone())
        .map(|(v, c)| -> crate::Result<SnappedRuns> {
            let map = times.time("render back", || -> crate::Result<Plane<u32>> {
                // The tile lists the per-view pass kept for this view, if any (else the splats are
                // sorted again): the same lists, so the same map.
                let kept = views[v].as_ref().and_then(|m| m.spill.as_deref()).map(visible::bins_path);
                match kept.filter(|p| p.is_file()) {
                    Some(path) => {
                        let bins = visible::read_bins(&path)?;
                        render_label_map_binned(prepared, &votes, c.camera, c.world_from_cam, config, bins)
                            .with_context(|| format!("rendering the labels back with {}", path.display()))
                    }
                    None => Ok(render_label_map(prepared, &votes, c.camera, c.world_from_cam, config)),
                }
            })?;
            Ok(match (&config.final_maps, &views[v]) {
                (FinalMaps::Snapped | FinalMaps::SnappedRaw, Some(_)) => {
                    let regions = times.time("read the region maps back", || (view_inputs.snap_map)(v))?;
                    let rule = config.snap_rule_for((map.width * map.height) as u64);
                    let mut s = times.time("snap", || snap_view(&regions, &map, &rule));
                    s.labels = refine(v, &s.labels)?;
                    let has_fallback = s.contained_fallback.data.iter().any(|&id| id != 0);
                    SnappedRuns {
                        labels: RunLengths::encode(&s.labels),
                        fallback: has_fallback.then(|| RunLengths::encode(&s.contained_fallback)),
                        owned: Some(s.region_winners),
                    }
                }
                _ => {
                    SnappedRuns { labels: RunLengths::encode(&refine(v, &map)?), fallback: None, owned: None }
                }
            })
        })
        .collect::<crate::Result<_>>()?;
    bar.finish_and_clear();
    let maps = give_unowned_ids_back(snapped);
    let mean_view_px =
        maps.iter().map(|m| (m.width * m.height) as u64).sum::<u64>() / maps.len().max(1) as u64;
    let new_of_old =
        drop_specks_and_number(&maps, &mut lifted.object_ids, config.min_object_px_for(mean_view_px));
    Ok(LiftOutput { lifted, maps, new_of_old })
}

/// How many views' spilled visible Gaussians the votes read at once (each ≈ 12 bytes per visible
/// Gaussian; a bounded batch).
const SPILLS_READ_AT_ONCE: usize = 4;

/// One view's snapped map as runs, with what [`give_unowned_ids_back`] needs.
struct SnappedRuns {
    /// The final labels (before numbering).
    labels: RunLengths,
    /// [`splatseg_lift::Snapped::contained_fallback`], when it has any pixel.
    fallback: Option<RunLengths>,
    /// Ids that win a region of the view; `None` for a view kept as rendered (all its ids count).
    owned: Option<Vec<u32>>,
}

/// Ids kept in some views only by snapping's containment rule that win no region in any view
/// are fragments of the objects around them (an object of their own would be SAM's mask in some
/// view): their pixels take the region winners they fell back to. Returns the final maps.
fn give_unowned_ids_back(snapped: Vec<SnappedRuns>) -> Vec<RunLengths> {
    let mut owners: BTreeSet<u32> = BTreeSet::new();
    for s in &snapped {
        match &s.owned {
            Some(ids) => owners.extend(ids),
            None => owners.extend(s.labels.runs.iter().map(|&(id, _)| id)),
        }
    }
    snapped
        .into_iter()
        .map(|s| match s.fallback {
            None => s.labels,
            Some(fallback) => {
                let mut labels = s.labels.decode(|id| id);
                let fallback = fallback.decode(|id| id);
                let mut changed = false;
                for (id, &back) in labels.data.iter_mut().zip(&fallback.data) {
                    if back != 0 && !owners.contains(id) {
                        *id = back;
                        changed = true;
                    }
                }
                if changed {
                    RunLengths::encode(&labels)
                } else {
                    s.labels
                }
            }
        })
        .collect()
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
