//! Per-mask steps of SAM's automatic mask generator: stability score, bounding boxes, box NMS,
//! crop-edge test, and small hole / island removal (8-connected components).

use splatseg_scene::Plane;

/// `#(logits > t + offset) / #(logits > t − offset)` (NaN when nothing exceeds `t − offset`).
///
/// `logits`: `[H·W]`.
pub fn stability_score(logits: &[f32], threshold: f32, offset: f32) -> f32 {
    let (hi, lo) = (threshold + offset, threshold - offset);
    let (mut inter, mut union) = (0u64, 0u64);
    for &v in logits {
        inter += u64::from(v > hi);
        union += u64::from(v > lo);
    }
    inter as f32 / union as f32
}

/// Box `[x0, y0, x1, y1]` with inclusive pixel indices (SAM's `batched_mask_to_box`); all zeros for
/// an empty mask. `mask`: `[H, W]`.
pub fn mask_box(mask: &Plane<bool>) -> [f32; 4] {
    let (w, h) = mask.size();
    let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0usize, 0usize);
    for y in 0..h {
        let row = mask.row(y);
        if let Some(first) = row.iter().position(|&v| v) {
            let last = row.iter().rposition(|&v| v).unwrap_or(first);
            x0 = x0.min(first);
            x1 = x1.max(last);
            y0 = y0.min(y);
            y1 = y;
        }
    }
    if x0 == usize::MAX || w == 0 {
        return [0.0; 4];
    }
    [x0 as f32, y0 as f32, x1 as f32, y1 as f32]
}

fn box_iou(a: &[f32; 4], b: &[f32; 4]) -> f32 {
    let area = |r: &[f32; 4]| (r[2] - r[0]) * (r[3] - r[1]);
    let iw = (a[2].min(b[2]) - a[0].max(b[0])).max(0.0);
    let ih = (a[3].min(b[3]) - a[1].max(b[1])).max(0.0);
    let inter = iw * ih;
    inter / (area(a) + area(b) - inter)
}

/// Greedy non-maximum suppression (torchvision's `nms`): boxes in decreasing score order (ties
/// keep their input order), each dropped if its IoU with a kept box exceeds `iou_threshold`.
/// Returns kept indices in decreasing score order.
///
/// `boxes`: `[N]` xyxy; `scores`: `[N]`.
pub fn nms(boxes: &[[f32; 4]], scores: &[f32], iou_threshold: f32) -> Vec<usize> {
    let mut order: Vec<usize> = (0..boxes.len()).collect();
    order.sort_by(|&a, &b| scores[b].total_cmp(&scores[a]));
    let mut kept: Vec<usize> = Vec::new();
    for i in order {
        // a NaN IoU (degenerate boxes) suppresses nothing, as in torchvision
        let suppressed = kept.iter().any(|&k| box_iou(&boxes[i], &boxes[k]) > iou_threshold);
        if !suppressed {
            kept.push(i);
        }
    }
    kept
}

/// Whether a box (in crop coordinates) lies within `atol` px of a crop edge that is not also an
/// image edge (SAM's `is_box_near_crop_edge`). Boxes are `[x0, y0, x1, y1]`.
pub fn near_crop_edge(
    box_in_crop: &[f32; 4],
    crop_box: &[usize; 4],
    image_box: &[usize; 4],
    atol: f32,
) -> bool {
    let offset = [crop_box[0], crop_box[1], crop_box[0], crop_box[1]];
    (0..4).any(|i| {
        let v = box_in_crop[i] + offset[i] as f32;
        let near_crop = (v - crop_box[i] as f32).abs() <= atol;
        let near_image = (v - image_box[i] as f32).abs() <= atol;
        near_crop && !near_image
    })
}

/// What [`remove_small_regions`] removes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RegionKind {
    /// Background components (inside the mask's complement) smaller than the area are filled.
    Holes,
    /// Foreground components smaller than the area are dropped (the largest is kept if all are small).
    Islands,
}

