//! Overlapping SAM masks → a partition of the image into regions (the merge stage's input).
//!
//! SAM's automatic masks overlap (nested parts and wholes) and leave holes. The rule:
//!
//! 1. **Smaller masks on top.** Masks are ordered by area (ascending, ties broken by the pixels
//!    themselves, so the order the file lists them in does not matter) and each pixel goes to the
//!    smallest mask covering it. Merging then rebuilds wholes from their parts, which keeps the
//!    finest boundaries SAM found; the reverse (large on top) would hide parts under wholes and
//!    lose objects that only appear as parts.
//! 2. **Remnants.** A mask left with fewer than `min_region_px` visible pixels (almost entirely
//!    covered by smaller masks) is dropped and its visible pixels go to the next mask under it.
//! 3. **Uncovered pixels.** Each 4-connected component of pixels no mask covers is either filled
//!    (component smaller than `min_region_px`: it joins the neighbouring region it shares the
//!    longest border with; these are SAM's small holes) or, for larger components, handled by
//!    [`UncoveredPolicy`]: by default they stay unlabelled. Measured on the synthetic scene
//!    (12 views, paper profile): unlabelled 14.3 masks/view, per-view mIoU 0.924; own regions
//!    15.1 masks/view, mIoU 0.919. The large uncovered components SAM leaves are mostly thin
//!    eroded outlines between masks; as regions they are long slivers whose descriptors mix both
//!    sides, and they either survive as extra masks or glue onto the wrong side.
//! 4. **Ids.** Regions are numbered 1..=n in raster order of their first pixel; 0 = unlabelled.
//!    The result depends only on the set of masks, never on their order.
//!
//! SAM's quality fields (`predicted_iou`, `stability_score`) are kept per region.

use crate::error::{CuesError, CuesResult};
use splatseg_scene::Plane;

/// One input mask as row-major pixel runs, plus SAM's quality fields.
#[derive(Clone, Debug, PartialEq)]
pub struct MaskInput {
    /// Sorted, non-overlapping, non-empty runs `(start, len)` of row-major pixel indices
    /// (`y * width + x`).
    pub runs: Vec<(u32, u32)>,
    /// SAM's predicted IoU (0 when unknown).
    pub predicted_iou: f32,
    /// SAM's stability score (0 when unknown).
    pub stability_score: f32,
}

impl MaskInput {
    /// From a dense boolean mask (`[H, W]`).
    pub fn from_plane(mask: &Plane<bool>, predicted_iou: f32, stability_score: f32) -> Self {
        let mut runs = Vec::new();
        for y in 0..mask.height {
            let row = mask.row(y);
            let mut x = 0;
            while x < row.len() {
                if row[x] {
                    let start = x;
                    while x < row.len() && row[x] {
                        x += 1;
                    }
                    runs.push(((y * mask.width + start) as u32, (x - start) as u32));
                } else {
                    x += 1;
                }
            }
        }
        MaskInput { runs, predicted_iou, stability_score }
    }

    /// From COCO RLE counts (column-major runs starting with zeros, as pycocotools writes them)
    /// of a `width × height` mask. `scratch` is a reusable all-`false` buffer of `width·height`
    /// (left all-`false` on return). Errors if the counts do not sum to `width·height`.
    pub fn from_coco_counts(
        counts: &[u32],
        width: usize,
        height: usize,
        scratch: &mut Vec<bool>,
        quality: (f32, f32),
    ) -> Result<Self, String> {
        let total: u64 = counts.iter().map(|&c| c as u64).sum();
        if total != (width * height) as u64 {
            return Err(format!("RLE counts sum to {total}, expected {width}×{height} = {}", width * height));
        }
        scratch.clear();
        scratch.resize(width * height, false);
        let (mut pos, mut value) = (0usize, false);
        let (mut y_min, mut y_max) = (usize::MAX, 0usize);
        for &c in counts {
            if value {
                for idx in pos..pos + c as usize {
                    let (x, y) = (idx / height, idx % height);
                    scratch[y * width + x] = true;
                    y_min = y_min.min(y);
                    y_max = y_max.max(y);
                }
            }
            pos += c as usize;
            value = !value;
        }
        let mut runs = Vec::new();
        if y_min <= y_max {
            for y in y_min..=y_max {
                let row = &mut scratch[y * width..(y + 1) * width];
                let mut x = 0;
                while x < width {
                    if row[x] {
                        let start = x;
                        while x < width && row[x] {
                            row[x] = false;
                            x += 1;
                        }
                        runs.push(((y * width + start) as u32, (x - start) as u32));
                    } else {
                        x += 1;
                    }
                }
            }
        }
        Ok(MaskInput { runs, predicted_iou: quality.0, stability_score: quality.1 })
    }

