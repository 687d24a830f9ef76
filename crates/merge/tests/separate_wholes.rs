//! The separate-wholes gate on a hand-built case: two regions that every per-view cue would merge
//! (alike descriptors, one depth, no edge between them), seen by four other views whose SAM masks
//! say either "two objects" (each side inside its own whole, never one mask over both), "one
//! object" (a whole over both sides: a two-tone box) or nothing about wholes (one mask per side).

use splatseg_cues::depth::DEPTH_GRADIENT_SIGMA_PX;
use splatseg_cues::edges::LOG_SIGMA_PX;
use splatseg_cues::{depth_gradient, log_edges, MaskInput, RegionDescriptors, RegionSource, Regions};
use splatseg_merge::{
    merge_view, merge_view_with_wholes, MergeConfig, Outcome, Profile, ViewInputs, ViewMaskSets, ViewWholes,
    WholesEvidence,
};
use splatseg_scene::Plane;

const W: usize = 60;
const H: usize = 40;

/// Left object x in 10..30, right object x in 30..50 (rows 10..30); background label 3.
fn label(x: usize, y: usize) -> u32 {
    match ((10..30).contains(&y), x) {
        (true, 10..=29) => 1,
        (true, 30..=49) => 2,
        _ => 3,
    }
}

fn plane<T: Clone>(f: impl Fn(usize, usize) -> T) -> Plane<T> {
    Plane::from_vec(W, H, (0..W * H).map(|p| f(p % W, p / W)).collect()).unwrap()
}

/// The view being merged: the two sides look alike and lie at one depth.
fn view() -> ViewInputs {
    let labels = plane(label);
    let descriptors: [[f32; 3]; 3] = [[1.0, 0.05, 0.0], [1.0, 0.0, 0.05], [0.0, 1.0, 0.2]];
    let mut areas = vec![0u64; 3];
    labels.data.iter().for_each(|&l| areas[l as usize - 1] += 1);
    let depth = plane(|x, y| if label(x, y) == 3 { 0.9 } else { 0.5 });
    ViewInputs {
        regions: Regions { labels, sources: vec![RegionSource::Uncovered; 3] },
        descriptors: RegionDescriptors { channels: 3, means: descriptors.concat(), areas },
        depth_gradient: depth_gradient(&depth, DEPTH_GRADIENT_SIGMA_PX),
        depth,
        edges: log_edges(&plane(|_, _| 0.5f32), LOG_SIGMA_PX),
        points: None,
        normals: None,
    }
}

fn mask(inside: impl Fn(usize, usize) -> bool) -> MaskInput {
    MaskInput::from_plane(&plane(inside), 0.9, 0.9)
}

/// What one other view's SAM says.
#[derive(Clone, Copy)]
enum Sam {
    /// Each side a part mask inside its own whole mask.
    TwoWholes,
    /// A part mask per side and a whole over both.
    OneWhole,
    /// One mask per side, nothing nested.
    Parts,
}

fn masks(sam: Sam) -> Vec<MaskInput> {
    let left = mask(|x, y| label(x, y) == 1);
    let right = mask(|x, y| label(x, y) == 2);
    let background = mask(|x, y| label(x, y) == 3);
    // A part: the half of a side nearer the contact.
    let left_part = mask(|x, y| label(x, y) == 1 && x >= 20);
    let right_part = mask(|x, y| label(x, y) == 2 && x < 40);
    match sam {
        Sam::TwoWholes => vec![left_part, left, right_part, right, background],
        Sam::OneWhole => vec![left, right, mask(|x, y| label(x, y) != 3), background],
        Sam::Parts => vec![left, right, background],
    }
}

/// Every view sees the same pixels (Gaussian `g` at pixel `g`, one per pixel); view 0 is merged,
/// the others' masks are `others`.
fn evidence(others: &[Sam]) -> WholesEvidence {
    let all: Vec<u32> = (0..(W * H) as u32).collect();
    let mut views = vec![ViewMaskSets::new(&masks(Sam::Parts), &all, &all, 1)];
    views.extend(others.iter().map(|&s| ViewMaskSets::new(&masks(s), &all, &all, 1)));
    WholesEvidence::new(W * H, 1, views)
}

