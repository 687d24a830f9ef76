//! Synthetic benchmark data: Gaussians on the surfaces of a grid of spheres, a ring of cameras
//! looking at them, and per-view id maps (sphere index, drawn as depth-ordered discs).

use glam::{DMat3, DVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use splatseg_scene::{Camera, Gaussians, Plane, Pose};

/// Sphere centres (`[K]`, on a 5 × 4 grid) and their radius.
pub fn spheres() -> (Vec<DVec3>, f64) {
    let mut centres = Vec::new();
    for i in 0..5 {
        for j in 0..4 {
            centres.push(DVec3::new(i as f64 * 1.4 - 2.8, 0.0, j as f64 * 1.4 - 2.1));
        }
    }
    (centres, 0.5)
}

/// `n` Gaussians spread uniformly over the spheres' surfaces, sized so neighbours overlap.
pub fn gaussians(n: usize, seed: u64) -> Gaussians {
    let (centres, radius) = spheres();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let area = centres.len() as f64 * 4.0 * std::f64::consts::PI * radius * radius;
    let scale = (area / n as f64).sqrt() as f32;
    let mut means = Vec::with_capacity(n);
    for k in 0..n {
        let c = centres[k * centres.len() / n];
        let z: f64 = rng.gen_range(-1.0..1.0);
        let phi: f64 = rng.gen_range(0.0..std::f64::consts::TAU);
        let r = (1.0 - z * z).sqrt();
        let p = c + radius * DVec3::new(r * phi.cos(), z, r * phi.sin());
        means.push([p.x as f32, p.y as f32, p.z as f32]);
    }
    Gaussians {
        means,
        normals: None,
        sh_dc: vec![[0.0; 3]; n],
        sh_degree: 0,
        sh_rest: Vec::new(),
        raw_opacities: vec![2.0; n],
        log_scales: vec![[scale.ln(); 3]; n],
        rotations: vec![[1.0, 0.0, 0.0, 0.0]; n],
        object_ids: None,
        features: None,
        extra: Vec::new(),
    }
}

/// A `width × height` pinhole camera with a 60° horizontal field of view.
pub fn camera(width: u32, height: u32) -> Camera {
    let f = width as f64 / 2.0 / 30f64.to_radians().tan();
    Camera::pinhole(1, width, height, f, f, width as f64 / 2.0, height as f64 / 2.0)
}

/// `n` cameras on a ring of radius 7, alternating heights, looking at the origin.
pub fn poses(n: usize) -> Vec<Pose> {
    (0..n)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / n as f64;
            let eye = DVec3::new(7.0 * a.sin(), if k % 2 == 0 { -2.5 } else { -1.0 }, -7.0 * a.cos());
            let z = (-eye).normalize();
            let x = -(DVec3::new(0.0, -1.0, 0.0).cross(z)).normalize();
            let y = z.cross(x);
            Pose { rotation: DMat3::from_cols(x, y, z), translation: eye }
        })
        .collect()
}

/// Per-view id maps `[height, width]`: sphere `k` (id `k + 1`) drawn as the disc of its
/// projected radius, far to near.
pub fn id_maps(camera: &Camera, poses: &[Pose]) -> Vec<Plane<u32>> {
    let (centres, radius) = spheres();
    poses
        .iter()
        .map(|pose| {
            let cam_from_world = pose.inverse();
            let mut order: Vec<(f64, usize)> =
                centres.iter().enumerate().map(|(k, c)| (cam_from_world.transform_point(*c).z, k)).collect();
            order.sort_by(|a, b| b.0.total_cmp(&a.0));
            let mut map = Plane::filled(camera.width as usize, camera.height as usize, 0u32);
            for (z, k) in order {
                let Some(uv) = camera.project(cam_from_world.transform_point(centres[k])) else { continue };
                let r = camera.fx * radius / z;
                let (x0, x1) = ((uv.x - r).max(0.0) as usize, ((uv.x + r).max(0.0) as usize).min(map.width));
                let (y0, y1) = ((uv.y - r).max(0.0) as usize, ((uv.y + r).max(0.0) as usize).min(map.height));
                for y in y0..y1 {
                    for x in x0..x1 {
                        let (dx, dy) = (x as f64 + 0.5 - uv.x, y as f64 + 0.5 - uv.y);
                        if dx * dx + dy * dy <= r * r {
                            *map.get_mut(x, y) = k as u32 + 1;
                        }
                    }
                }
            }
            map
        })
        .collect()
}

/// Unit identity features for the spheres: `[K, 8]`, pseudo-random directions.
pub fn object_features() -> Vec<f32> {
    let (centres, _) = spheres();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut out = Vec::new();
    for _ in 0..centres.len() {
        let f: Vec<f32> = (0..8).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let norm = f.iter().map(|x| x * x).sum::<f32>().sqrt();
        out.extend(f.iter().map(|x| x / norm));
    }
    out
}