    /// Pixel count.
    pub fn area(&self) -> u64 {
        self.runs.iter().map(|&(_, n)| n as u64).sum()
    }

    /// True if row-major pixel `idx` is in the mask.
    pub fn contains(&self, idx: u32) -> bool {
        let i = self.runs.partition_point(|&(s, _)| s <= idx);
        i > 0 && idx < self.runs[i - 1].0 + self.runs[i - 1].1
    }

    fn pixels(&self) -> impl Iterator<Item = usize> + '_ {
        self.runs.iter().flat_map(|&(s, n)| s as usize..(s + n) as usize)
    }
}

/// What happens to large areas no mask covers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum UncoveredPolicy {
    /// Each connected component becomes a region of its own.
    OwnRegions,
    /// They stay unlabelled (0) (default).
    #[default]
    Unlabelled,
}

/// How masks become regions.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct RegionOptions {
    /// Masks with fewer visible pixels are dropped; uncovered components with fewer pixels are
    /// filled from their neighbours.
    pub min_region_px: u32,
    /// What large uncovered components become.
    pub uncovered: UncoveredPolicy,
}

impl Default for RegionOptions {
    fn default() -> Self {
        RegionOptions { min_region_px: 32, uncovered: UncoveredPolicy::Unlabelled }
    }
}

/// Where a region came from.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum RegionSource {
    /// The visible part of a SAM mask.
    SamMask {
        /// Position of the mask in the input list.
        input_index: usize,
        /// SAM's predicted IoU.
        predicted_iou: f32,
        /// SAM's stability score.
        stability_score: f32,
        /// The mask's full area before overlaps were resolved.
        mask_area: u64,
    },
    /// A connected component no mask covered.
    Uncovered,
}

/// A partition of a view into regions.
#[derive(Clone, Debug, PartialEq)]
pub struct Regions {
    /// `[H, W]` labels: 0 = unlabelled, regions `1..=sources.len()`.
    pub labels: Plane<u32>,
    /// `[n]` origin of region `r + 1`.
    pub sources: Vec<RegionSource>,
}

impl Regions {
    /// Number of regions.
    pub fn count(&self) -> usize {
        self.sources.len()
    }
}

