//! [`TrainConfig`]: the `[train]` section of the TOML config. Defaults are the paper's values
//! (supplement, "Optimization Details"), and 3DGS's where the paper follows 3DGS without restating them.
//!
//! Fields marked "code only" are not read from files (`#[serde(skip)]`): their defaults are
//! 3DGS's, which nobody running this method has reason to change from a config file; code
//! (tests, studies) may still set them.

use serde::{Deserialize, Serialize};

use crate::error::{TrainError, TrainResult};

/// Learning rates (Adam for every group), 3DGS's; code only (not a file key).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LearningRates {
    /// Position, start of the exponential decay, times the scene extent (3DGS's `spatial_lr_scale`).
    pub position_init: f64,
    /// Position, end of the decay (times the extent).
    pub position_final: f64,
    /// Iterations over which the position rate decays (afterwards it stays at `position_final`).
    pub position_decay_iterations: usize,
    /// Degree-0 SH colour (3DGS's `feature_lr`).
    pub sh_dc: f64,
    /// Higher SH coefficients: `sh_dc / 20` in 3DGS.
    pub sh_rest: f64,
    /// Opacity (before the sigmoid).
    pub opacity: f64,
    /// Log scales.
    pub scaling: f64,
    /// Quaternions.
    pub rotation: f64,
    /// The 16-d object features (paper: 2.5e-3, frozen in stage 1).
    pub object_features: f64,
    /// The identity maps' linear classifier (not in the paper; Gaussian Grouping's 5e-4).
    pub classifier: f64,
}

impl Default for LearningRates {
    fn default() -> Self {
        Self {
            position_init: 1.6e-4,
            position_final: 1.6e-6,
            position_decay_iterations: 50_000,
            sh_dc: 2.5e-3,
            sh_rest: 2.5e-3 / 20.0,
            opacity: 5.0e-2,
            scaling: 5.0e-3,
            rotation: 1.0e-3,
            object_features: 2.5e-3,
            classifier: 5.0e-4,
        }
    }
}

/// Adaptive density control (3DGS §5.2), run every `interval` iterations in `[from, until)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DensifyConfig {
    /// First iteration of densification (paper: 500).
    pub from: usize,
    /// Densification stops here (paper: 15k); the joint stage starts here.
    pub until: usize,
    /// Every this many iterations (paper: 100); code only.
    #[serde(skip)]
    pub interval: usize,
    /// Mean view-space positional gradient (3DGS's NDC units) above which a Gaussian is densified (3DGS: 2e-4).
    pub grad_threshold: f64,
    /// A Gaussian whose largest scale is at most this fraction of the scene extent is cloned, larger
    /// ones are split (3DGS: 0.01); code only.
    #[serde(skip)]
    pub percent_dense: f64,
    /// Gaussians with opacity below this are pruned (3DGS: 0.005); code only.
    #[serde(skip)]
    pub min_opacity: f64,
    /// Every this many iterations all opacities are reset to `reset_opacity` (3DGS: 3000); code only.
    #[serde(skip)]
    pub opacity_reset_interval: usize,
    /// Opacity after a reset (3DGS: 0.01); code only.
    #[serde(skip)]
    pub reset_opacity: f64,
    /// After the first opacity reset, prune Gaussians wider than this many pixels on screen (3DGS: 20)
    /// or than 0.1 × the extent in the world; code only.
    #[serde(skip)]
    pub max_screen_size_px: f64,
}

impl Default for DensifyConfig {
    fn default() -> Self {
        Self {
            from: 500,
            until: 15_000,
            interval: 100,
            grad_threshold: 2e-4,
            percent_dense: 0.01,
            min_opacity: 0.005,
            opacity_reset_interval: 3000,
            reset_opacity: 0.01,
            max_screen_size_px: 20.0,
        }
    }
}

