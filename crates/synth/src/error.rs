//! The one error type of the `synth` crate.

use std::path::PathBuf;

/// What can go wrong generating or writing a synthetic scene.
#[derive(Debug, thiserror::Error)]
pub enum SynthError {
    /// The configuration cannot produce a scene (e.g. zero views or a zero-sized image).
    #[error("invalid synthetic scene config: {0}")]
    Config(String),
    /// Writing one of the output files failed.
    #[error(transparent)]
    Scene(#[from] splatseg_scene::SceneError),
    /// Encoding an output file failed.
    #[error("cannot encode {what}: {reason}: {}", path.display())]
    Encode {
        /// What was being encoded, e.g. "PNG image".
        what: &'static str,
        /// The encoder's message.
        reason: String,
        /// The file being written.
        path: PathBuf,
    },
    /// The `--config` file of `splatseg synth` cannot be read.
    #[error("cannot read synth config {}", path.display())]
    ReadConfig {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The `--config` file of `splatseg synth` is not a valid `SynthConfig` TOML.
    #[error("invalid synth config {}", path.display())]
    ParseConfig {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: toml::de::Error,
    },
}
