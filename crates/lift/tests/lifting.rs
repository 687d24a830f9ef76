//! Majority vote, fusion, variance filter, render-back, renumbering, and the whole stage
//! ([`LiftStage::run`]) on an in-memory [`ViewStore`].

use crate::common::{camera, gaussians, look_at, sphere};
use glam::DVec3;
use splatseg_lift::{
    render_label_map, render_votes, renumber, view_visibility, FinalMaps, GaussianStatus, LiftConfig,
    LiftError, LiftResult, LiftStage, Lifted, MatchedViews, ObjectFeatures, PosedCamera, PreparedGaussians,
    RenderVotes, ViewRegions, ViewStore, ViewVisibility, VisibleGaussians, VoteAccumulator,
};
use splatseg_render::bin::TileBins;
use splatseg_scene::Plane;
use std::collections::BTreeMap;

/// The votes of every view (`visibility: [n_views]`, `id_maps: [n_views]` global ids at each
/// visible Gaussian's centre pixel), added view by view in order, then decided.
fn lift_views(
    n_gaussians: usize,
    visibility: &[ViewVisibility],
    id_maps: &[Plane<u32>],
    features: ObjectFeatures,
    config: &LiftConfig,
) -> LiftResult<Lifted> {
    let mut votes = VoteAccumulator::new(n_gaussians);
    for (vis, map) in visibility.iter().zip(id_maps) {
        let ids: Vec<u32> = vis.pixels.iter().map(|&p| map.data[p as usize]).collect();
        votes.add_view(&vis.gaussians, &vis.weights, &ids)?;
    }
    votes.finish(features, config)
}

/// Every view's visible Gaussians (own surface depth).
fn visibility_of(
    prepared: &PreparedGaussians,
    cams: &[PosedCamera],
    config: &LiftConfig,
) -> Vec<ViewVisibility> {
    cams.iter().map(|c| view_visibility(prepared, c.camera, c.world_from_cam, None, config).visible).collect()
}

/// Every view's label map rendered from `votes`.
fn render_views(
    prepared: &PreparedGaussians,
    votes: &RenderVotes,
    cams: &[PosedCamera],
    config: &LiftConfig,
) -> Vec<Plane<u32>> {
    cams.iter()
        .map(|c| render_label_map(prepared, votes, c.camera, c.world_from_cam, config, None).unwrap())
        .collect()
}

/// The f_g row of Gaussian `g`.
fn fused_row(lifted: &Lifted, g: usize) -> Vec<f32> {
    let fused = lifted.fused_features.as_ref().unwrap();
    let mut row = vec![0.0; fused.dim];
    fused.row(g, &mut row);
    row
}

/// One Gaussian (index 0) seen in one pixel per view, with the given ids and weights.
fn single_gaussian_views(ids: &[u32], weights: &[f32]) -> (Vec<ViewVisibility>, Vec<Plane<u32>>) {
    let vis = weights
        .iter()
        .map(|&w| ViewVisibility { gaussians: vec![0], pixels: vec![0], weights: vec![w] })
        .collect();
    let maps = ids.iter().map(|&id| Plane::filled(1, 1, id)).collect();
    (vis, maps)
}

/// Three objects: 1 and 2 orthogonal, 3 close to 1 (cos 0.99).
const FEATURES: [f32; 6] = [1.0, 0.0, 0.0, 1.0, 0.99, 0.141_067_4];

fn features() -> ObjectFeatures<'static> {
    ObjectFeatures { dim: 2, values: &FEATURES }
}

#[test]
fn majority_vote_counts_views_not_weights() {
    // Two views say 1 (light), one says 2 (heavy): the count wins.
    let (vis, maps) = single_gaussian_views(&[1, 2, 1], &[1.0, 10.0, 1.0]);
    let config = LiftConfig { tau_var: 10.0, ..LiftConfig::default() };
    let lifted = lift_views(1, &vis, &maps, features(), &config).unwrap();
    assert_eq!(lifted.object_ids, vec![1]);
    assert_eq!(lifted.views_seen, vec![3]);
    // Fused feature = weighted mean: (1·f1 + 10·f2 + 1·f1) / 12.
    let f = fused_row(&lifted, 0);
    assert!((f[0] - 2.0 / 12.0).abs() < 1e-6 && (f[1] - 10.0 / 12.0).abs() < 1e-6, "{f:?}");
    // A tie in counts goes to the larger weight.
    let (vis, maps) = single_gaussian_views(&[1, 2], &[1.0, 3.0]);
    let lifted = lift_views(1, &vis, &maps, features(), &config).unwrap();
    assert_eq!(lifted.object_ids, vec![2]);
}

