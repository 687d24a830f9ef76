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

/// A plane of flat discs with unit normal `normal` through `centre`, `steps × steps` discs
/// spaced `spacing` apart (σ 0.6 spacing in the plane, 0.02 spacing across).
fn disc_plane(centre: DVec3, normal: DVec3, steps: usize, spacing: f64) -> splatseg_scene::Gaussians {
    let rotation = glam::DQuat::from_rotation_arc(DVec3::Z, normal);
    let (u, v) = (rotation * DVec3::X, rotation * DVec3::Y);
    let half = (steps as f64 - 1.0) / 2.0;
    let means: Vec<[f32; 3]> = (0..steps * steps)
        .map(|k| {
            let (i, j) = ((k % steps) as f64 - half, (k / steps) as f64 - half);
            (centre + spacing * (i * u + j * v)).as_vec3().to_array()
        })
        .collect();
    let mut g = gaussians(&means, 1.0, 0.95);
    let q = [rotation.w, rotation.x, rotation.y, rotation.z].map(|c| c as f32);
    g.rotations = vec![q; means.len()];
    g.log_scales =
        vec![
            [(0.6 * spacing).ln() as f32, (0.6 * spacing).ln() as f32, (0.02 * spacing).ln() as f32];
            means.len()
        ];
    g
}

#[test]
fn rendered_normals_are_the_discs_normals_in_the_camera_frame_facing_it() {
    // A plane tilted 40° about the world y axis, seen from an off-axis camera; its rendered
    // normal at the image centre is the world normal in camera axes, turned towards the camera
    // (whichever way the discs' own axes point).
    let tilt = 40f64.to_radians();
    let normal = DVec3::new(tilt.sin(), 0.0, -tilt.cos());
    let pose = look_at(DVec3::new(0.6, -0.3, -2.5), DVec3::ZERO);
    let expected = pose.rotation.transpose() * normal;
    let cam = camera(64);
    for sign in [1.0, -1.0] {
        let g = disc_plane(DVec3::ZERO, sign * normal, 41, 0.05);
        let prepared = PreparedGaussians::new(&g).unwrap();
        let pass = view_visibility(&prepared, &cam, &pose, None, &LiftConfig::default());
        let normals = pass.surface_normals.expect("rendered normals with the surface depth");
        let n = DVec3::from((*normals.get(32, 32)).map(f64::from));
        assert!(n.dot(expected) > 1f64.to_radians().cos(), "{n:?} vs {expected:?}");
        assert!(
            n.dot(pose.rotation.transpose() * (DVec3::ZERO - pose.translation)) < 0.0,
            "faces the camera"
        );
    }
    // A given depth map: no surface of the Gaussians' own, no normals.
    let g = PreparedGaussians::new(&disc_plane(DVec3::ZERO, normal, 11, 0.05)).unwrap();
    let wall = splatseg_scene::Plane::filled(64, 64, 1.0f32);
    assert!(view_visibility(&g, &cam, &pose, Some(&wall), &LiftConfig::default()).surface_normals.is_none());
}

#[test]
fn round_gaussians_and_empty_pixels_have_no_rendered_normal() {
    // Round Gaussians have no preferred axis; a pixel no Gaussian covers has no surface.
    let g = gaussians(&[[0.0, 0.0, 2.0]], 0.1, 0.95);
    let prepared = PreparedGaussians::new(&g).unwrap();
    let pass = view_visibility(&prepared, &camera(64), &Pose::IDENTITY, None, &LiftConfig::default());
    let normals = pass.surface_normals.expect("normals");
    assert!(pass.surface_depth.expect("depth").get(32, 32).is_finite(), "the centre has a surface");
    assert!(normals.get(32, 32)[0].is_nan(), "round: {:?}", normals.get(32, 32));
    assert!(normals.get(0, 0)[0].is_nan(), "empty pixel: {:?}", normals.get(0, 0));
}
