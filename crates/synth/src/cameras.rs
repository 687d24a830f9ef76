//! The camera arc: pinhole cameras on an orbit around the scene centre, looking at it, as
//! `world_from_cam` poses with OpenCV axes (x right, y down, z forward).

use crate::config::SynthConfig;
use crate::noise::{rng_for, stream};
use glam::{DMat3, DVec3};
use rand::Rng;
use splatseg_scene::{Camera, Pose};

/// The point every camera looks at (world; z up).
pub const TARGET: DVec3 = DVec3::new(0.0, 0.0, 0.4);
/// Horizontal distance of the cameras from [`TARGET`], metres.
pub const ORBIT_RADIUS: f64 = 4.3;
/// Height of the cameras above the floor, metres.
pub const CAMERA_HEIGHT: f64 = 1.9;
/// World azimuth (radians from +x) of the middle of the arc: the cameras sit in the +x, +y
/// quadrant and look towards the room corner at (−x, −y).
pub const MID_AZIMUTH: f64 = std::f64::consts::FRAC_PI_4;

/// The one shared pinhole camera (COLMAP id 1): `fx = fy = (W / 2) / tan(fov_x / 2)`,
/// principal point at the image centre.
pub fn camera(config: &SynthConfig) -> Camera {
    let f = config.width as f64 / 2.0 / (config.fov_x_deg.to_radians() / 2.0).tan();
    Camera::pinhole(
        1,
        config.width,
        config.height,
        f,
        f,
        config.width as f64 / 2.0,
        config.height as f64 / 2.0,
    )
}

/// A `world_from_cam` pose at `eye` looking at `target` with world z up.
pub fn look_at(eye: DVec3, target: DVec3) -> Pose {
    let forward = (target - eye).normalize();
    let right = forward.cross(DVec3::Z).normalize();
    let down = forward.cross(right);
    Pose { rotation: DMat3::from_cols(right, down, forward), translation: eye }
}

/// One pose per view, evenly spaced over `arc_deg` around [`MID_AZIMUTH`], with a small
/// per-seed jitter of the arc's start, each camera's height and its aim.
pub fn orbit_poses(config: &SynthConfig) -> Vec<Pose> {
    let mut rng = rng_for(config.seed, stream::CAMERAS, 0);
    let arc = config.arc_deg.to_radians();
    let offset = rng.gen_range(-0.05..=0.05);
    (0..config.views)
        .map(|i| {
            let s = if config.views > 1 { i as f64 / (config.views - 1) as f64 - 0.5 } else { 0.0 };
            let azimuth = MID_AZIMUTH + offset + arc * s;
            let height = CAMERA_HEIGHT + rng.gen_range(-0.08..=0.08);
            let eye = TARGET + DVec3::new(ORBIT_RADIUS * azimuth.cos(), ORBIT_RADIUS * azimuth.sin(), 0.0);
            let eye = DVec3::new(eye.x, eye.y, height);
            let aim = TARGET + DVec3::new(rng.gen_range(-0.1..=0.1), rng.gen_range(-0.1..=0.1), 0.0);
            look_at(eye, aim)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn look_at_is_a_rotation_with_opencv_axes() {
        let pose = look_at(DVec3::new(3.0, 3.0, 2.0), DVec3::ZERO);
        let r = pose.rotation;
        assert!((r.determinant() - 1.0).abs() < 1e-12);
        assert!((r * r.transpose() - DMat3::IDENTITY).abs_diff_eq(DMat3::ZERO, 1e-12));
        // The target projects to the image centre; a point above it projects above (smaller v).
        let cam = Camera::pinhole(1, 320, 240, 277.0, 277.0, 160.0, 120.0);
        let cam_from_world = pose.inverse();
        let uv = cam.project(cam_from_world.transform_point(DVec3::ZERO)).expect("in front");
        assert!((uv.x - 160.0).abs() < 1e-9 && (uv.y - 120.0).abs() < 1e-9);
        let up = cam.project(cam_from_world.transform_point(DVec3::Z * 0.5)).expect("in front");
        assert!(up.y < 120.0);
    }

    #[test]
    fn orbit_spans_the_arc_and_looks_at_the_target() {
        let config = SynthConfig { views: 9, ..SynthConfig::default() };
        let poses = orbit_poses(&config);
        assert_eq!(poses.len(), 9);
        let azimuth = |p: &Pose| (p.translation.y - TARGET.y).atan2(p.translation.x - TARGET.x);
        let span = azimuth(&poses[8]) - azimuth(&poses[0]);
        assert!((span - config.arc_deg.to_radians()).abs() < 1e-9);
        for p in &poses {
            let forward = p.rotation.z_axis;
            assert!(forward.dot((TARGET - p.translation).normalize()) > 0.99);
        }
    }
}
