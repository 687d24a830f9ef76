//! The one error type of the `eval` crate.

use std::path::PathBuf;

/// What can go wrong while scoring predictions. Messages name the problem first and the file or
/// view last.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// A prediction label map does not have the size of its ground-truth map.
    #[error(
        "prediction is {pred_width}×{pred_height} px but the ground truth is {gt_width}×{gt_height} px: view `{view}`{}",
        location(.path)
    )]
    SizeMismatch {
        /// View (file stem) concerned.
        view: String,
        /// Ground-truth width.
        gt_width: usize,
        /// Ground-truth height.
        gt_height: usize,
        /// Prediction width.
        pred_width: usize,
        /// Prediction height.
        pred_height: usize,
        /// The prediction file, when known.
        path: Option<PathBuf>,
    },
    /// An option names a prediction set that no `--pred` set has.
    #[error("{option} names set `{name}` but no --pred set has that name")]
    UnknownSet {
        /// The option (`--view-local`, `--pred-ply`).
        option: &'static str,
        /// The name given.
        name: String,
    },
    /// A prediction exists for a view the ground truth does not have.
    #[error("prediction for a view the ground truth does not have (no `{view}.png` in {}): {}", gt_dir.display(), path.display())]
    UnknownView {
        /// The view's stem.
        view: String,
        /// The ground-truth folder searched.
        gt_dir: PathBuf,
        /// The prediction file.
        path: PathBuf,
    },
    /// The ground truth holds no labelled instance, so mIoU is undefined.
    #[error("ground truth has no labelled instance (every pixel is 0){}", location(.path))]
    NoGroundTruth {
        /// Ground-truth folder, when known.
        path: Option<PathBuf>,
    },
    /// A folder holds no label map.
    #[error("no label map (*.png) found in folder: {}", path.display())]
    NoLabelMaps {
        /// The folder.
        path: PathBuf,
    },
    /// Two per-Gaussian id arrays of different lengths.
    #[error(
        "{pred_len} predicted Gaussian ids but {gt_len} ground-truth ids: the PLY and the ground truth describe different Gaussians{}",
        location(.path)
    )]
    GaussianCountMismatch {
        /// Number of ground-truth ids.
        gt_len: usize,
        /// Number of predicted ids.
        pred_len: usize,
        /// The prediction PLY, when known.
        path: Option<PathBuf>,
    },
    /// An assignment problem with a non-finite weight.
    #[error("assignment weight at row {row}, column {col} is not finite ({value})")]
    NonFiniteWeight {
        /// Row index.
        row: usize,
        /// Column index.
        col: usize,
        /// The offending value.
        value: f64,
    },
    /// A weight matrix whose length is not `rows × cols`.
    #[error("assignment matrix has {len} entries, expected {rows} × {cols}")]
    BadMatrixShape {
        /// Declared rows.
        rows: usize,
        /// Declared columns.
        cols: usize,
        /// Actual length.
        len: usize,
    },
    /// Reading a file failed (label map, `.npy`, PLY).
    #[error(transparent)]
    Scene(#[from] splatseg_scene::SceneError),
    /// Listing a folder failed.
    #[error("cannot list folder: {source}: {}", path.display())]
    Io {
        /// The folder.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A PLY without per-Gaussian object ids.
    #[error("the PLY has no `object_id` property to score (run `splatseg run` first): {}", path.display())]
    NoObjectIds {
        /// The PLY.
        path: PathBuf,
    },
    /// A per-Gaussian id file holds something other than integers.
    #[error("invalid ground-truth Gaussian ids: {reason}: {}", path.display())]
    BadGaussianIds {
        /// What is wrong.
        reason: String,
        /// The file.
        path: PathBuf,
    },
    /// An image given to a photometric metric (PSNR, SSIM) whose size is zero or does not match
    /// its buffer.
    #[error("invalid image for a photometric metric: {reason}")]
    BadImage {
        /// What is wrong.
        reason: String,
    },
}

fn location(path: &Option<PathBuf>) -> String {
    path.as_ref().map(|p| format!(": {}", p.display())).unwrap_or_default()
}
