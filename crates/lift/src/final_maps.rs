//! The lift stage from the votes to the final label maps, streaming view by view
//! ([`LiftStage::run`]): the steps of paper §4.3 and the ones after it, in order,
//!
//! 1. votes, fusion and variance filter ([`VoteAccumulator`]), with each Gaussian's [`Facing`];
//! 2. touching objects joined ([`join_touching_objects`], from per-view [`ViewCounts`]);
//! 3. objects split where their Gaussians lie apart in 3D, a piece that continues another
//!    object's surface joining it ([`split_disconnected_objects`]);
//! 4. every view's labels rendered back ([`render_label_map`]), snapped onto its regions
//!    ([`snap_view`], with `final_maps = "snapped"` / `"snapped-raw"`) and refined by its
//!    colours ([`refine_boundaries`]);
//! 5. ids kept only by snapping's containment rule and owning no region anywhere given back
//!    ([`give_unowned_ids_back`]);
//! 6. where the Gaussians say nothing (a pixel left without an id, inside a merged region that
//!    matching gave a global id), the matched id, as the object it became in 3D
//!    ([`fill_from_matches`]);
//! 7. specks dropped and ids numbered by first appearance ([`drop_specks_and_number`]).
//!
//! Nothing here holds every view's visible Gaussians or an `[H, W]` map per view: the caller's
//! [`ViewStore`] hands over one view's visible Gaussians, tile lists, regions and image at a time
//! (in view order where order matters), and the maps wait for the all-view steps as runs
//! ([`RunLengths`]).

use crate::config::{FinalMaps, LiftConfig};
use crate::error::LiftError;
use crate::facing::Facing;
use crate::graph::{EdgeRecord, ViewCounts};
use crate::lifting::{Lifted, ObjectFeatures, VoteAccumulator};
use crate::numbering::drop_specks_and_number;
use crate::project::PreparedGaussians;
use crate::refine::refine_boundaries;
use crate::render_labels::{render_label_map, render_votes, RenderVotes};
use crate::run_lengths::RunLengths;
use crate::snap::snap_view;
use crate::split::split_disconnected_objects;
use crate::touching::{join_touching_objects, JoinReport, SeparateWholes};
use crate::PosedCamera;
use rayon::prelude::*;
use splatseg_render::bin::TileBins;
use splatseg_scene::Plane;
use std::collections::{BTreeMap, BTreeSet};

/// The Gaussians one view sees, as the per-view pass found them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VisibleGaussians {
    /// `[n_visible]` Gaussian indices, strictly increasing.
    pub gaussians: Vec<u32>,
    /// `[n_visible]` fusion weights.
    pub weights: Vec<f32>,
    /// `[n_visible]` merged (view-local) label at each one's centre pixel, 0 = none.
    pub labels: Vec<u32>,
}

/// What the stage reads back one view at a time, from wherever the caller keeps it (the
/// pipeline: its per-view cache on disk). Lift's own errors convert into the caller's.
pub trait ViewStore: Sync {
    /// The caller's error type.
    type Error: From<LiftError> + Send;

    /// The visible Gaussians of view `v` (a view with masks).
    fn visible(&self, v: usize) -> Result<VisibleGaussians, Self::Error>;

    /// The tile lists the per-view pass kept for view `v` (the same lists as sorting the splats
    /// again, so the same map), or `None`.
    fn tile_lists(&self, v: usize) -> Result<Option<TileBins>, Self::Error>;

    /// The regions of view `v` (a view with masks): those to snap onto and the merged ones.
    fn regions(&self, v: usize) -> Result<ViewRegions, Self::Error>;

    /// `[H, W, 3]` 8-bit row-major colours of view `v`'s image, for the boundary refinement.
    fn image_rgb(&self, v: usize) -> Result<Vec<u8>, Self::Error>;

    /// The error of view `v`'s kept tile lists not fitting the view (default: lift's as it is).
    fn unfit_tile_lists(&self, _v: usize, error: LiftError) -> Self::Error {
        error.into()
    }

