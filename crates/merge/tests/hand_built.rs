//! The merge stage's done-when tests on hand-built views: (a) white-on-white, (b) texture stripe,
//! (c) strong edge, (d) partition, (e) order independence, (f) repeatability; plus the profiles.

use splatseg_cues::depth::DEPTH_GRADIENT_SIGMA_PX;
use splatseg_cues::edges::LOG_SIGMA_PX;
use splatseg_cues::{
    depth_gradient, log_edges, regions_from_sam_masks, MaskInput, RegionDescriptors, RegionOptions,
    RegionSource, Regions,
};
use splatseg_merge::{merge_view, DepthGapAt, MergeConfig, Outcome, Profile, ViewInputs};
use splatseg_scene::Plane;

const W: usize = 80;
const H: usize = 60;

fn plane<T: Clone>(f: impl Fn(usize, usize) -> T) -> Plane<T> {
    Plane::from_vec(W, H, (0..W * H).map(|p| f(p % W, p / W)).collect()).unwrap()
}

/// A view from a label function, per-label descriptors, a grey image and a normalised depth map.
fn view(
    label: impl Fn(usize, usize) -> u32,
    descriptors: &[[f32; 3]],
    grey: impl Fn(usize, usize) -> f32,
    depth: impl Fn(usize, usize) -> f32,
) -> ViewInputs {
    let labels = plane(label);
    let n = descriptors.len();
    let mut areas = vec![0u64; n];
    labels.data.iter().filter(|&&l| l > 0).for_each(|&l| areas[l as usize - 1] += 1);
    let depth = plane(depth);
    ViewInputs {
        regions: Regions { labels, sources: vec![RegionSource::Uncovered; n] },
        descriptors: RegionDescriptors {
            channels: 3,
            means: descriptors.iter().flatten().copied().collect(),
            areas,
        },
        depth_gradient: depth_gradient(&depth, DEPTH_GRADIENT_SIGMA_PX),
        depth,
        edges: log_edges(&plane(grey), LOG_SIGMA_PX),
        points: None,
        normals: None,
    }
}

/// Object in the middle (x in 20..60, y in 15..45) split at x = 40 into labels 1 and 2;
/// background label 3.
fn split_object(x: usize, y: usize) -> u32 {
    if (20..60).contains(&x) && (15..45).contains(&y) {
        if x < 40 {
            1
        } else {
            2
        }
    } else {
        3
    }
}

const HALF_A: [f32; 3] = [1.0, 0.05, 0.0];
const HALF_B: [f32; 3] = [1.0, 0.0, 0.05];
const BACKGROUND: [f32; 3] = [0.0, 1.0, 0.2];

fn object_depth(x: usize, y: usize) -> f32 {
    if split_object(x, y) == 3 {
        0.9
    } else {
        0.5
    }
}

#[test]
fn a_white_on_white_pair_at_different_depths_is_not_merged() {
    // Two halves of an all-white image, identical descriptors, normalised depths 0.2 and 0.6.
    let v = view(
        |x, _| if x < 40 { 1 } else { 2 },
        &[[1.0, 0.0, 0.0]; 2],
        |_, _| 1.0,
        |x, _| if x < 40 { 0.2 } else { 0.6 },
    );
    let r = merge_view(&v, &MergeConfig::default()).unwrap();
    assert_eq!(r.regions.len(), 2);
    let d = &r.log.decisions[0];
    assert_eq!((d.a, d.b, d.outcome), (1, 2, Outcome::DepthGate));
    assert!(d.terms.cos > 0.999);
    // Without the depth gate the same pair would merge only if the ∇D penalty did not stop it; the
    // gate is what rejects it here.
    let no_gate = MergeConfig { tau_depth: f32::INFINITY, ..MergeConfig::default() };
    let r = merge_view(&v, &no_gate).unwrap();
    assert_ne!(r.log.decisions[0].outcome, Outcome::DepthGate);
}

#[test]
fn b_an_object_split_along_a_faint_texture_stripe_is_merged() {
    // Object grey 0.6 on a 0.1 background; a faint stripe (0.63) along the split.
    let grey = |x: usize, y: usize| match split_object(x, y) {
        3 => 0.1,
        _ if (39..=40).contains(&x) => 0.63,
        _ => 0.6,
    };
    let v = view(split_object, &[HALF_A, HALF_B, BACKGROUND], grey, object_depth);
    let r = merge_view(&v, &MergeConfig::default()).unwrap();
    assert_eq!(r.regions.len(), 2, "{:#?}", r.log.decisions);
    assert_eq!(r.labels.get(25, 30), r.labels.get(55, 30));
    assert_ne!(r.labels.get(25, 30), r.labels.get(5, 5));
    let merge = r.log.decisions.iter().find(|d| d.merged).unwrap();
    assert_eq!((merge.a, merge.b), (1, 2));
}