/// How the Gaussians' ids are read back after the joint stage.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ReadBack {
    /// The id of the nearest object code (cosine > `assign_min_cosine`, else −1).
    NearestCode,
    /// The identity classifier applied to the Gaussian's own feature (background → −1); needs
    /// `identity_maps`, else falls back to `nearest-code`.
    Classifier,
    /// Per training view the identity map is rendered and classified; each Gaussian takes the class
    /// with the largest summed blending weight `α·T` over the pixels of that class in all views
    /// (Gaussians no pixel saw: the classifier on their own feature). Needs `identity_maps`, else
    /// falls back to `nearest-code`.
    Rendered,
}

/// The paper's joint optimisation (§4.4): `L = L_render + λ_s·L_semantic + λ_reg·L_3D-reg`, plus, with
/// `identity_maps`, the supplement's 3D-to-2D supervision `λ_identity·CE(classifier(identity map), label map)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct JointConfig {
    /// Turn the joint stage on (needs lifted object ids).
    pub enabled: bool,
    /// Object-feature width (paper: 16).
    pub feature_dim: usize,
    /// Standard deviation of the initial features: the paper's `N(0, 0.01)` read as variance
    /// 0.01; code only.
    #[serde(skip)]
    pub init_std: f64,
    /// λ_s (paper: 0.1).
    pub lambda_semantic: f64,
    /// λ_reg (paper: 0.01).
    pub lambda_reg: f64,
    /// Neighbours of the 3D regulariser (paper: 5).
    pub knn: usize,
    /// Neighbour lists are rebuilt every this many iterations (positions keep moving slowly);
    /// code only.
    #[serde(skip)]
    pub knn_refresh_interval: usize,
    /// A Gaussian takes the id of the nearest object code when their cosine exceeds this;
    /// otherwise −1. Code only.
    #[serde(skip)]
    pub assign_min_cosine: f64,
    /// Render the D-channel identity maps and supervise them in 2D against each training view's label
    /// map (the supplement's "16-channel identity feature maps for 3D-to-2D supervision"); needs the
    /// label maps of `splatseg run` (`masks/`).
    pub identity_maps: bool,
    /// Weight of the identity maps' cross-entropy (the paper's λ_s, 0.1).
    pub lambda_identity: f64,
    /// How ids are read back at the end.
    pub readback: ReadBack,
}

impl Default for JointConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            feature_dim: 16,
            init_std: 0.1,
            lambda_semantic: 0.1,
            lambda_reg: 0.01,
            knn: 5,
            knn_refresh_interval: 1000,
            assign_min_cosine: 0.5,
            identity_maps: true,
            lambda_identity: 0.1,
            readback: ReadBack::Rendered,
        }
    }
}

/// Everything `splatseg train` reads from `[train]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrainConfig {
    /// Total iterations, one view each (paper: 100k).
    pub iterations: usize,
    /// Weight of the D-SSIM term in `L_render = (1 − λ)·L1 + λ·(1 − SSIM)` (3DGS: 0.2).
    pub lambda_dssim: f64,
    /// The SH degree grows by one every this many iterations up to the model's degree (3DGS:
    /// 1000); code only.
    #[serde(skip)]
    pub sh_degree_interval: usize,
    /// Seed of the view order and of the object-feature initialisation.
    pub seed: u64,
    /// Every `test_every`-th view (0, 8, 16, …) is held out for PSNR/SSIM (3DGS's `llffhold`: 8); 0 = none.
    pub test_every: usize,
    /// RGB background the images were composited on.
    pub background: [f32; 3],
    /// Iterations after which the Gaussians are also saved (3DGS's `--save_iterations`: 7000, 30000);
    /// the final ones are always saved.
    pub save_iterations: Vec<usize>,
    /// Learning rates (3DGS's); code only.
    #[serde(skip)]
    pub lr: LearningRates,
    /// Densification.
    pub densify: DensifyConfig,
    /// Joint optimisation.
    pub joint: JointConfig,
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            iterations: 100_000,
            lambda_dssim: 0.2,
            sh_degree_interval: 1000,
            seed: 0,
            test_every: 8,
            background: [0.0; 3],
            save_iterations: vec![7000, 30_000],
            lr: LearningRates::default(),
            densify: DensifyConfig::default(),
            joint: JointConfig::default(),
        }
    }
}

