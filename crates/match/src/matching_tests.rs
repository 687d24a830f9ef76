//! Behaviour of `match_masks` on hand-made views.

use crate::{match_masks, MatchConfig, MatchError, MatchInput, ViewMasks, ViewObservations};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A view whose masks have the given 2D descriptors and area 100.
fn view(features: &[[f32; 2]]) -> ViewMasks {
    ViewMasks { features: features.iter().flatten().copied().collect(), areas_px: vec![100; features.len()] }
}

/// Observations of one view: `(first Gaussian, count, label)` runs, in increasing Gaussian order.
fn observed(runs: &[(u32, u32, u32)]) -> ViewObservations {
    let mut obs = ViewObservations::default();
    for &(start, count, label) in runs {
        obs.gaussians.extend(start..start + count);
        obs.labels.extend(std::iter::repeat_n(label, count as usize));
    }
    obs
}

const A: [f32; 2] = [1.0, 0.0];
const B: [f32; 2] = [0.0, 1.0];

#[test]
fn descriptors_alone_give_consistent_stable_ids() {
    // View 1 lists the objects in the other order; ids follow first appearance (view 0).
    let input =
        MatchInput { dim: 2, views: vec![view(&[A, B]), view(&[B, A]), view(&[A, B])], observations: None };
    let m = match_masks(&input, &MatchConfig::default()).unwrap();
    assert_eq!(m.n_objects, 2);
    assert_eq!(m.global_of_label, vec![vec![0, 1, 2], vec![0, 2, 1], vec![0, 1, 2]]);
    assert!((m.object_feature(1).unwrap()[0] - 1.0).abs() < 1e-6);
    assert!((m.object_feature(2).unwrap()[1] - 1.0).abs() < 1e-6);
}

#[test]
fn below_tau_match_stays_apart() {
    // cos = 0.6 < 0.7.
    let input = MatchInput { dim: 2, views: vec![view(&[A]), view(&[[0.6, 0.8]])], observations: None };
    let m = match_masks(&input, &MatchConfig::default()).unwrap();
    assert_eq!(m.n_objects, 2);
}

#[test]
fn union_find_refuses_two_masks_of_one_view() {
    // View 0 has two fragments both similar to view 1's mask: only the better one joins it.
    let near = [0.95, 0.312_25];
    let input = MatchInput { dim: 2, views: vec![view(&[near, A]), view(&[A])], observations: None };
    let m = match_masks(&input, &MatchConfig::default()).unwrap();
    assert_eq!(m.n_objects, 2);
    assert_eq!(m.global_of_label[1][1], m.global_of_label[0][2], "the exact match wins");
    assert_ne!(m.global_of_label[0][1], m.global_of_label[0][2]);
    assert_eq!(m.stats.refused_same_view, 1);
}

#[test]
fn disjoint_gaussians_keep_identical_looking_masks_apart() {
    // White-on-white: two objects with the same descriptor. View 0 sees object P (Gaussians
    // 0..50) in its mask, object Q (50..100) unlabelled; view 1 the opposite.
    let views = vec![view(&[A]), view(&[A])];
    let without = MatchInput { dim: 2, views: views.clone(), observations: None };
    assert_eq!(match_masks(&without, &MatchConfig::default()).unwrap().n_objects, 1);
    let obs = vec![observed(&[(0, 50, 1), (50, 50, 0)]), observed(&[(0, 50, 0), (50, 50, 1)])];
    let with = MatchInput { dim: 2, views, observations: Some(obs) };
    let m = match_masks(&with, &MatchConfig::default()).unwrap();
    assert_eq!(m.n_objects, 2);
    assert_eq!(m.stats.cannot_links, 1);
}

