//! 3DGS's photometric loss `L_render = (1 − λ)·L1 + λ·(1 − SSIM)` and its gradient w.r.t. the rendered image.

use splatseg_eval::photometric::ssim_with_grad;

use crate::error::{TrainError, TrainResult};

/// The terms of one evaluation of [`render_loss`].
#[derive(Clone, Debug, PartialEq)]
pub struct RenderLoss {
    /// `L_render`.
    pub loss: f64,
    /// Mean absolute error.
    pub l1: f64,
    /// Mean SSIM (3DGS's definition).
    pub ssim: f64,
    /// `[H, W, 3]` ∂L_render/∂rendered.
    pub grad: Vec<f32>,
}

/// `rendered`, `target`: `[H, W, 3]`; `lambda_dssim`: the weight λ of the D-SSIM term.
pub fn render_loss(
    rendered: &[f32],
    target: &[f32],
    width: usize,
    height: usize,
    lambda_dssim: f64,
) -> TrainResult<RenderLoss> {
    if rendered.len() != target.len() || rendered.len() != width * height * 3 {
        return Err(TrainError::Input(format!(
            "rendered image has {} values, target {}, expected {width}×{height}×3",
            rendered.len(),
            target.len()
        )));
    }
    let n = rendered.len() as f64;
    let (ssim, ssim_grad) = if lambda_dssim > 0.0 {
        ssim_with_grad(rendered, target, width, height, 3)?
    } else {
        (0.0, vec![0.0; rendered.len()])
    };
    let l1_weight = ((1.0 - lambda_dssim) / n) as f32;
    let ssim_weight = lambda_dssim as f32;
    let mut l1 = 0.0f64;
    let grad: Vec<f32> = rendered
        .iter()
        .zip(target)
        .zip(&ssim_grad)
        .map(|((&r, &t), &ds)| {
            l1 += f64::from((r - t).abs());
            let sign = if r > t {
                1.0
            } else if r < t {
                -1.0
            } else {
                0.0
            };
            l1_weight * sign - ssim_weight * ds
        })
        .collect();
    let l1 = l1 / n;
    let loss = (1.0 - lambda_dssim) * l1 + lambda_dssim * (1.0 - ssim);
    Ok(RenderLoss { loss, l1, ssim, grad })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gradient_matches_finite_differences_and_identical_images_cost_nothing() {
        let (w, h) = (13, 11);
        let target: Vec<f32> = (0..w * h * 3).map(|i| ((i * 37 % 97) as f32) / 97.0).collect();
        let rendered: Vec<f32> =
            target.iter().enumerate().map(|(i, t)| t + ((i % 7) as f32 - 3.0) * 0.02).collect();
        let same = render_loss(&target, &target, w, h, 0.2).unwrap();
        assert!(same.loss.abs() < 1e-9 && same.l1 == 0.0);
        let base = render_loss(&rendered, &target, w, h, 0.2).unwrap();
        for i in [0, 5, 77, 200, w * h * 3 - 1] {
            let eps = 1e-3;
            let mut plus = rendered.clone();
            plus[i] += eps;
            let mut minus = rendered.clone();
            minus[i] -= eps;
            let numeric = (render_loss(&plus, &target, w, h, 0.2).unwrap().loss
                - render_loss(&minus, &target, w, h, 0.2).unwrap().loss)
                / (2.0 * f64::from(eps));
            assert!(
                (numeric - f64::from(base.grad[i])).abs() < 2e-5,
                "pixel value {i}: numeric {numeric}, analytic {}",
                base.grad[i]
            );
        }
        assert!(render_loss(&rendered, &target[1..], w, h, 0.2).is_err());
    }
}
