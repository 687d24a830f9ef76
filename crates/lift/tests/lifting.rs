//! Majority vote, fusion, variance filter, render-back and renumbering.

mod common;
use common::{camera, gaussians, look_at, sphere};
use glam::DVec3;
use splatseg_lift::{
    drop_small_objects, lift_labels, render_all, render_votes, renumber, visibility_all, GaussianStatus,
    LiftConfig, LiftError, ObjectFeatures, PosedCamera, PreparedGaussians, RenderVotes, ViewVisibility,
};
use splatseg_scene::Plane;

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
    let lifted = lift_labels(1, &vis, &maps, features(), &config).unwrap();
    assert_eq!(lifted.object_ids, vec![1]);
    assert_eq!(lifted.views_seen, vec![3]);
    // Fused feature = weighted mean: (1·f1 + 10·f2 + 1·f1) / 12.
    let f = &lifted.fused_features.as_ref().unwrap().to_block().values;
    assert!((f[0] - 2.0 / 12.0).abs() < 1e-6 && (f[1] - 10.0 / 12.0).abs() < 1e-6, "{f:?}");
    // A tie in counts goes to the larger weight.
    let (vis, maps) = single_gaussian_views(&[1, 2], &[1.0, 3.0]);
    let lifted = lift_labels(1, &vis, &maps, features(), &config).unwrap();
    assert_eq!(lifted.object_ids, vec![2]);
}

#[test]
fn variance_filter_marks_disagreeing_gaussians_unreliable() {
    let config = LiftConfig::default();
    // 3 views say 1, one says 2 (orthogonal): σ² = p(1−p)·‖f1 − f2‖² = 0.75·0.25·2 = 0.375.
    let (vis, maps) = single_gaussian_views(&[1, 1, 1, 2], &[1.0; 4]);
    let lifted = lift_labels(1, &vis, &maps, features(), &config).unwrap();
    assert!((lifted.variances[0] - 0.375).abs() < 1e-5, "{}", lifted.variances[0]);
    assert_eq!(lifted.status, vec![GaussianStatus::Unreliable]);
    assert_eq!(lifted.object_ids, vec![-1]);
    assert_eq!(lifted.majority_ids, vec![1]);
    // Disagreeing with a near-identical object (cos 0.99) is fine: σ² = 0.1875·0.02 ≈ 0.004.
    let (vis, maps) = single_gaussian_views(&[1, 1, 1, 3], &[1.0; 4]);
    let lifted = lift_labels(1, &vis, &maps, features(), &config).unwrap();
    assert_eq!(lifted.object_ids, vec![1]);
    assert!(lifted.variances[0] < 0.005);
    // Full agreement: zero variance.
    let (vis, maps) = single_gaussian_views(&[2, 2], &[1.0, 5.0]);
    let lifted = lift_labels(1, &vis, &maps, features(), &config).unwrap();
    assert_eq!((lifted.object_ids[0], lifted.variances[0]), (2, 0.0));
}

#[test]
fn mostly_unmasked_gaussian_gets_no_object_and_unseen_is_marked() {
    let (vis, maps) = single_gaussian_views(&[0, 0, 1], &[1.0; 3]);
    let lifted = lift_labels(2, &vis, &maps, features(), &LiftConfig::default()).unwrap();
    assert_eq!(lifted.status, vec![GaussianStatus::NoObject, GaussianStatus::Unseen]);
    assert_eq!(lifted.object_ids, vec![-1, -1]);
    assert_eq!(lifted.stats.no_object, 1);
    assert_eq!(lifted.stats.unseen, 1);
}