/// Resolves overlapping masks of a `width × height` view into [`Regions`] (rule in the module
/// documentation).
pub fn regions_from_sam_masks(
    masks: &[MaskInput],
    width: usize,
    height: usize,
    options: &RegionOptions,
) -> CuesResult<Regions> {
    let n_px = width * height;
    for (i, m) in masks.iter().enumerate() {
        if let Some(&(s, n)) = m.runs.last() {
            if (s + n) as usize > n_px {
                return Err(CuesError::shape(
                    format!("mask {i}"),
                    format!("runs exceed the {width}×{height} image"),
                ));
            }
        }
    }
    // 1. Order: smallest first, ties by content (independent of the input order).
    let areas: Vec<u64> = masks.iter().map(MaskInput::area).collect();
    let mut order: Vec<usize> = (0..masks.len()).filter(|&i| areas[i] > 0).collect();
    order.sort_by(|&a, &b| {
        areas[a].cmp(&areas[b]).then_with(|| masks[a].runs.cmp(&masks[b].runs)).then(a.cmp(&b))
    });
    // owner[p] = rank + 1 in `order`, 0 = uncovered.
    let mut owner = vec![0u32; n_px];
    for (rank, &mi) in order.iter().enumerate() {
        for p in masks[mi].pixels() {
            if owner[p] == 0 {
                owner[p] = rank as u32 + 1;
            }
        }
    }
    // 2. Remnants go to the next mask under them.
    let mut visible = vec![0u64; order.len()];
    owner.iter().filter(|&&o| o > 0).for_each(|&o| visible[o as usize - 1] += 1);
    let removed: Vec<bool> = visible.iter().map(|&v| v < options.min_region_px as u64).collect();
    if removed.iter().any(|&r| r) {
        for (p, o) in owner.iter_mut().enumerate() {
            if *o > 0 && removed[*o as usize - 1] {
                let start = *o as usize;
                *o = (start..order.len())
                    .find(|&rank| !removed[rank] && masks[order[rank]].contains(p as u32))
                    .map_or(0, |rank| rank as u32 + 1);
            }
        }
    }
    // 3. Uncovered components: fill small ones, keep or drop large ones.
    let mut next_label = order.len() as u32 + 1;
    let mut uncovered_labels = Vec::new();
    resolve_uncovered(&mut owner, width, height, options, &mut next_label, &mut uncovered_labels);
    // 4. Canonical ids by first pixel.
    let mut remap = vec![0u32; next_label as usize];
    let mut sources = Vec::new();
    let mut labels = vec![0u32; n_px];
    for (p, &o) in owner.iter().enumerate() {
        if o == 0 {
            continue;
        }
        if remap[o as usize] == 0 {
            sources.push(if (o as usize) <= order.len() {
                let mi = order[o as usize - 1];
                RegionSource::SamMask {
                    input_index: mi,
                    predicted_iou: masks[mi].predicted_iou,
                    stability_score: masks[mi].stability_score,
                    mask_area: areas[mi],
                }
            } else {
                RegionSource::Uncovered
            });
            remap[o as usize] = sources.len() as u32;
        }
        labels[p] = remap[o as usize];
    }
    let labels = Plane { width, height, data: labels };
    Ok(Regions { labels, sources })
}

