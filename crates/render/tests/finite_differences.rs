//! Central finite differences for every parameter group on a tiny scene.
//!
//! The blending cut-offs (α ≥ 1/255, T stop, finite footprints) make the image a discontinuous
//! function of the parameters, so these checks use smooth settings (no α floor, no T stop, a wide
//! footprint); the cut-offs themselves are checked against gsplat in `parity.rs`.
//!
//! Two scenes: every output with 2 feature channels, and 16 feature channels alone (the identity
//! maps of the joint stage), whose loss reaches opacity, means, scales and rotations only through α.

use crate::common::{random_gaussians, test_camera};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use splatseg_render::{
    render_bwd, render_with_state, Extent, FeatureInput, GaussianGrads, OutputGrads, RasterSettings,
    RenderCamera, RenderRequest,
};
use splatseg_scene::Gaussians;

/// Adds `h` to parameter `idx` of a group (Gaussians or the feature array).
type Perturb = dyn Fn(&mut Gaussians, &mut [f32], usize, f32);

struct Setup {
    camera: RenderCamera,
    /// Feature channels D.
    dim: usize,
    /// `[N, D]`.
    features: Vec<f32>,
    w_rgb: Vec<f32>,
    w_depth: Vec<f32>,
    w_alpha: Vec<f32>,
    w_feat: Vec<f32>,
}

fn smooth_settings() -> RasterSettings {
    RasterSettings {
        alpha_min: 0.0,
        transmittance_min: 0.0,
        extent: Extent::PerAxis { sigmas: 40.0 },
        ..RasterSettings::default()
    }
}

fn request(features: &[f32], dim: usize) -> RenderRequest<'_> {
    RenderRequest {
        rgb: true,
        depth: true,
        alpha: true,
        max_weight_ids: false,
        features: Some(FeatureInput { values: features, dim }),
        background: [0.2, 0.5, 0.9],
        sh_degree: None,
        settings: smooth_settings(),
    }
}

