//! Contributions: occlusion and footprints through the renderer's compositor; surface depth.

mod common;
use common::{camera, gaussians};
use splatseg_lift::{
    view_contributions, view_surface_depth, LiftConfig, PreparedGaussians, ViewContributions,
};
use splatseg_scene::{Plane, Pose};

/// Contributions of `means` (scale `scale`, opacity `opacity`) to a 64 px view whose pixels all
/// carry label 1.
fn seen(means: &[[f32; 3]], scale: f32, opacity: f32) -> ViewContributions {
    let prepared = PreparedGaussians::new(&gaussians(means, scale, opacity)).unwrap();
    let labels = Plane::filled(64, 64, 1u32);
    view_contributions(&prepared, &camera(64), &Pose::IDENTITY, &labels, &LiftConfig::default()).unwrap()
}

fn seen_ids(c: &ViewContributions) -> Vec<u32> {
    c.dominant(&LiftConfig::default()).iter().map(|d| d.gaussian).collect()
}

/// Total weight of Gaussian `g` in `c`.
fn weight_of(c: &ViewContributions, g: u32) -> f32 {
    c.gaussians.iter().zip(&c.weights).filter(|(&x, _)| x == g).map(|(_, &w)| w).sum()
}

/// A wall of overlapping Gaussians at depth `z` (a 13 × 13 grid, spacing 0.08, centred on
/// the optical axis) followed by `extra`.
fn wall_and(z: f32, extra: [f32; 3]) -> Vec<[f32; 3]> {
    let mut means: Vec<[f32; 3]> =
        (0..169).map(|k| [(k % 13) as f32 * 0.08 - 0.48, (k / 13) as f32 * 0.08 - 0.48, z]).collect();
    means.push(extra);
    means
}

#[test]
fn occluded_gaussian_gets_almost_no_weight() {
    // A wall at z = 2 in front of a Gaussian at z = 4 on the optical axis.
    let alone = weight_of(&seen(&[[0.0, 0.0, 4.0]], 0.08, 0.95), 0);
    let c = seen(&wall_and(2.0, [0.0, 0.0, 4.0]), 0.08, 0.95);
    let behind = weight_of(&c, 169);
    assert!(alone > 1.0, "alone it covers pixels: {alone}");
    assert!(behind < 0.01 * alone, "hidden: {behind} of {alone}");
    assert!(!seen_ids(&c).contains(&169));
    // In front of the wall it is seen, and the wall behind it loses weight where it covers.
    let c = seen(&wall_and(4.0, [0.0, 0.0, 2.0]), 0.08, 0.95);
    assert!(seen_ids(&c).contains(&169));
}

#[test]
fn footprint_not_centre_decides_occlusion() {
    // The occluder's centre is off to the side of the far Gaussian's pixel, but its wide
    // footprint (scale 0.3 at z = 2, ≈ 8 px σ on a 64 px / 60° camera) covers it: the far
    // Gaussian keeps a small share of the weight it has alone.
    let alone = weight_of(&seen(&[[0.0, 0.0, 4.0]], 0.05, 0.95), 0);
    let prepared = PreparedGaussians::new(&{
        let mut g = gaussians(&[[0.12, 0.0, 2.0], [0.0, 0.0, 4.0]], 0.05, 0.95);
        g.log_scales[0] = [0.3f32.ln(); 3];
        g
    })
    .unwrap();
    let labels = Plane::filled(64, 64, 1u32);
    let c =
        view_contributions(&prepared, &camera(64), &Pose::IDENTITY, &labels, &LiftConfig::default()).unwrap();
    let behind = weight_of(&c, 1);
    assert!(behind < 0.2 * alone, "the near footprint hides the far Gaussian: {behind} of {alone}");
}

#[test]
fn translucent_occluder_does_not_hide() {
    let alone = weight_of(&seen(&[[0.0, 0.0, 4.0]], 0.1, 0.3), 0);
    let behind = weight_of(&seen(&[[0.0, 0.0, 2.0], [0.0, 0.0, 4.0]], 0.1, 0.3), 1);
    assert!(behind > 0.6 * alone, "{behind} of {alone}");
}

#[test]
fn gaussians_behind_the_camera_are_not_seen() {
    assert_eq!(seen_ids(&seen(&[[0.0, 0.0, 3.0], [0.0, 0.0, -3.0]], 0.05, 0.9)), vec![0]);
}

/// A footprint on a mask edge contributes to both labels, in proportion to its pixels.
#[test]
fn a_footprint_on_an_edge_splits_its_weight() {
    let prepared = PreparedGaussians::new(&gaussians(&[[0.0, 0.0, 2.0]], 0.1, 0.9)).unwrap();
    let labels =
        Plane::from_vec(64, 64, (0..64 * 64).map(|p| if p % 64 < 32 { 1 } else { 2 }).collect()).unwrap();
    let c =
        view_contributions(&prepared, &camera(64), &Pose::IDENTITY, &labels, &LiftConfig::default()).unwrap();
    assert_eq!(c.labels, vec![1, 2]);
    let (a, b) = (c.weights[0], c.weights[1]);
    assert!(a > 1.0 && (a - b).abs() < 0.1 * a, "symmetric split: {a} vs {b}");
}

#[test]
fn surface_depth_is_the_median_depth_of_the_front_surface() {
    let prepared =
        PreparedGaussians::new(&gaussians(&[[0.0, 0.0, 2.0], [0.0, 0.0, 4.0]], 0.3, 0.95)).unwrap();
    let depth = view_surface_depth(&prepared, &camera(64), &Pose::IDENTITY, &LiftConfig::default()).unwrap();
    assert_eq!(*depth.get(32, 32), 2.0);
    assert_eq!(*depth.get(0, 0), f32::INFINITY, "no surface in the corner");
    let wrong = Plane::filled(10, 10, 1u32);
    let err = view_contributions(&prepared, &camera(64), &Pose::IDENTITY, &wrong, &LiftConfig::default());
    assert!(err.is_err());
}