#[test]
fn cannot_link_blocks_a_descriptor_chain() {
    // Views 0 and 2 see disjoint Gaussians in their masks (cannot-link); view 1's mask has no
    // 3D support with either (it sees nothing), so descriptors alone would chain all three.
    let views = vec![view(&[A]), view(&[A]), view(&[A])];
    let obs = vec![
        observed(&[(0, 50, 1), (50, 50, 0)]),
        ViewObservations::default(),
        observed(&[(0, 50, 0), (50, 50, 1)]),
    ];
    let m =
        match_masks(&MatchInput { dim: 2, views, observations: Some(obs) }, &MatchConfig::default()).unwrap();
    assert_eq!(m.n_objects, 2);
    assert_eq!(m.stats.refused_cannot_link, 1);
    assert_eq!(m.global_of_label[1][1], 1, "view 1 joins view 0 first (lower mask index)");
}

#[test]
fn shared_gaussians_join_masks_whose_descriptors_differ() {
    // cos = 0.6: below τ_match, above the 3D-backed gate of 0.5; same Gaussians in both views.
    let views = vec![view(&[A]), view(&[[0.6, 0.8]])];
    let obs = vec![observed(&[(0, 60, 1)]), observed(&[(0, 60, 1)])];
    let m =
        match_masks(&MatchInput { dim: 2, views, observations: Some(obs) }, &MatchConfig::default()).unwrap();
    assert_eq!(m.n_objects, 1);
    assert_eq!(m.stats.edges_3d, 1);
}

#[test]
fn a_fragment_joins_its_whole_by_containment() {
    // View 0: one mask over Gaussians 0..100. View 1: the object split in two fragments
    // (0..70 and 70..100). The larger fragment has more shared Gaussians... both are fully
    // contained (overlap 1); the tie is broken by cosine, then index: only one may join.
    let views = vec![view(&[A]), view(&[A, [0.9, 0.435_89]])];
    let obs = vec![observed(&[(0, 100, 1)]), observed(&[(0, 70, 1), (70, 30, 2)])];
    let m =
        match_masks(&MatchInput { dim: 2, views, observations: Some(obs) }, &MatchConfig::default()).unwrap();
    assert_eq!(m.global_of_label[1][1], m.global_of_label[0][1]);
    assert_ne!(m.global_of_label[1][2], m.global_of_label[0][1]);
}

fn random_input(seed: u64) -> MatchInput {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let dim = 8;
    let centres: Vec<Vec<f32>> =
        (0..6).map(|_| (0..dim).map(|_| rng.gen_range(-1.0..1.0)).collect()).collect();
    let mut views = Vec::new();
    let mut observations = Vec::new();
    for _ in 0..7 {
        let mut masks = ViewMasks::default();
        let mut obs = ViewObservations::default();
        for (o, c) in centres.iter().enumerate() {
            if rng.gen_bool(0.8) {
                masks.features.extend(c.iter().map(|x| x + rng.gen_range(-0.2..0.2)));
                masks.areas_px.push(rng.gen_range(50..500));
                let label = masks.len() as u32;
                for g in (o as u32 * 40)..(o as u32 * 40 + 40) {
                    if rng.gen_bool(0.7) {
                        obs.gaussians.push(g);
                        obs.labels.push(if rng.gen_bool(0.9) { label } else { 0 });
                    }
                }
            }
        }
        views.push(masks);
        observations.push(obs);
    }
    MatchInput { dim, views, observations: Some(observations) }
}

#[test]
fn deterministic_across_runs_and_thread_counts() {
    for seed in 0..4 {
        let input = random_input(seed);
        let config = MatchConfig::default();
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let two = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let a = one.install(|| match_masks(&input, &config).unwrap());
        let b = two.install(|| match_masks(&input, &config).unwrap());
        let c = match_masks(&input, &config).unwrap();
        assert_eq!(a, b);
        assert_eq!(a, c);
        // Each view's masks got distinct ids, and ids are numbered by first appearance.
        let mut seen = 0;
        for ids in &a.global_of_label {
            let mut sorted = ids[1..].to_vec();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), ids.len() - 1, "two masks of one view share an id");
            for &id in &ids[1..] {
                assert!(id <= seen + 1, "id {id} appears before id {}", seen + 1);
                seen = seen.max(id);
            }
        }
        // The 6 underlying objects are recovered (each object's masks share Gaussians).
        assert_eq!(a.n_objects, 6, "seed {seed}");
    }
}

