//! Hand-made Gaussians and cameras shared by the lift tests.
#![allow(dead_code)]

use glam::{DMat3, DVec3};
use splatseg_lift::{GaussianStatus, LiftStats, Lifted};
use splatseg_scene::{Camera, Gaussians, Pose};

/// Isotropic Gaussians at `means` with scale `scale` and opacity ≈ `opacity`.
pub fn gaussians(means: &[[f32; 3]], scale: f32, opacity: f32) -> Gaussians {
    let n = means.len();
    let raw = (opacity / (1.0 - opacity)).ln();
    Gaussians {
        means: means.to_vec(),
        normals: None,
        sh_dc: vec![[0.0; 3]; n],
        sh_degree: 0,
        sh_rest: Vec::new(),
        raw_opacities: vec![raw; n],
        log_scales: vec![[scale.ln(); 3]; n],
        rotations: vec![[1.0, 0.0, 0.0, 0.0]; n],
        object_ids: None,
        features: None,
        extra: Vec::new(),
    }
}

/// A `size × size` pinhole camera with a 60° field of view.
pub fn camera(size: u32) -> Camera {
    let f = size as f64 / 2.0 / (30f64.to_radians().tan());
    Camera::pinhole(1, size, size, f, f, size as f64 / 2.0, size as f64 / 2.0)
}

/// A camera at `eye` looking at `target` (OpenCV axes: x right, y down, z forward), world up −y.
pub fn look_at(eye: DVec3, target: DVec3) -> Pose {
    let z = (target - eye).normalize();
    let up = DVec3::new(0.0, -1.0, 0.0);
    let x = up.cross(z).normalize_or(DVec3::X);
    let x = -x;
    let y = z.cross(x);
    Pose { rotation: DMat3::from_cols(x, y, z), translation: eye }
}

/// Points on a sphere of `radius` around `centre`, on a latitude–longitude grid.
pub fn sphere(centre: [f32; 3], radius: f32, steps: usize) -> Vec<[f32; 3]> {
    let mut out = Vec::new();
    for i in 0..steps {
        let theta = std::f32::consts::PI * (i as f32 + 0.5) / steps as f32;
        for j in 0..2 * steps {
            let phi = std::f32::consts::PI * j as f32 / steps as f32;
            out.push([
                centre[0] + radius * theta.sin() * phi.cos(),
                centre[1] + radius * theta.cos(),
                centre[2] + radius * theta.sin() * phi.sin(),
            ]);
        }
    }
    out
}

/// A lift result with `ids: [N]` as object and majority ids, every Gaussian labelled and seen once.
pub fn lifted(ids: Vec<i32>) -> Lifted {
    let n = ids.len();
    Lifted {
        majority_ids: ids.iter().map(|&i| i.max(0) as u32).collect(),
        object_ids: ids,
        status: vec![GaussianStatus::Labelled; n],
        variances: vec![0.0; n],
        views_seen: vec![1; n],
        fused_features: None,
        stats: LiftStats::default(),
    }
}