#[test]
fn variance_filter_marks_disagreeing_gaussians_unreliable() {
    let config = LiftConfig::default();
    // 3 views say 1, one says 2 (orthogonal): σ² = p(1−p)·‖f1 − f2‖² = 0.75·0.25·2 = 0.375.
    let (vis, maps) = single_gaussian_views(&[1, 1, 1, 2], &[1.0; 4]);
    let lifted = lift_views(1, &vis, &maps, features(), &config).unwrap();
    assert!((lifted.variances[0] - 0.375).abs() < 1e-5, "{}", lifted.variances[0]);
    assert_eq!(lifted.status, vec![GaussianStatus::Unreliable]);
    assert_eq!(lifted.object_ids, vec![-1]);
    assert_eq!(lifted.majority_ids, vec![1]);
    // Disagreeing with a near-identical object (cos 0.99) is fine: σ² = 0.1875·0.02 ≈ 0.004.
    let (vis, maps) = single_gaussian_views(&[1, 1, 1, 3], &[1.0; 4]);
    let lifted = lift_views(1, &vis, &maps, features(), &config).unwrap();
    assert_eq!(lifted.object_ids, vec![1]);
    assert!(lifted.variances[0] < 0.005);
    // Full agreement: zero variance.
    let (vis, maps) = single_gaussian_views(&[2, 2], &[1.0, 5.0]);
    let lifted = lift_views(1, &vis, &maps, features(), &config).unwrap();
    assert_eq!((lifted.object_ids[0], lifted.variances[0]), (2, 0.0));
}

#[test]
fn mostly_unmasked_gaussian_gets_no_object_and_unseen_is_marked() {
    let (vis, maps) = single_gaussian_views(&[0, 0, 1], &[1.0; 3]);
    let lifted = lift_views(2, &vis, &maps, features(), &LiftConfig::default()).unwrap();
    assert_eq!(lifted.status, vec![GaussianStatus::NoObject, GaussianStatus::Unseen]);
    assert_eq!(lifted.object_ids, vec![-1, -1]);
    assert_eq!(lifted.stats.no_object, 1);
    assert_eq!(lifted.stats.unseen, 1);
}

#[test]
fn an_id_past_the_known_objects_is_an_error() {
    let (vis, maps) = single_gaussian_views(&[1, 9], &[1.0, 1.0]);
    let err = lift_views(1, &vis, &maps, features(), &LiftConfig::default()).unwrap_err();
    assert!(matches!(err, LiftError::UnknownObject { view: 0, id: 9, n_objects: 3 }), "{err}");
}

