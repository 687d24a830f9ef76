//! The one error type of the `merge` crate.

/// What can go wrong merging a view.
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    /// The per-view inputs disagree in size or count.
    #[error("merge inputs: {0}")]
    Inputs(String),
    /// A merge configuration could not be read.
    #[error("invalid merge config: {0}")]
    Config(String),
    /// Building a cue failed.
    #[error(transparent)]
    Cues(#[from] splatseg_cues::CuesError),
}

/// Result alias for this crate.
pub type MergeResultOf<T> = Result<T, MergeError>;
