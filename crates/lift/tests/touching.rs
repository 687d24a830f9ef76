//! Joining touching look-alike objects.

use crate::common::{gaussians, lifted};
use splatseg_lift::{
    join_touching_objects, Facing, LiftConfig, Lifted, ObjectFeatures, PreparedGaussians, SeparateWholes,
    ViewCounts,
};

/// A 20 × 20 grid of Gaussians (spacing 0.02) at x offset `x0` and depth `z`.
fn patch(x0: f32, z: f32) -> Vec<[f32; 3]> {
    (0..400).map(|k| [x0 + (k % 20) as f32 * 0.02, (k / 20) as f32 * 0.02, z]).collect()
}

/// Objects 1, 2, 3: object 1 and 2 alike (cos 0.98), 3 different (cos 0.3 with 1).
const FEATURES: [f32; 6] = [1.0, 0.0, 0.98, 0.198_99, 0.3, 0.953_94];

/// Every Gaussian facing one camera in front of the patches.
fn facing_camera(prepared: &PreparedGaussians) -> Facing {
    let all: Vec<u32> = (0..prepared.len() as u32).collect();
    let mut facing = Facing::new(prepared.len());
    facing.add_view(prepared, &all, glam::Vec3::new(0.4, 0.2, 0.0));
    facing
}

/// The join with no view counts (so no rule that asks the views decides).
fn run(means: Vec<[f32; 3]>, ids: Vec<i32>) -> (usize, Lifted) {
    let prepared = PreparedGaussians::new(&gaussians(&means, 0.01, 0.9)).unwrap();
    let mut l = lifted(ids);
    let features = ObjectFeatures { dim: 2, values: &FEATURES };
    let joins = join_touching_objects(
        &prepared,
        &mut l,
        features,
        &[],
        Some(&facing_camera(&prepared)),
        None,
        &LiftConfig::default(),
    )
    .joins;
    (joins, l)
}

#[test]
fn touching_look_alikes_join_and_distant_ones_do_not() {
    // Object 2 continues object 1's surface (a seam at x = 0.4).
    let mut means = patch(0.0, 2.0);
    means.extend(patch(0.4, 2.0));
    let ids: Vec<i32> = (0..800).map(|i| if i < 400 { 1 } else { 2 }).collect();
    let (joins, l) = run(means, ids);
    assert_eq!(joins, 1);
    assert!(l.object_ids.iter().all(|&i| i == 1));
    assert!(l.majority_ids.iter().all(|&i| i == 1));

    // The same two look-alikes 1 m apart in depth (white-on-white): untouched.
    let mut means = patch(0.0, 2.0);
    means.extend(patch(0.4, 3.0));
    let ids: Vec<i32> = (0..800).map(|i| if i < 400 { 1 } else { 2 }).collect();
    let (joins, l) = run(means, ids.clone());
    assert_eq!(joins, 0);
    assert_eq!(l.object_ids, ids);
}

#[test]
fn touching_different_objects_stay_apart() {
    let mut means = patch(0.0, 2.0);
    means.extend(patch(0.4, 2.0));
    let ids: Vec<i32> = (0..800).map(|i| if i < 400 { 1 } else { 3 }).collect();
    let (joins, l) = run(means, ids.clone());
    assert_eq!(joins, 0);
    assert_eq!(l.object_ids, ids);
}

/// [`patch`] at x offset `x0` and depth `z`, turned up by 30° about its edge at `x0` (a crease
/// with a patch ending there: no one surface continues, so only the look-alike rule can join).
fn creased_patch(x0: f32, z: f32) -> Vec<[f32; 3]> {
    let (sin, cos) = 30f32.to_radians().sin_cos();
    patch(0.0, 0.0).into_iter().map(|[x, y, _]| [x0 + x * cos, y, z - x * sin]).collect()
}