impl TrainConfig {
    /// Rejects values no training can use, naming the field.
    pub fn validate(&self) -> TrainResult<()> {
        let bad = |what: &str| Err(TrainError::Config(what.to_string()));
        if !(0.0..=1.0).contains(&self.lambda_dssim) {
            return bad("lambda_dssim must be in [0, 1]");
        }
        if self.densify.interval == 0 || self.densify.opacity_reset_interval == 0 {
            return bad("densify.interval and densify.opacity_reset_interval must be ≥ 1");
        }
        if self.sh_degree_interval == 0 {
            return bad("sh_degree_interval must be ≥ 1");
        }
        if self.joint.enabled && (self.joint.feature_dim == 0 || self.joint.knn == 0) {
            return bad("joint.feature_dim and joint.knn must be ≥ 1");
        }
        if self.joint.knn_refresh_interval == 0 {
            return bad("joint.knn_refresh_interval must be ≥ 1");
        }
        let rates = [
            self.lr.position_init,
            self.lr.position_final,
            self.lr.sh_dc,
            self.lr.sh_rest,
            self.lr.opacity,
            self.lr.scaling,
            self.lr.rotation,
            self.lr.object_features,
            self.lr.classifier,
            self.joint.lambda_identity,
        ];
        if rates.iter().any(|r| !r.is_finite() || *r < 0.0) || self.lr.position_final <= 0.0 {
            return bad(
                "learning rates and joint.lambda_identity must be finite and ≥ 0 (position_final > 0)",
            );
        }
        Ok(())
    }

    /// The position learning rate at `iteration` (before the extent factor): log-linear from
    /// `position_init` to `position_final` over `position_decay_iterations`, as 3DGS's `expon_lr_func`
    /// without delay.
    pub fn position_lr(&self, iteration: usize) -> f64 {
        let span = self.lr.position_decay_iterations.max(1) as f64;
        let t = (iteration as f64 / span).clamp(0.0, 1.0);
        let (a, b) = (self.lr.position_init.max(1e-300).ln(), self.lr.position_final.ln());
        (a * (1.0 - t) + b * t).exp()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_papers_and_the_decay_hits_both_ends() {
        let c = TrainConfig::default();
        assert_eq!(c.iterations, 100_000);
        assert_eq!((c.densify.from, c.densify.until, c.densify.interval), (500, 15_000, 100));
        assert_eq!(
            (c.joint.lambda_semantic, c.joint.lambda_reg, c.joint.knn, c.joint.feature_dim),
            (0.1, 0.01, 5, 16)
        );
        assert!(c.joint.identity_maps && c.joint.lambda_identity == 0.1);
        assert_eq!(c.joint.readback, ReadBack::Rendered);
        assert!((c.position_lr(0) - 1.6e-4).abs() < 1e-12);
        assert!((c.position_lr(50_000) - 1.6e-6).abs() < 1e-14);
        assert!((c.position_lr(90_000) - 1.6e-6).abs() < 1e-14);
        // halfway is the geometric mean
        assert!((c.position_lr(25_000) - 1.6e-5).abs() < 1e-12);
        c.validate().unwrap();
        let bad = TrainConfig { lambda_dssim: 1.5, ..TrainConfig::default() };
        assert!(bad.validate().unwrap_err().to_string().contains("lambda_dssim"));
    }

    #[test]
    fn code_only_fields_keep_their_defaults_when_a_file_is_read() {
        let c: TrainConfig = toml::from_str("iterations = 10\n[densify]\nuntil = 5\n").unwrap();
        assert_eq!(c.lr, LearningRates::default());
        assert_eq!(c.sh_degree_interval, 1000);
        assert_eq!(c.densify, DensifyConfig { until: 5, ..DensifyConfig::default() });
        assert_eq!(c.joint, JointConfig::default());
        assert_eq!(toml::from_str::<TrainConfig>("").unwrap(), TrainConfig::default());
        assert!(toml::from_str::<TrainConfig>("sh_degree_interval = 5").is_err());
    }
}
