//! Adaptive density control (3DGS §5.2): accumulate each Gaussian's view-space positional gradient,
//! then clone small Gaussians and split large ones where it is high, and prune transparent (and,
//! after the first opacity reset, oversized) ones; opacity resets.
//!
//! One deliberate difference from the 3DGS code: there, `densification_postfix` zeroes every
//! Gaussian's maximum screen radius before the pruning step reads it, so the "larger than 20 px on
//! screen" rule can never fire. Here the radii of the Gaussians that existed are kept (new ones start
//! at 0), so the rule does what the paper says.

use rand_chacha::ChaCha8Rng;
use splatseg_render::GaussianGrads;
use splatseg_render::RenderState;
use splatseg_scene::Gaussians;

use crate::config::DensifyConfig;
use crate::optimizer::GaussianAdam;
use crate::sampling::standard_normal;

/// Per-Gaussian statistics between two densification steps.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DensifyStats {
    /// `[N]` Σ over views where the Gaussian was visible of |∂L/∂mean2d| in NDC units.
    grad_sum: Vec<f64>,
    /// `[N]` number of those views.
    seen: Vec<u32>,
    /// `[N]` largest screen radius (px) seen.
    max_radius: Vec<f32>,
}

impl DensifyStats {
    /// Zero statistics for `n` Gaussians.
    pub fn new(n: usize) -> Self {
        Self { grad_sum: vec![0.0; n], seen: vec![0; n], max_radius: vec![0.0; n] }
    }

    /// Adds one rendered view: `state` from its forward pass, `grads` from its backward pass,
    /// `width × height` its size. 3DGS's NDC gradient is the pixel gradient times `(W/2, H/2)`.
    pub fn add_view(&mut self, state: &RenderState, grads: &GaussianGrads, width: u32, height: u32) {
        let (half_w, half_h) = (f64::from(width) / 2.0, f64::from(height) / 2.0);
        for (i, splat) in state.splats.iter().enumerate() {
            if splat.is_culled() {
                continue;
            }
            let g = grads.means2d[i];
            let (gx, gy) = (f64::from(g[0]) * half_w, f64::from(g[1]) * half_h);
            self.grad_sum[i] += (gx * gx + gy * gy).sqrt();
            self.seen[i] += 1;
            let radius = splat.radii[0].max(splat.radii[1]) as f32;
            self.max_radius[i] = self.max_radius[i].max(radius);
        }
    }

    /// Mean NDC gradient of Gaussian `i` (0 if never seen).
    pub fn mean_grad(&self, i: usize) -> f64 {
        if self.seen[i] == 0 {
            0.0
        } else {
            self.grad_sum[i] / f64::from(self.seen[i])
        }
    }
}

/// What one densification step did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DensifyReport {
    /// Gaussians duplicated.
    pub cloned: usize,
    /// Gaussians replaced by two smaller ones.
    pub split: usize,
    /// Gaussians removed (after cloning and splitting).
    pub pruned: usize,
}

/// The settings of one densification step.
#[derive(Clone, Copy, Debug)]
pub struct DensifyStep<'a> {
    /// Thresholds.
    pub config: &'a DensifyConfig,
    /// Scene radius ([`crate::trainer::cameras_extent`]).
    pub extent: f64,
    /// Apply the screen/world size rule (3DGS: after the first opacity reset).
    pub prune_large: bool,
}