#[test]
fn c_a_strong_edge_between_similar_regions_blocks_the_merge() {
    // Same layout and descriptors, but the halves differ strongly in brightness.
    let grey = |x: usize, y: usize| match split_object(x, y) {
        3 => 0.45,
        1 => 0.1,
        _ => 0.9,
    };
    let v = view(split_object, &[HALF_A, HALF_B, BACKGROUND], grey, object_depth);
    let r = merge_view(&v, &MergeConfig::default()).unwrap();
    assert_eq!(r.regions.len(), 3);
    let d = r.log.decisions.iter().find(|d| (d.a, d.b) == (1, 2)).unwrap();
    assert_eq!(d.outcome, Outcome::BelowThreshold);
    assert!(d.terms.edge_boundary > 0.6, "edge term {}", d.terms.edge_boundary);
    // The edge term is what blocks it: without it the pair merges.
    let no_edge = MergeConfig { w_edge: 0.0, ..MergeConfig::default() };
    assert_eq!(merge_view(&v, &no_edge).unwrap().regions.len(), 2);
}

/// A view from overlapping rectangles as SAM masks, with descriptors from a pattern.
fn masks_view(masks: &[MaskInput]) -> ViewInputs {
    let regions = regions_from_sam_masks(masks, W, H, &RegionOptions::default()).unwrap();
    let n = regions.count();
    // Descriptor of a region: from the position of its first pixel (object = x / 27).
    let mut means = Vec::new();
    let mut areas = vec![0u64; n];
    regions.labels.data.iter().filter(|&&l| l > 0).for_each(|&l| areas[l as usize - 1] += 1);
    for l in 1..=n as u32 {
        let p = regions.labels.data.iter().position(|&v| v == l).unwrap();
        let object = (p % W) / 27;
        let mut d = [0.05f32; 3];
        d[object] = 1.0;
        means.extend(d);
    }
    let depth = plane(|x, _| [0.3, 0.35, 0.8][x / 27]);
    let grey = plane(|x, y| [0.2, 0.5, 0.8][x / 27] + 0.02 * (((x * 7 + y * 3) % 5) as f32));
    ViewInputs {
        descriptors: RegionDescriptors { channels: 3, means, areas },
        depth_gradient: depth_gradient(&depth, DEPTH_GRADIENT_SIGMA_PX),
        depth,
        edges: log_edges(&grey, LOG_SIGMA_PX),
        points: None,
        normals: None,
        regions,
    }
}

fn rect_masks() -> Vec<MaskInput> {
    let rect = |x0: usize, y0: usize, x1: usize, y1: usize| {
        MaskInput::from_plane(&plane(|x, y| (x0..x1).contains(&x) && (y0..y1).contains(&y)), 0.9, 0.9)
    };
    vec![
        rect(0, 0, 27, 30),
        rect(0, 30, 27, 60),
        rect(5, 20, 20, 40),
        rect(27, 0, 54, 60),
        rect(30, 10, 50, 25),
        rect(30, 25, 50, 50),
        rect(54, 0, 80, 20),
        rect(54, 20, 80, 60),
        rect(0, 0, 80, 60),
        rect(60, 30, 70, 40),
    ]
}

#[test]
fn d_output_is_a_partition_of_the_input_pixels() {
    let v = masks_view(&rect_masks());
    let r = merge_view(&v, &MergeConfig::default()).unwrap();
    assert!(r.regions.len() < v.regions.count());
    // Every labelled input pixel is labelled in the output, every unlabelled one stays unlabelled,
    // and each input region maps to exactly one output region.
    let mut map = vec![0u32; v.regions.count() + 1];
    for (&i, &o) in v.regions.labels.data.iter().zip(&r.labels.data) {
        assert_eq!(i == 0, o == 0);
        if i > 0 {
            assert!(map[i as usize] == 0 || map[i as usize] == o, "input region {i} split");
            map[i as usize] = o;
        }
    }
    // Output ids are 1..=k, areas agree with the label map.
    for s in &r.regions {
        assert_eq!(r.labels.data.iter().filter(|&&l| l == s.id).count() as u64, s.area);
    }
    let total: u64 = r.regions.iter().map(|s| s.area).sum();
    assert_eq!(total, r.labels.data.iter().filter(|&&l| l > 0).count() as u64);
    assert_eq!(r.log.final_id_of_input, map[1..].to_vec());
}