#[test]
fn inconsistent_inputs_are_errors() {
    let bad = MatchInput {
        dim: 2,
        views: vec![ViewMasks { features: vec![1.0], areas_px: vec![1] }],
        observations: None,
    };
    assert!(matches!(match_masks(&bad, &MatchConfig::default()), Err(MatchError::Shape { view: 0, .. })));
    let obs = vec![observed(&[(0, 5, 3)])];
    let bad = MatchInput { dim: 2, views: vec![view(&[A])], observations: Some(obs) };
    let err = match_masks(&bad, &MatchConfig::default()).unwrap_err();
    assert!(matches!(err, MatchError::UnknownLabel { view: 0, label: 3, masks: 1 }), "{err}");
    let nan = MatchInput { dim: 2, views: vec![view(&[[f32::NAN, 0.0]])], observations: None };
    assert!(matches!(match_masks(&nan, &MatchConfig::default()), Err(MatchError::NonFinite { .. })));
}

/// Object O is Gaussians 0..100, object P 100..200. View 0 holds O in two fragments (masks 1:
/// 0..50, 2: 50..100) and P in mask 3; `whole` views hold O in mask 1 and P in mask 2; a
/// `merged` view holds both in mask 1.
fn fragment_scene(whole: usize, merged: usize) -> MatchInput {
    let masks = |n: usize| ViewMasks { features: Vec::new(), areas_px: vec![100; n] };
    let mut views = vec![masks(3)];
    let mut observations = vec![observed(&[(0, 50, 1), (50, 50, 2), (100, 100, 3)])];
    for _ in 0..whole {
        views.push(masks(2));
        observations.push(observed(&[(0, 100, 1), (100, 100, 2)]));
    }
    for _ in 0..merged {
        views.push(masks(1));
        observations.push(observed(&[(0, 200, 1)]));
    }
    MatchInput { dim: 0, views, observations: Some(observations) }
}

#[test]
fn a_view_that_merged_two_objects_joins_neither_and_a_fragment_keeps_its_own_mask() {
    // O and P are one mask in one view only; three views see them apart. View 0's second
    // fragment of O joins nothing in matching (each cluster holds one mask per view): lifting's
    // vote gives its Gaussians O's id.
    let input = fragment_scene(3, 1);
    let m = match_masks(&input, &MatchConfig::default()).unwrap();
    let g = &m.global_of_label;
    assert_ne!(g[0][1], g[0][3], "{g:?}");
    assert_ne!(g[0][2], g[0][3], "{g:?}");
    assert_eq!(g[0][1], g[1][1], "{g:?}");
    assert_eq!(g[0][3], g[1][2], "{g:?}");
    assert_ne!(g[0][1], g[0][2], "{g:?}");
}

/// Keeps the observations of the Gaussians whose index is a multiple of `stride`.
fn every_nth(input: &MatchInput, stride: u32) -> MatchInput {
    let observations = input.observations.as_ref().map(|obs| {
        obs.iter()
            .map(|o| {
                let (gaussians, labels) = o
                    .gaussians
                    .iter()
                    .zip(&o.labels)
                    .filter(|(&g, _)| g % stride == 0)
                    .map(|(&g, &l)| (g, l))
                    .unzip();
                ViewObservations { gaussians, labels }
            })
            .collect()
    });
    MatchInput { observations, ..input.clone() }
}