/// Clones, splits and prunes in place, keeping `features` (`[N, D]`, may be empty), `adam` and the
/// returned statistics (fresh zeros) row-aligned with `gaussians`.
pub fn densify_and_prune(
    gaussians: &mut Gaussians,
    features: &mut Vec<f32>,
    feature_dim: usize,
    adam: &mut GaussianAdam,
    stats: &DensifyStats,
    step: &DensifyStep,
    rng: &mut ChaCha8Rng,
) -> (DensifyReport, DensifyStats) {
    let (config, extent, prune_large) = (step.config, step.extent, step.prune_large);
    let n = gaussians.len();
    let threshold = config.grad_threshold;
    let dense_scale = (config.percent_dense * extent) as f32;
    let mut clone_rows = Vec::new();
    let mut split_rows = Vec::new();
    for i in 0..n {
        if stats.mean_grad(i) < threshold {
            continue;
        }
        let largest = gaussians.scales(i).into_iter().fold(0f32, f32::max);
        if largest <= dense_scale {
            clone_rows.push(i);
        } else {
            split_rows.push(i);
        }
    }
    // New order: the originals that are not split, the clones, then two children per split one.
    let mut order: Vec<usize> = (0..n).filter(|i| split_rows.binary_search(i).is_err()).collect();
    let kept_originals = order.len();
    order.extend(&clone_rows);
    let first_child = order.len();
    for &i in &split_rows {
        order.extend([i, i]);
    }
    let mut next = gaussians.select(&order);
    for (k, &i) in split_rows.iter().enumerate() {
        let scales = gaussians.scales(i);
        let rotation = rotation_matrix(gaussians.rotations[i]);
        for child in 0..2 {
            let row = first_child + 2 * k + child;
            let local: [f32; 3] = [0, 1, 2].map(|a| scales[a] * standard_normal(rng));
            let mean = gaussians.means[i];
            next.means[row] =
                [0, 1, 2].map(|r| mean[r] + (0..3).map(|c| rotation[r][c] * local[c]).sum::<f32>());
            // scale / (0.8 · 2)
            next.log_scales[row] = gaussians.log_scales[i].map(|s| s - 1.6f32.ln());
        }
    }
    let next_features: Vec<f32> = if feature_dim == 0 || features.is_empty() {
        Vec::new()
    } else {
        order.iter().flat_map(|&i| features[i * feature_dim..(i + 1) * feature_dim].iter().copied()).collect()
    };
    let keep_split: Vec<bool> = (0..n).map(|i| split_rows.binary_search(&i).is_err()).collect();
    adam.retain(&keep_split);
    adam.append(order.len() - kept_originals);
    let mut radius: Vec<f32> = order[..kept_originals].iter().map(|&i| stats.max_radius[i]).collect();
    radius.resize(order.len(), 0.0);

    // Prune the transparent (and, when asked, the oversized) ones.
    let world_limit = (0.1 * extent) as f32;
    let keep: Vec<bool> = (0..next.len())
        .map(|i| {
            let transparent = f64::from(next.opacity(i)) < config.min_opacity;
            let too_big = prune_large
                && (f64::from(radius[i]) > config.max_screen_size_px
                    || next.scales(i).into_iter().fold(0f32, f32::max) > world_limit);
            !(transparent || too_big)
        })
        .collect();
    let survivors: Vec<usize> = (0..next.len()).filter(|&i| keep[i]).collect();
    let pruned = next.len() - survivors.len();
    *gaussians = next.select(&survivors);
    *features = if next_features.is_empty() {
        next_features
    } else {
        survivors
            .iter()
            .flat_map(|&i| next_features[i * feature_dim..(i + 1) * feature_dim].iter().copied())
            .collect()
    };
    adam.retain(&keep);
    let report = DensifyReport { cloned: clone_rows.len(), split: split_rows.len(), pruned };
    (report, DensifyStats::new(gaussians.len()))
}

/// 3DGS's opacity reset: every opacity becomes `min(opacity, target)`, and its Adam moments are zeroed.
pub fn reset_opacity(gaussians: &mut Gaussians, adam: &mut GaussianAdam, target: f64) {
    let target = target.clamp(1e-6, 1.0 - 1e-6) as f32;
    let raw_target = (target / (1.0 - target)).ln();
    for raw in &mut gaussians.raw_opacities {
        *raw = raw.min(raw_target);
    }
    adam.reset_opacity_state();
}

