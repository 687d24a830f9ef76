//! Snapping rendered-back ids onto a view's regions: by default SAM's masks resolved into
//! regions before merging (`[final_maps] kind = "snapped-raw"`), or the merged regions
//! (`"snapped"`). Every region takes the global id that the label map rendered from the Gaussians
//! gives most of its pixels, so the final map has the regions' boundaries (sharp, from the
//! image) and the 3D consensus ids (the same in every view).
//!
//! Per region (local id `r ≥ 1` of the region map): count the rendered ids over its pixels,
//! ignoring 0. The id with most pixels wins; ties go to the smaller id, so the result does not
//! depend on pixel order. When the winner covers fewer pixels than the region's 0-rendered
//! pixels (the Gaussians mostly say "no object" there), or no pixel has an id, the region keeps
//! its rendered labels pixel by pixel. Pixels outside every region (0) keep their
//! rendered label too, so nothing the Gaussians label is lost.
//!
//! A region over two objects keeps the rendered labels, except a thin band of another id along
//! pixels of that id outside the region: the splats of a neighbouring object bleeding across the
//! SAM boundary, given to the region's own objects. A region is taken for two objects when
//! ([`SnapRule`]) the second id covers at least `split_share` of its labelled pixels, or when an
//! id other than the winner lies mostly inside the region (`contained_share` of all the view's
//! pixels of that id) and covers at least `contained_min_share` of it: an object SAM merged into
//! its neighbour's mask (a post with the box beside it) is not split off by a share rule alone,
//! while the blur of a neighbour's splats into the region leaves most of that neighbour outside.

use splatseg_scene::Plane;
use std::collections::BTreeMap;

/// When a region is kept as several objects rather than snapped whole, and what of a split region
/// goes back to it (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SnapRule {
    /// Split when the second most rendered id covers at least this share of the region's
    /// labelled pixels (above 1: never by this rule).
    pub split_share: f32,
    /// Split when an id other than the winner has at least this share of all its rendered
    /// pixels in the view inside the region (above 1: never by this rule)…
    pub contained_share: f32,
    /// …and covers at least this share of the region's labelled pixels…
    pub contained_min_share: f32,
    /// …and at least this many pixels (smaller: a fragment of the region's own object, left
    /// with an id of its own in 3D).
    pub contained_min_px: u64,
    /// The thickest band of a neighbour's splats given back to a split region (pixels / contact
    /// length), 0 = none.
    pub bleed_px: f32,
}

impl SnapRule {
    /// Every region snapped whole, nothing given back.
    pub const SNAP_ALL: SnapRule = SnapRule {
        split_share: 2.0,
        contained_share: 2.0,
        contained_min_share: 2.0,
        contained_min_px: 0,
        bleed_px: 0.0,
    };
}

/// What snapping one view gives.
#[derive(Clone, Debug, PartialEq)]
pub struct Snapped {
    /// `[H, W]` global ids (0 = none).
    pub labels: Plane<u32>,
    /// `[H, W]` at each pixel that keeps an id other than its region's winner only because the
    /// containment rule split the region: the winner (what the share rule alone would have
    /// given it); 0 elsewhere. An id no view's region is won by is a fragment of the objects
    /// around it, not an object SAM merged into a neighbour: the caller gives its pixels these
    /// ids back once every view is snapped.
    pub contained_fallback: Plane<u32>,
    /// Ids that win at least one region of the view, ascending.
    pub region_winners: Vec<u32>,
}

/// Why a region keeps several rendered ids.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Split {
    /// Snapped whole to its winner.
    No,
    /// The second id covers `split_share` of it.
    Share,
    /// Only an id lying mostly inside it.
    Contained,
}

