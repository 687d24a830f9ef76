//! Metric values on hand-made label maps whose answers are worked out in the comments.

use splatseg_eval::band::band_of_mask_reference;
use splatseg_eval::{EvalConfig, EvalError, Metrics, UnlabelledGt, ViewCounts};
use splatseg_scene::Plane;

fn plane(w: usize, h: usize, data: &[u32]) -> Plane<u32> {
    Plane::from_vec(w, h, data.to_vec()).unwrap()
}

fn score(views: &[(&Plane<u32>, &Plane<u32>)], cfg: &EvalConfig) -> Metrics {
    let counts: Vec<ViewCounts> = views
        .iter()
        .enumerate()
        .map(|(i, (g, p))| ViewCounts::compute(&format!("v{i}"), g, p, cfg).unwrap())
        .collect();
    Metrics::from_views(&counts, cfg).unwrap()
}

fn close(a: f64, b: f64) {
    assert!((a - b).abs() < 1e-12, "{a} != {b}");
}

/// GT   1 1 1 1 1 1 2 2 2
/// pred 20 20 10 10 10 10 10 10 10
/// IoU(1,10) = 4/9 is the largest entry, so greedy matching takes it and leaves GT 2 with
/// nothing: (4/9 + 0)/2 = 0.222. Hungarian: 1↔20 (2/6) and 2↔10 (3/7): mIoU = 8/21 = 0.381.
#[test]
fn hungarian_beats_greedy_on_label_maps() {
    let gt = plane(9, 1, &[1, 1, 1, 1, 1, 1, 2, 2, 2]);
    let pred = plane(9, 1, &[20, 20, 10, 10, 10, 10, 10, 10, 10]);
    let m = score(&[(&gt, &pred)], &EvalConfig::default());
    close(m.miou, 8.0 / 21.0);
    assert_eq!(m.instances[0].matched_pred, Some(20));
    assert_eq!(m.instances[1].matched_pred, Some(10));
    assert!(m.miou > (4.0 / 9.0) / 2.0 + 0.1, "must beat greedy's 0.222");
    assert_eq!((m.gt_instances, m.pred_masks), (2, 2));
    // Consistency: GT 1 is {20: 2, 10: 4} → 4/6; GT 2 is {10: 3} → 1.
    close(m.consistency, (4.0 / 6.0 + 1.0) / 2.0);
    assert_eq!(m.instances[0].dominant_pred, Some(10));
    // Boundary (disk radius 5, one row): both bands are columns 1..=8.
    // 1↔20: B∩M1 = {1..5} (5 px), B∩M1∩M20 = {1}, no pred-20 pixel outside M1 → 1/5.
    // 2↔10: B∩M2 = {6,7,8}, all predicted 10; pred 10 outside M2 in B = {2..5} → 3/7.
    close(m.instances[0].boundary_iou, 1.0 / 5.0);
    close(m.instances[1].boundary_iou, 3.0 / 7.0);
    close(m.boundary_miou, (1.0 / 5.0 + 3.0 / 7.0) / 2.0);
}

/// 20×3 image, GT left half (x < 10) = 1, right half = 2; the prediction's boundary is 2 px to
/// the right (x < 12 → 1). The band of either instance is columns 5..=14 (image top and bottom
/// are not boundaries).
/// Mask IoU: 1 → 30/36, 2 → 24/30. Band IoU: 1 → cols 5..9 / cols 5..11 = 5/7;
/// 2 → cols 12..14 / cols 10..14 = 3/5.
#[test]
fn boundary_band_half_planes() {
    let gt = Plane::from_vec(20, 3, (0..60).map(|i| if i % 20 < 10 { 1 } else { 2 }).collect()).unwrap();
    let pred = Plane::from_vec(20, 3, (0..60).map(|i| if i % 20 < 12 { 1 } else { 2 }).collect()).unwrap();
    let m = score(&[(&gt, &pred)], &EvalConfig::default());
    close(m.miou, (30.0 / 36.0 + 24.0 / 30.0) / 2.0);
    close(m.boundary_miou, (5.0 / 7.0 + 3.0 / 5.0) / 2.0);
    // A wider band dilutes the error: radius 8 → band cols 2..=17: 1 → 8/10, 2 → 6/8.
    let wide = EvalConfig { band_radius_px: 8, ..EvalConfig::default() };
    let m = score(&[(&gt, &pred)], &wide);
    close(m.boundary_miou, (8.0 / 10.0 + 6.0 / 8.0) / 2.0);
}

