//! Adam (PyTorch's form, 3DGS's ε = 1e-15) over the Gaussians' parameter groups, with the row
//! operations densification needs: keep a subset, append rows with fresh (zero) moments, zero the
//! moments of a group (after an opacity reset).

use splatseg_render::GaussianGrads;
use splatseg_scene::Gaussians;

/// β₁, β₂, ε of every group (3DGS: PyTorch's defaults with ε = 1e-15).
const BETA1: f32 = 0.9;
const BETA2: f32 = 0.999;
const EPSILON: f32 = 1e-15;

/// The first and second moments of one parameter group laid out as `[N, width]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AdamGroup {
    /// Values per row.
    pub width: usize,
    /// `[N, width]` first moments.
    m: Vec<f32>,
    /// `[N, width]` second moments.
    v: Vec<f32>,
}

impl AdamGroup {
    /// Zero moments for `rows` rows.
    pub fn new(rows: usize, width: usize) -> Self {
        Self { width, m: vec![0.0; rows * width], v: vec![0.0; rows * width] }
    }

    /// Rows held.
    pub fn rows(&self) -> usize {
        self.m.len() / self.width.max(1)
    }

    /// One Adam step at step number `t` (1-based): `params`, `grads`: `[N, width]`.
    pub fn step(&mut self, params: &mut [f32], grads: &[f32], lr: f32, t: u32) {
        debug_assert_eq!(params.len(), self.m.len());
        debug_assert_eq!(grads.len(), self.m.len());
        let bias1 = 1.0 - BETA1.powi(t as i32);
        let bias2_sqrt = (1.0 - BETA2.powi(t as i32)).sqrt();
        let step_size = lr / bias1;
        for (((p, &g), m), v) in params.iter_mut().zip(grads).zip(&mut self.m).zip(&mut self.v) {
            *m = BETA1 * *m + (1.0 - BETA1) * g;
            *v = BETA2 * *v + (1.0 - BETA2) * g * g;
            *p -= step_size * *m / (v.sqrt() / bias2_sqrt + EPSILON);
        }
    }

    /// Keeps the rows whose `keep` entry is true, in order.
    pub fn retain(&mut self, keep: &[bool]) {
        let w = self.width;
        if w == 0 {
            return;
        }
        let filter = |values: &[f32]| -> Vec<f32> {
            values.chunks(w).zip(keep).filter(|(_, &k)| k).flat_map(|(row, _)| row.iter().copied()).collect()
        };
        self.m = filter(&self.m);
        self.v = filter(&self.v);
    }

    /// Appends `rows` rows with zero moments (PyTorch's state for a freshly concatenated tensor).
    pub fn append(&mut self, rows: usize) {
        let len = self.m.len() + rows * self.width;
        self.m.resize(len, 0.0);
        self.v.resize(len, 0.0);
    }

    /// Forgets everything (3DGS replaces the opacity tensor and its state on an opacity reset).
    pub fn zero(&mut self) {
        self.m.iter_mut().for_each(|x| *x = 0.0);
        self.v.iter_mut().for_each(|x| *x = 0.0);
    }
}

/// Learning rates of one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepRates {
    /// Positions (already times the scene extent).
    pub means: f32,
    /// SH degree 0.
    pub sh_dc: f32,
    /// Higher SH.
    pub sh_rest: f32,
    /// Opacity.
    pub opacity: f32,
    /// Log scales.
    pub scaling: f32,
    /// Quaternions.
    pub rotation: f32,
    /// Object features (0 = frozen).
    pub features: f32,
}

/// Adam over every group of a [`Gaussians`] plus optional `[N, D]` object features.
#[derive(Clone, Debug, PartialEq)]
pub struct GaussianAdam {
    /// Steps taken.
    pub t: u32,
    means: AdamGroup,
    log_scales: AdamGroup,
    rotations: AdamGroup,
    raw_opacities: AdamGroup,
    sh_dc: AdamGroup,
    sh_rest: AdamGroup,
    features: AdamGroup,
}

impl GaussianAdam {
    /// Zero state for `gaussians` and `feature_dim`-wide object features (0 = none).
    pub fn new(gaussians: &Gaussians, feature_dim: usize) -> Self {
        let n = gaussians.len();
        Self {
            t: 0,
            means: AdamGroup::new(n, 3),
            log_scales: AdamGroup::new(n, 3),
            rotations: AdamGroup::new(n, 4),
            raw_opacities: AdamGroup::new(n, 1),
            sh_dc: AdamGroup::new(n, 3),
            sh_rest: AdamGroup::new(n, 3 * gaussians.rest_per_channel()),
            features: AdamGroup::new(n, feature_dim),
        }
    }