/// Two spheres of Gaussians (ids 1 and 2) seen by a ring of cameras; per-view id maps come from
/// rendering the ground truth back, then one view's map is corrupted.
#[test]
fn lifting_recovers_objects_and_renders_consistent_maps() {
    let mut means = sphere([-0.6, 0.0, 0.0], 0.4, 24);
    let n1 = means.len();
    means.extend(sphere([0.6, 0.0, 0.0], 0.4, 24));
    let g = gaussians(&means, 0.06, 0.9);
    let prepared = PreparedGaussians::new(&g).unwrap();
    let truth: Vec<u32> = (0..means.len()).map(|i| if i < n1 { 1 } else { 2 }).collect();
    let cam = camera(96);
    let poses: Vec<_> = (0..12)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / 12.0;
            let height = if k % 2 == 0 { -1.5 } else { 1.2 };
            look_at(DVec3::new(3.5 * a.sin(), height, -3.5 * a.cos()), DVec3::ZERO)
        })
        .collect();
    let cams: Vec<PosedCamera> =
        poses.iter().map(|p| PosedCamera { camera: &cam, world_from_cam: p }).collect();
    let config = LiftConfig::default();
    let mut maps = render_views(&prepared, &RenderVotes::uniform(truth.clone()), &cams, &config);
    for id in [1, 2] {
        assert!(maps.iter().any(|m| m.data.contains(&id)), "object {id} shows in some view");
    }
    // View 0 swaps the two objects (a matching error): the other views outvote it.
    for v in maps[0].data.iter_mut() {
        *v = match *v {
            1 => 2,
            2 => 1,
            x => x,
        };
    }
    let vis = visibility_of(&prepared, &cams, &config);
    let total_visible: usize = vis.iter().map(|v| v.gaussians.len()).sum();
    assert!(total_visible < 12 * means.len() * 3 / 4, "back faces are culled: {total_visible}");
    let lifted = lift_views(means.len(), &vis, &maps, features(), &config).unwrap();
    // Gaussians seen in 3+ views are outvoting view 0 (those seen by view 0 alone cannot).
    let seen: Vec<usize> = (0..means.len()).filter(|&i| lifted.views_seen[i] >= 3).collect();
    let correct = seen.iter().filter(|&&i| lifted.majority_ids[i] == truth[i]).count();
    assert!(seen.len() > means.len() / 2, "{} seen in 3+ views", seen.len());
    assert!(correct as f64 >= 0.98 * seen.len() as f64, "{correct}/{}", seen.len());
    // Rendered back, every view (including the corrupted one, which had every object pixel
    // wrong) shows the truth on ≥ 95 % of its object pixels.
    let votes = render_votes(&lifted, &config);
    let back = render_views(&prepared, &votes, &cams, &config);
    let truth_maps = render_views(&prepared, &RenderVotes::uniform(truth.clone()), &cams, &config);
    let object_px = |m: &Plane<u32>| m.data.iter().filter(|&&x| x > 0).count();
    for (v, (b, t)) in back.iter().zip(&truth_maps).enumerate() {
        let wrong = b.data.iter().zip(&t.data).filter(|(x, y)| x != y).count();
        assert!(wrong * 20 <= object_px(t), "view {v}: {wrong} wrong of {} object pixels", object_px(t));
    }
}

#[test]
fn lifting_is_deterministic_across_thread_counts() {
    let means = sphere([0.0, 0.0, 0.0], 0.5, 20);
    let g = gaussians(&means, 0.05, 0.8);
    let prepared = PreparedGaussians::new(&g).unwrap();
    let cam = camera(64);
    let poses: Vec<_> = (0..4)
        .map(|k| look_at(DVec3::new(3.0 * (k as f64).sin(), 0.3, -3.0 * (k as f64).cos()), DVec3::ZERO))
        .collect();
    let cams: Vec<PosedCamera> =
        poses.iter().map(|p| PosedCamera { camera: &cam, world_from_cam: p }).collect();
    let truth: Vec<u32> = means.iter().map(|m| if m[0] < 0.0 { 1 } else { 2 }).collect();
    let config = LiftConfig::default();
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let maps = render_views(&prepared, &RenderVotes::uniform(truth.clone()), &cams, &config);
            let vis = visibility_of(&prepared, &cams, &config);
            lift_views(means.len(), &vis, &maps, features(), &config).unwrap()
        })
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn renumber_orders_by_first_appearance() {
    let mut maps =
        vec![Plane::from_vec(3, 1, vec![0, 7, 3]).unwrap(), Plane::from_vec(3, 1, vec![5, 3, 0]).unwrap()];
    let mut ids = vec![3, -1, 9, 7, 5];
    let old_of_new = renumber(&mut maps, &mut ids);
    assert_eq!(maps[0].data, vec![0, 1, 2]);
    assert_eq!(maps[1].data, vec![3, 2, 0]);
    assert_eq!(ids, vec![2, -1, 4, 1, 3]);
    assert_eq!(old_of_new, vec![0, 7, 3, 5, 9]);
}

#[test]
fn bad_visible_lists_are_errors() {
    let mut votes = VoteAccumulator::new(3);
    let err = votes.add_view(&[2, 1], &[1.0, 1.0], &[1, 1]).unwrap_err();
    assert!(matches!(err, LiftError::VisibleList { view: 0, n_gaussians: 3 }), "{err}");
    assert!(votes.add_view(&[0, 3], &[1.0, 1.0], &[1, 1]).is_err(), "index past the end");
    assert!(votes.add_view(&[0], &[1.0, 1.0], &[1]).is_err(), "weights of another length");
    assert!(votes.add_view(&[0], &[1.0], &[1, 2]).is_err(), "ids of another length");
}

