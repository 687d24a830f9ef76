//! SAM's part–whole hierarchy across views: the evidence of the "separate wholes" gate.
//!
//! # Why
//!
//! Within one view, two different objects that touch at one depth (two boxes pushed together, a
//! cylinder against a box, a bowl on a box) and two differently coloured parts of one object (a
//! two-tone box, a striped cylinder) look the same to the merge's cues: the contact is continuous
//! in depth, the crease between the sides is faint or unreliable, and the region descriptors of
//! parts of one object differ as much as those of two similar objects. On the blind families the
//! merge joined such pairs in 22–24 of 24 views although SAM kept them apart
//! (`docs/benchmarks/15-touching-objects.md`).
//!
//! SAM's automatic masks are multi-granular: besides a mask per part they often hold a larger
//! mask over a whole object (the masks overlap). Such a whole holds both parts of a
//! multi-coloured object; it never holds two objects, unless SAM merged them by mistake, and then
//! not in most views. One view seldom shows a whole for every pair, but the Gaussians tie the
//! views together: the Gaussians either side of the contact of two regions of view `v` are seen
//! by other views, where SAM's masks either hold both sides (*together*) or put the sides in
//! different masks, at least one of them inside a larger one (*apart in a whole*: SAM says what
//! the side is part of, and the other side is not in it).
//!
//! # Rule
//!
//! For the pair `(a, b)` of view `v`: the sampled Gaussians whose centre pixel in `v` lies in
//! `a`'s *zone* — the pixels of `a` about 2 to 4 px from `b` (within 2 px of `a`'s pixels of the
//! pair's band `dil(a) ∩ dil(b)`, and not next to `b`) — and those in `b`'s zone. The zone stays
//! near the contact (what is measured is the contact, not the whole regions, which other views
//! may cut anywhere) but leaves out the boundary itself, where SAM's outlines and the centres'
//! pixels are uncertain by a pixel. Measured on the tuning families
//! (`docs/benchmarks/15-touching-objects.md`): the band itself (0–2 px) refused fewer wrong merges
//! of touching objects; a zone that also leaves out the pixels next to any third region refused
//! fewer correct merges in a replay of the merges, but scored lower end to end (mean mIoU 0.972
//! against 0.976: a thin post has no pixel off every outline, so it has no evidence).
//!
//! In another view `w` that sees at least [`MIN_SIDE_GAUSSIANS`] of each side's Gaussians, a mask
//! *holds* a side when at least half of that side's Gaussians seen by `w` have their centre
//! pixel in it. `w` counts as
//! - *together* when one mask holds both sides;
//! - *apart in a whole* when no mask holds both and some side is held by two or more masks
//!   (nested: a part and the whole it belongs to);
//! - neither otherwise (one mask each, no hierarchy: SAM says nothing about wholes there).
//!
//! The gate refuses the merge when the views apart in a whole are at least [`MIN_APART_VIEWS`],
//! at least a share [`MIN_APART_SHARE`] of the views that see both sides, and more than the views
//! together. SAM's wholes come in some views only, and a stray nested mask (a mask grown by a
//! pixel over its neighbour) in one or two views is weak evidence; a share keeps the rule the same
//! for 12 views and for 100 (on the tuning replay the share of a quarter refuses 226 rather than
//! 231 of the 309 wrong merges below, and 201 rather than 332 correct ones). Where SAM gives no nested masks (the synthetic SAM gives
//! none over floors and walls) nothing is *apart in a whole* and the gate leaves the pair to the
//! score; a piece SAM cut off by a random line is held whole by other views, where the lines fall
//! elsewhere.
//!
//! Measured on the tuning families (seeds 0–7, 24 views; every merge the current merge executes,
//! replayed against the ground truth, with the gate's evidence computed as here from the
//! rendered depth): it would refuse 226 of the 309 merges that join two objects at a contact (76 %
//! of their pixels) and 201 of the 51,103 correct merges (0.1 % of their pixels; 47 of 13,604
//! between parts of patterned objects). No single-view cue tried (the minima rule on the union's
//! outline, the descriptor cosine, the score, the crease) separated them
//! (`docs/benchmarks/15-touching-objects.md`).
//!
//! # Cost
//!
//! [`ViewMaskSets::new`] looks each sampled visible Gaussian's pixel up in every mask's runs
//! (binary search per run); [`WholesEvidence`] groups the observations by Gaussian, like the
//! matching's 3D evidence; one evaluation reads the entries of the zones' Gaussians only, and the
//! merge asks only for pairs every other rule would accept.

