//! Outputs and gradients are bit-identical on 1 and 2 threads (per-pixel work is independent and
//! per-Gaussian sums are combined in a fixed order).

use crate::common::{random_gaussians, test_camera};
use splatseg_render::{
    render_bwd, render_with_state, FeatureInput, GaussianGrads, OutputGrads, RenderOutput, RenderRequest,
};

fn run(threads: usize) -> (RenderOutput, GaussianGrads) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
    pool.install(|| {
        let g = random_gaussians(3000, 3, 21);
        let camera = test_camera(160, 120);
        let features: Vec<f32> = (0..g.len() * 2).map(|i| (i % 7) as f32 * 0.1).collect();
        let req = RenderRequest {
            features: Some(FeatureInput { values: &features, dim: 2 }),
            ..RenderRequest::all()
        };
        let (out, state) = render_with_state(&g, &camera, &req).expect("render");
        let px = camera.pixel_count();
        let d_rgb: Vec<f32> = (0..px * 3).map(|i| ((i * 7919) % 13) as f32 * 0.01 - 0.06).collect();
        let d_depth = vec![0.01f32; px];
        let d_feat = vec![-0.02f32; px * 2];
        let grads =
            OutputGrads { rgb: Some(&d_rgb), depth: Some(&d_depth), alpha: None, features: Some(&d_feat) };
        let gr = render_bwd(&g, &camera, &req, &state, &grads).expect("backward");
        (out, gr)
    })
}

#[test]
fn one_and_two_threads_give_identical_bits() {
    let (out1, g1) = run(1);
    let (out2, g2) = run(2);
    assert!(out1.stats.blends > 10_000, "the scene should be non-trivial ({} blends)", out1.stats.blends);
    assert_eq!(out1.rgb, out2.rgb);
    assert_eq!(out1.depth, out2.depth);
    assert_eq!(out1.alpha, out2.alpha);
    assert_eq!(out1.features, out2.features);
    assert_eq!(out1.max_weight_ids, out2.max_weight_ids);
    assert_eq!(g1, g2);
}