#[test]
fn e_result_does_not_depend_on_the_mask_order() {
    let masks = rect_masks();
    let reference = merge_view(&masks_view(&masks), &MergeConfig::default()).unwrap();
    for shift in 1..masks.len() {
        let mut shuffled = masks.clone();
        shuffled.rotate_left(shift);
        shuffled.swap(0, masks.len() - 1);
        let r = merge_view(&masks_view(&shuffled), &MergeConfig::default()).unwrap();
        assert_eq!(r.labels, reference.labels, "rotation {shift}");
        assert_eq!(r.regions.len(), reference.regions.len());
    }
}

#[test]
fn f_repeated_runs_give_identical_output() {
    let v = masks_view(&rect_masks());
    let first = merge_view(&v, &MergeConfig::default()).unwrap();
    for _ in 0..3 {
        assert_eq!(merge_view(&v, &MergeConfig::default()).unwrap(), first);
    }
}

#[test]
fn the_literal_formula_merges_nothing() {
    // Even identical descriptors, flat depth and no edges give S = 0.7 < 0.85.
    let v = view(|x, _| 1 + (x / 20) as u32, &[[1.0, 0.0, 0.0]; 4], |_, _| 0.5, |_, _| 0.5);
    let literal = MergeConfig::for_profile(Profile::Literal);
    let r = merge_view(&v, &literal).unwrap();
    assert_eq!(r.regions.len(), 4);
    assert!(r
        .log
        .decisions
        .iter()
        .all(|d| d.outcome == Outcome::BelowThreshold && d.terms.score <= 0.7 + 1e-6));
    // The paper profile merges all four.
    assert_eq!(merge_view(&v, &MergeConfig::default()).unwrap().regions.len(), 1);
}

#[test]
fn mismatched_inputs_are_rejected() {
    let mut v = view(|x, _| if x < 40 { 1 } else { 2 }, &[[1.0, 0.0, 0.0]; 2], |_, _| 1.0, |_, _| 0.5);
    v.edges = Plane::filled(3, 3, 0.0);
    let e = merge_view(&v, &MergeConfig::default()).unwrap_err().to_string();
    assert!(e.contains("edges"), "{e}");
}

#[test]
fn the_maximum_on_the_boundary_is_too_noisy_for_a_faint_stripe() {
    // Measured reason for the robust default: the max picks up the object's own outline where the
    // split meets it (|LoG| with σ = 2 reaches ~3σ px), so the faint-stripe pair of (b) fails.
    let grey = |x: usize, y: usize| match split_object(x, y) {
        3 => 0.1,
        _ if (39..=40).contains(&x) => 0.63,
        _ => 0.6,
    };
    let v = view(split_object, &[HALF_A, HALF_B, BACKGROUND], grey, object_depth);
    let max = MergeConfig {
        boundary_statistic: splatseg_merge::BoundaryStatistic::Max,
        max_depth_boundary: None,
        ..MergeConfig::default()
    };
    let r = merge_view(&v, &max).unwrap();
    let d = r.log.decisions.iter().find(|d| (d.a, d.b) == (1, 2)).unwrap();
    assert_eq!(d.outcome, Outcome::BelowThreshold);
    assert!(d.terms.edge_boundary > 0.5);
}

#[test]
fn views_without_regions_or_with_one_region_pass_through() {
    let empty = view(|_, _| 0, &[], |_, _| 0.5, |_, _| 0.5);
    let r = merge_view(&empty, &MergeConfig::default()).unwrap();
    assert!(r.regions.is_empty() && r.log.decisions.is_empty());
    assert!(r.labels.data.iter().all(|&l| l == 0));
    let one = view(|_, _| 1, &[[0.0, 1.0, 0.0]], |_, _| 0.5, |_, _| 0.5);
    let r = merge_view(&one, &MergeConfig::default()).unwrap();
    assert_eq!(r.regions.len(), 1);
    assert_eq!(r.regions[0].area, (W * H) as u64);
    assert_eq!(r.regions[0].bbox_px, [0, 0, W as u32 - 1, H as u32 - 1]);
}

/// A floor split by its texture into a near and a far half (labels 1 and 2, depth a ramp from
/// 0.1 to 0.7 across the image, so the halves' mean depths differ by 0.3) above a far
/// background band (label 3, depth 1.0).
fn ramp_floor() -> ViewInputs {
    view(
        |x, y| match (x < 40, y < 45) {
            (_, false) => 3,
            (true, true) => 1,
            (false, true) => 2,
        },
        &[[1.0, 0.0, 0.0], [1.0, 0.02, 0.0], [0.0, 1.0, 0.2]],
        |x, y| {
            if y >= 45 {
                0.1
            } else if x < 40 {
                0.6
            } else {
                0.62
            }
        },
        |x, y| if y >= 45 { 1.0 } else { 0.1 + 0.6 * x as f32 / W as f32 },
    )
}

