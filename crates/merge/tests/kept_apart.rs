//! A shape edge a view confirms keeps what lies on either side of it apart for the rest of that
//! view's merge. Four alike regions at one depth in a 2 × 2 grid (`a1 b1` above `a2 b2`): `a1` and
//! `b1` are two faces meeting in a concave crease of 60° (each turned 30° from the camera, like the
//! inside of a corner), `a2` and `b2` one flat face. Each column merges first (identical
//! descriptors, 30° between `a1` and `a2`); the two columns then meet along a contact whose mean
//! normals differ by much less than the crease gate's 45°, so the score alone would join them
//! across the crease that refused `a1`–`b1`.

use splatseg_cues::edges::LOG_SIGMA_PX;
use splatseg_cues::{log_edges, RegionDescriptors, RegionSource, Regions};
use splatseg_merge::{merge_view, MergeConfig, Outcome, ViewInputs};
use splatseg_scene::Plane;

const W: usize = 60;
const H: usize = 40;

/// `a1` = 1, `b1` = 2 (rows 5..15), `a2` = 3, `b2` = 4 (rows 15..35); left x 10..30, right
/// x 30..50; background 5.
fn label(x: usize, y: usize) -> u32 {
    match (y, x) {
        (5..=14, 10..=29) => 1,
        (5..=14, 30..=49) => 2,
        (15..=34, 10..=29) => 3,
        (15..=34, 30..=49) => 4,
        _ => 5,
    }
}

fn plane<T: Clone>(f: impl Fn(usize, usize) -> T) -> Plane<T> {
    Plane::from_vec(W, H, (0..W * H).map(|p| f(p % W, p / W)).collect()).unwrap()
}

/// Camera-space points, 1 cm per pixel, 5 m away; with `crease`, `a1` and `b1` recede by
/// tan 30° per unit across towards their common edge at x = 30 (a concave crease of 60°).
fn point(x: usize, y: usize, crease: bool) -> [f32; 3] {
    let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
    let slope = 30f32.to_radians().tan();
    let z = match label(x, y) {
        1 | 2 if crease => 5.0 + slope * 0.01 * (20.0 - (px - 30.0).abs()),
        5 => 6.0,
        _ => 5.0,
    };
    [(px - 30.0) * 0.01, (py - 20.0) * 0.01, z]
}

fn view(crease: bool) -> ViewInputs {
    let labels = plane(label);
    let left = [1.0, 0.0, 0.0];
    let right = [0.97, 0.243, 0.0];
    let descriptors: [[f32; 3]; 5] = [left, right, left, right, [0.0, 0.0, 1.0]];
    let mut areas = vec![0u64; 5];
    labels.data.iter().for_each(|&l| areas[l as usize - 1] += 1);
    let depth = plane(|x, y| if label(x, y) == 5 { 0.9 } else { 0.5 });
    ViewInputs {
        regions: Regions { labels, sources: vec![RegionSource::Uncovered; 5] },
        descriptors: RegionDescriptors { channels: 3, means: descriptors.concat(), areas },
        depth_gradient: plane(|x, y| if label(x, y) == 5 { 1.0 } else { 0.0f32 }),
        depth,
        edges: log_edges(&plane(|_, _| 0.5f32), LOG_SIGMA_PX),
        points: Some(plane(|x, y| point(x, y, crease))),
        normals: None,
    }
}

/// Final region of input region `l` (the label at its first pixel).
fn region_of(labels: &Plane<u32>, l: u32) -> u32 {
    let p = (0..W * H).find(|&p| label(p % W, p / W) == l).unwrap();
    labels.data[p]
}

#[test]
fn without_the_crease_the_two_columns_merge() {
    let r = merge_view(&view(false), &MergeConfig::default()).unwrap();
    assert_eq!(r.regions.len(), 2, "the four regions and the background");
    assert!(r.log.decisions.iter().all(|d| d.outcome != Outcome::KeptApart));
}

#[test]
fn a_crease_refused_once_keeps_the_two_sides_apart_after_each_grows() {
    let r = merge_view(&view(true), &MergeConfig::default()).unwrap();
    let crease = r.log.decisions.iter().find(|d| (d.a, d.b) == (1, 2)).unwrap();
    assert_eq!(crease.outcome, Outcome::ConcaveCrease, "{crease:?}");
    let columns = r.log.decisions.iter().find(|d| d.outcome == Outcome::KeptApart).expect("a refusal");
    let angle = columns.terms.crease_deg.expect("measured");
    assert!(angle > -45.0, "the grown columns pass the crease gate: {columns:?}");
    assert_eq!(r.regions.len(), 3, "left column, right column, background");
    let ids: Vec<u32> = (1..=4).map(|l| region_of(&r.labels, l)).collect();
    assert_eq!((ids[0] == ids[2], ids[1] == ids[3], ids[0] == ids[1]), (true, true, false), "{ids:?}");
}