#[test]
fn views_that_keep_the_pieces_apart_block_the_join() {
    // Two touching look-alike pieces meeting at a crease; every view sees all 800 Gaussians (one
    // per pixel) and its merged masks keep the pieces apart (mask 1 | mask 2).
    let mut means = patch(0.0, 2.0);
    means.extend(creased_patch(0.4, 2.0));
    let ids: Vec<i32> = (0..800).map(|i| if i < 400 { 1 } else { 2 }).collect();
    let prepared = PreparedGaussians::new(&gaussians(&means, 0.01, 0.9)).unwrap();
    // Every view sees all 800 Gaussians, one per pixel: a view's merged mask at each is its pixel's.
    let all: Vec<u32> = (0..800).collect();
    let apart: Vec<u32> = (0..800).map(|p| if p < 400 { 1 } else { 2 }).collect();
    let together = vec![1u32; 800];
    let counts = |masks: &[u32]| ViewCounts::new(&all, masks, &ids);
    let config = LiftConfig::default();
    let features = ObjectFeatures { dim: 2, values: &FEATURES };
    let facing = facing_camera(&prepared);
    // One view of three unites them: share 1/3 < 0.5, no join.
    let views = [counts(&apart), counts(&apart), counts(&together)];
    let mut l = lifted(ids.clone());
    assert_eq!(
        join_touching_objects(&prepared, &mut l, features, &views, Some(&facing), None, &config).joins,
        0
    );
    // Two of three: share 2/3, joined.
    let views = [counts(&apart), counts(&together), counts(&together)];
    let mut l = lifted(ids.clone());
    assert_eq!(
        join_touching_objects(&prepared, &mut l, features, &views, Some(&facing), None, &config).joins,
        1
    );
}

/// SAM's wholes (a stand-in for the merge's evidence): object 1's Gaussians (0..400) and object
/// 3's (800..1200) are in different wholes, so any two sets holding one each are.
struct OneAndThreeApart;

impl SeparateWholes for OneAndThreeApart {
    fn separate(&self, a: &[u32], b: &[u32]) -> bool {
        let has = |s: &[u32], r: std::ops::Range<u32>| s.iter().any(|g| r.contains(g));
        (has(a, 0..400) && has(b, 800..1200)) || (has(b, 0..400) && has(a, 800..1200))
    }
}

/// Three look-alike patches in a row on one plane, objects 1 | 2 | 3 (Gaussians `[400 (k-1)..400 k]`),
/// seams at x = 0.4 and 0.8: the Gaussians and their ids.
fn three_patches_in_a_row() -> (PreparedGaussians, Vec<i32>) {
    let mut means = patch(0.0, 2.0);
    means.extend(patch(0.4, 2.0));
    means.extend(patch(0.8, 2.0));
    let ids: Vec<i32> = (0..1200).map(|i| 1 + i / 400).collect();
    (PreparedGaussians::new(&gaussians(&means, 0.01, 0.9)).unwrap(), ids)
}

#[test]
fn sam_wholes_veto_a_chain_of_joins_through_a_piece_touching_both() {
    // Three look-alike patches in a row on one plane: 1 | 2 | 3, seams at x = 0.4 and 0.8. Pair
    // (2, 3) is the better one (cos 0.998, then (1, 2) 0.990); 1 and 3 never touch.
    let (prepared, ids) = three_patches_in_a_row();
    let features = ObjectFeatures { dim: 2, values: &[1.0, 0.0, 0.99, 0.141_07, 0.98, 0.198_99] };
    let facing = facing_camera(&prepared);
    let join = |wholes: Option<&dyn SeparateWholes>| {
        let mut l = lifted(ids.clone());
        let config = LiftConfig::default();
        let joins =
            join_touching_objects(&prepared, &mut l, features, &[], Some(&facing), wholes, &config).joins;
        (joins, l.object_ids)
    };
    // Without SAM's wholes the chain makes one object.
    let (joins, joined) = join(None);
    assert_eq!(joins, 2);
    assert!(joined.iter().all(|&i| i == 1));
    // With them: (2, 3) joins (neither side holds object 1), then (1, 2) would put 1 with 3 through
    // 2, which the wholes keep apart, although the pair (1, 2) alone is not.
    assert!(!OneAndThreeApart.separate(&(0..400).collect::<Vec<_>>(), &(400..800).collect::<Vec<_>>()));
    let (joins, joined) = join(Some(&OneAndThreeApart));
    assert_eq!(joins, 1);
    assert!(joined[..400].iter().all(|&i| i == 1));
    assert!(joined[400..].iter().all(|&i| i == 2));
}

