//! Contribution-weighted ids, fusion, variance filter, render-back and renumbering.

mod common;
use common::{camera, gaussians, look_at, sphere};
use glam::DVec3;
use splatseg_lift::{
    drop_small_objects, lift_labels, render_all, render_votes, renumber, view_contributions, GaussianStatus,
    IdRule, LiftConfig, LiftError, LiftView, ObjectFeatures, PosedCamera, PreparedGaussians, RenderVotes,
    ViewContributions,
};
use splatseg_scene::Plane;

/// One Gaussian (index 0) per view, contributing `weight` to label `id` (labels are global ids:
/// the identity table below).
fn single_gaussian_views(ids: &[u32], weights: &[f32]) -> Vec<ViewContributions> {
    ids.iter()
        .zip(weights)
        .map(|(&id, &w)| ViewContributions {
            gaussians: vec![0],
            labels: vec![id],
            weights: vec![w],
            alphas: vec![w],
        })
        .collect()
}

const IDENTITY: [u32; 10] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9];

fn lift(
    n: usize,
    views: &[ViewContributions],
    config: &LiftConfig,
) -> Result<splatseg_lift::Lifted, LiftError> {
    let views: Vec<LiftView> =
        views.iter().map(|c| LiftView { contributions: c, global_of_label: &IDENTITY[..4] }).collect();
    lift_labels(n, &views, features(), config)
}

/// Three objects: 1 and 2 orthogonal, 3 close to 1 (cos 0.99).
const FEATURES: [f32; 6] = [1.0, 0.0, 0.0, 1.0, 0.99, 0.141_067_4];

fn features() -> ObjectFeatures<'static> {
    ObjectFeatures { dim: 2, values: &FEATURES }
}

#[test]
fn the_id_of_largest_summed_contribution_or_soft_vote_wins() {
    // Two views give 1 a little weight each, one gives 2 much more: the summed contribution
    // picks 2, the soft vote (one vote per view) picks 1.
    let views = single_gaussian_views(&[1, 2, 1], &[1.0, 10.0, 1.0]);
    let config = LiftConfig { tau_var: 10.0, id_rule: IdRule::Contribution, ..LiftConfig::default() };
    let lifted = lift(1, &views, &config).unwrap();
    assert_eq!(lifted.object_ids, vec![2]);
    let soft = LiftConfig { id_rule: IdRule::SoftVote, ..config.clone() };
    assert_eq!(lift(1, &views, &soft).unwrap().object_ids, vec![1]);
    assert_eq!(lifted.views_seen, vec![3]);
    // Fused feature = weighted mean of the views' votes: (1·f1 + 10·f2 + 1·f1) / 12.
    let f = &lifted.fused_features.as_ref().unwrap().values;
    assert!((f[0] - 2.0 / 12.0).abs() < 1e-6 && (f[1] - 10.0 / 12.0).abs() < 1e-6, "{f:?}");
    // Equal sums go to the smaller id.
    let views = single_gaussian_views(&[2, 1], &[3.0, 3.0]);
    assert_eq!(lift(1, &views, &config).unwrap().object_ids, vec![1]);
}

#[test]
fn variance_filter_marks_disagreeing_gaussians_unreliable() {
    let config = LiftConfig::default();
    // 3 views say 1, one says 2 (orthogonal): σ² = p(1−p)·‖f1 − f2‖² = 0.75·0.25·2 = 0.375.
    let lifted = lift(1, &single_gaussian_views(&[1, 1, 1, 2], &[1.0; 4]), &config).unwrap();
    assert!((lifted.variances[0] - 0.375).abs() < 1e-5, "{}", lifted.variances[0]);
    assert_eq!(lifted.status, vec![GaussianStatus::Unreliable]);
    assert_eq!(lifted.object_ids, vec![-1]);
    assert_eq!(lifted.majority_ids, vec![1]);
    // Disagreeing with a near-identical object (cos 0.99) is fine: σ² = 0.1875·0.02 ≈ 0.004.
    let lifted = lift(1, &single_gaussian_views(&[1, 1, 1, 3], &[1.0; 4]), &config).unwrap();
    assert_eq!(lifted.object_ids, vec![1]);
    assert!(lifted.variances[0] < 0.005);
    // Full agreement: zero variance.
    let lifted = lift(1, &single_gaussian_views(&[2, 2], &[1.0, 5.0]), &config).unwrap();
    assert_eq!((lifted.object_ids[0], lifted.variances[0]), (2, 0.0));
}