/// Snaps one view. `regions`: `[H, W]` regions of the view (SAM's or merged), 0 = none, any local ids;
/// `rendered`: `[H, W]` global ids rendered back from the Gaussians, 0 = none. See the module
/// docs and [`SnapRule`]. Panics if the two sizes differ.
pub fn snap_view(regions: &Plane<u32>, rendered: &Plane<u32>, rule: &SnapRule) -> Snapped {
    assert_eq!(regions.size(), rendered.size(), "regions and rendered map differ in size");
    // in_view[id] = pixels rendered with that id over the whole view.
    let mut in_view: BTreeMap<u32, u64> = BTreeMap::new();
    // counts[region] = (pixels rendered 0, pixels per rendered id ≥ 1).
    let mut counts: BTreeMap<u32, (u64, BTreeMap<u32, u64>)> = BTreeMap::new();
    // Counted run by run of equal (region, id) pixels (row-major), the same sums.
    for ((r, k), n) in pair_runs(&regions.data, &rendered.data) {
        if k != 0 {
            *in_view.entry(k).or_insert(0) += n;
        }
        if r == 0 {
            continue;
        }
        let entry = counts.entry(r).or_default();
        if k == 0 {
            entry.0 += n;
        } else {
            *entry.1.entry(k).or_insert(0) += n;
        }
    }
    // winner[region] = (its id, why it is split, if it is); absent = keep the rendered labels.
    let winner: BTreeMap<u32, (u32, Split)> = counts
        .into_iter()
        .filter_map(|(r, (zeros, ids))| {
            // Ascending ids with a strict `>`: the smallest id wins ties.
            let (mut best, mut second): (Option<(u32, u64)>, u64) = (None, 0);
            let labelled: u64 = ids.values().sum();
            for (&k, &n) in &ids {
                match best {
                    Some((_, m)) if n <= m => second = second.max(n),
                    _ => {
                        second = second.max(best.map_or(0, |(_, m)| m));
                        best = Some((k, n));
                    }
                }
            }
            let best = best.filter(|&(_, n)| n >= zeros)?;
            let at_least = |n: u64, share: f32| n as f64 >= share as f64 * labelled as f64;
            let contained = ids.iter().any(|(k, &n)| {
                *k != best.0
                    && at_least(n, rule.contained_min_share)
                    && n >= rule.contained_min_px
                    && n as f64 >= rule.contained_share as f64 * in_view[k] as f64
            });
            let split = if at_least(second, rule.split_share) {
                Split::Share
            } else if contained {
                Split::Contained
            } else {
                Split::No
            };
            Some((r, (best.0, split)))
        })
        .collect();
    // The region's entry is looked up once per run of pixels of one region.
    let mut last: Option<(u32, Option<(u32, Split)>)> = None;
    let mut winner_of = |r: u32| match last {
        Some((region, w)) if region == r => w,
        _ => {
            let w = winner.get(&r).copied();
            last = Some((r, w));
            w
        }
    };
    let mut data: Vec<u32> = regions
        .data
        .iter()
        .zip(&rendered.data)
        .map(|(&r, &k)| match winner_of(r) {
            Some((_, Split::Share | Split::Contained)) if k != 0 => k,
            Some((id, _)) => id,
            None => k,
        })
        .collect();
    give_bleeding_pixels_to_their_region(regions, &winner, &mut data, rule.bleed_px);
    let fallback: Vec<u32> = regions
        .data
        .iter()
        .zip(&data)
        .map(|(&r, &k)| match winner_of(r) {
            Some((id, Split::Contained)) if k != 0 && k != id => id,
            _ => 0,
        })
        .collect();
    let mut region_winners: Vec<u32> = winner.values().map(|&(id, _)| id).collect();
    region_winners.sort_unstable();
    region_winners.dedup();
    let (width, height) = (regions.width, regions.height);
    Snapped {
        labels: Plane { width, height, data },
        contained_fallback: Plane { width, height, data: fallback },
        region_winners,
    }
}

/// The runs of equal `(a[p], b[p])` pairs of `a`, `b` (`[n]` each), in order, with their lengths.
fn pair_runs<'a>(a: &'a [u32], b: &'a [u32]) -> impl Iterator<Item = ((u32, u32), u64)> + 'a {
    let mut pairs = a.iter().copied().zip(b.iter().copied()).peekable();
    std::iter::from_fn(move || {
        let first = pairs.next()?;
        let mut n = 1u64;
        while pairs.next_if_eq(&first).is_some() {
            n += 1;
        }
        Some((first, n))
    })
}