#[test]
fn a_floor_split_by_its_texture_merges_when_depth_is_compared_at_the_contact() {
    let v = ramp_floor();
    let r = merge_view(&v, &MergeConfig::default()).unwrap();
    let d = r.log.decisions.iter().find(|d| (d.a, d.b) == (1, 2)).expect("the halves are evaluated");
    assert!(d.terms.depth_gap < 0.05, "contact gap {}", d.terms.depth_gap);
    assert!(r.log.decisions.iter().any(|d| (d.a, d.b) == (1, 2) && d.merged));
    assert_eq!(r.regions.len(), 2, "the floor and the background");
    // The formula as printed compares the halves' means (0.25 vs 0.55) and splits the floor.
    let means = MergeConfig { depth_gap_at: DepthGapAt::RegionMeans, ..MergeConfig::default() };
    let r = merge_view(&v, &means).unwrap();
    let d = r.log.decisions.iter().find(|d| (d.a, d.b) == (1, 2)).expect("the halves are evaluated");
    assert_eq!(d.outcome, Outcome::DepthGate);
    assert_eq!(r.regions.len(), 3);
}

#[test]
fn a_depth_step_on_the_contact_stops_a_merge_the_contact_gap_misses() {
    // Two identical-looking halves (labels 1, 2) whose depth steps from 0.40 to 0.48 at x = 40,
    // above a far background band (label 3, depth 1.0): the contact medians differ by less
    // than τ_depth and the score passes, but ∇D on the contact is well above a smooth surface's.
    let v = view(
        |x, y| match (x < 40, y < 45) {
            (_, false) => 3,
            (true, true) => 1,
            (false, true) => 2,
        },
        &[[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.2]],
        |_, y| if y >= 45 { 0.1 } else { 1.0 },
        |x, y| match (x < 40, y < 45) {
            (_, false) => 1.0,
            (true, true) => 0.40,
            (false, true) => 0.48,
        },
    );
    let pair = |r: &splatseg_merge::MergeResult| {
        r.log.decisions.iter().find(|d| (d.a, d.b) == (1, 2)).expect("the halves are evaluated").clone()
    };
    let d = pair(&merge_view(&v, &MergeConfig::default()).unwrap());
    assert!(d.terms.depth_gap < 0.15, "contact gap {}", d.terms.depth_gap);
    assert!(d.terms.score > 0.85, "{:?}", d.terms);
    assert_eq!(d.outcome, Outcome::DepthStep, "{:?}", d.terms);
    let off = MergeConfig { max_depth_boundary: None, ..MergeConfig::default() };
    assert_eq!(pair(&merge_view(&v, &off).unwrap()).outcome, Outcome::Accepted);
}

/// Intrinsics of the geometric views below: 80 × 60 pixels, a wide lens.
const K: splatseg_cues::Intrinsics = splatseg_cues::Intrinsics { fx: 30.0, fy: 30.0, cx: 40.0, cy: 30.0 };

/// A view of planes seen by a pinhole camera at the origin (y down, z forward): `surface(ry)`
/// gives the label and metric z along the ray of a pixel row (`ry = (y + 0.5 − c_y) / f_y`).
/// Every region looks the same (descriptor, grey), so only geometry can keep them apart.
fn planes_view(surface: impl Fn(f32) -> (u32, f32), regions: usize) -> ViewInputs {
    let ray_y = |y: usize| (y as f32 + 0.5 - K.cy) / K.fy;
    let z = plane(|_, y| surface(ray_y(y)).1);
    let mut v = view(
        |_, y| surface(ray_y(y)).0,
        &vec![[1.0, 0.0, 0.0]; regions],
        |_, _| 0.5,
        |_, y| surface(ray_y(y)).1 / 10.0,
    );
    v.points = Some(splatseg_cues::camera_points(&z, &K));
    v
}

