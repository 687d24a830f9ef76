//! The one error type of the `train` crate.

/// What can go wrong while training.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// The rasteriser refused the Gaussians or a camera.
    #[error(transparent)]
    Render(#[from] splatseg_render::RenderError),
    /// An image-quality computation failed (sizes).
    #[error(transparent)]
    Eval(#[from] splatseg_eval::EvalError),
    /// Inputs that do not fit together (named in the message).
    #[error("{0}")]
    Input(String),
    /// A configuration value out of range (named in the message).
    #[error("invalid training configuration: {0}")]
    Config(String),
}

/// Result alias.
pub type TrainResult<T> = Result<T, TrainError>;