/// The merge of view 0 with `others`' masks: the number of regions, and the decision the gate
/// took on the pair 1–2 when it came up for merging (the merge, or the refusal), the only
/// decision of the pair with the gate's counts.
fn merge(others: &[Sam]) -> (usize, splatseg_merge::Decision) {
    let evidence = evidence(others);
    let all: Vec<u32> = (0..(W * H) as u32).collect();
    let wholes = ViewWholes::new(&evidence, 0, (&all, &all), (W, H));
    let r = merge_view_with_wholes(&view(), &MergeConfig::default(), Some(&wholes)).unwrap();
    let pair: Vec<_> = r.log.decisions.iter().filter(|d| (d.a, d.b) == (1, 2)).collect();
    assert_eq!(pair[0].terms.wholes, None, "scored without the gate, which is asked at merge time");
    let gated: Vec<_> = pair.iter().filter(|d| d.terms.wholes.is_some()).collect();
    assert_eq!(gated.len(), 1, "{pair:?}");
    let gated = (*gated[0]).clone();
    assert_eq!(gated.merged, gated.outcome == Outcome::Accepted);
    (r.regions.len(), gated)
}

#[test]
fn without_other_views_the_two_sides_merge() {
    let r = merge_view(&view(), &MergeConfig::default()).unwrap();
    assert_eq!(r.regions.len(), 2, "object and background: the cues alone join the sides");
    let d = r.log.decisions.iter().find(|d| (d.a, d.b) == (1, 2)).unwrap();
    assert_eq!((d.outcome, d.terms.wholes), (Outcome::Accepted, None));
}

#[test]
fn sides_other_views_hold_in_different_wholes_stay_apart() {
    let (regions, gated) = merge(&[Sam::TwoWholes; 4]);
    assert_eq!(regions, 3, "two objects and the background");
    assert_eq!((gated.outcome, gated.terms.wholes), (Outcome::SeparateWholes, Some([0, 4, 4])));
}

#[test]
fn sides_one_whole_holds_in_other_views_merge() {
    let (regions, gated) = merge(&[Sam::OneWhole, Sam::Parts, Sam::Parts, Sam::Parts]);
    assert_eq!(regions, 2);
    assert_eq!((gated.outcome, gated.terms.wholes), (Outcome::Accepted, Some([1, 0, 4])));
}

#[test]
fn masks_without_nesting_say_nothing_and_the_score_decides() {
    let (regions, gated) = merge(&[Sam::Parts; 4]);
    assert_eq!(regions, 2);
    assert_eq!((gated.outcome, gated.terms.wholes), (Outcome::Accepted, Some([0, 0, 4])));
}

#[test]
fn the_gate_refuses_only_when_apart_views_outnumber_together_ones() {
    use Sam::*;
    // Two apart, two together: not refused. Three apart, two together: refused. One apart only:
    // too little evidence. Two apart among nine views: under a quarter of them.
    let (regions, gated) = merge(&[TwoWholes, TwoWholes, OneWhole, OneWhole]);
    assert_eq!((regions, gated.terms.wholes), (2, Some([2, 2, 4])));
    let (regions, gated) = merge(&[TwoWholes, TwoWholes, TwoWholes, OneWhole, OneWhole]);
    assert_eq!((regions, gated.outcome, gated.terms.wholes), (3, Outcome::SeparateWholes, Some([2, 3, 5])));
    let (regions, gated) = merge(&[TwoWholes, Parts, Parts, Parts]);
    assert_eq!((regions, gated.terms.wholes), (2, Some([0, 1, 4])));
    let (regions, gated) = merge(&[TwoWholes, TwoWholes, Parts, Parts, Parts, Parts, Parts, Parts, Parts]);
    assert_eq!((regions, gated.terms.wholes), (2, Some([0, 2, 9])));
    let (regions, gated) = merge(&[TwoWholes, TwoWholes, Parts, Parts, Parts, Parts]);
    assert_eq!((regions, gated.outcome, gated.terms.wholes), (3, Outcome::SeparateWholes, Some([0, 2, 6])));
}

#[test]
fn the_literal_profile_and_a_wrong_size_leave_the_gate_out() {
    let evidence = evidence(&[Sam::TwoWholes; 4]);
    let all: Vec<u32> = (0..(W * H) as u32).collect();
    let wholes = ViewWholes::new(&evidence, 0, (&all, &all), (W, H));
    let literal = MergeConfig::for_profile(Profile::Literal);
    let r = merge_view_with_wholes(&view(), &literal, Some(&wholes)).unwrap();
    assert!(r.log.decisions.iter().all(|d| d.outcome != Outcome::SeparateWholes && d.terms.wholes.is_none()));
    let small = ViewWholes::new(&evidence, 0, (&all, &all), (W, H - 1));
    let e = merge_view_with_wholes(&view(), &MergeConfig::default(), Some(&small)).unwrap_err().to_string();
    assert!(e.contains("label map"), "{e}");
}