#[test]
fn a_concave_crease_keeps_a_wall_and_the_floor_apart_and_a_convex_one_joins_two_faces() {
    let pair = |r: &splatseg_merge::MergeResult, a: u32, b: u32| {
        r.log.decisions.iter().find(|d| (d.a, d.b) == (a, b)).expect("the pair is evaluated").clone()
    };
    // The depth-step gate is off: the floor's depth ramps fastest at the contact here, and this
    // test is about the crease alone.
    let on = MergeConfig { max_depth_boundary: None, ..MergeConfig::default() };
    let off = MergeConfig { max_concave_crease_deg: None, ..on.clone() };
    // A wall at z = 2 (label 1) standing on a floor 1 below the camera (label 2): concave.
    let wall_on_floor = planes_view(|ry| if ry > 0.5 { (2, 1.0 / ry) } else { (1, 2.0) }, 2);
    let d = pair(&merge_view(&wall_on_floor, &on).unwrap(), 1, 2);
    let crease = d.terms.crease_deg.expect("both sides have normals");
    assert!((-95.0..-80.0).contains(&crease), "a right angle, concave: {crease}");
    assert_eq!(d.outcome, Outcome::ConcaveCrease, "{:?}", d.terms);
    assert_eq!(pair(&merge_view(&wall_on_floor, &off).unwrap(), 1, 2).outcome, Outcome::Accepted);
    // Two faces of one object meeting at a ridge 2 in front of the camera, each tilted 37°
    // away from it (label 1 above, 2 below): a convex edge, like a box's.
    let ridge =
        planes_view(|ry| if ry < 0.0 { (1, 1.6 / (0.8 + 0.6 * ry)) } else { (2, 1.6 / (0.8 - 0.6 * ry)) }, 2);
    let r = merge_view(&ridge, &on).unwrap();
    let d = pair(&r, 1, 2);
    let crease = d.terms.crease_deg.expect("both sides have normals");
    assert!((65.0..80.0).contains(&crease), "74°, convex: {crease}");
    assert!(d.merged || r.log.decisions.iter().any(|d| (d.a, d.b) == (1, 2) && d.merged), "the faces join");
    // The same faces folded the other way (a valley) are two surfaces.
    let valley =
        planes_view(|ry| if ry < 0.0 { (1, 1.6 / (0.8 - 0.6 * ry)) } else { (2, 1.6 / (0.8 + 0.6 * ry)) }, 2);
    let d = pair(&merge_view(&valley, &on).unwrap(), 1, 2);
    assert!((-80.0..-65.0).contains(&d.terms.crease_deg.expect("normals")), "{:?}", d.terms);
    assert_eq!(d.outcome, Outcome::ConcaveCrease);
}

#[test]
fn rendered_normals_when_given_are_what_the_crease_gate_reads() {
    let pair = |v: &ViewInputs| {
        let on = MergeConfig { max_depth_boundary: None, ..MergeConfig::default() };
        let r = merge_view(v, &on).unwrap();
        r.log.decisions.iter().find(|d| (d.a, d.b) == (1, 2)).expect("the pair is evaluated").clone()
    };
    // The wall standing on the floor of the test above, its points jittered in depth by up to
    // ±1 % from pixel to pixel (as a surface depth from blended footprints is): the rendered
    // normals (the wall faces the camera, the floor 1 below it faces up) still give the right
    // angle, concave.
    let mut v = planes_view(|ry| if ry > 0.5 { (2, 1.0 / ry) } else { (1, 2.0) }, 2);
    let points = v.points.as_mut().expect("points");
    for (i, p) in points.data.iter_mut().enumerate() {
        let jitter = 1.0 + 0.01 * (((i * 7919) % 101) as f32 / 50.0 - 1.0);
        *p = p.map(|c| c * jitter);
    }
    let facing = |x: usize, y: usize| -> [f32; 3] {
        if v.regions.labels.data[y * W + x] == 2 {
            [0.0, -1.0, 0.0]
        } else {
            [0.0, 0.0, -1.0]
        }
    };
    let normals = Plane { width: W, height: H, data: (0..W * H).map(|i| facing(i % W, i / W)).collect() };
    v.normals = Some(normals);
    let d = pair(&v);
    let crease = d.terms.crease_deg.expect("both sides have normals");
    assert!((-91.0..-89.0).contains(&crease), "a right angle, concave: {crease}");
    assert_eq!(d.outcome, Outcome::ConcaveCrease, "{:?}", d.terms);
    // Normals saying the two sides face one way make them one surface, whatever the points say.
    v.normals = Some(Plane::filled(W, H, [0.0, 0.0, -1.0]));
    let d = pair(&v);
    assert!(d.terms.crease_deg.expect("normals").abs() < 1.0, "{:?}", d.terms);
    assert_ne!(d.outcome, Outcome::ConcaveCrease);
    // Pixels without a rendered normal (NaN) give the gate nothing to read.
    v.normals = Some(Plane::filled(W, H, [f32::NAN; 3]));
    assert_eq!(pair(&v).terms.crease_deg, None);
}