#[test]
fn the_join_reports_every_edge_with_its_evidence_rule_and_outcome() {
    // The chain of the test above, vetoed by SAM's wholes: the report lists the two touching pairs
    // (1 and 3 never touch), each with the rule that asked for its join and what became of it.
    let (prepared, ids) = three_patches_in_a_row();
    let features = ObjectFeatures { dim: 2, values: &[1.0, 0.0, 0.99, 0.141_07, 0.98, 0.198_99] };
    let facing = facing_camera(&prepared);
    let mut l = lifted(ids);
    let report = join_touching_objects(
        &prepared,
        &mut l,
        features,
        &[],
        Some(&facing),
        Some(&OneAndThreeApart),
        &LiftConfig::default(),
    );
    assert_eq!(report.joins, 1);
    let edges: Vec<(u32, u32, &str, &str)> =
        report.edges.iter().map(|e| (e.a, e.b, e.rule, e.outcome)).collect();
    assert_eq!(edges, vec![(1, 2, "seam", "refused: SAM's wholes"), (2, 3, "seam", "joined")]);
    let e = &report.edges[1];
    assert_eq!(e.sizes, [400, 400]);
    assert!(e.voxel_pairs >= 8 && e.smooth > 0 && e.coplanar, "{e:?}");
    assert!((e.cos - (0.99 * 0.98 + 0.141_07 * 0.198_99)).abs() < 1e-5, "{e:?}");
    assert_eq!(e.sam, None, "this stand-in gives no counts");
}

/// SAM's wholes (a stand-in): object 2's Gaussians (400..800) alone sit in nested masks apart
/// from object 1's (0..400); object 2 with object 3 beside it fills no nested mask, so the sets
/// `{2, 3}` and `{1}` are not apart.
struct TwoAloneApartFromOne;

impl SeparateWholes for TwoAloneApartFromOne {
    fn separate(&self, a: &[u32], b: &[u32]) -> bool {
        let two_alone = |s: &[u32]| s.len() == 400 && s.iter().all(|g| (400..800).contains(g));
        let has_one = |s: &[u32]| s.iter().any(|g| (0..400).contains(g));
        (two_alone(a) && has_one(b)) || (two_alone(b) && has_one(a))
    }
}

#[test]
fn sam_wholes_that_keep_two_objects_apart_veto_their_join_after_one_joined_a_third() {
    // The three patches of the test above: (2, 3) joins first, then (1, 2) is asked. The sets
    // {1} and {2, 3} are not apart by the masks, but objects 1 and 2 themselves are.
    let (prepared, ids) = three_patches_in_a_row();
    let features = ObjectFeatures { dim: 2, values: &[1.0, 0.0, 0.99, 0.141_07, 0.98, 0.198_99] };
    let facing = facing_camera(&prepared);
    let sets = |a: std::ops::Range<u32>, b: std::ops::Range<u32>| {
        TwoAloneApartFromOne.separate(&a.collect::<Vec<_>>(), &b.collect::<Vec<_>>())
    };
    assert!(sets(400..800, 0..400) && !sets(400..1200, 0..400) && !sets(400..800, 800..1200));
    let mut l = lifted(ids);
    let config = LiftConfig::default();
    let joins = join_touching_objects(
        &prepared,
        &mut l,
        features,
        &[],
        Some(&facing),
        Some(&TwoAloneApartFromOne),
        &config,
    )
    .joins;
    assert_eq!(joins, 1);
    assert!(l.object_ids[..400].iter().all(|&i| i == 1));
    assert!(l.object_ids[400..].iter().all(|&i| i == 2));
}