    /// Runs `f` as the named part of the stage (for the caller's profile; default: just runs it).
    fn time<T>(&self, _part: &'static str, f: impl FnOnce() -> T) -> T {
        f()
    }

    /// Called once per view rendered back (for a progress bar).
    fn view_rendered(&self) {}
}

/// One view's region maps, as the lift stage reads them back.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewRegions {
    /// `[H, W]` regions to snap onto ([`FinalMaps::snapped_onto`]), any local ids, 0 = none.
    pub snap: Plane<u32>,
    /// `[H, W]` merged regions, the labels [`MatchedViews::global_of_label`] maps (0 = none).
    pub merged: Plane<u32>,
}

/// What matching gave the lift stage.
#[derive(Clone, Debug)]
pub struct MatchedViews<'a> {
    /// `[n_views]`: for a view with masks, the global object id of each merged label (index =
    /// label, 0 → 0); `None` for a view without masks (it is rendered, not voted or snapped).
    pub global_of_label: Vec<Option<&'a [u32]>>,
    /// Identity features of the global objects.
    pub objects: ObjectFeatures<'a>,
}

/// The lift stage's inputs that do not come view by view.
pub struct LiftStage<'a> {
    /// The Gaussians.
    pub gaussians: &'a PreparedGaussians,
    /// `[n_views]` cameras.
    pub cams: &'a [PosedCamera<'a>],
    /// What matching decided.
    pub matched: MatchedViews<'a>,
    /// Lift settings.
    pub config: &'a LiftConfig,
    /// Other views' SAM masks over objects' Gaussians, for the touching joins (`None`: not used).
    pub wholes: Option<&'a dyn SeparateWholes>,
}

/// What the stage produced.
pub struct LiftOutput {
    /// Per-Gaussian results (ids in the final numbering).
    pub lifted: Lifted,
    /// `[n_views]` final label maps as runs, *before* the final numbering.
    pub maps: Vec<RunLengths>,
    /// `new_of_old[id]`: final id of an id of `maps` (0 for the dropped specks).
    pub new_of_old: Vec<u32>,
    /// Pixels over all views the Gaussians left without an id that took their merged region's
    /// matched object (step 6): the rest of the labelled pixels are the Gaussians' own.
    pub filled_px: u64,
    /// `[N]` the vote's ids (step 1, -1 = none): the object graph's nodes.
    pub voted_ids: Vec<i32>,
    /// The object graph's edges as step 2 weighed them.
    pub edges: Vec<EdgeRecord>,
}

impl LiftOutput {
    /// `[H, W]` final label map of view `v`, 0 = none.
    pub fn final_map(&self, v: usize) -> Plane<u32> {
        self.maps[v].decode(|id| self.new_of_old.get(id as usize).copied().unwrap_or(0))
    }
}

/// How many views' visible Gaussians the votes read at once (each ≈ 12 bytes per visible
/// Gaussian; a bounded batch).
const VIEWS_READ_AT_ONCE: usize = 4;

