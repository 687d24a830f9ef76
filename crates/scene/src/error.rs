//! The one error type of the `scene` crate. Every variant names the file it is about.

use std::path::PathBuf;

/// Result alias for this crate.
pub type SceneResult<T> = Result<T, SceneError>;

/// What can go wrong reading or writing scene data. Messages put the problem first and the
/// file path last, so they read well after `anyhow` context in the CLI.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// An operating-system level failure (missing file, permission, disk full).
    #[error("{action}: {source}: {}", path.display())]
    Io {
        /// What we were doing, e.g. "cannot open".
        action: &'static str,
        /// The file or folder.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The file exists but its content is not what the format says (truncated, malformed,
    /// inconsistent, non-finite values, ...).
    #[error("invalid {format} file: {reason}: {}", path.display())]
    Invalid {
        /// Human name of the format, e.g. "COLMAP cameras.bin".
        format: &'static str,
        /// What is wrong, specific enough to act on.
        reason: String,
        /// The offending file.
        path: PathBuf,
    },
    /// A file or folder the scene needs is absent.
    #[error("missing {what}: expected {}", path.display())]
    Missing {
        /// What was looked for, e.g. "COLMAP model (cameras.bin or cameras.txt)".
        what: String,
        /// Where it was expected.
        path: PathBuf,
    },
    /// Something the format allows but splatseg does not handle (e.g. a COLMAP FISHEYE camera).
    #[error("unsupported {what}: {}", path.display())]
    Unsupported {
        /// What is unsupported and what is supported instead.
        what: String,
        /// The offending file.
        path: PathBuf,
    },
    /// An output path would overwrite an input (see [`crate::paths::refuse_overwrite`]).
    #[error("{0}")]
    Overwrite(Box<crate::paths::Clash>),
    /// An image could not be decoded or encoded.
    #[error("image error: {source}: {}", path.display())]
    Image {
        /// The image file.
        path: PathBuf,
        /// What the decoder or encoder refused.
        #[source]
        source: crate::image_io::CodecError,
    },
}

impl SceneError {
    /// Shorthand for [`SceneError::Io`].
    pub fn io(action: &'static str, path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        SceneError::Io { action, path: path.into(), source }
    }

    /// Shorthand for [`SceneError::Invalid`].
    pub fn invalid(format: &'static str, path: impl Into<PathBuf>, reason: impl Into<String>) -> Self {
        SceneError::Invalid { format, reason: reason.into(), path: path.into() }
    }

    /// Shorthand for [`SceneError::Missing`].
    pub fn missing(what: impl Into<String>, path: impl Into<PathBuf>) -> Self {
        SceneError::Missing { what: what.into(), path: path.into() }
    }
}
