//! The one error type of the `cues` crate.

use std::path::PathBuf;

/// What can go wrong building per-view cues.
#[derive(Debug, thiserror::Error)]
pub enum CuesError {
    /// An input map or list does not have the size or shape it must have.
    #[error("{what}: {reason}")]
    Shape {
        /// Which input, e.g. "SAM mask 3" or "feature grid".
        what: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A cue file could not be read or holds bad data.
    #[error("invalid {what}: {reason}: {}", path.display())]
    File {
        /// What the file should hold, e.g. "depth map".
        what: &'static str,
        /// What is wrong.
        reason: String,
        /// The offending file.
        path: PathBuf,
    },
    /// No cue file exists for a view.
    #[error("missing {what} for view `{stem}`: expected {}", path.display())]
    Missing {
        /// What was looked for.
        what: &'static str,
        /// The view's image stem.
        stem: String,
        /// Where it was expected.
        path: PathBuf,
    },
}

impl CuesError {
    /// Shorthand for [`CuesError::Shape`].
    pub fn shape(what: impl Into<String>, reason: impl Into<String>) -> Self {
        CuesError::Shape { what: what.into(), reason: reason.into() }
    }
}

/// Result alias for this crate.
pub type CuesResult<T> = Result<T, CuesError>;