impl LiftStage<'_> {
    /// The whole stage (module docs): the Gaussians labelled and every view's final map.
    pub fn run<S: ViewStore>(&self, store: &S) -> Result<LiftOutput, S::Error> {
        let (mut lifted, facing) = store.time("votes, fusion, variance filter", || self.vote(store))?;
        let voted_ids = lifted.object_ids.clone();
        let joined = store.time("touching objects", || self.join_touching(&mut lifted, &facing, store))?;
        tracing::info!("joined {} pairs of touching objects", joined.joins);
        let split = store.time("split objects apart in 3D", || {
            let objects = &self.matched.objects;
            let reserved = objects.values.len().checked_div(objects.dim).unwrap_or(0) as u32;
            split_disconnected_objects(self.gaussians, &mut lifted, reserved, self.config)
        });
        tracing::info!(
            "split {} objects into {} more, whose Gaussians lie apart in 3D ({} of them joined the \
             object whose surface they continue)",
            split.objects_split,
            split.parents.len(),
            split.continued.len()
        );
        let votes = render_votes(&lifted, self.config);
        let snapped: Vec<(SnappedRuns, LeftEmpty)> = (0..self.cams.len())
            .into_par_iter()
            .map(|v| {
                let map = self.view_map(v, &votes, store);
                store.view_rendered();
                map
            })
            .collect::<Result<_, S::Error>>()?;
        let (snapped, left): (Vec<SnappedRuns>, Vec<LeftEmpty>) = snapped.into_iter().unzip();
        let (maps, filled_px) = fill_from_matches(give_unowned_ids_back(snapped), left);
        let mean_view_px =
            maps.iter().map(|m| (m.width * m.height) as u64).sum::<u64>() / maps.len().max(1) as u64;
        let min_px = self.config.min_object_px_for(mean_view_px);
        let new_of_old = drop_specks_and_number(&maps, &mut lifted.object_ids, min_px);
        Ok(LiftOutput { lifted, maps, new_of_old, filled_px, voted_ids, edges: joined.edges })
    }

    /// The views with masks, in view order, with their label → global id tables.
    fn voting_views(&self) -> Vec<(usize, &[u32])> {
        self.matched.global_of_label.iter().enumerate().filter_map(|(v, t)| t.map(|t| (v, t))).collect()
    }

    /// Step 1: every view's votes and facing, in view order (a few views read at once, the next
    /// few while these are added; the same as one view at a time).
    fn vote<S: ViewStore>(&self, store: &S) -> Result<(Lifted, Facing), S::Error> {
        let n = self.gaussians.len();
        let (mut votes, mut facing) = (VoteAccumulator::new(n), Facing::new(n));
        let views = self.voting_views();
        let read = |chunk: &[(usize, &[u32])]| -> Vec<Result<VisibleGaussians, S::Error>> {
            chunk.par_iter().map(|&(v, _)| store.visible(v)).collect()
        };
        let chunks: Vec<_> = views.chunks(VIEWS_READ_AT_ONCE).collect();
        let mut this_read = chunks.first().map(|c| read(c)).unwrap_or_default();
        for (k, chunk) in chunks.iter().enumerate() {
            let mut add = |lists: Vec<Result<VisibleGaussians, S::Error>>| -> Result<(), S::Error> {
                for (&(v, table), list) in chunk.iter().zip(lists) {
                    let list = list?;
                    let ids: Vec<u32> =
                        list.labels.iter().map(|&l| table.get(l as usize).copied().unwrap_or(0)).collect();
                    let centre = self.cams[v].world_from_cam.centre().as_vec3();
                    let (added, ()) = rayon::join(
                        || votes.add_view(&list.gaussians, &list.weights, &ids),
                        || facing.add_view(self.gaussians, &list.gaussians, centre),
                    );
                    added?;
                }
                Ok(())
            };
            let next = chunks.get(k + 1);
            let (added, next_read) =
                rayon::join(|| add(std::mem::take(&mut this_read)), || next.map(|c| read(c)));
            added?;
            this_read = next_read.unwrap_or_default();
        }
        Ok((votes.finish(self.matched.objects, self.config)?, facing))
    }

    /// Step 2: the views' counts (one view's visible Gaussians at a time), then the join.
    fn join_touching<S: ViewStore>(
        &self,
        lifted: &mut Lifted,
        facing: &Facing,
        store: &S,
    ) -> Result<JoinReport, S::Error> {
        let counts: Vec<ViewCounts> = self
            .voting_views()
            .par_iter()
            .map(|&(v, _)| -> Result<ViewCounts, S::Error> {
                let list = store.visible(v)?;
                Ok(ViewCounts::new(&list.gaussians, &list.labels, &lifted.object_ids))
            })
            .collect::<Result<_, S::Error>>()?;
        let objects = self.matched.objects;
        Ok(join_touching_objects(
            self.gaussians,
            lifted,
            objects,
            &counts,
            Some(facing),
            self.wholes,
            self.config,
        ))
    }

    /// Step 4 for view `v`: rendered back, snapped (a view with masks) and refined.
    fn view_map<S: ViewStore>(
        &self,
        v: usize,
        votes: &RenderVotes,
        store: &S,
    ) -> Result<(SnappedRuns, LeftEmpty), S::Error> {
        let c = &self.cams[v];
        let map = store.time("render back", || -> Result<Plane<u32>, S::Error> {
            let bins = store.tile_lists(v)?;
            let kept = bins.is_some();
            render_label_map(self.gaussians, votes, c.camera, c.world_from_cam, self.config, bins)
                .map_err(|e| if kept { store.unfit_tile_lists(v, e) } else { e.into() })
        })?;
        let with_masks = self.matched.global_of_label.get(v).is_some_and(|t| t.is_some());
        Ok(match self.config.final_maps {
            FinalMaps::Snapped | FinalMaps::SnappedRaw if with_masks => {
                let regions = store.time("read the region maps back", || store.regions(v))?;
                let rule = self.config.snap_rule_for((map.width * map.height) as u64);
                let mut s = store.time("snap", || snap_view(&regions.snap, &map, &rule));
                s.labels = self.refine(v, &s.labels, store)?;
                let table = self.matched.global_of_label[v].unwrap_or_default();
                let left = LeftEmpty::new(&s.labels, &regions.merged, table);
                let has_fallback = s.contained_fallback.data.iter().any(|&id| id != 0);
                let runs = SnappedRuns {
                    labels: RunLengths::encode(&s.labels),
                    fallback: has_fallback.then(|| RunLengths::encode(&s.contained_fallback)),
                    owned: Some(s.region_winners),
                };
                (runs, left)
            }
            _ => {
                let labels = RunLengths::encode(&self.refine(v, &map, store)?);
                (SnappedRuns { labels, fallback: None, owned: None }, LeftEmpty::default())
            }
        })
    }

    /// `labels` (`[H, W]`) of view `v` refined by the view's colours (unchanged when the rule
    /// for its size does nothing: the image is then not read).
    fn refine<S: ViewStore>(&self, v: usize, labels: &Plane<u32>, store: &S) -> Result<Plane<u32>, S::Error> {
        let rule = self.config.refine_rule_for((labels.width * labels.height) as u64);
        if rule.window_px == 0 || rule.passes == 0 {
            return Ok(labels.clone());
        }
        let rgb = store.time("read the image back", || store.image_rgb(v))?;
        Ok(store.time("refine boundaries by colour", || refine_boundaries(labels, &rgb, &rule)))
    }
}