use splatseg_cues::MaskInput;
use std::collections::BTreeMap;

/// Fewest Gaussians of each side another view must see for its masks to count.
pub const MIN_SIDE_GAUSSIANS: u32 = 3;

/// Fewest views holding the two sides apart in a whole for the gate to refuse.
pub const MIN_APART_VIEWS: u32 = 2;

/// Smallest share of the views that see both sides which must hold them apart in a whole.
pub const MIN_APART_SHARE: f32 = 0.25;

/// The distinct sets of masks that hold the pixels of one view's sampled visible Gaussians.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ViewMaskSets {
    /// `[n]` sampled visible Gaussians, strictly increasing.
    gaussians: Vec<u32>,
    /// `[n]` the mask set of each (index into the sets; set 0 is the empty set).
    set_of: Vec<u32>,
    /// `[n_sets + 1]` start of each set in `masks`.
    starts: Vec<u32>,
    /// The sets' mask indices (positions in the view's mask list), each set increasing.
    masks: Vec<u32>,
}

impl ViewMaskSets {
    /// The masks holding the centre pixel of each visible Gaussian whose index is a multiple of
    /// `stride`. `gaussians`, `pixels`: `[n_visible]` Gaussian indices (strictly increasing) and
    /// the row-major index of the pixel each centre falls in; `masks`: the view's SAM masks
    /// (overlapping, in any order).
    pub fn new(masks: &[MaskInput], gaussians: &[u32], pixels: &[u32], stride: u32) -> Self {
        let stride = stride.max(1);
        let kept: Vec<(u32, u32)> = gaussians
            .iter()
            .zip(pixels)
            .filter(|(&g, _)| g.is_multiple_of(stride))
            .map(|(&g, &p)| (g, p))
            .collect();
        // Query positions sorted by pixel, to find those inside a run by binary search.
        let mut by_pixel: Vec<(u32, u32)> =
            kept.iter().enumerate().map(|(i, &(_, p))| (p, i as u32)).collect();
        by_pixel.sort_unstable();
        let mut held: Vec<(u32, u32)> = Vec::new(); // (query, mask)
        for (k, mask) in masks.iter().enumerate() {
            for &(start, len) in &mask.runs {
                let lo = by_pixel.partition_point(|&(p, _)| p < start);
                let hi = by_pixel.partition_point(|&(p, _)| p < start + len);
                held.extend(by_pixel[lo..hi].iter().map(|&(_, q)| (q, k as u32)));
            }
        }
        held.sort_unstable();
        held.dedup();
        let mut sets: BTreeMap<Vec<u32>, u32> = BTreeMap::new();
        sets.insert(Vec::new(), 0);
        let mut order: Vec<Vec<u32>> = vec![Vec::new()];
        let mut set_of = vec![0u32; kept.len()];
        let mut i = 0;
        while i < held.len() {
            let q = held[i].0;
            let mut set = Vec::new();
            while i < held.len() && held[i].0 == q {
                set.push(held[i].1);
                i += 1;
            }
            let next = order.len() as u32;
            let id = *sets.entry(set.clone()).or_insert_with(|| {
                order.push(set);
                next
            });
            set_of[q as usize] = id;
        }
        let mut starts = Vec::with_capacity(order.len() + 1);
        let mut flat = Vec::new();
        starts.push(0);
        for set in &order {
            flat.extend_from_slice(set);
            starts.push(flat.len() as u32);
        }
        ViewMaskSets { gaussians: kept.iter().map(|&(g, _)| g).collect(), set_of, starts, masks: flat }
    }