/// The same object gets id 5 in one view and id 6 in the other. Each view alone is perfect
/// (per-view mIoU 1), but across views id 5 covers only half of the object: mIoU 16/32 = 0.5,
/// consistency 0.5, #masks 2 for 1 instance.
#[test]
fn ids_that_change_between_views_are_penalised() {
    let mut gt = Plane::filled(10, 10, 0u32);
    for y in 3..7 {
        for x in 3..7 {
            *gt.get_mut(x, y) = 1;
        }
    }
    let pred_a = gt.map(|v| if *v == 1 { 5 } else { 0 });
    let pred_b = gt.map(|v| if *v == 1 { 6 } else { 0 });
    let m = score(&[(&gt, &pred_a), (&gt, &pred_b)], &EvalConfig::default());
    close(m.miou, 0.5);
    close(m.per_view_miou.unwrap(), 1.0);
    close(m.consistency, 0.5);
    assert_eq!((m.pred_masks, m.gt_instances), (2, 1));
    assert_eq!(m.instances[0].views, 2);
    // Every pixel of the 4×4 block is within 5 px of the background, so the band holds the
    // whole block in both views: boundary IoU = 16 / 32 as well.
    close(m.boundary_miou, 0.5);
    // Consistent ids in both views: everything is 1.
    let m = score(&[(&gt, &pred_a), (&gt, &pred_a)], &EvalConfig::default());
    close(m.miou, 1.0);
    close(m.boundary_miou, 1.0);
    close(m.consistency, 1.0);
    assert_eq!(m.pred_masks, 1);
}

/// GT 1 on the left 4 pixels of 8, the rest unlabelled; the prediction covers all 8 pixels.
/// As background, the spill counts: 4/8. As "ignore", it does not: 4/4.
#[test]
fn unlabelled_ground_truth_policy() {
    let gt = plane(8, 1, &[1, 1, 1, 1, 0, 0, 0, 0]);
    let pred = plane(8, 1, &[7; 8]);
    close(score(&[(&gt, &pred)], &EvalConfig::default()).miou, 0.5);
    let ignore = EvalConfig { unlabelled_gt: UnlabelledGt::Ignore, ..EvalConfig::default() };
    let m = score(&[(&gt, &pred)], &ignore);
    close(m.miou, 1.0);
    close(m.boundary_miou, 1.0);
}

/// Pixels predicted 0 are inconsistent even when 0 is the most common prediction.
#[test]
fn unpredicted_pixels_are_inconsistent() {
    let gt = plane(4, 1, &[1, 1, 1, 1]);
    let pred = plane(4, 1, &[0, 0, 0, 3]);
    let m = score(&[(&gt, &pred)], &EvalConfig::default());
    close(m.consistency, 0.25);
    assert_eq!(m.instances[0].dominant_pred, Some(3));
    // The object covers the whole image: no band anywhere, boundary IoU falls back to mask IoU.
    close(m.boundary_miou, 0.25);
}

/// Per-view mIoU is the mean over views that hold an instance; a view with none is skipped.
#[test]
fn per_view_miou_skips_views_without_instances() {
    let gt1 = plane(4, 1, &[1, 1, 2, 2]);
    let pred1 = plane(4, 1, &[4, 4, 4, 0]); // 1 ↔ 4: 2/3; 2: unmatched → (2/3 + 0)/2 = 1/3
    let empty = plane(4, 1, &[0; 4]);
    let m = score(&[(&gt1, &pred1), (&empty, &pred1)], &EvalConfig::default());
    close(m.per_view[0].miou.unwrap(), 1.0 / 3.0);
    assert_eq!(m.per_view[1].miou, None);
    close(m.per_view_miou.unwrap(), 1.0 / 3.0);
    // Globally, pred 4 also covers 3 pixels of view 2 (unlabelled, counted as background):
    // IoU(1, 4) = 2 / (2 + 6 - 2) = 1/3, mIoU = 1/6.
    close(m.miou, 1.0 / 6.0);
    assert_eq!(m.per_view[0].gt_instances, 2);
    assert_eq!(m.per_view[1].pred_ids, 1);
}