#[test]
fn bad_maps_are_errors() {
    let (vis, _) = single_gaussian_views(&[1], &[1.0]);
    let err =
        lift_labels(1, &vis, &[Plane::filled(1, 1, 9)], features(), &LiftConfig::default()).unwrap_err();
    assert!(matches!(err, LiftError::UnknownObject { view: 0, id: 9, n_objects: 3 }), "{err}");
    let err = lift_labels(1, &vis, &[], features(), &LiftConfig::default()).unwrap_err();
    assert!(matches!(err, LiftError::Count { .. }), "{err}");
    let vis = vec![ViewVisibility { gaussians: vec![0], pixels: vec![5], weights: vec![1.0] }];
    let err =
        lift_labels(1, &vis, &[Plane::filled(2, 2, 1)], features(), &LiftConfig::default()).unwrap_err();
    assert!(matches!(err, LiftError::MapTooSmall { view: 0, pixels: 4 }), "{err}");
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
    let mut maps = render_all(&prepared, &RenderVotes::uniform(truth.clone()), &cams, &config);
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
    let vis = visibility_all(&prepared, &cams, None, &config).unwrap();
    let total_visible: usize = vis.iter().map(|v| v.len()).sum();
    assert!(total_visible < 12 * means.len() * 3 / 4, "back faces are culled: {total_visible}");
    let lifted = lift_labels(means.len(), &vis, &maps, features(), &config).unwrap();
    // Gaussians seen in 3+ views are outvoting view 0 (those seen by view 0 alone cannot).
    let seen: Vec<usize> = (0..means.len()).filter(|&i| lifted.views_seen[i] >= 3).collect();
    let correct = seen.iter().filter(|&&i| lifted.majority_ids[i] == truth[i]).count();
    assert!(seen.len() > means.len() / 2, "{} seen in 3+ views", seen.len());
    assert!(correct as f64 >= 0.98 * seen.len() as f64, "{correct}/{}", seen.len());
    // Rendered back, every view (including the corrupted one, which had every object pixel
    // wrong) shows the truth on ≥ 95 % of its object pixels.
    let votes = render_votes(&lifted, &config);
    let back = render_all(&prepared, &votes, &cams, &config);
    let truth_maps = render_all(&prepared, &RenderVotes::uniform(truth.clone()), &cams, &config);
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
            let maps = render_all(&prepared, &RenderVotes::uniform(truth.clone()), &cams, &config);
            let vis = visibility_all(&prepared, &cams, None, &config).unwrap();
            lift_labels(means.len(), &vis, &maps, features(), &config).unwrap()
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
fn specks_are_dropped() {
    let mut maps = vec![
        Plane::from_vec(4, 1, vec![1, 1, 2, 0]).unwrap(),
        Plane::from_vec(4, 1, vec![1, 3, 3, 3]).unwrap(),
    ];
    let mut ids = vec![1, 2, 3, -1];
    assert_eq!(drop_small_objects(&mut maps, &mut ids, 3), 1);
    assert_eq!(maps[0].data, vec![1, 1, 0, 0]);
    assert_eq!(ids, vec![1, -1, 3, -1]);
}

#[test]
fn votes_accumulated_view_by_view_equal_the_whole_lift_and_bad_lists_are_errors() {
    let (vis, maps) = single_gaussian_views(&[1, 2, 1, 3], &[1.0, 2.0, 0.5, 1.5]);
    let config = LiftConfig::default();
    let whole = lift_labels(1, &vis, &maps, features(), &config).unwrap();
    let mut votes = splatseg_lift::VoteAccumulator::new(1);
    for (v, m) in vis.iter().zip(&maps) {
        votes.add_view(&v.gaussians, &v.weights, &[m.data[0]]).unwrap();
    }
    assert_eq!(votes.finish(features(), &config).unwrap(), whole);
    let mut votes = splatseg_lift::VoteAccumulator::new(3);
    let err = votes.add_view(&[2, 1], &[1.0, 1.0], &[1, 1]).unwrap_err();
    assert!(matches!(err, LiftError::VisibleList { view: 0, n_gaussians: 3 }), "{err}");
    assert!(votes.add_view(&[0, 3], &[1.0, 1.0], &[1, 1]).is_err(), "index past the end");
    assert!(votes.add_view(&[0], &[1.0, 1.0], &[1]).is_err(), "weights of another length");
}