    fn groups(&mut self) -> [&mut AdamGroup; 7] {
        [
            &mut self.means,
            &mut self.log_scales,
            &mut self.rotations,
            &mut self.raw_opacities,
            &mut self.sh_dc,
            &mut self.sh_rest,
            &mut self.features,
        ]
    }

    /// One step on every group. `features`: `[N, D]` with `feature_grads` of the same shape (or both
    /// `None` / empty when there are no object features).
    pub fn step(
        &mut self,
        gaussians: &mut Gaussians,
        grads: &GaussianGrads,
        features: Option<(&mut [f32], &[f32])>,
        rates: &StepRates,
    ) {
        self.t += 1;
        let t = self.t;
        self.means.step(gaussians.means.as_flattened_mut(), grads.means.as_flattened(), rates.means, t);
        self.log_scales.step(
            gaussians.log_scales.as_flattened_mut(),
            grads.log_scales.as_flattened(),
            rates.scaling,
            t,
        );
        self.rotations.step(
            gaussians.rotations.as_flattened_mut(),
            grads.rotations.as_flattened(),
            rates.rotation,
            t,
        );
        self.raw_opacities.step(&mut gaussians.raw_opacities, &grads.raw_opacities, rates.opacity, t);
        self.sh_dc.step(gaussians.sh_dc.as_flattened_mut(), grads.sh_dc.as_flattened(), rates.sh_dc, t);
        if !gaussians.sh_rest.is_empty() && grads.sh_rest.len() == gaussians.sh_rest.len() {
            self.sh_rest.step(&mut gaussians.sh_rest, &grads.sh_rest, rates.sh_rest, t);
        }
        if let Some((values, feature_grads)) = features {
            if rates.features > 0.0 && !values.is_empty() {
                self.features.step(values, feature_grads, rates.features, t);
            }
        }
    }

    /// Keeps the rows of every group whose `keep` entry is true.
    pub fn retain(&mut self, keep: &[bool]) {
        for group in self.groups() {
            group.retain(keep);
        }
    }

    /// Appends `rows` fresh rows to every group.
    pub fn append(&mut self, rows: usize) {
        for group in self.groups() {
            group.append(rows);
        }
    }

    /// Zeroes the opacity moments (after an opacity reset).
    pub fn reset_opacity_state(&mut self) {
        self.raw_opacities.zero();
    }

    /// Rows per group (all equal).
    pub fn rows(&self) -> usize {
        self.means.rows()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_step_moves_by_the_learning_rate_and_state_follows_rows() {
        // PyTorch Adam: the first step is lr · g / (|g| + ε) = ±lr for any g ≠ 0.
        let mut group = AdamGroup::new(3, 2);
        let mut params = vec![1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
        group.step(&mut params, &[0.5, -3.0, 0.0, 1e-3, 2.0, -2.0], 0.1, 1);
        let expected = [0.9, 1.1, 1.0, 0.9, 0.9, 1.1];
        for (p, e) in params.iter().zip(expected) {
            assert!((p - e).abs() < 1e-6, "{params:?}");
        }
        group.retain(&[true, false, true]);
        assert_eq!(group.rows(), 2);
        for (m, e) in group.m.iter().zip([0.05, -0.3, 0.2, -0.2]) {
            assert!((m - e).abs() < 1e-6, "{:?}", group.m);
        }
        group.append(2);
        assert_eq!(group.rows(), 4);
        assert!(group.m[4..].iter().all(|&x| x == 0.0));
        group.zero();
        assert!(group.v.iter().all(|&x| x == 0.0));
    }

    #[test]
    fn repeated_steps_descend_a_quadratic() {
        // f(p) = (p − 3)²: Adam with lr 0.05 gets close within 400 steps.
        let mut group = AdamGroup::new(1, 1);
        let mut p = vec![0.0f32];
        for t in 1..=400 {
            let g = 2.0 * (p[0] - 3.0);
            group.step(&mut p, &[g], 0.05, t);
        }
        assert!((p[0] - 3.0).abs() < 0.05, "p = {}", p[0]);
    }
}
