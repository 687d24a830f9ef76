//! Colour refinement of a final label map's boundaries.
//!
//! The ids rendered back from the Gaussians, and SAM's masks, are both blurred at object
//! boundaries: a splat's footprint reaches past the silhouette it belongs to, and SAM's masks are
//! often a pixel too wide. The image itself is sharp there. Each pass looks at every pixel on a
//! boundary (a 4-neighbour has another id) and gives it the id whose interior pixels (not on a
//! boundary) within a `(2·window + 1)²` window around it have the mean colour nearest to the
//! pixel's own colour. The pixel keeps its id unless another id is strictly nearer; ties between
//! other ids go to the smaller id. When the pixel's own id has no interior pixel in the window (a
//! post two pixels wide is all boundary), its mean is taken over all its pixels there instead, so
//! a thin object is not erased for being thin. All pixels of a pass are decided from the labels before it,
//! so the result does not depend on pixel order.
//!
//! This moves a boundary by at most one pixel per pass, and only where the colours say so: two
//! objects of the same colour (the white-on-white pair) keep their rendered boundary.

use splatseg_scene::Plane;

/// How far the refinement looks and how many passes it makes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RefineRule {
    /// Half-width of the window whose interior pixels give each id's mean colour (pixels);
    /// 0 turns the refinement off.
    pub window_px: usize,
    /// Passes; each moves a boundary by at most one pixel.
    pub passes: usize,
}

/// Sum of colours and count of one id's interior pixels in a window.
#[derive(Clone, Copy)]
struct ColourSum {
    id: u32,
    sum: [u32; 3],
    count: u32,
}

/// `labels`: `[H, W]` ids; `rgb`: `[H, W, 3]` 8-bit colours, row-major (`rgb.len() == 3·H·W`).
/// Returns the refined `[H, W]` ids (module docs). With `rule.window_px == 0`, `rule.passes == 0`
/// or colours of the wrong length, the labels are returned unchanged.
pub fn refine_boundaries(labels: &Plane<u32>, rgb: &[u8], rule: &RefineRule) -> Plane<u32> {
    let mut current = labels.clone();
    if rule.window_px == 0 || rgb.len() != labels.data.len() * 3 {
        return current;
    }
    for _ in 0..rule.passes {
        let boundary = boundary_pixels(&current);
        if !boundary.iter().any(|&b| b) {
            break;
        }
        let mut next = current.clone();
        let mut changed = false;
        let mut sums: Vec<ColourSum> = Vec::new();
        for y in 0..current.height {
            for x in 0..current.width {
                let i = y * current.width + x;
                if !boundary[i] {
                    continue;
                }
                let own = window_sums(&current, &boundary, rgb, x, y, rule.window_px, &mut sums);
                let id =
                    nearest_id(current.data[i], [rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]], &sums, &own);
                if id != current.data[i] {
                    next.data[i] = id;
                    changed = true;
                }
            }
        }
        current = next;
        if !changed {
            break;
        }
    }
    current
}

/// `[H·W]` true where a 4-neighbour has another id.
fn boundary_pixels(labels: &Plane<u32>) -> Vec<bool> {
    let (w, h) = (labels.width, labels.height);
    let mut out = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let id = labels.data[i];
            if x + 1 < w && labels.data[i + 1] != id {
                out[i] = true;
                out[i + 1] = true;
            }
            if y + 1 < h && labels.data[i + w] != id {
                out[i] = true;
                out[i + w] = true;
            }
        }
    }
    out
}

/// Colour sums per id of the interior pixels in the window of half-width `half` around
/// `(x, y)` (clipped at the image border), into `sums` (sorted by id). Returns the sum over all
/// pixels (interior or not) of the id at `(x, y)`.
fn window_sums(
    labels: &Plane<u32>,
    boundary: &[bool],
    rgb: &[u8],
    x: usize,
    y: usize,
    half: usize,
    sums: &mut Vec<ColourSum>,
) -> ColourSum {
    sums.clear();
    let w = labels.width;
    let own_id = labels.data[y * w + x];
    let mut own = ColourSum { id: own_id, sum: [0; 3], count: 0 };
    let (x0, x1) = (x.saturating_sub(half), (x + half).min(w - 1));
    let (y0, y1) = (y.saturating_sub(half), (y + half).min(labels.height - 1));
    for yy in y0..=y1 {
        for xx in x0..=x1 {
            let j = yy * w + xx;
            let id = labels.data[j];
            if id == own_id {
                for c in 0..3 {
                    own.sum[c] += rgb[3 * j + c] as u32;
                }
                own.count += 1;
            }
            if boundary[j] {
                continue;
            }
            let slot = match sums.iter().position(|s| s.id == id) {
                Some(k) => k,
                None => {
                    sums.push(ColourSum { id, sum: [0; 3], count: 0 });
                    sums.len() - 1
                }
            };
            let s = &mut sums[slot];
            for c in 0..3 {
                s.sum[c] += rgb[3 * j + c] as u32;
            }
            s.count += 1;
        }
    }
    sums.sort_unstable_by_key(|s| s.id);
    own
}