/// The views of `lifting_recovers_objects_and_renders_consistent_maps` as a per-view pass keeps
/// them: each view's visible Gaussians with the label at their centres, its tile lists, its
/// regions (the truth map) and a grey image.
struct MemoryViews {
    passes: Vec<(VisibleGaussians, TileBins)>,
    regions: Vec<Plane<u32>>,
    keep_tile_lists: bool,
}

impl ViewStore for MemoryViews {
    type Error = LiftError;

    fn visible(&self, v: usize) -> LiftResult<VisibleGaussians> {
        Ok(self.passes[v].0.clone())
    }

    fn tile_lists(&self, v: usize) -> LiftResult<Option<TileBins>> {
        Ok(self.keep_tile_lists.then(|| self.passes[v].1.clone()))
    }

    fn regions(&self, v: usize) -> LiftResult<ViewRegions> {
        Ok(ViewRegions { snap: self.regions[v].clone(), merged: self.regions[v].clone() })
    }

    fn image_rgb(&self, v: usize) -> LiftResult<Vec<u8>> {
        Ok(vec![128; 3 * self.regions[v].data.len()])
    }
}

/// The whole stage on a ring of views of two spheres, the first view's labels swapped: every
/// final map shows the two objects where the truth has them (numbered by first appearance), and
/// the result is the same whether the views' tile lists were kept or the splats sorted again.
#[test]
fn the_stage_labels_the_objects_with_or_without_kept_tile_lists() {
    let mut means = sphere([-0.6, 0.0, 0.0], 0.4, 24);
    let n1 = means.len();
    means.extend(sphere([0.6, 0.0, 0.0], 0.4, 24));
    let prepared = PreparedGaussians::new(&gaussians(&means, 0.06, 0.9)).unwrap();
    let truth: Vec<u32> = (0..means.len()).map(|i| if i < n1 { 1 } else { 2 }).collect();
    let cam = camera(96);
    let poses: Vec<_> = (0..12)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / 12.0;
            look_at(
                DVec3::new(3.5 * a.sin(), if k % 2 == 0 { -1.5 } else { 1.2 }, -3.5 * a.cos()),
                DVec3::ZERO,
            )
        })
        .collect();
    let cams: Vec<PosedCamera> =
        poses.iter().map(|p| PosedCamera { camera: &cam, world_from_cam: p }).collect();
    let truth_maps = render_views(&prepared, &RenderVotes::uniform(truth), &cams, &LiftConfig::default());
    let passes: Vec<(VisibleGaussians, TileBins)> = cams
        .iter()
        .zip(&truth_maps)
        .enumerate()
        .map(|(v, (c, t))| {
            let pass = view_visibility(&prepared, c.camera, c.world_from_cam, None, &LiftConfig::default());
            let swap = |l: u32| if v == 0 && l > 0 { 3 - l } else { l };
            let labels = pass.visible.pixels.iter().map(|&p| swap(t.data[p as usize])).collect();
            let visible =
                VisibleGaussians { gaussians: pass.visible.gaussians, weights: pass.visible.weights, labels };
            (visible, pass.tile_lists)
        })
        .collect();
    // The truth in the final numbering (by first appearance).
    let mut numbered_truth = truth_maps.clone();
    renumber(&mut numbered_truth, &mut []);
    let table = [0u32, 1, 2];
    for final_maps in [FinalMaps::Rendered, FinalMaps::Snapped] {
        let config = LiftConfig { final_maps, ..LiftConfig::default() };
        let run = |keep_tile_lists| {
            let store = MemoryViews { passes: passes.clone(), regions: truth_maps.clone(), keep_tile_lists };
            let matched =
                MatchedViews { global_of_label: vec![Some(&table[..]); cams.len()], objects: features() };
            LiftStage { gaussians: &prepared, cams: &cams, matched, config: &config, wholes: None }
                .run(&store)
                .unwrap()
        };
        let (kept, sorted) = (run(true), run(false));
        assert_eq!(kept.lifted, sorted.lifted, "{final_maps:?}");
        let (mut wrong, mut object_px) = (0, 0);
        for (v, t) in numbered_truth.iter().enumerate() {
            let map = kept.final_map(v);
            assert_eq!(map, sorted.final_map(v), "{final_maps:?}, view {v}");
            wrong += map.data.iter().zip(&t.data).filter(|(x, y)| x != y).count();
            object_px += t.data.iter().filter(|&&x| x > 0).count();
        }
        assert!(wrong * 20 <= object_px, "{final_maps:?}: {wrong} wrong of {object_px} object pixels");
        let labelled = kept.lifted.object_ids.iter().filter(|&&id| id > 0).count();
        assert!(labelled * 2 > means.len(), "{final_maps:?}: {labelled} labelled");
    }
}