/// Rotation matrix of a quaternion `w, x, y, z` (normalised here), row-major.
fn rotation_matrix(q: [f32; 4]) -> [[f32; 3]; 3] {
    let norm = q.iter().map(|v| v * v).sum::<f32>().sqrt().max(1e-12);
    let [w, x, y, z] = q.map(|v| v / norm);
    [
        [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
        [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
        [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)],
    ]
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;

    use super::*;

    fn step(config: &DensifyConfig, prune_large: bool) -> DensifyStep<'_> {
        DensifyStep { config, extent: 10.0, prune_large }
    }

    fn gaussians(n: usize) -> Gaussians {
        Gaussians {
            means: (0..n).map(|i| [i as f32, 0.0, 0.0]).collect(),
            sh_dc: vec![[0.1, 0.2, 0.3]; n],
            raw_opacities: vec![2.0; n],
            log_scales: vec![[-4.0; 3]; n],
            rotations: vec![[1.0, 0.0, 0.0, 0.0]; n],
            ..Gaussians::default()
        }
    }

    #[test]
    fn clones_small_splits_large_prunes_transparent_and_keeps_rows_aligned() {
        // 0: high gradient, small → cloned; 1: high gradient, large → split; 2: low gradient, kept;
        // 3: transparent → pruned.
        let mut g = gaussians(4);
        g.log_scales[1] = [0.0, -1.0, -2.0]; // scale 1 > 0.01 · extent
        g.raw_opacities[3] = -8.0;
        let mut stats = DensifyStats::new(4);
        stats.grad_sum = vec![1e-3, 1e-3, 1e-5, 0.0];
        stats.seen = vec![1, 1, 1, 0];
        let mut features: Vec<f32> = (0..8).map(|v| v as f32).collect(); // [4, 2]
        let mut adam = GaussianAdam::new(&g, 2);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let config = DensifyConfig::default();
        let (report, fresh) =
            densify_and_prune(&mut g, &mut features, 2, &mut adam, &stats, &step(&config, false), &mut rng);
        assert_eq!(report, DensifyReport { cloned: 1, split: 1, pruned: 1 });
        // kept originals 0, 2 (3 pruned), clone of 0, two children of 1
        assert_eq!(g.len(), 5);
        assert_eq!(adam.rows(), 5);
        assert_eq!(fresh, DensifyStats::new(5));
        assert_eq!(features, vec![0.0, 1.0, 4.0, 5.0, 0.0, 1.0, 2.0, 3.0, 2.0, 3.0]);
        assert_eq!(g.means[2], g.means[0]);
        for child in [3, 4] {
            assert!((g.log_scales[child][0] - (1.0f32 / 1.6).ln()).abs() < 1e-6);
            // children are sampled around the parent (x = 1) within a few of its scales
            let d = g.means[child][0] - 1.0;
            assert!(d.abs() < 4.0 && g.means[child] != [1.0, 0.0, 0.0]);
        }
    }

    #[test]
    fn large_gaussians_are_pruned_only_when_asked_and_opacity_resets() {
        let mut g = gaussians(3);
        g.log_scales[2] = [0.5; 3]; // 1.65 > 0.1 · extent (1.0)
        let stats = DensifyStats::new(3);
        let mut adam = GaussianAdam::new(&g, 0);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let config = DensifyConfig::default();
        let mut features = Vec::new();
        let (report, _) = densify_and_prune(
            &mut g.clone(),
            &mut features,
            0,
            &mut adam.clone(),
            &stats,
            &step(&config, true),
            &mut rng,
        );
        assert_eq!(report.pruned, 1);
        let (report, _) =
            densify_and_prune(&mut g, &mut features, 0, &mut adam, &stats, &step(&config, false), &mut rng);
        assert_eq!(report.pruned, 0);
        reset_opacity(&mut g, &mut adam, 0.01);
        for i in 0..g.len() {
            assert!((g.opacity(i) - 0.01).abs() < 1e-6);
        }
        // a rotation matrix is orthonormal
        let r = rotation_matrix([0.3, -0.5, 0.2, 0.7]);
        for a in 0..3 {
            for b in 0..3 {
                let dot: f32 = (0..3).map(|k| r[a][k] * r[b][k]).sum();
                assert!((dot - if a == b { 1.0 } else { 0.0 }).abs() < 1e-5);
            }
        }
    }
}