/// One view's map after snapping, as runs, with what [`give_unowned_ids_back`] needs.
struct SnappedRuns {
    /// The final labels (before numbering).
    labels: RunLengths,
    /// [`crate::Snapped::contained_fallback`], when it has any pixel.
    fallback: Option<RunLengths>,
    /// Ids that win a region of the view; `None` for a view kept as rendered (all its ids count).
    owned: Option<Vec<u32>>,
}

/// Step 5: ids kept in some views only by snapping's containment rule that win no region in
/// any view are fragments of the objects around them (an object of their own would be SAM's
/// mask in some view): their pixels take the region winners they fell back to. Returns the
/// final maps.
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

/// One view's pixels the Gaussians left without an id inside a matched merged region, and how
/// the view's labelled pixels of each matched object were labelled (for [`fill_from_matches`]).
#[derive(Default)]
struct LeftEmpty {
    /// `[H, W]` as runs: the matched global id at each pixel left at 0, 0 elsewhere; `None`
    /// when there is no such pixel.
    matched: Option<RunLengths>,
    /// (matched global id, final id) → pixels of the view labelled so.
    labelled_as: BTreeMap<(u32, u32), u64>,
}

impl LeftEmpty {
    /// `labels` `[H, W]` (the view's final ids, 0 = none), `merged` `[H, W]` (merged labels),
    /// `global_of_label[label]`: the matched global id of each merged label.
    fn new(labels: &Plane<u32>, merged: &Plane<u32>, global_of_label: &[u32]) -> LeftEmpty {
        let global = |l: u32| global_of_label.get(l as usize).copied().unwrap_or(0);
        let mut labelled_as: BTreeMap<(u32, u32), u64> = BTreeMap::new();
        let mut left =
            Plane { width: labels.width, height: labels.height, data: vec![0u32; labels.data.len()] };
        let mut any = false;
        // Counted run by run of equal (g, id) pixels (row-major), the same sums.
        let mut run: ((u32, u32), u64) = ((0, 0), 0);
        for ((&id, &l), out) in labels.data.iter().zip(&merged.data).zip(&mut left.data) {
            let g = global(l);
            if g != 0 && id == 0 {
                *out = g;
                any = true;
            }
            let key = if id == 0 { (0, 0) } else { (g, id) };
            if key != run.0 {
                if run.0 .0 != 0 {
                    *labelled_as.entry(run.0).or_insert(0) += run.1;
                }
                run = (key, 0);
            }
            run.1 += 1;
        }
        if run.0 .0 != 0 {
            *labelled_as.entry(run.0).or_insert(0) += run.1;
        }
        LeftEmpty { matched: any.then(|| RunLengths::encode(&left)), labelled_as }
    }
}