    /// The masks of set `set`.
    fn set(&self, set: u32) -> &[u32] {
        &self.masks[self.starts[set as usize] as usize..self.starts[set as usize + 1] as usize]
    }
}

/// Every view's mask sets, grouped by Gaussian: which masks of which views hold each sampled
/// Gaussian (every `stride`-th).
#[derive(Clone, Debug, Default)]
pub struct WholesEvidence {
    stride: u32,
    /// `[n_rows + 1]` start of each row's entries; row `r` is Gaussian `r · stride`.
    starts: Vec<usize>,
    /// `(view, set)` per observation, grouped by row, views increasing.
    entries: Vec<(u32, u32)>,
    /// `[n_views]` the sets of each view (their Gaussian lists are dropped).
    views: Vec<ViewMaskSets>,
}

impl WholesEvidence {
    /// Groups `views` (`[n_views]`, in the scene's view order; a view without masks or
    /// Gaussians is an empty [`ViewMaskSets`]) by Gaussian; `stride` as they were sampled with.
    pub fn new(n_gaussians: usize, stride: u32, mut views: Vec<ViewMaskSets>) -> Self {
        let stride = stride.max(1);
        let n_rows = n_gaussians.div_ceil(stride as usize);
        let row = |g: u32| (g / stride) as usize;
        let mut counts = vec![0usize; n_rows + 1];
        for v in &views {
            for &g in &v.gaussians {
                if row(g) < n_rows {
                    counts[row(g) + 1] += 1;
                }
            }
        }
        for r in 0..n_rows {
            counts[r + 1] += counts[r];
        }
        let starts = counts.clone();
        let mut fill = counts;
        let mut entries = vec![(0u32, 0u32); starts[n_rows]];
        for (w, v) in views.iter().enumerate() {
            for (&g, &set) in v.gaussians.iter().zip(&v.set_of) {
                if row(g) < n_rows {
                    entries[fill[row(g)]] = (w as u32, set);
                    fill[row(g)] += 1;
                }
            }
        }
        for v in &mut views {
            v.gaussians = Vec::new();
            v.set_of = Vec::new();
        }
        WholesEvidence { stride, starts, entries, views }
    }

    /// Number of views.
    pub fn views(&self) -> usize {
        self.views.len()
    }

    /// The row of Gaussian `g`, when it was sampled.
    fn row(&self, g: u32) -> Option<u32> {
        let r = g / self.stride;
        (g.is_multiple_of(self.stride) && (r as usize) + 1 < self.starts.len()).then_some(r)
    }

    fn entries(&self, row: u32) -> &[(u32, u32)] {
        &self.entries[self.starts[row as usize]..self.starts[row as usize + 1]]
    }
}

/// What other views' masks say about one pair: views *together*, views *apart in a whole*, and
/// the views that see both sides.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WholesCount {
    /// Views where one mask holds both sides.
    pub together: u32,
    /// Views where no mask holds both and a side is held by nested masks.
    pub apart: u32,
    /// Views that see at least [`MIN_SIDE_GAUSSIANS`] of each side's Gaussians.
    pub seen: u32,
}

impl WholesCount {
    /// True when the pair belongs to different wholes by the rule of the module docs.
    pub fn separate(self) -> bool {
        self.apart >= MIN_APART_VIEWS
            && self.apart as f32 >= MIN_APART_SHARE * self.seen as f32
            && self.together < self.apart
    }
}