/// SAM's `remove_small_regions` (8-connectivity); returns whether the mask changed.
pub fn remove_small_regions(mask: &mut Plane<bool>, min_area: usize, kind: RegionKind) -> bool {
    let (w, h) = mask.size();
    let working: Vec<bool> = mask.map(|&v| if kind == RegionKind::Holes { !v } else { v }).data;
    let (labels, sizes) = components8(&working, w, h);
    let small: Vec<bool> = sizes.iter().map(|&s| s < min_area).collect();
    if !small.iter().any(|&s| s) {
        return false;
    }
    // keep[l]: whether pixels of component l (1-based; 0 = outside `working`) end up in the mask
    let keep: Vec<bool> = match kind {
        RegionKind::Holes => std::iter::once(true).chain(small.iter().copied()).collect(),
        RegionKind::Islands => {
            let mut keep: Vec<bool> = std::iter::once(false).chain(small.iter().map(|&s| !s)).collect();
            if !keep.iter().any(|&k| k) {
                let largest = (0..sizes.len()).max_by_key(|&i| (sizes[i], std::cmp::Reverse(i))).unwrap_or(0);
                keep[largest + 1] = true;
            }
            keep
        }
    };
    for (i, label) in labels.iter().enumerate() {
        *mask.get_mut(i % w, i / w) = keep[*label as usize];
    }
    true
}

/// 8-connected components of `on` (`[H·W]`): per-pixel labels (0 = off, components from 1 in
/// raster order of their first pixel) and component sizes (`sizes[l − 1]`).
fn components8(on: &[bool], w: usize, h: usize) -> (Vec<u32>, Vec<usize>) {
    let mut labels = vec![0u32; w * h];
    let mut sizes = Vec::new();
    let mut stack = Vec::new();
    for start in 0..w * h {
        if !on[start] || labels[start] != 0 {
            continue;
        }
        let label = sizes.len() as u32 + 1;
        labels[start] = label;
        stack.push(start);
        let mut size = 0;
        while let Some(i) = stack.pop() {
            size += 1;
            let (x, y) = ((i % w) as isize, (i / w) as isize);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w as isize || ny >= h as isize {
                        continue;
                    }
                    let j = ny as usize * w + nx as usize;
                    if on[j] && labels[j] == 0 {
                        labels[j] = label;
                        stack.push(j);
                    }
                }
            }
        }
        sizes.push(size);
    }
    (labels, sizes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plane(rows: &[&str]) -> Plane<bool> {
        let w = rows[0].len();
        let data = rows.iter().flat_map(|r| r.chars().map(|c| c == '#')).collect();
        Plane::from_vec(w, rows.len(), data).unwrap()
    }

    #[test]
    fn boxes_are_inclusive_and_nms_keeps_best_first() {
        let m = plane(&["....", ".##.", ".#..", "...."]);
        assert_eq!(mask_box(&m), [1.0, 1.0, 2.0, 2.0]);
        assert_eq!(mask_box(&plane(&["..", ".."])), [0.0; 4]);
        let boxes = [[0.0, 0.0, 10.0, 10.0], [1.0, 1.0, 10.0, 10.0], [20.0, 20.0, 30.0, 30.0]];
        assert_eq!(nms(&boxes, &[0.5, 0.9, 0.1], 0.7), vec![1, 2]);
        assert_eq!(nms(&boxes, &[0.5, 0.9, 0.1], 1.0), vec![1, 0, 2]);
    }

    #[test]
    fn stability_counts_pixels_above_shifted_thresholds() {
        assert_eq!(stability_score(&[2.0, 0.5, -0.5, -2.0], 0.0, 1.0), 1.0 / 3.0);
    }

    #[test]
    fn small_holes_filled_and_islands_dropped() {
        let mut m = plane(&["#####.", "#.###.", "#####.", "......", ".....#"]);
        assert!(remove_small_regions(&mut m, 2, RegionKind::Holes));
        assert_eq!(m, plane(&["#####.", "#####.", "#####.", "......", ".....#"]));
        assert!(remove_small_regions(&mut m, 2, RegionKind::Islands));
        assert_eq!(m, plane(&["#####.", "#####.", "#####.", "......", "......"]));
        assert!(!remove_small_regions(&mut m, 2, RegionKind::Islands));
    }
}