/// 4-connected components of `owner == 0`; small ones take their most common neighbour, large
/// ones get fresh labels (`OwnRegions`) or stay 0.
fn resolve_uncovered(
    owner: &mut [u32],
    width: usize,
    height: usize,
    options: &RegionOptions,
    next_label: &mut u32,
    new_labels: &mut Vec<u32>,
) {
    let mut seen = vec![false; owner.len()];
    let mut stack = Vec::new();
    let mut component = Vec::new();
    let mut neighbours: Vec<(u32, u32)> = Vec::new(); // (label, border count)
    for start in 0..owner.len() {
        if owner[start] != 0 || seen[start] {
            continue;
        }
        component.clear();
        neighbours.clear();
        seen[start] = true;
        stack.push(start);
        while let Some(p) = stack.pop() {
            component.push(p);
            let (x, y) = (p % width, p / width);
            let mut visit = |q: usize| {
                let o = owner[q];
                if o == 0 {
                    if !seen[q] {
                        seen[q] = true;
                        stack.push(q);
                    }
                } else if let Some(e) = neighbours.iter_mut().find(|e| e.0 == o) {
                    e.1 += 1;
                } else {
                    neighbours.push((o, 1));
                }
            };
            if x > 0 {
                visit(p - 1);
            }
            if x + 1 < width {
                visit(p + 1);
            }
            if y > 0 {
                visit(p - width);
            }
            if y + 1 < height {
                visit(p + width);
            }
        }
        let fill = if component.len() < options.min_region_px as usize {
            // Longest shared border; ties to the smaller (content-ordered) rank.
            neighbours.iter().max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0))).map_or(0, |e| e.0)
        } else {
            match options.uncovered {
                UncoveredPolicy::Unlabelled => 0,
                UncoveredPolicy::OwnRegions => {
                    let l = *next_label;
                    *next_label += 1;
                    new_labels.push(l);
                    l
                }
            }
        };
        // Filled pixels stay `seen`, so later components do not revisit them.
        component.iter().for_each(|&p| owner[p] = fill);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(w: usize, h: usize, x0: usize, y0: usize, x1: usize, y1: usize) -> Plane<bool> {
        Plane::from_vec(
            w,
            h,
            (0..w * h).map(|i| (x0..x1).contains(&(i % w)) && (y0..y1).contains(&(i / w))).collect(),
        )
        .unwrap()
    }

    #[test]
    fn smaller_masks_win_and_ids_follow_raster_order() {
        let big = MaskInput::from_plane(&rect(20, 20, 0, 0, 20, 20), 0.9, 0.95);
        let small = MaskInput::from_plane(&rect(20, 20, 5, 5, 15, 15), 0.8, 0.9);
        let opts = RegionOptions::default();
        let a = regions_from_sam_masks(&[big.clone(), small.clone()], 20, 20, &opts).unwrap();
        let b = regions_from_sam_masks(&[small, big], 20, 20, &opts).unwrap();
        assert_eq!(a.labels, b.labels);
        assert_eq!(a.count(), 2);
        assert_eq!(*a.labels.get(0, 0), 1);
        assert_eq!(*a.labels.get(10, 10), 2);
        assert!(matches!(a.sources[1], RegionSource::SamMask { mask_area: 100, .. }));
    }

    #[test]
    fn small_holes_are_filled_and_large_uncovered_areas_become_regions() {
        // Mask covers everything except a 2×2 hole and the right 10 columns.
        let mut m = rect(30, 20, 0, 0, 20, 20);
        for (x, y) in [(5, 5), (6, 5), (5, 6), (6, 6)] {
            *m.get_mut(x, y) = false;
        }
        let masks = [MaskInput::from_plane(&m, 0.0, 0.0)];
        let own_opts = RegionOptions { uncovered: UncoveredPolicy::OwnRegions, ..Default::default() };
        let own = regions_from_sam_masks(&masks, 30, 20, &own_opts).unwrap();
        assert_eq!(*own.labels.get(5, 5), 1, "hole filled");
        assert_eq!(own.count(), 2);
        assert_eq!(own.sources[1], RegionSource::Uncovered);
        let unl = regions_from_sam_masks(&masks, 30, 20, &RegionOptions::default()).unwrap();
        assert_eq!(unl.count(), 1);
        assert_eq!(*unl.labels.get(25, 3), 0);
    }

    #[test]
    fn covered_remnants_fall_through_to_the_mask_below() {
        let big = MaskInput::from_plane(&rect(20, 20, 0, 0, 20, 20), 0.0, 0.0);
        let mid = MaskInput::from_plane(&rect(20, 20, 0, 0, 10, 10), 0.0, 0.0); // 100 px
                                                                                // 98 px of `mid` are covered by two smaller masks; 2 px stay visible.
        let a = MaskInput::from_plane(&rect(20, 20, 0, 0, 10, 5), 0.0, 0.0);
        let mut bm = rect(20, 20, 0, 5, 10, 10);
        *bm.get_mut(9, 9) = false;
        *bm.get_mut(8, 9) = false;
        let b = MaskInput::from_plane(&bm, 0.0, 0.0);
        let r = regions_from_sam_masks(&[big, mid, a, b], 20, 20, &RegionOptions::default()).unwrap();
        assert_eq!(r.count(), 3, "mid dropped");
        assert_eq!(*r.labels.get(9, 9), *r.labels.get(15, 15));
    }

    #[test]
    fn coco_counts_decode_column_major() {
        // 3×2 image (w = 3, h = 2); column-major pixels: (0,0) (0,1) (1,0) (1,1) (2,0) (2,1).
        // counts [1, 2, 3]: zero, then (x=0,y=1) and (x=1,y=0) set.
        let mut scratch = Vec::new();
        let m = MaskInput::from_coco_counts(&[1, 2, 3], 3, 2, &mut scratch, (0.5, 0.6)).unwrap();
        assert_eq!(m.runs, vec![(1, 1), (3, 1)]);
        assert!(scratch.iter().all(|&b| !b));
        assert!(MaskInput::from_coco_counts(&[1, 2], 3, 2, &mut scratch, (0.0, 0.0)).is_err());
    }
}