/// The evidence as one view's merge reads it: the view's own sampled visible Gaussians by pixel.
#[derive(Clone, Debug)]
pub struct ViewWholes<'a> {
    evidence: &'a WholesEvidence,
    view: u32,
    /// The view's image size `(W, H)`, checked against the label map.
    pub(crate) size: (usize, usize),
    /// `(pixel, row)` of the view's sampled visible Gaussians, sorted.
    by_pixel: Vec<(u32, u32)>,
}

/// Reusable buffers for [`ViewWholes::count`].
#[derive(Default)]
pub(crate) struct WholesScratch {
    zone: [Vec<u32>; 2],
    held: [Vec<(u32, u32)>; 2],
    seen: [Vec<u32>; 2],
    masks: [Vec<u32>; 2],
}

/// How far from its band pixels a side's zone reaches, px (band: ≤ 2 px from the other side,
/// so the zone reaches ≈ 4 px).
const ZONE_REACH_PX: i64 = 2;

impl<'a> ViewWholes<'a> {
    /// View `view`'s handle; `gaussians`, `pixels`: `[n_visible]` the Gaussians it sees and the
    /// row-major pixel of each centre in its `W × H` image, `size = (W, H)` (only the sampled
    /// ones are kept).
    pub fn new(
        evidence: &'a WholesEvidence,
        view: usize,
        (gaussians, pixels): (&[u32], &[u32]),
        size: (usize, usize),
    ) -> Self {
        let mut by_pixel: Vec<(u32, u32)> =
            gaussians.iter().zip(pixels).filter_map(|(&g, &p)| evidence.row(g).map(|r| (p, r))).collect();
        by_pixel.sort_unstable();
        ViewWholes { evidence, view: view as u32, size, by_pixel }
    }

    /// Each side's zone (see the module docs) into `scratch.zone`, sorted.
    fn zones(&self, band: &[u32], side: &mut impl FnMut(u32) -> Option<bool>, scratch: &mut WholesScratch) {
        let (w, h) = (self.size.0 as i64, self.size.1 as i64);
        scratch.zone.iter_mut().for_each(Vec::clear);
        for &p in band {
            let Some(mine) = side(p) else { continue };
            let (x, y) = (p as i64 % w, p as i64 / w);
            for qy in (y - ZONE_REACH_PX).max(0)..=(y + ZONE_REACH_PX).min(h - 1) {
                for qx in (x - ZONE_REACH_PX).max(0)..=(x + ZONE_REACH_PX).min(w - 1) {
                    let q = (qy * w + qx) as u32;
                    if side(q) == Some(mine) {
                        scratch.zone[usize::from(!mine)].push(q);
                    }
                }
            }
        }
        for (k, zone) in scratch.zone.iter_mut().enumerate() {
            zone.sort_unstable();
            zone.dedup();
            let other = Some(k == 1);
            // Not next to the other side: its 3×3 window (inside the image) holds none of it.
            zone.retain(|&q| {
                let (x, y) = (q as i64 % w, q as i64 / w);
                !((y - 1).max(0)..=(y + 1).min(h - 1)).any(|ny| {
                    ((x - 1).max(0)..=(x + 1).min(w - 1)).any(|nx| side((ny * w + nx) as u32) == other)
                })
            });
        }
    }

    /// The counts for the pair whose band is `band` (sorted pixel indices); `side(p)`: `Some(true)`
    /// for a pixel of the first region, `Some(false)` of the second, `None` otherwise.
    pub(crate) fn count(
        &self,
        band: &[u32],
        side: &mut impl FnMut(u32) -> Option<bool>,
        scratch: &mut WholesScratch,
    ) -> WholesCount {
        let n_views = self.evidence.views();
        self.zones(band, side, scratch);
        for k in 0..2 {
            scratch.held[k].clear();
            scratch.seen[k].clear();
            scratch.seen[k].resize(n_views, 0);
        }
        for k in 0..2 {
            for i in 0..scratch.zone[k].len() {
                let p = scratch.zone[k][i];
                let lo = self.by_pixel.partition_point(|&(q, _)| q < p);
                for &(_, row) in self.by_pixel[lo..].iter().take_while(|&&(q, _)| q == p) {
                    for &(w, set) in self.evidence.entries(row) {
                        if w == self.view {
                            continue;
                        }
                        scratch.seen[k][w as usize] += 1;
                        let masks = self.evidence.views[w as usize].set(set);
                        scratch.held[k].extend(masks.iter().map(|&m| (w, m)));
                    }
                }
            }
        }
        classify(n_views, &scratch.seen, &mut scratch.held, &mut scratch.masks)
    }
}

