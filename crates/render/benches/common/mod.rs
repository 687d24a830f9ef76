//! Synthetic benchmark scenes: `n` Gaussians filling a camera's frustum between depths 2 and 10,
//! anisotropic, footprints of a few pixels (σ ≈ 1–4 px), SH degree 3, like a trained 3DGS scene.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use splatseg_render::RenderCamera;
use splatseg_scene::{Camera, Gaussians, Pose};

/// A `width × height` camera at the origin looking along +z, horizontal field of view ≈ 64°.
pub fn bench_camera(width: u32, height: u32) -> RenderCamera {
    let f = 0.8 * width as f64;
    let cam = Camera::pinhole(1, width, height, f, f, width as f64 / 2.0, height as f64 / 2.0);
    RenderCamera::from_scene(&cam, &Pose::IDENTITY)
}

/// `n` Gaussians in the frustum of `camera` (seeded). World scales are fixed for an 800 px
/// wide camera, so footprints in pixels grow with the image width.
pub fn bench_gaussians(n: usize, camera: &RenderCamera, seed: u64) -> Gaussians {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (hx, hy) = (camera.cx / camera.fx, camera.cy / camera.fy);
    let k = 15;
    let mut g = Gaussians { sh_degree: 3, ..Default::default() };
    g.means.reserve(n);
    for _ in 0..n {
        let z: f32 = rng.gen_range(2.0..10.0);
        g.means.push([rng.gen_range(-hx..hx) * z, rng.gen_range(-hy..hy) * z, z]);
        let base = (z * 2.5 / 640.0).ln();
        g.log_scales.push([0, 1, 2].map(|_| base + rng.gen_range(-0.6f32..0.6)));
        g.rotations.push([0, 1, 2, 3].map(|_| rng.gen_range(-1.0f32..1.0)));
        g.raw_opacities.push(rng.gen_range(-2.0..3.0));
        g.sh_dc.push([0, 1, 2].map(|_| rng.gen_range(-1.5f32..1.5)));
        g.sh_rest.extend((0..3 * k).map(|_| rng.gen_range(-0.2f32..0.2)));
    }
    g
}
