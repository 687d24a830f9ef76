//! Visibility: the depth test against composited footprints.

use crate::common::{camera, gaussians, look_at};
use glam::DVec3;
use splatseg_lift::{view_visibility, LiftConfig, PreparedGaussians};
use splatseg_scene::Pose;

#[test]
fn occluded_gaussian_is_not_visible() {
    // An opaque Gaussian at z = 2 in front of a small one at z = 4, both on the optical axis.
    let g = gaussians(&[[0.0, 0.0, 2.0], [0.0, 0.0, 4.0]], 0.1, 0.95);
    let prepared = PreparedGaussians::new(&g).unwrap();
    let cam = camera(64);
    let vis = view_visibility(&prepared, &cam, &Pose::IDENTITY, None, &LiftConfig::default()).visible;
    assert_eq!(vis.gaussians, vec![0]);
    // Alone, the far one is visible.
    let far = PreparedGaussians::new(&gaussians(&[[0.0, 0.0, 4.0]], 0.1, 0.95)).unwrap();
    let vis = view_visibility(&far, &cam, &Pose::IDENTITY, None, &LiftConfig::default()).visible;
    assert_eq!(vis.gaussians, vec![0]);
}

#[test]
fn footprint_not_centre_decides_occlusion() {
    // The occluder's centre is off to the side of the far Gaussian's pixel, but its footprint
    // (scale 0.3 at z = 2, ≈ 8 px σ on a 64 px / 60° camera) covers it.
    let g = gaussians(&[[0.12, 0.0, 2.0], [0.0, 0.0, 4.0]], 0.3, 0.95);
    let prepared = PreparedGaussians::new(&g).unwrap();
    let cam = camera(64);
    let vis = view_visibility(&prepared, &cam, &Pose::IDENTITY, None, &LiftConfig::default()).visible;
    assert_eq!(vis.gaussians, vec![0], "the far Gaussian is hidden by the near footprint");
}

#[test]
fn translucent_occluder_does_not_hide() {
    // Opacity 0.3 < 1 − 0.5: transmittance stays above the surface threshold in front.
    let g = gaussians(&[[0.0, 0.0, 2.0], [0.0, 0.0, 4.0]], 0.1, 0.3);
    let prepared = PreparedGaussians::new(&g).unwrap();
    let vis = view_visibility(&prepared, &camera(64), &Pose::IDENTITY, None, &LiftConfig::default()).visible;
    assert_eq!(vis.gaussians, vec![0, 1]);
}

#[test]
fn given_depth_map_is_used_and_behind_camera_is_invisible() {
    let g = gaussians(&[[0.0, 0.0, 3.0], [0.0, 0.0, -3.0]], 0.05, 0.9);
    let prepared = PreparedGaussians::new(&g).unwrap();
    let cam = camera(32);
    // A wall at depth 1 everywhere hides the Gaussian at z = 3.
    let wall = splatseg_scene::Plane::filled(32, 32, 1.0f32);
    let vis = view_visibility(&prepared, &cam, &Pose::IDENTITY, Some(&wall), &LiftConfig::default()).visible;
    assert!(vis.gaussians.is_empty());
    let vis = view_visibility(&prepared, &cam, &Pose::IDENTITY, None, &LiftConfig::default()).visible;
    assert_eq!(vis.gaussians, vec![0]);
}

#[test]
fn near_frontal_views_weigh_more() {
    // A flat Gaussian (normal +z... facing the first camera) seen face-on from z = −2 and at
    // a grazing 80° angle from the side, both at distance 2.
    let mut g = gaussians(&[[0.0, 0.0, 0.0]], 0.05, 0.9);
    g.log_scales[0] = [0.1f32.ln(), 0.1f32.ln(), 0.005f32.ln()];
    let prepared = PreparedGaussians::new(&g).unwrap();
    let cam = camera(64);
    let config = LiftConfig::default();
    let face_on = look_at(DVec3::new(0.0, 0.0, -2.0), DVec3::ZERO);
    let a = 80f64.to_radians();
    let grazing = look_at(DVec3::new(2.0 * a.sin(), 0.0, -2.0 * a.cos()), DVec3::ZERO);
    let near = look_at(DVec3::new(0.0, 0.0, -1.0), DVec3::ZERO);
    let w = |pose| view_visibility(&prepared, &cam, &pose, None, &config).visible.weights[0];
    let (w_face, w_graze, w_near) = (w(face_on), w(grazing), w(near));
    assert!(w_face > 4.0 * w_graze, "face-on {w_face} vs grazing {w_graze}");
    assert!((w_near / w_face - 2.0).abs() < 0.01, "half the distance, twice the weight");
}