impl WholesEvidence {
    /// What every view's masks say about two sets of Gaussians (`sides`: Gaussian indices, any
    /// order; only the sampled ones count), e.g. two objects of the lift: the same counts as a
    /// pair's zones in [`ViewWholes`], over whole sets and all views.
    pub fn count_gaussians(&self, sides: [&[u32]; 2]) -> WholesCount {
        let n_views = self.views();
        let mut seen = [vec![0u32; n_views], vec![0u32; n_views]];
        let mut held: [Vec<(u32, u32)>; 2] = Default::default();
        for k in 0..2 {
            for row in sides[k].iter().filter_map(|&g| self.row(g)) {
                for &(w, set) in self.entries(row) {
                    seen[k][w as usize] += 1;
                    held[k].extend(self.views[w as usize].set(set).iter().map(|&m| (w, m)));
                }
            }
        }
        classify(n_views, &seen, &mut held, &mut Default::default())
    }

    /// What every view's masks hold of one set of Gaussians, gathered once so that the set can be
    /// counted against many others ([`WholesEvidence::count_observed`]).
    pub fn observe(&self, gaussians: &[u32]) -> Observed {
        let mut seen = vec![0u32; self.views()];
        let mut held: Vec<(u32, u32)> = Vec::new();
        for row in gaussians.iter().filter_map(|&g| self.row(g)) {
            for &(w, set) in self.entries(row) {
                seen[w as usize] += 1;
                held.extend(self.views[w as usize].set(set).iter().map(|&m| (w, m)));
            }
        }
        held.sort_unstable();
        Observed { seen, held }
    }

    /// [`WholesEvidence::count_gaussians`] of two sets observed by [`WholesEvidence::observe`]
    /// (the same counts).
    pub fn count_observed(&self, sides: [&Observed; 2]) -> WholesCount {
        let seen = [sides[0].seen.clone(), sides[1].seen.clone()];
        let mut held = [sides[0].held.clone(), sides[1].held.clone()];
        classify(self.views(), &seen, &mut held, &mut Default::default())
    }
}

/// One set of Gaussians as every view's masks hold it ([`WholesEvidence::observe`]).
#[derive(Clone, Debug, Default)]
pub struct Observed {
    /// `[n_views]` the set's Gaussians each view sees.
    seen: Vec<u32>,
    /// A `(view, mask)` per observation inside a mask, sorted.
    held: Vec<(u32, u32)>,
}

