//! [`PipelineError`], the one error type of the crate: every stage crate's error, I/O, and
//! messages that name the file and what is wrong, with context added on the way up
//! ([`Context`]). [`PipelineError::report`] prints the whole chain, as `anyhow`'s `{:#}` does.

use std::fmt::Display;

/// Everything the pipeline can fail with.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// Bad input or a refused request, with the file named in the message.
    #[error("{0}")]
    Invalid(String),
    /// `context` around an inner error (the chain is walked by [`PipelineError::report`]).
    #[error("{context}")]
    Context {
        /// What was being done.
        context: String,
        /// Why it failed.
        #[source]
        source: Box<PipelineError>,
    },
    /// A file-system error.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// Reading or writing scenes, PLYs, masks, label maps, `.npy`.
    #[error(transparent)]
    Scene(#[from] splatseg_scene::SceneError),
    /// Region partition, edges, depth, descriptors.
    #[error(transparent)]
    Cues(#[from] splatseg_cues::CuesError),
    /// Mask merging.
    #[error(transparent)]
    Merge(#[from] splatseg_merge::MergeError),
    /// Cross-view matching.
    #[error(transparent)]
    Match(#[from] splatseg_match::MatchError),
    /// Lifting onto the Gaussians.
    #[error(transparent)]
    Lift(#[from] splatseg_lift::LiftError),
    /// Metrics.
    #[error(transparent)]
    Eval(#[from] splatseg_eval::EvalError),
    /// Edits (`edits.json`) and labelled-PLY tables.
    #[error(transparent)]
    Edit(#[from] splatseg_edit::EditError),
    /// Training.
    #[error(transparent)]
    Train(#[from] splatseg_train::TrainError),
    /// Rendering.
    #[error(transparent)]
    Render(#[from] splatseg_render::RenderError),
    /// Generating a synthetic scene (`demo`).
    #[error(transparent)]
    Synth(#[from] splatseg_synth::SynthError),
    /// The `--config` TOML file.
    #[error(transparent)]
    Toml(#[from] toml::de::Error),
    /// JSON (cache entries, summaries).
    #[error(transparent)]
    Json(#[from] serde_json::Error),
}

/// The crate's result type.
pub type Result<T, E = PipelineError> = std::result::Result<T, E>;

impl PipelineError {
    /// The error and its causes joined by `": "` (what `anyhow` prints for `{:#}`).
    pub fn report(&self) -> String {
        let mut text = self.to_string();
        let mut source = std::error::Error::source(self);
        while let Some(s) = source {
            text.push_str(": ");
            text.push_str(&s.to_string());
            source = s.source();
        }
        text
    }
}

/// Adds what was being done to an error (as `anyhow::Context`, for the crate's own type).
pub trait Context<T> {
    /// Wraps the error with `context()`'s message.
    fn with_context<C: Display, F: FnOnce() -> C>(self, context: F) -> Result<T>;
    /// Wraps the error with `context`.
    fn context<C: Display>(self, context: C) -> Result<T>;
}

impl<T, E: Into<PipelineError>> Context<T> for std::result::Result<T, E> {
    fn with_context<C: Display, F: FnOnce() -> C>(self, context: F) -> Result<T> {
        self.map_err(|e| PipelineError::Context {
            context: context().to_string(),
            source: Box::new(e.into()),
        })
    }

    fn context<C: Display>(self, context: C) -> Result<T> {
        self.with_context(|| context)
    }
}

impl<T> Context<T> for Option<T> {
    fn with_context<C: Display, F: FnOnce() -> C>(self, context: F) -> Result<T> {
        self.ok_or_else(|| PipelineError::Invalid(context().to_string()))
    }

    fn context<C: Display>(self, context: C) -> Result<T> {
        self.with_context(|| context)
    }
}

/// Returns early with [`PipelineError::Invalid`] and a formatted message.
macro_rules! bail {
    ($($arg:tt)*) => {
        return Err($crate::PipelineError::Invalid(format!($($arg)*)))
    };
}
pub(crate) use bail;