/// Step 6: a pixel the Gaussians left without an id (a part the 3DGS reconstructed poorly or not
/// at all, or Gaussians the variance filter left unlabelled) inside a merged region that
/// matching gave the global id `g` takes the final id that most of `g`'s labelled pixels have
/// over all views (ties: the smaller id) when that id covers at least as many of `g`'s pixels as
/// are left empty (snapping's rule for a region), else `g` itself (an object the Gaussians do
/// not hold, or only a neighbour's bleed covers: kept, not lost). One table for all views, so
/// the fill is the same object in every view. Returns the final maps and the pixels filled.
fn fill_from_matches(maps: Vec<RunLengths>, left: Vec<LeftEmpty>) -> (Vec<RunLengths>, u64) {
    let mut labelled_as: BTreeMap<(u32, u32), u64> = BTreeMap::new();
    for l in &left {
        for (&key, &n) in &l.labelled_as {
            *labelled_as.entry(key).or_insert(0) += n;
        }
    }
    let mut empty_px: BTreeMap<u32, u64> = BTreeMap::new();
    for runs in left.iter().filter_map(|l| l.matched.as_ref()) {
        for &(g, n) in runs.runs.iter().filter(|&&(g, _)| g != 0) {
            *empty_px.entry(g).or_insert(0) += n as u64;
        }
    }
    // Ascending (g, id) with a strict `>`: the smallest id wins ties.
    let mut most: BTreeMap<u32, (u32, u64)> = BTreeMap::new();
    for (&(g, id), &n) in &labelled_as {
        let best = most.entry(g).or_insert((id, n));
        if n > best.1 {
            *best = (id, n);
        }
    }
    // As snapping decides a region: the winner must cover at least the pixels left empty.
    let became = |g: u32| match most.get(&g) {
        Some(&(id, n)) if n >= empty_px.get(&g).copied().unwrap_or(0) => id,
        _ => g,
    };
    let mut filled = 0u64;
    let maps: Vec<RunLengths> = maps
        .into_iter()
        .zip(left)
        .map(|(map, l)| match l.matched {
            None => map,
            Some(matched) => {
                let mut labels = map.decode(|id| id);
                let matched = matched.decode(|g| if g == 0 { 0 } else { became(g) });
                for (id, &fill) in labels.data.iter_mut().zip(&matched.data) {
                    if *id == 0 && fill != 0 {
                        *id = fill;
                        filled += 1;
                    }
                }
                RunLengths::encode(&labels)
            }
        })
        .collect();
    tracing::info!(
        "{filled} pixels without an id from the Gaussians took their merged region's matched object"
    );
    (maps, filled)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn runs(width: usize, data: Vec<u32>) -> RunLengths {
        RunLengths::encode(&Plane { width, height: 1, data })
    }

    /// Pixels left at 0 inside matched regions take, in every view, the final id most of that
    /// matched object's labelled pixels have over all views (ties: the smaller id) if it covers
    /// as many pixels as are empty, else the matched id itself; labelled pixels never change.
    #[test]
    fn empty_pixels_take_what_their_matched_object_became() {
        // Merged labels 1, 2, 3 are the matched objects 10, 20, 30 (label 4 matched nothing).
        let table = [0u32, 10, 20, 30, 0];
        let plane = |data: Vec<u32>| Plane { width: data.len(), height: 1, data };
        // View 0: object 10 labelled 7 on two pixels, 8 on one; object 20 labelled 5 and 6 once each.
        let v0 = (plane(vec![7, 7, 8, 0, 5, 6, 0, 0, 0]), plane(vec![1, 1, 1, 1, 2, 2, 2, 3, 4]));
        // View 1: object 10 labelled 8 once (7: 2 px, 8: 2 px over both views: the smaller wins).
        let v1 = (plane(vec![0, 8, 0, 0]), plane(vec![1, 1, 3, 0]));
        let left: Vec<LeftEmpty> = [&v0, &v1].iter().map(|(l, m)| LeftEmpty::new(l, m, &table)).collect();
        let maps = vec![RunLengths::encode(&v0.0), RunLengths::encode(&v1.0)];
        let (filled, n) = fill_from_matches(maps, left);
        assert_eq!(n, 5);
        assert_eq!(filled[0].decode(|id| id).data, vec![7, 7, 8, 7, 5, 6, 5, 30, 0]);
        assert_eq!(filled[1].decode(|id| id).data, vec![7, 8, 30, 0]);
        // Object 20 with a third empty pixel: its one labelled pixel of 5 is outnumbered.
        let v2 = (plane(vec![0, 0]), plane(vec![2, 2]));
        let left: Vec<LeftEmpty> = [&v0, &v2].iter().map(|(l, m)| LeftEmpty::new(l, m, &table)).collect();
        let (filled, _) = fill_from_matches(vec![RunLengths::encode(&v0.0), RunLengths::encode(&v2.0)], left);
        assert_eq!(filled[0].decode(|id| id).data, vec![7, 7, 8, 7, 5, 6, 20, 30, 0]);
        assert_eq!(filled[1].decode(|id| id).data, vec![20, 20]);
    }

    /// An id kept only by the containment rule gives its pixels back unless some view's region
    /// is won by it (or a view kept as rendered shows it).
    #[test]
    fn contained_ids_that_own_no_region_anywhere_are_given_back() {
        let snapped = |owned_elsewhere: Option<Vec<u32>>| {
            vec![
                SnappedRuns {
                    labels: runs(4, vec![1, 1, 5, 5]),
                    fallback: Some(runs(4, vec![0, 0, 1, 1])),
                    owned: Some(vec![1]),
                },
                SnappedRuns { labels: runs(2, vec![2, 2]), fallback: None, owned: owned_elsewhere },
            ]
        };
        let back = give_unowned_ids_back(snapped(Some(vec![2])));
        assert_eq!(back[0].decode(|id| id).data, vec![1, 1, 1, 1]);
        assert_eq!(back[1].decode(|id| id).data, vec![2, 2]);
        let kept = give_unowned_ids_back(snapped(Some(vec![2, 5])));
        assert_eq!(kept[0].decode(|id| id).data, vec![1, 1, 5, 5]);
        let rendered = give_unowned_ids_back(vec![
            SnappedRuns {
                labels: runs(4, vec![1, 1, 5, 5]),
                fallback: Some(runs(4, vec![0, 0, 1, 1])),
                owned: Some(vec![1]),
            },
            SnappedRuns { labels: runs(2, vec![5, 0]), fallback: None, owned: None },
        ]);
        assert_eq!(rendered[0].decode(|id| id).data, vec![1, 1, 5, 5]);
    }
}
