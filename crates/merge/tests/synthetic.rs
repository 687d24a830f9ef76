//! Scene-level tests on the synthetic benchmark scene (all views): merging cuts the masks per
//! view by ≥ 3× and raises per-view mIoU (Hungarian, `splatseg-eval`) over the raw masks.

use splatseg_cues::{
    DenseFeatureDescriptors, DepthKind, DepthMap, FeatureGrid, FeatureGrids, MaskInput, RegionOptions,
};
use splatseg_eval::{EvalConfig, ViewCounts};
use splatseg_merge::study::{keep_apart_decisions, merged_row, raw_row, StudyView};
use splatseg_merge::{build_view_inputs, CueRequest, MergeConfig, Outcome};
use splatseg_scene::Plane;
use splatseg_synth::{generate, SynthConfig, SynthScene};

fn study_views(scene: &SynthScene, region_options: RegionOptions) -> Vec<StudyView> {
    let white = scene.white_pair();
    scene
        .views
        .iter()
        .zip(&scene.scene.views)
        .map(|(v, view)| {
            let (w, h) = v.image.size();
            let rgb = v.image.map(|p| p.map(|c| c as f32 / 255.0));
            let mut scratch = Vec::new();
            let masks: Vec<MaskInput> = v
                .sam_masks
                .iter()
                .map(|m| {
                    let q = (m.predicted_iou as f32, m.stability_score as f32);
                    MaskInput::from_coco_counts(&m.segmentation.counts, w, h, &mut scratch, q).unwrap()
                })
                .collect();
            let f = &v.features;
            let grid = FeatureGrid::new(f.grid_h, f.grid_w, f.dim, f.values.clone()).unwrap();
            let descriptors =
                DenseFeatureDescriptors { grids: FeatureGrids::InMemory(vec![(v.stem.clone(), grid)]) };
            let depth = DepthMap { values: v.relative_depth.clone(), kind: DepthKind::InverseRelative };
            let inputs = build_view_inputs(&CueRequest {
                stem: &v.stem,
                rgb: &rgb,
                masks: &masks,
                depth: &depth,
                metric_depth: Some(&v.gt_depth_z),
                normals: None,
                descriptors: &descriptors,
                region_options,
                intrinsics: Some(splatseg_cues::Intrinsics::of_camera(scene.scene.camera(view), w, h)),
            })
            .unwrap();
            StudyView { stem: v.stem.clone(), inputs, gt: v.gt_instance.clone(), keep_apart: Some(white) }
        })
        .collect()
}

fn miou(stem: &str, gt: &Plane<u32>, pred: &Plane<u32>) -> Option<f64> {
    let cfg = EvalConfig::default();
    ViewCounts::compute(stem, gt, pred, &cfg).ok()?.miou(&cfg)
}

fn scene() -> SynthScene {
    generate(&SynthConfig::default()).unwrap()
}

#[test]
fn merging_cuts_masks_threefold_and_raises_per_view_miou() {
    let scene = scene();
    let sam_masks_per_view =
        scene.views.iter().map(|v| v.sam_masks.len() as f64).sum::<f64>() / scene.views.len() as f64;
    let views = study_views(&scene, RegionOptions::default());
    let raw = raw_row(&views, &miou);
    let merged = merged_row("paper", &views, &MergeConfig::default(), &miou).unwrap();
    eprintln!("SAM masks per view {sam_masks_per_view:.2}\nraw regions: {raw:?}\nmerged: {merged:?}");
    assert!(sam_masks_per_view >= 3.0 * merged.masks_per_view, "{sam_masks_per_view} vs {merged:?}");
    assert!(raw.masks_per_view >= 2.5 * merged.masks_per_view, "{raw:?} vs {merged:?}");
    assert!(merged.miou > raw.miou + 0.3, "{raw:?} vs {merged:?}");
    // Merging never joins the white-on-white pair (the views where it shares a region are those
    // where the simulated SAM itself put both objects in one mask).
    assert_eq!(merged.pair_merged_views, raw.pair_merged_views);
}

#[test]
fn the_white_on_white_pair_is_stopped_by_the_depth_gates() {
    let scene = scene();
    let views = study_views(&scene, RegionOptions::default());
    let decisions = keep_apart_decisions(&views, &MergeConfig::default()).unwrap();
    assert!(decisions.len() >= 10);
    assert!(decisions.iter().all(|d| !d.decision.merged), "{decisions:?}");
    // A pair is accepted at all only where neither depth map shows a step at the contact (one
    // such evaluation in view 7: a sliver at the same depth, never executed).
    for d in decisions.iter().filter(|d| d.decision.outcome == Outcome::Accepted) {
        let t = d.decision.terms;
        assert!(t.depth_gap < 0.01, "{d:?}");
    }
    // Most evaluations are stopped by a depth gate, not by the score alone.
    let by_depth = decisions
        .iter()
        .filter(|d| matches!(d.decision.outcome, Outcome::DepthStep | Outcome::DepthGate))
        .count();
    assert!(by_depth * 2 > decisions.len(), "{by_depth} of {} by a depth gate", decisions.len());
}

/// The paper's gate compares region means and splits floors and walls whose halves lie at
/// different depths; comparing at the contact merges them, and the depth-step gate keeps
/// what it must apart (measured: 14.5 masks/view and mIoU 0.946 with region means, 14.4 and
/// 0.956 at the contact with the step gate).
#[test]
fn comparing_depth_at_the_contact_beats_region_means_on_the_scene() {
    let scene = scene();
    let views = study_views(&scene, RegionOptions::default());
    let means = MergeConfig {
        depth_gap_at: splatseg_merge::DepthGapAt::RegionMeans,
        max_depth_boundary: None,
        ..MergeConfig::default()
    };
    let before = merged_row("region means", &views, &means, &miou).unwrap();
    let after = merged_row("contact", &views, &MergeConfig::default(), &miou).unwrap();
    eprintln!("{before:?}\n{after:?}");
    assert!(after.miou > before.miou + 0.005, "{before:?} vs {after:?}");
    assert!(after.masks_per_view <= before.masks_per_view, "{before:?} vs {after:?}");
    assert!(after.pair_merged_views <= before.pair_merged_views);
}