/// In a region split between objects, the pixels of a rendered id other than the region's
/// winner that lie along pixels of that id outside the region (a neighbouring region it wins,
/// or the unlabelled pixels between SAM's masks), in a band no thicker than
/// `bleed_px` (pixels / contact length), are the object's splats bleeding across the SAM
/// boundary (a thin post's footprint over the object behind it), not an object of this region:
/// they take the label of the nearest pixel of the region's other ids (breadth-first within the
/// region, 4-neighbours, in row-major order, so the result does not depend on threads). `data`:
/// `[H · W]` snapped labels, updated in place.
fn give_bleeding_pixels_to_their_region(
    regions: &Plane<u32>,
    winner: &BTreeMap<u32, (u32, Split)>,
    data: &mut [u32],
    bleed_px: f32,
) {
    if bleed_px <= 0.0 || winner.values().all(|&(_, split)| split == Split::No) {
        return;
    }
    let (w, h) = (regions.width, regions.height);
    let split = |r: u32| matches!(winner.get(&r), Some(&(_, Split::Share | Split::Contained)));
    let wins = |r: u32, k: u32| matches!(winner.get(&r), Some(&(id, _)) if id == k);
    let neighbours = |p: usize| {
        let (x, y) = (p % w, p / w);
        [
            (x > 0).then(|| p - 1),
            (x + 1 < w).then(|| p + 1),
            (y > 0).then(|| p - w),
            (y + 1 < h).then(|| p + w),
        ]
        .into_iter()
        .flatten()
    };
    // (pixels, contact pixels) per (split region, non-winning id).
    let mut bands: BTreeMap<(u32, u32), (u64, u64)> = BTreeMap::new();
    // Neighbouring pixels mostly repeat the (region, id) pair: its test is kept for the next.
    let mut last: Option<((u32, u32), bool)> = None;
    for (p, (&r, &k)) in regions.data.iter().zip(data.iter()).enumerate() {
        let skip = match last {
            Some((pair, skip)) if pair == (r, k) => skip,
            _ => {
                let skip = r == 0 || k == 0 || !split(r) || wins(r, k);
                last = Some(((r, k), skip));
                skip
            }
        };
        if skip {
            continue;
        }
        let band = bands.entry((r, k)).or_default();
        band.0 += 1;
        if neighbours(p).any(|q| regions.data[q] != r && data[q] == k) {
            band.1 += 1;
        }
    }
    let bleeding: Vec<(u32, u32)> = bands
        .into_iter()
        .filter(|&(_, (n, contact))| contact > 0 && n as f64 <= bleed_px as f64 * contact as f64)
        .map(|(pair, _)| pair)
        .collect();
    if bleeding.is_empty() {
        return;
    }
    let mut last: Option<((u32, u32), bool)> = None;
    let mut todo: Vec<bool> = regions
        .data
        .iter()
        .zip(data.iter())
        .map(|(&r, &k)| match last {
            Some((pair, bleeds)) if pair == (r, k) => bleeds,
            _ => {
                let bleeds = r != 0 && bleeding.binary_search(&(r, k)).is_ok();
                last = Some(((r, k), bleeds));
                bleeds
            }
        })
        .collect();
    // Seeds: pixels of the region's other ids next to a pixel to relabel.
    let mut queue: std::collections::VecDeque<usize> = (0..data.len())
        .filter(|&p| !todo[p] && neighbours(p).any(|q| todo[q] && regions.data[q] == regions.data[p]))
        .collect();
    while let Some(p) = queue.pop_front() {
        for q in neighbours(p) {
            if todo[q] && regions.data[q] == regions.data[p] {
                todo[q] = false;
                data[q] = data[p];
                queue.push_back(q);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The share rule alone (no containment rule).
    fn shares(split_share: f32, bleed_px: f32) -> SnapRule {
        SnapRule { split_share, bleed_px, ..SnapRule::SNAP_ALL }
    }

    /// The labels of [`snap_view`].
    fn snapped_labels(regions: &Plane<u32>, rendered: &Plane<u32>, rule: &SnapRule) -> Plane<u32> {
        snap_view(regions, rendered, rule).labels
    }

    fn plane(width: usize, rows: &[&[u32]]) -> Plane<u32> {
        Plane::from_vec(width, rows.len(), rows.concat()).expect("rectangular")
    }

    #[test]
    fn pair_runs_are_the_runs_of_equal_pairs() {
        let runs: Vec<_> = pair_runs(&[1, 1, 2, 2, 2, 1], &[0, 0, 0, 1, 1, 0]).collect();
        assert_eq!(runs, vec![((1, 0), 2), ((2, 0), 1), ((2, 1), 2), ((1, 0), 1)]);
        assert_eq!(pair_runs(&[], &[]).count(), 0);
    }

    #[test]
    fn a_region_takes_its_majority_rendered_id() {
        // Region 1 = left three columns, region 2 = right column, row 2 outside every region.
        let regions = plane(4, &[&[1, 1, 1, 2], &[1, 1, 1, 2], &[0, 0, 0, 0]]);
        let rendered = plane(4, &[&[7, 7, 3, 3], &[7, 0, 7, 9], &[5, 0, 5, 5]]);
        let snapped = snapped_labels(&regions, &rendered, &SnapRule::SNAP_ALL);
        // Region 1: 7 ×4, 3 ×1, 0 ×1 → all 7. Region 2: 3 and 9 tie → 3 (smaller id).
        // Outside: rendered labels kept.
        assert_eq!(snapped, plane(4, &[&[7, 7, 7, 3], &[7, 7, 7, 3], &[5, 0, 5, 5]]));
    }

    #[test]
    fn ties_go_to_the_smaller_id_whatever_the_pixel_order() {
        let regions = plane(4, &[&[4, 4, 4, 4]]);
        for rendered in [plane(4, &[&[8, 8, 2, 2]]), plane(4, &[&[2, 8, 2, 8]]), plane(4, &[&[2, 2, 8, 8]])] {
            assert_eq!(snapped_labels(&regions, &rendered, &SnapRule::SNAP_ALL), plane(4, &[&[2, 2, 2, 2]]));
        }
    }

    #[test]
    fn regions_the_gaussians_mostly_leave_unlabelled_keep_the_rendered_labels() {
        let regions = plane(5, &[&[1, 1, 1, 1, 1], &[2, 2, 2, 2, 2]]);
        let rendered = plane(5, &[&[0, 0, 0, 6, 6], &[0, 0, 0, 0, 0]]);
        // Region 1: 0 ×3 beats 6 ×2; region 2: no id at all.
        assert_eq!(snapped_labels(&regions, &rendered, &SnapRule::SNAP_ALL), rendered);
    }

    #[test]
    fn a_region_over_two_objects_keeps_the_rendered_labels() {
        // One region over two objects the Gaussians tell apart (7 ×3, 4 ×2, one pixel 0).
        let regions = plane(6, &[&[1, 1, 1, 1, 1, 1]]);
        let rendered = plane(6, &[&[7, 7, 7, 0, 4, 4]]);
        // 4 has 2 of 5 labelled pixels (0.4): at split share 0.25 the region is split, its
        // 0 pixel takes the majority id; at 0.5 it is snapped whole.
        assert_eq!(snapped_labels(&regions, &rendered, &shares(0.25, 0.0)), plane(6, &[&[7, 7, 7, 7, 4, 4]]));
        assert_eq!(snapped_labels(&regions, &rendered, &shares(0.5, 0.0)), plane(6, &[&[7, 7, 7, 7, 7, 7]]));
    }

    #[test]
    fn a_thin_objects_splats_bleeding_into_a_split_region_go_back_to_its_objects() {
        // Region 1 (columns 0–5) lies over two objects (7 and 4); region 2 (columns 6–7) is a
        // post the Gaussians label 9, whose splats also cover column 5 of region 1: a band one
        // pixel thick along region 2; each of its pixels takes its nearest neighbour in the
        // region (4 above, 5 below: ties go to the first in row-major order). Column 4 of row 1 is
        // an id 5 with no region of its own next to it: it stays.
        let regions = plane(8, &[&[1, 1, 1, 1, 1, 1, 2, 2], &[1, 1, 1, 1, 1, 1, 2, 2]]);
        let rendered = plane(8, &[&[7, 7, 7, 4, 4, 9, 9, 9], &[7, 7, 4, 4, 5, 9, 9, 9]]);
        let given_back = plane(8, &[&[7, 7, 7, 4, 4, 4, 9, 9], &[7, 7, 4, 4, 5, 5, 9, 9]]);
        assert_eq!(snapped_labels(&regions, &rendered, &shares(0.25, 2.0)), given_back);
        // Without giving back, the band keeps the post's id.
        let kept = plane(8, &[&[7, 7, 7, 4, 4, 9, 9, 9], &[7, 7, 4, 4, 5, 9, 9, 9]]);
        assert_eq!(snapped_labels(&regions, &rendered, &shares(0.25, 0.0)), kept);
    }

    #[test]
    fn an_object_reaching_deep_into_a_split_region_keeps_its_pixels() {
        // Id 9 covers three columns of region 1 along region 2 (3 pixels thick): more than a
        // bleeding band of 2, so it is an object of region 1 too.
        let regions = plane(8, &[&[1, 1, 1, 1, 1, 1, 2, 2], &[1, 1, 1, 1, 1, 1, 2, 2]]);
        let rendered = plane(8, &[&[7, 7, 7, 9, 9, 9, 9, 9], &[7, 7, 7, 9, 9, 9, 9, 9]]);
        let snapped = snapped_labels(&regions, &rendered, &shares(0.25, 2.0));
        assert_eq!(snapped, plane(8, &[&[7, 7, 7, 9, 9, 9, 9, 9], &[7, 7, 7, 9, 9, 9, 9, 9]]));
    }

    #[test]
    fn an_object_sam_merged_into_its_neighbours_mask_is_split_off_when_it_lies_inside() {
        // Region 1 (columns 0–9) is SAM's one mask over a box (7) and a post beside it (9, two
        // columns, 20 % of the region: under a 0.25 share). Every pixel of 9 in the view lies in
        // region 1, so the region is two objects. Region 2 (columns 10–11) is the wall.
        let row: &[u32] = &[7, 7, 7, 7, 7, 7, 7, 7, 9, 9, 3, 3];
        let outline: &[u32] = &[1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 2, 2];
        let regions = plane(12, &[outline; 2]);
        let rendered = plane(12, &[row; 2]);
        let rule = SnapRule {
            contained_share: 0.5,
            contained_min_share: 0.05,
            contained_min_px: 4,
            ..shares(0.25, 0.0)
        };
        let snapped = snap_view(&regions, &rendered, &rule);
        assert_eq!(snapped.labels, rendered);
        // Only the containment rule keeps the post: its pixels fall back to the box's 7 if no
        // view's region is won by 9; the other pixels have no fallback.
        let fallback: &[u32] = &[0, 0, 0, 0, 0, 0, 0, 0, 7, 7, 0, 0];
        assert_eq!(snapped.contained_fallback, plane(12, &[fallback; 2]));
        assert_eq!(snapped.region_winners, vec![3, 7]);
        // The share rule alone gives the post to the box.
        let swallowed: &[u32] = &[7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 3, 3];
        assert_eq!(snapped_labels(&regions, &rendered, &shares(0.25, 0.0)), plane(12, &[swallowed; 2]));
        // Four pixels of the post are its minimum: with five it is a fragment, snapped away.
        let rule = SnapRule { contained_min_px: 5, ..rule };
        assert_eq!(snapped_labels(&regions, &rendered, &rule), plane(12, &[swallowed; 2]));
    }

    #[test]
    fn a_neighbours_blur_mostly_outside_the_region_does_not_split_it() {
        // The same 20 % of region 1 rendered 3, but 3 is the wall whose pixels lie mostly in
        // region 2: the blur of its splats, snapped away.
        let row: &[u32] = &[7, 7, 7, 7, 7, 7, 7, 7, 3, 3, 3, 3, 3, 3];
        let outline: &[u32] = &[1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 2, 2, 2, 2];
        let regions = plane(14, &[outline; 2]);
        let rendered = plane(14, &[row; 2]);
        let rule = SnapRule {
            contained_share: 0.5,
            contained_min_share: 0.05,
            contained_min_px: 4,
            ..shares(0.25, 0.0)
        };
        let snapped: &[u32] = &[7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 3, 3, 3, 3];
        assert_eq!(snapped_labels(&regions, &rendered, &rule), plane(14, &[snapped; 2]));
    }
}