#[test]
fn observations_a_caller_sampled_are_subsampled_by_multiples_of_their_stride() {
    let input = every_nth(&random_input(3), 4);
    let unlimited = MatchConfig { max_pair_samples: u64::MAX, ..MatchConfig::default() };
    assert_eq!(
        match_masks(&input, &unlimited).unwrap().stats.evidence_stride,
        4,
        "the caller's stride is reported"
    );
    // A pair budget that asks for half of the sampled pairs: every 8th Gaussian, not every 4th again.
    let tight = MatchConfig { max_pair_samples: 1, ..MatchConfig::default() };
    let halved = every_nth(&input, 8);
    let pairs_budget = |m: &MatchInput| {
        let mut per_gaussian = std::collections::BTreeMap::<u32, u64>::new();
        for o in m.observations.iter().flatten() {
            for &g in &o.gaussians {
                *per_gaussian.entry(g).or_default() += 1;
            }
        }
        per_gaussian.values().map(|&k| k * k.saturating_sub(1) / 2).sum::<u64>()
    };
    let config = MatchConfig { max_pair_samples: pairs_budget(&input).div_ceil(2), ..tight };
    let sampled = match_masks(&input, &config).unwrap();
    assert_eq!(sampled.stats.evidence_stride, 8);
    let direct = match_masks(&halved, &unlimited).unwrap();
    assert_eq!(direct.stats.evidence_stride, 8);
    assert_eq!(sampled.global_of_label, direct.global_of_label, "the same Gaussians were counted");
}

/// `n_views` views of the same four objects (descriptors with a little noise), each object's
/// Gaussians seen in every view inside its mask.
fn many_views(n_views: usize, seed: u64) -> MatchInput {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let centres = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
    let mut views = Vec::new();
    let mut observations = Vec::new();
    for _ in 0..n_views {
        let mut masks = ViewMasks::default();
        for c in &centres {
            masks.features.extend(c.iter().map(|x| x + rng.gen_range(-0.1..0.1)));
            masks.areas_px.push(100);
        }
        views.push(masks);
        observations.push(observed(&[(0, 30, 1), (30, 30, 2), (60, 30, 3), (90, 30, 4)]));
    }
    MatchInput { dim: 4, views, observations: Some(observations) }
}

#[test]
fn a_tight_candidate_budget_keeps_memory_bounded_and_still_finds_every_object() {
    // 80 views × 4 masks: each mask has 79 candidate partners, the budget keeps 16 per mask.
    for with_3d in [false, true] {
        let mut input = many_views(80, 5);
        if !with_3d {
            input.observations = None;
        }
        let tight = MatchConfig { max_candidate_edges: 1, ..MatchConfig::default() };
        let all = MatchConfig { max_candidate_edges: u64::MAX, ..MatchConfig::default() };
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let two = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let bounded = one.install(|| match_masks(&input, &tight).unwrap());
        assert_eq!(bounded, two.install(|| match_masks(&input, &tight).unwrap()), "thread count");
        let candidates = bounded.stats.edges_3d + bounded.stats.edges_descriptor;
        assert_eq!(candidates, 4 * 80 * 79 / 2, "every candidate is counted (3D: {with_3d})");
        // The union-find saw at most 16 edges per mask (of 79), yet every object is found.
        assert_eq!(bounded.n_objects, 4, "3D: {with_3d}");
        let unbounded = match_masks(&input, &all).unwrap();
        assert_eq!(bounded.global_of_label, unbounded.global_of_label, "3D: {with_3d}");
    }
}

#[test]
fn the_default_budget_keeps_every_candidate_on_small_captures() {
    // 25 views × 4 masks: 100 masks, 24 candidates each, well under 500,000 / 100 kept per mask.
    let input = many_views(25, 6);
    let default = match_masks(&input, &MatchConfig::default()).unwrap();
    let all = match_masks(&input, &MatchConfig { max_candidate_edges: u64::MAX, ..MatchConfig::default() })
        .unwrap();
    assert_eq!(default, all);
}