fn weights(n: usize, rng: &mut ChaCha8Rng) -> Vec<f32> {
    (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect()
}

/// Depth weights are kept only where the alpha is substantial: expected depth `Σwz / Σw` is
/// ill-conditioned in the far tails where both sums underflow.
fn mask_depth_weights(g: &Gaussians, s: &mut Setup) {
    let (out, _) = render_with_state(g, &s.camera, &request(&s.features, s.dim)).expect("render");
    for (w, &a) in s.w_depth.iter_mut().zip(&out.alpha.as_ref().unwrap().data) {
        if a < 0.05 {
            *w = 0.0;
        }
    }
}

fn setup(n: usize, dim: usize) -> Setup {
    let camera = test_camera(24, 20);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let px = camera.pixel_count();
    Setup {
        camera,
        dim,
        features: weights(n * dim, &mut rng),
        w_rgb: weights(px * 3, &mut rng),
        w_depth: weights(px, &mut rng).iter().map(|v| v * 0.1).collect(),
        w_alpha: weights(px, &mut rng),
        w_feat: weights(px * dim, &mut rng),
    }
}

fn dot(a: &[f32], b: &[f32]) -> f64 {
    a.iter().zip(b).map(|(&x, &y)| x as f64 * y as f64).sum()
}

fn loss(g: &Gaussians, features: &[f32], s: &Setup) -> f64 {
    let (out, _) = render_with_state(g, &s.camera, &request(features, s.dim)).expect("render");
    dot(out.rgb.as_ref().unwrap(), &s.w_rgb)
        + dot(&out.depth.as_ref().unwrap().data, &s.w_depth)
        + dot(&out.alpha.as_ref().unwrap().data, &s.w_alpha)
        + dot(out.features.as_ref().unwrap(), &s.w_feat)
}

fn analytic(g: &Gaussians, s: &Setup) -> GaussianGrads {
    let req = request(&s.features, s.dim);
    let (_, state) = render_with_state(g, &s.camera, &req).expect("render");
    let grads = OutputGrads {
        rgb: Some(&s.w_rgb),
        depth: Some(&s.w_depth),
        alpha: Some(&s.w_alpha),
        features: Some(&s.w_feat),
    };
    render_bwd(g, &s.camera, &req, &state, &grads).expect("backward")
}

/// Checks the analytic gradient of one parameter group against central differences.
fn check_group(name: &str, g: &Gaussians, s: &Setup, analytic: &[f32], perturb: &Perturb) {
    let h = 1e-3f32;
    let mut checked_nonzero = 0;
    let count = analytic.len();
    for (idx, &an) in analytic.iter().enumerate() {
        let (mut up, mut dn) = (g.clone(), g.clone());
        let (mut fu, mut fdn) = (s.features.clone(), s.features.clone());
        perturb(&mut up, &mut fu, idx, h);
        perturb(&mut dn, &mut fdn, idx, -h);
        let fd = ((loss(&up, &fu, s) - loss(&dn, &fdn, s)) / (2.0 * h as f64)) as f32;
        let tol = 2e-2 + 2e-2 * fd.abs();
        assert!((fd - an).abs() <= tol, "{name}[{idx}]: finite difference {fd} vs analytic {an}");
        if fd.abs() > 1e-2 {
            checked_nonzero += 1;
        }
    }
    assert!(
        checked_nonzero * 2 >= count,
        "{name}: too few non-zero gradients ({checked_nonzero} of {count})"
    );
}

#[test]
fn gradients_match_central_differences() {
    let n = 5;
    let g = random_gaussians(n, 3, 11);
    let mut s = setup(n, 2);
    mask_depth_weights(&g, &mut s);
    let a = analytic(&g, &s);
    let flat3 = |v: &[[f32; 3]]| v.iter().flatten().copied().collect::<Vec<_>>();
    check_group("means", &g, &s, &flat3(&a.means), &|g, _, i, h| g.means[i / 3][i % 3] += h);
    check_group("log_scales", &g, &s, &flat3(&a.log_scales), &|g, _, i, h| g.log_scales[i / 3][i % 3] += h);
    let rot: Vec<f32> = a.rotations.iter().flatten().copied().collect();
    check_group("rotations", &g, &s, &rot, &|g, _, i, h| g.rotations[i / 4][i % 4] += h);
    check_group("raw_opacities", &g, &s, &a.raw_opacities, &|g, _, i, h| g.raw_opacities[i] += h);
    check_group("sh_dc", &g, &s, &flat3(&a.sh_dc), &|g, _, i, h| g.sh_dc[i / 3][i % 3] += h);
    check_group("sh_rest", &g, &s, &a.sh_rest, &|g, _, i, h| g.sh_rest[i] += h);
    let feats = a.features.as_ref().expect("feature gradients");
    check_group("features", &g, &s, feats, &|_, f, i, h| f[i] += h);
}

#[test]
fn sixteen_feature_channels_match_central_differences() {
    let n = 4;
    let g = random_gaussians(n, 0, 12);
    let mut s = setup(n, 16);
    // the loss sees only the 16 rendered channels
    s.w_rgb.fill(0.0);
    s.w_depth.fill(0.0);
    s.w_alpha.fill(0.0);
    let a = analytic(&g, &s);
    assert!(a.sh_dc.iter().flatten().all(|&v| v == 0.0), "colour gets no gradient from features");
    let flat3 = |v: &[[f32; 3]]| v.iter().flatten().copied().collect::<Vec<_>>();
    let feats = a.features.as_ref().expect("feature gradients");
    assert_eq!(feats.len(), n * 16);
    check_group("features (16)", &g, &s, feats, &|_, f, i, h| f[i] += h);
    check_group("raw_opacities via features", &g, &s, &a.raw_opacities, &|g, _, i, h| {
        g.raw_opacities[i] += h
    });
    check_group("means via features", &g, &s, &flat3(&a.means), &|g, _, i, h| g.means[i / 3][i % 3] += h);
    check_group("log_scales via features", &g, &s, &flat3(&a.log_scales), &|g, _, i, h| {
        g.log_scales[i / 3][i % 3] += h
    });
    let rot: Vec<f32> = a.rotations.iter().flatten().copied().collect();
    check_group("rotations via features", &g, &s, &rot, &|g, _, i, h| g.rotations[i / 4][i % 4] += h);
}
