//! Bad input gives clear errors, never panics; extreme but finite values render finite images.

use crate::common::{random_gaussians, test_camera};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use splatseg_render::{render, render_bwd, render_with_state, OutputGrads, RenderError, RenderRequest};

#[test]
fn inconsistent_lengths_are_reported() {
    let camera = test_camera(32, 24);
    let mut g = random_gaussians(5, 1, 1);
    g.sh_rest.pop();
    let err = render(&g, &camera, &RenderRequest::default()).unwrap_err();
    assert!(matches!(err, RenderError::Shape { what: "sh_rest", .. }), "{err}");
    let mut g = random_gaussians(5, 0, 1);
    g.rotations.pop();
    let err = render(&g, &camera, &RenderRequest::default()).unwrap_err();
    assert_eq!(err.to_string(), "rotations has 4 values, expected 5");
}

#[test]
fn non_finite_parameters_are_reported_with_their_index() {
    let camera = test_camera(32, 24);
    let mut g = random_gaussians(5, 2, 1);
    g.means[3][1] = f32::NAN;
    let err = render(&g, &camera, &RenderRequest::default()).unwrap_err();
    assert_eq!(err.to_string(), "mean of Gaussian 3 is not finite");
    let mut g = random_gaussians(5, 2, 1);
    g.sh_rest[2 * 24 + 5] = f32::INFINITY;
    let err = render(&g, &camera, &RenderRequest::default()).unwrap_err();
    assert_eq!(err.to_string(), "SH coefficient of Gaussian 2 is not finite");
}

#[test]
fn unsupported_degree_camera_and_gradients_are_reported() {
    let camera = test_camera(32, 24);
    let mut g = random_gaussians(2, 3, 1);
    g.sh_degree = 4;
    g.sh_rest = vec![0.0; 2 * 3 * 24];
    assert!(matches!(render(&g, &camera, &RenderRequest::default()), Err(RenderError::ShDegree(4))));
    let g = random_gaussians(2, 0, 1);
    let mut bad = camera.clone();
    bad.fx = 0.0;
    assert!(matches!(render(&g, &bad, &RenderRequest::default()), Err(RenderError::Camera(_))));
    let req = RenderRequest::default();
    let (_, state) = render_with_state(&g, &camera, &req).unwrap();
    let depth = vec![0.0; camera.pixel_count()];
    let grads = OutputGrads { depth: Some(&depth), ..Default::default() };
    let err = render_bwd(&g, &camera, &req, &state, &grads).unwrap_err();
    assert!(matches!(err, RenderError::GradientWithoutOutput("depth")), "{err}");
}

/// Seeded fuzz: huge, tiny, denormal, degenerate (zero quaternion) and behind-camera values.
#[test]
fn extreme_finite_values_render_finite_images_and_gradients() {
    let camera = test_camera(48, 32);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let specials = [0.0f32, 1e-40, -1e-40, 1e30, -1e30, 88.0, -88.0, 1e-7];
    for round in 0..20 {
        let mut g = random_gaussians(30, 1, round);
        for _ in 0..10 {
            let i = rng.gen_range(0..g.len());
            let v = specials[rng.gen_range(0..specials.len())];
            match rng.gen_range(0..5) {
                0 => g.means[i][rng.gen_range(0..3)] = v,
                1 => g.log_scales[i][rng.gen_range(0..3)] = v.clamp(-80.0, 30.0),
                2 => g.rotations[i] = [v, 0.0, 0.0, 0.0],
                3 => g.raw_opacities[i] = v,
                _ => g.sh_dc[i][rng.gen_range(0..3)] = v.clamp(-1e3, 1e3),
            }
        }
        let req = RenderRequest::all();
        let (out, state) = render_with_state(&g, &camera, &req).expect("render");
        for (name, v) in [("rgb", out.rgb.as_ref().unwrap()), ("depth", &out.depth.as_ref().unwrap().data)] {
            assert!(v.iter().all(|x| x.is_finite()), "round {round}: non-finite {name}");
        }
        let d_rgb = vec![0.01f32; camera.pixel_count() * 3];
        let grads = OutputGrads { rgb: Some(&d_rgb), ..Default::default() };
        let gr = render_bwd(&g, &camera, &req, &state, &grads).expect("backward");
        let finite = gr.means.iter().flatten().chain(gr.log_scales.iter().flatten()).all(|x| x.is_finite());
        assert!(finite, "round {round}: non-finite gradients");
    }
}
