//! `eval` stage: the paper's segmentation metrics (supplement, "Evaluation Metrics") and the
//! cross-view and 3D ones splatseg adds.
//!
//! - [`hungarian`]: optimal assignment on real-valued rectangular matrices.
//! - [`band`]: the disk boundary band `(M ⊕ ε) \ (M ⊖ ε)` of every instance of a label map.
//! - [`view`]: sparse per-view pixel counts ([`ViewCounts`]), computed view by view in parallel.
//! - [`metrics`]: [`Metrics`] from the counts: mIoU, boundary mIoU, #masks, per-view mIoU,
//!   cross-view consistency (definitions there).
//! - [`accuracy3d`]: per-Gaussian label accuracy.
//! - [`args`]: `splatseg eval`'s arguments (clap's `Args` with the `cli` feature).
//! - [`folders`]: scoring folders of `<stem>.png` label maps.
//! - [`markdown`]: tables for reports.
//! - [`photometric`]: PSNR and SSIM as 3DGS computes them, and the SSIM gradient for training.
//!
//! ```
//! use splatseg_eval::{EvalConfig, Metrics, ViewCounts};
//! use splatseg_scene::Plane;
//! let gt = Plane::from_vec(4, 1, vec![1, 1, 2, 2]).unwrap();
//! let pred = Plane::from_vec(4, 1, vec![9, 9, 9, 3]).unwrap();
//! let cfg = EvalConfig::default();
//! let view = ViewCounts::compute("v0", &gt, &pred, &cfg).unwrap();
//! let m = Metrics::from_views(&[view], &cfg).unwrap();
//! // 1 ↔ 9: 2/3, 2 ↔ 3: 1/2.
//! assert!((m.miou - (2.0 / 3.0 + 0.5) / 2.0).abs() < 1e-12);
//! ```

pub mod accuracy3d;
pub mod args;
pub mod band;
pub mod config;
pub mod error;
pub mod folders;
pub mod hungarian;
pub mod markdown;
pub mod metrics;
pub mod named;
pub mod photometric;
pub mod view;

pub use accuracy3d::{label_accuracy_3d, label_accuracy_3d_files, read_gaussian_ids_npy};
pub use args::EvalArgs;
pub use config::{EvalConfig, IdScope, UnlabelledGt};
pub use error::EvalError;
pub use folders::{evaluate_folders, evaluate_prediction_sets, list_label_maps, PredictionSet};
pub use markdown::{summary_table, EvalReport, NamedMetrics};
pub use metrics::{InstanceScore, LabelAccuracy3d, Metrics, ViewScore};
pub use named::{evaluate_named_sets, NamedSets};
pub use photometric::{psnr, psnr_masked, ssim, ssim_map, ssim_with_grad};
pub use view::ViewCounts;