/// The id whose mean colour in `sums` is nearest to `colour`: `own` unless another id is strictly
/// nearer (then the nearest, the smaller id on ties). `own_all`: the own id's sum over all its
/// pixels in the window, used when `sums` has no interior pixel of it.
fn nearest_id(own: u32, colour: [u8; 3], sums: &[ColourSum], own_all: &ColourSum) -> u32 {
    let distance = |s: &ColourSum| -> f64 {
        (0..3)
            .map(|c| {
                let d = colour[c] as f64 - s.sum[c] as f64 / s.count as f64;
                d * d
            })
            .sum()
    };
    let own_distance = distance(sums.iter().find(|s| s.id == own).unwrap_or(own_all));
    let mut best = (own, own_distance);
    for s in sums.iter().filter(|s| s.id != own) {
        let d = distance(s);
        if d < best.1 {
            best = (s.id, d);
        }
    }
    best.0
}

#[cfg(test)]
mod tests {
    use super::*;

    const RED: [u8; 3] = [200, 40, 40];
    const GREY: [u8; 3] = [120, 120, 120];

    /// A `w × h` view: a red post of `post_w` columns from column `x0` on grey, and the labels of a
    /// post `grow` columns wider on each side (as splats blur it).
    fn blurred_post(
        w: usize,
        h: usize,
        x0: usize,
        post_w: usize,
        grow: usize,
    ) -> (Plane<u32>, Vec<u8>, Plane<u32>) {
        let mut rgb = Vec::with_capacity(w * h * 3);
        let mut truth = Plane::filled(w, h, 1u32);
        let mut labels = Plane::filled(w, h, 1u32);
        for y in 0..h {
            for x in 0..w {
                let in_post = x >= x0 && x < x0 + post_w;
                rgb.extend_from_slice(if in_post { &RED } else { &GREY });
                if in_post {
                    truth.data[y * w + x] = 2;
                }
                if x + grow >= x0 && x < x0 + post_w + grow {
                    labels.data[y * w + x] = 2;
                }
            }
        }
        (labels, rgb, truth)
    }

    #[test]
    fn a_post_rendered_one_pixel_too_wide_gets_its_image_boundary_back() {
        let (labels, rgb, truth) = blurred_post(20, 12, 8, 3, 1);
        assert_ne!(labels, truth);
        let refined = refine_boundaries(&labels, &rgb, &RefineRule { window_px: 2, passes: 1 });
        assert_eq!(refined, truth);
    }

    #[test]
    fn each_pass_moves_a_boundary_by_at_most_one_pixel() {
        let (labels, rgb, truth) = blurred_post(24, 12, 9, 4, 2);
        let one = refine_boundaries(&labels, &rgb, &RefineRule { window_px: 3, passes: 1 });
        assert_ne!(one, truth);
        let wrong = |m: &Plane<u32>| m.data.iter().zip(&truth.data).filter(|(a, b)| a != b).count();
        assert_eq!(wrong(&labels), 2 * 2 * 12);
        assert_eq!(
            wrong(&one),
            2 * 12,
            "the column next to the post was not on a boundary in the first pass"
        );
        let two = refine_boundaries(&labels, &rgb, &RefineRule { window_px: 3, passes: 2 });
        assert_eq!(two, truth);
    }

    #[test]
    fn objects_of_one_colour_keep_their_boundary_and_off_changes_nothing() {
        let (labels, _, _) = blurred_post(20, 12, 8, 3, 1);
        let flat: Vec<u8> = GREY.iter().copied().cycle().take(20 * 12 * 3).collect();
        assert_eq!(refine_boundaries(&labels, &flat, &RefineRule { window_px: 2, passes: 3 }), labels);
        let (labels, rgb, _) = blurred_post(20, 12, 8, 3, 1);
        assert_eq!(refine_boundaries(&labels, &rgb, &RefineRule { window_px: 0, passes: 3 }), labels);
        assert_eq!(refine_boundaries(&labels, &rgb[3..], &RefineRule { window_px: 2, passes: 1 }), labels);
    }

    #[test]
    fn a_post_two_pixels_wide_is_all_boundary_and_stays() {
        let (labels, rgb, truth) = blurred_post(20, 12, 8, 2, 0);
        assert_eq!(labels, truth);
        let refined = refine_boundaries(&labels, &rgb, &RefineRule { window_px: 2, passes: 3 });
        assert_eq!(refined, truth, "the post has no interior pixel, its own mean colour is its own");
    }

    #[test]
    fn the_result_does_not_depend_on_the_order_ids_are_numbered() {
        let (labels, rgb, _) = blurred_post(20, 12, 8, 3, 1);
        let swapped = Plane { data: labels.data.iter().map(|&id| 3 - id).collect(), ..labels.clone() };
        let rule = RefineRule { window_px: 2, passes: 2 };
        let a = refine_boundaries(&labels, &rgb, &rule);
        let b = refine_boundaries(&swapped, &rgb, &rule);
        assert!(a.data.iter().zip(&b.data).all(|(&x, &y)| x == 3 - y));
    }
}
