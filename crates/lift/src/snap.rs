//! Snapping rendered-back ids onto a view's merged regions: every merged region takes the
//! global id that the label map rendered from the Gaussians gives most of its pixels, so the
//! final map has the merged masks' boundaries (sharp, from the image) and the 3D consensus ids
//! (the same in every view).
//!
//! Per region (local id `r ≥ 1` of the merged map): count the rendered ids over its pixels,
//! ignoring 0. The id with most pixels wins; ties go to the smaller id, so the result does not
//! depend on pixel order. When the winner covers fewer pixels than the region's 0-rendered
//! pixels (the Gaussians mostly say "no object" there), or no pixel has an id, the region keeps
//! its rendered labels pixel by pixel. Pixels outside every region (merged 0) keep their
//! rendered label too, so nothing the Gaussians label is lost.

use splatseg_scene::Plane;
use std::collections::BTreeMap;

/// The snapped label map. `regions`: `[H, W]` merged regions of the view, 0 = none, any local
/// ids; `rendered`: `[H, W]` global ids rendered back from the Gaussians, 0 = none. Returns
/// `[H, W]` global ids (see the module docs; `split_share` above 1 snaps every region). Panics if
/// the two sizes differ.
pub fn snap_to_regions(regions: &Plane<u32>, rendered: &Plane<u32>, split_share: f32) -> Plane<u32> {
    assert_eq!(regions.size(), rendered.size(), "regions and rendered map differ in size");
    // counts[region] = (pixels rendered 0, pixels per rendered id ≥ 1).
    let mut counts: BTreeMap<u32, (u64, BTreeMap<u32, u64>)> = BTreeMap::new();
    for (&r, &k) in regions.data.iter().zip(&rendered.data) {
        if r == 0 {
            continue;
        }
        let entry = counts.entry(r).or_default();
        if k == 0 {
            entry.0 += 1;
        } else {
            *entry.1.entry(k).or_insert(0) += 1;
        }
    }
    // winner[region] = (its id, whether the region is split between two objects); absent = keep
    // the rendered labels.
    let winner: BTreeMap<u32, (u32, bool)> = counts
        .into_iter()
        .filter_map(|(r, (zeros, ids))| {
            // Ascending ids with a strict `>`: the smallest id wins ties.
            let (mut best, mut second): (Option<(u32, u64)>, u64) = (None, 0);
            let labelled: u64 = ids.values().sum();
            for (k, n) in ids {
                match best {
                    Some((_, m)) if n <= m => second = second.max(n),
                    _ => {
                        second = second.max(best.map_or(0, |(_, m)| m));
                        best = Some((k, n));
                    }
                }
            }
            let split = second as f64 >= split_share as f64 * labelled as f64;
            best.filter(|&(_, n)| n >= zeros).map(|(k, _)| (r, (k, split)))
        })
        .collect();
    let data = regions
        .data
        .iter()
        .zip(&rendered.data)
        .map(|(r, &k)| match winner.get(r) {
            Some(&(_, true)) if k != 0 => k,
            Some(&(id, _)) => id,
            None => k,
        })
        .collect();
    Plane { width: regions.width, height: regions.height, data }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plane(width: usize, rows: &[&[u32]]) -> Plane<u32> {
        Plane::from_vec(width, rows.len(), rows.concat()).expect("rectangular")
    }

    #[test]
    fn a_region_takes_its_majority_rendered_id() {
        // Region 1 = left three columns, region 2 = right column, row 2 outside every region.
        let regions = plane(4, &[&[1, 1, 1, 2], &[1, 1, 1, 2], &[0, 0, 0, 0]]);
        let rendered = plane(4, &[&[7, 7, 3, 3], &[7, 0, 7, 9], &[5, 0, 5, 5]]);
        let snapped = snap_to_regions(&regions, &rendered, 2.0);
        // Region 1: 7 ×4, 3 ×1, 0 ×1 → all 7. Region 2: 3 and 9 tie → 3 (smaller id).
        // Outside: rendered labels kept.
        assert_eq!(snapped, plane(4, &[&[7, 7, 7, 3], &[7, 7, 7, 3], &[5, 0, 5, 5]]));
    }

    #[test]
    fn ties_go_to_the_smaller_id_whatever_the_pixel_order() {
        let regions = plane(4, &[&[4, 4, 4, 4]]);
        for rendered in [plane(4, &[&[8, 8, 2, 2]]), plane(4, &[&[2, 8, 2, 8]]), plane(4, &[&[2, 2, 8, 8]])] {
            assert_eq!(snap_to_regions(&regions, &rendered, 2.0), plane(4, &[&[2, 2, 2, 2]]));
        }
    }

    #[test]
    fn regions_the_gaussians_mostly_leave_unlabelled_keep_the_rendered_labels() {
        let regions = plane(5, &[&[1, 1, 1, 1, 1], &[2, 2, 2, 2, 2]]);
        let rendered = plane(5, &[&[0, 0, 0, 6, 6], &[0, 0, 0, 0, 0]]);
        // Region 1: 0 ×3 beats 6 ×2; region 2: no id at all.
        assert_eq!(snap_to_regions(&regions, &rendered, 2.0), rendered);
    }

    #[test]
    fn a_region_over_two_objects_keeps_the_rendered_labels() {
        // One region over two objects the Gaussians tell apart (7 ×3, 4 ×2, one pixel 0).
        let regions = plane(6, &[&[1, 1, 1, 1, 1, 1]]);
        let rendered = plane(6, &[&[7, 7, 7, 0, 4, 4]]);
        // 4 has 2 of 5 labelled pixels (0.4): at split share 0.25 the region is split, its
        // 0 pixel takes the majority id; at 0.5 it is snapped whole.
        assert_eq!(snap_to_regions(&regions, &rendered, 0.25), plane(6, &[&[7, 7, 7, 7, 4, 4]]));
        assert_eq!(snap_to_regions(&regions, &rendered, 0.5), plane(6, &[&[7, 7, 7, 7, 7, 7]]));
    }
}
