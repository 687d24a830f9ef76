//! Ids read back from the rendered identity maps: per view the D-channel identity map is rendered and
//! classified, and every Gaussian votes, per class, with its blending weights `α·T` over the pixels
//! classified as that class (FlashSplat's assignment, here on the classified maps).
//!
//! The votes come from the rasteriser's backward: the rendered map is linear in the per-Gaussian
//! channel values, so with K extra zero channels and the output gradient the one-hot class map
//! (`[H·W, K]`), `∂/∂(channel k of Gaussian g) = Σ_{pixels p of class k} α_g(p)·T_g(p)`. One forward and
//! one backward per view; views are added in order, so the result does not depend on the thread count.

use splatseg_render::{
    render_bwd, render_with_state, FeatureInput, OutputGrads, RenderCamera, RenderRequest,
};
use splatseg_scene::Gaussians;

use crate::error::{TrainError, TrainResult};
use crate::identity::Classifier;

/// `[N, K]` summed blending weights per class over the views of `cameras` (the training views).
/// `features`: `[N, D]` object features.
pub fn rendered_votes(
    gaussians: &Gaussians,
    features: &[f32],
    classifier: &Classifier,
    cameras: &[&RenderCamera],
) -> TrainResult<Vec<f64>> {
    let (n, d, k) = (gaussians.len(), classifier.dim, classifier.classes);
    if features.len() != n * d {
        return Err(TrainError::Input(format!(
            "{} feature values for {n} Gaussians of width {d}",
            features.len()
        )));
    }
    let width = d + k;
    // [N, D + K]: the features, then K zero channels whose gradients are the votes
    let mut channels = vec![0.0f32; n * width];
    for (row, f) in channels.chunks_exact_mut(width).zip(features.chunks_exact(d)) {
        row[..d].copy_from_slice(f);
    }
    let request = RenderRequest {
        rgb: false,
        features: Some(FeatureInput { values: &channels, dim: width }),
        ..RenderRequest::default()
    };
    let mut votes = vec![0.0f64; n * k];
    for &camera in cameras {
        let (out, state) = render_with_state(gaussians, camera, &request)?;
        let rendered =
            out.features.ok_or_else(|| TrainError::Input("the rasteriser returned no features".into()))?;
        let map: Vec<f32> = rendered.chunks_exact(width).flat_map(|px| px[..d].iter().copied()).collect();
        let classes = classifier.classify(&map);
        let mut one_hot = vec![0.0f32; rendered.len()];
        for (px, &c) in one_hot.chunks_exact_mut(width).zip(&classes) {
            px[d + c as usize] = 1.0;
        }
        let grads = OutputGrads { features: Some(&one_hot), ..OutputGrads::default() };
        let g = render_bwd(gaussians, camera, &request, &state, &grads)?;
        let per_gaussian = g.features.ok_or_else(|| TrainError::Input("no feature gradients".into()))?;
        for (v, row) in votes.chunks_exact_mut(k).zip(per_gaussian.chunks_exact(width)) {
            v.iter_mut().zip(&row[d..]).for_each(|(a, &b)| *a += f64::from(b));
        }
    }
    Ok(votes)
}