/// A footprint straddling a mask edge in every view is no disagreement between views.
#[test]
fn a_boundary_split_within_each_view_is_not_unreliable() {
    let view = ViewContributions {
        gaussians: vec![0, 0],
        labels: vec![1, 2],
        weights: vec![0.6, 0.4],
        alphas: vec![0.6, 0.4],
    };
    let lifted = lift(1, &[view.clone(), view.clone(), view], &LiftConfig::default()).unwrap();
    assert_eq!(lifted.object_ids, vec![1]);
    assert_eq!(lifted.variances, vec![0.0]);
}

#[test]
fn background_and_unseen_gaussians_get_no_id() {
    // Weight 2 on unmasked pixels against 1 on object 1: no object.
    let views = single_gaussian_views(&[0, 0, 1], &[1.0; 3]);
    let lifted = lift(2, &views, &LiftConfig::default()).unwrap();
    assert_eq!(lifted.status, vec![GaussianStatus::NoObject, GaussianStatus::Unseen]);
    assert_eq!(lifted.object_ids, vec![-1, -1]);
    assert_eq!(lifted.stats.no_object, 1);
    assert_eq!(lifted.stats.unseen, 1);
    // With FlashSplat's background bias below ½ the object wins.
    let config = LiftConfig { background_weight: 0.4, ..LiftConfig::default() };
    assert_eq!(lift(2, &views, &config).unwrap().object_ids, vec![1, -1]);
    // A Gaussian whose weight in every view is below min_view_weight is seen by none.
    let faint = single_gaussian_views(&[1, 1], &[0.01, 0.01]);
    assert_eq!(lift(1, &faint, &LiftConfig::default()).unwrap().status, vec![GaussianStatus::TooFewViews]);
}

#[test]
fn bad_inputs_are_errors() {
    let views = single_gaussian_views(&[1], &[1.0]);
    let table = [0, 9];
    let bad = [LiftView { contributions: &views[0], global_of_label: &table }];
    let err = lift_labels(1, &bad, features(), &LiftConfig::default()).unwrap_err();
    assert!(matches!(err, LiftError::UnknownObject { view: 0, id: 9, n_objects: 3 }), "{err}");
    let far =
        ViewContributions { gaussians: vec![5], labels: vec![1], weights: vec![1.0], alphas: vec![1.0] };
    let err = lift(2, &[far], &LiftConfig::default()).unwrap_err();
    assert!(matches!(err, LiftError::Count { .. }), "{err}");
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
    let mut maps = render_all(&prepared, &RenderVotes::uniform(truth.clone()), &cams, &config).unwrap();
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
    let contributions: Vec<ViewContributions> = cams
        .iter()
        .zip(&maps)
        .map(|(c, m)| view_contributions(&prepared, c.camera, c.world_from_cam, m, &config).unwrap())
        .collect();
    let total_seen: usize = contributions.iter().map(|c| c.dominant(&config).len()).sum();
    assert!(total_seen < 12 * means.len() * 3 / 4, "back faces are hidden: {total_seen}");
    let lifted = lift(means.len(), &contributions, &config).unwrap();
    // Gaussians seen in 3+ views are outvoting view 0 (those seen by view 0 alone cannot).
    let seen: Vec<usize> = (0..means.len()).filter(|&i| lifted.views_seen[i] >= 3).collect();
    let correct = seen.iter().filter(|&&i| lifted.majority_ids[i] == truth[i]).count();
    assert!(seen.len() > means.len() / 2, "{} seen in 3+ views", seen.len());
    assert!(correct as f64 >= 0.98 * seen.len() as f64, "{correct}/{}", seen.len());
    // Rendered back, every view (including the corrupted one, which had every object pixel
    // wrong) shows the truth on ≥ 95 % of its object pixels.
    let votes = render_votes(&lifted, &config);
    let back = render_all(&prepared, &votes, &cams, &config).unwrap();
    let truth_maps = render_all(&prepared, &RenderVotes::uniform(truth.clone()), &cams, &config).unwrap();
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
            let maps = render_all(&prepared, &RenderVotes::uniform(truth.clone()), &cams, &config).unwrap();
            let contributions: Vec<ViewContributions> = cams
                .iter()
                .zip(&maps)
                .map(|(c, m)| view_contributions(&prepared, c.camera, c.world_from_cam, m, &config).unwrap())
                .collect();
            lift(means.len(), &contributions, &config).unwrap()
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