/// The counts from each side's observations: `seen[k][w]` the side's Gaussians view `w` sees,
/// `held[k]` a `(view, mask)` per observation inside a mask (sorted here). `masks`: scratch.
fn classify(
    n_views: usize,
    seen: &[Vec<u32>; 2],
    held: &mut [Vec<(u32, u32)>; 2],
    masks: &mut [Vec<u32>; 2],
) -> WholesCount {
    for list in held.iter_mut() {
        list.sort_unstable();
    }
    let mut count = WholesCount::default();
    let mut at = [0usize; 2];
    for w in 0..n_views as u32 {
        let seen = [seen[0][w as usize], seen[1][w as usize]];
        for k in 0..2 {
            // The masks of view w holding side k: at least half of its Gaussians seen by w.
            masks[k].clear();
            let list = &held[k];
            while at[k] < list.len() && list[at[k]].0 == w {
                let m = list[at[k]].1;
                let mut n = 0;
                while at[k] < list.len() && list[at[k]] == (w, m) {
                    n += 1;
                    at[k] += 1;
                }
                if 2 * n >= seen[k] {
                    masks[k].push(m);
                }
            }
        }
        if seen[0] < MIN_SIDE_GAUSSIANS || seen[1] < MIN_SIDE_GAUSSIANS {
            continue;
        }
        count.seen += 1;
        let [a, b] = &*masks;
        if a.iter().any(|m| b.binary_search(m).is_ok()) {
            count.together += 1;
        } else if a.len() >= 2 || b.len() >= 2 {
            count.apart += 1;
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;
    use splatseg_scene::Plane;

    /// A mask over the pixels `x0..x1` of every row of a `w × h` image.
    fn columns(w: usize, h: usize, x0: usize, x1: usize) -> MaskInput {
        let plane =
            Plane { width: w, height: h, data: (0..w * h).map(|p| (x0..x1).contains(&(p % w))).collect() };
        MaskInput::from_plane(&plane, 0.9, 0.9)
    }

    #[test]
    fn mask_sets_hold_every_mask_over_a_pixel_and_keep_the_sampled_gaussians() {
        let masks = [columns(8, 2, 0, 4), columns(8, 2, 0, 8), columns(8, 2, 6, 8)];
        let gaussians = [0, 1, 2, 4, 6];
        let pixels = [1, 5, 7, 9, 3];
        let sets = ViewMaskSets::new(&masks, &gaussians, &pixels, 2);
        assert_eq!(sets.gaussians, vec![0, 2, 4, 6]);
        let held: Vec<&[u32]> = sets.set_of.iter().map(|&s| sets.set(s)).collect();
        assert_eq!(held, vec![&[0, 1][..], &[1, 2][..], &[0, 1][..], &[0, 1][..]]);
        assert_eq!(sets.set(0), &[] as &[u32]);
    }

    #[test]
    fn two_sets_of_gaussians_are_separate_when_views_nest_one_and_no_mask_holds_both() {
        // Gaussian g at pixel g of an 8 × 1 image; sides 0..4 and 4..8.
        let gaussians: Vec<u32> = (0..8).collect();
        let nested = [columns(8, 1, 0, 4), columns(8, 1, 0, 2), columns(8, 1, 4, 8)];
        let one_mask = [columns(8, 1, 0, 8)];
        let plain = [columns(8, 1, 0, 4), columns(8, 1, 4, 8)];
        let sets = |masks: &[MaskInput]| ViewMaskSets::new(masks, &gaussians, &gaussians, 1);
        let (a, b): (Vec<u32>, Vec<u32>) = ((0..4).collect(), (4..8).collect());
        let count = |views: Vec<ViewMaskSets>| {
            let evidence = WholesEvidence::new(8, 1, views);
            let c = evidence.count_gaussians([&a, &b]);
            let observed = evidence.count_observed([&evidence.observe(&a), &evidence.observe(&b)]);
            assert_eq!(observed, c, "observed once, counted the same");
            c
        };
        // Apart in a whole in two views, together in one, no hierarchy in one: separate.
        let c = count(vec![sets(&nested), sets(&one_mask), sets(&nested), sets(&plain)]);
        assert_eq!(c, WholesCount { together: 1, apart: 2, seen: 4 });
        assert!(c.separate());
        // As many views together as apart: not separate.
        let c = count(vec![sets(&nested), sets(&one_mask), sets(&nested), sets(&one_mask)]);
        assert_eq!(c, WholesCount { together: 2, apart: 2, seen: 4 });
        assert!(!c.separate());
        // One mask each everywhere: SAM says nothing about wholes.
        assert_eq!(count(vec![sets(&plain); 3]), WholesCount { together: 0, apart: 0, seen: 3 });
    }
}