/// Where the Gaussians say nothing the final maps keep the matched ids (issue 27): of two
/// spheres matched in every view, the second has no Gaussians at all (a part the 3DGS did not
/// reconstruct); its pixels still end with one id of their own, the same in every view, and the
/// first sphere keeps its pixels.
#[test]
fn an_object_without_gaussians_keeps_its_matched_id_in_every_view() {
    let first = sphere([-0.6, 0.0, 0.0], 0.4, 24);
    let mut both = first.clone();
    both.extend(sphere([0.6, 0.0, 0.0], 0.4, 24));
    let all = PreparedGaussians::new(&gaussians(&both, 0.06, 0.9)).unwrap();
    let truth: Vec<u32> = (0..both.len()).map(|i| if i < first.len() { 1 } else { 2 }).collect();
    let only_first = PreparedGaussians::new(&gaussians(&first, 0.06, 0.9)).unwrap();
    let cam = camera(96);
    let poses: Vec<_> = (0..8)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / 8.0;
            look_at(DVec3::new(3.5 * a.sin(), 1.0, -3.5 * a.cos()), DVec3::ZERO)
        })
        .collect();
    let cams: Vec<PosedCamera> =
        poses.iter().map(|p| PosedCamera { camera: &cam, world_from_cam: p }).collect();
    let truth_maps = render_views(&all, &RenderVotes::uniform(truth), &cams, &LiftConfig::default());
    let passes: Vec<(VisibleGaussians, TileBins)> = cams
        .iter()
        .zip(&truth_maps)
        .map(|(c, t)| {
            let pass = view_visibility(&only_first, c.camera, c.world_from_cam, None, &LiftConfig::default());
            let labels = pass.visible.pixels.iter().map(|&p| t.data[p as usize]).collect();
            let visible =
                VisibleGaussians { gaussians: pass.visible.gaussians, weights: pass.visible.weights, labels };
            (visible, pass.tile_lists)
        })
        .collect();
    let table = [0u32, 1, 2];
    for final_maps in [FinalMaps::Snapped, FinalMaps::SnappedRaw] {
        let config = LiftConfig { final_maps, ..LiftConfig::default() };
        let store =
            MemoryViews { passes: passes.clone(), regions: truth_maps.clone(), keep_tile_lists: true };
        let matched =
            MatchedViews { global_of_label: vec![Some(&table[..]); cams.len()], objects: features() };
        let out = LiftStage { gaussians: &only_first, cams: &cams, matched, config: &config, wholes: None }
            .run(&store)
            .unwrap();
        // Pixels per final id of each sphere's truth pixels, over all views.
        let mut px_of: [BTreeMap<u32, usize>; 2] = [BTreeMap::new(), BTreeMap::new()];
        for (v, t) in truth_maps.iter().enumerate() {
            for (&id, &truth) in out.final_map(v).data.iter().zip(&t.data) {
                if truth > 0 {
                    *px_of[truth as usize - 1].entry(id).or_insert(0) += 1;
                }
            }
        }
        let main = |m: &BTreeMap<u32, usize>| m.iter().max_by_key(|(_, &n)| n).map(|(&id, &n)| (id, n));
        let ((first_id, _), (second_id, second_main)) = (main(&px_of[0]).unwrap(), main(&px_of[1]).unwrap());
        let second_px: usize = px_of[1].values().sum();
        assert!(second_px > 1000, "{second_px} px");
        assert!(second_id != 0 && second_id != first_id, "{final_maps:?}: {px_of:?}");
        // All but the band the first sphere's splats bleed into (snapping keeps it).
        assert!(second_main * 20 >= second_px * 17, "{final_maps:?}: {px_of:?}");
        assert_eq!(px_of[1].get(&0), None, "{final_maps:?}: pixels of the second sphere left at 0");
    }
}
