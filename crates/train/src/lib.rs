//! `train` stage: 3DGS optimisation on splatseg's CPU rasteriser and the paper's joint optimisation
//! of per-Gaussian object features (§4.4 and the supplement's "Optimization Details").
//!
//! - [`config`]: [`TrainConfig`], the `[train]` TOML section, defaults = the paper's (3DGS's where unstated).
//! - [`optimizer`]: Adam over the Gaussians' parameter groups, with densification's row operations.
//! - [`densify`]: adaptive density control (clone / split / prune, opacity reset).
//! - [`init`]: starting Gaussians from a point cloud or a random cube (3DGS's initialisations).
//! - [`knn`]: exact k nearest neighbours with a k-d tree (the regulariser's `N₅`, the initial scales).
//! - [`joint`]: object codes, `L_semantic`, `L_3D-reg`, reading ids back from the feature field.
//! - [`identity`]: the 2D term: identity maps → linear classifier → cross-entropy against label maps.
//! - [`readback`]: ids from the rendered, classified identity maps (blending-weight votes).
//! - [`loss`]: `L_render = (1 − λ)·L1 + λ·(1 − SSIM)` and its image gradient.
//! - [`trainer`]: the loop ([`train`]), held-out PSNR/SSIM ([`evaluate_views`]).

pub mod config;
pub mod densify;
pub mod error;
pub mod identity;
pub mod init;
pub mod joint;
pub mod knn;
pub mod loss;
pub mod optimizer;
pub mod readback;
mod sampling;
pub mod trainer;

pub use config::{DensifyConfig, JointConfig, LearningRates, ReadBack, TrainConfig};
pub use error::{TrainError, TrainResult};
pub use init::{gaussians_from_points, random_gaussians_in_cube};
pub use trainer::{
    evaluate_views, train, train_with_checkpoints, TrainView, Trained, TrainingProgress, ViewQuality,
};