#[test]
fn view_without_prediction_scores_zero() {
    let gt = plane(4, 1, &[1, 1, 2, 0]);
    let cfg = EvalConfig::default();
    let m = Metrics::from_views(&[ViewCounts::without_prediction("v", &gt, &cfg)], &cfg).unwrap();
    assert_eq!((m.miou, m.boundary_miou, m.consistency, m.pred_masks), (0.0, 0.0, 0.0, 0));
}

#[test]
fn bad_inputs_are_clear_errors() {
    let cfg = EvalConfig::default();
    let gt = Plane::filled(4, 3, 1u32);
    let pred = Plane::filled(3, 4, 1u32);
    let err = ViewCounts::compute("frame_007", &gt, &pred, &cfg).unwrap_err();
    assert!(matches!(err, EvalError::SizeMismatch { .. }));
    let msg = err.to_string();
    assert!(msg.contains("frame_007") && msg.contains("3×4") && msg.contains("4×3"), "{msg}");
    let zero = Plane::filled(4, 3, 0u32);
    let view = ViewCounts::compute("v", &zero, &zero, &cfg).unwrap();
    assert!(matches!(Metrics::from_views(&[view], &cfg), Err(EvalError::NoGroundTruth { .. })));
    assert!(matches!(Metrics::from_views(&[], &cfg), Err(EvalError::NoGroundTruth { .. })));
}

/// Global metrics do not depend on the order views are given in.
#[test]
fn view_order_does_not_matter() {
    let a = (plane(4, 1, &[1, 1, 2, 2]), plane(4, 1, &[3, 3, 3, 4]));
    let b = (plane(4, 1, &[2, 2, 0, 1]), plane(4, 1, &[4, 3, 3, 0]));
    let cfg = EvalConfig::default();
    let m1 = score(&[(&a.0, &a.1), (&b.0, &b.1)], &cfg);
    let m2 = score(&[(&b.0, &b.1), (&a.0, &a.1)], &cfg);
    assert_eq!(m1.instances, m2.instances);
    assert_eq!((m1.miou, m1.boundary_miou, m1.consistency), (m2.miou, m2.boundary_miou, m2.consistency));
}

/// Boundary IoU from the sparse band counts equals the formula evaluated with literal disk
/// dilation and erosion of each matched ground-truth mask, on random maps.
#[test]
fn boundary_iou_matches_literal_morphology() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    for trial in 0..8 {
        let (w, h) = (rng.gen_range(8..36), rng.gen_range(8..36));
        let mut views = Vec::new();
        for _ in 0..rng.gen_range(1..4) {
            let mut gt = Plane::filled(w, h, 0u32);
            let mut pred = Plane::filled(w, h, 0u32);
            for _ in 0..5 {
                let id = rng.gen_range(1..5u32);
                let (x0, y0) = (rng.gen_range(0..w), rng.gen_range(0..h));
                let (x1, y1) = (rng.gen_range(x0..w), rng.gen_range(y0..h));
                let (dx, dy) = (rng.gen_range(0..3), rng.gen_range(0..3));
                let pid = if rng.gen_bool(0.3) { id + 10 } else { id };
                for y in y0..=y1 {
                    for x in x0..=x1 {
                        *gt.get_mut(x, y) = id;
                        *pred.get_mut((x + dx).min(w - 1), (y + dy).min(h - 1)) = pid;
                    }
                }
            }
            views.push((gt, pred));
        }
        if views.iter().all(|(g, _)| g.data.iter().all(|v| *v == 0)) {
            continue;
        }
        let cfg = EvalConfig::default();
        let refs: Vec<(&Plane<u32>, &Plane<u32>)> = views.iter().map(|(g, p)| (g, p)).collect();
        let m = score(&refs, &cfg);
        for inst in &m.instances {
            let Some(p) = inst.matched_pred else { continue };
            let (mut inter, mut union) = (0u64, 0u64);
            for (gt, pred) in &views {
                let mask = gt.map(|v| *v == inst.gt_id);
                let band = band_of_mask_reference(&mask, 5);
                for i in 0..gt.data.len() {
                    if band.data[i] {
                        let (in_g, in_p) = (gt.data[i] == inst.gt_id, pred.data[i] == p);
                        inter += (in_g && in_p) as u64;
                        union += (in_g || in_p) as u64;
                    }
                }
            }
            let expected = if union == 0 { inst.iou } else { inter as f64 / union as f64 };
            assert!((inst.boundary_iou - expected).abs() < 1e-12, "trial {trial}, gt {}", inst.gt_id);
        }
    }
}
