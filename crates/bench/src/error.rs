//! [`BenchError`], the one error type of the crate, with context added on the way up
//! ([`Context`]); [`BenchError::report`] prints the whole chain.

use std::fmt::Display;

/// Everything a measurement can fail with.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// A refused request or a failed step, said in words.
    #[error("{0}")]
    Invalid(String),
    /// `context` around an inner error.
    #[error("{context}")]
    Context {
        /// What was being done.
        context: String,
        /// Why it failed.
        #[source]
        source: Box<BenchError>,
    },
    /// A file-system error.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// The pipeline.
    #[error(transparent)]
    Pipeline(#[from] splatseg_pipeline::PipelineError),
    /// Generating a synthetic scene.
    #[error(transparent)]
    Synth(#[from] splatseg_synth::SynthError),
    /// Reading or writing files of a scene.
    #[error(transparent)]
    Scene(#[from] splatseg_scene::SceneError),
    /// Metrics.
    #[error(transparent)]
    Eval(#[from] splatseg_eval::EvalError),
    /// Mask merging.
    #[error(transparent)]
    Merge(#[from] splatseg_merge::MergeError),
    /// Cues.
    #[error(transparent)]
    Cues(#[from] splatseg_cues::CuesError),
    /// Rendering.
    #[error(transparent)]
    Render(#[from] splatseg_render::RenderError),
    /// JSON.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// Formatting a table.
    #[error(transparent)]
    Fmt(#[from] std::fmt::Error),
}

/// The crate's result type.
pub type Result<T, E = BenchError> = std::result::Result<T, E>;

impl BenchError {
    /// The error and its causes joined by `": "`.
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

/// Adds what was being done to an error.
pub trait Context<T> {
    /// Wraps the error with `context()`'s message.
    fn with_context<C: Display, F: FnOnce() -> C>(self, context: F) -> Result<T>;
    /// Wraps the error with `context`.
    fn context<C: Display>(self, context: C) -> Result<T>;
}

impl<T, E: Into<BenchError>> Context<T> for std::result::Result<T, E> {
    fn with_context<C: Display, F: FnOnce() -> C>(self, context: F) -> Result<T> {
        self.map_err(|e| BenchError::Context { context: context().to_string(), source: Box::new(e.into()) })
    }

    fn context<C: Display>(self, context: C) -> Result<T> {
        self.with_context(|| context)
    }
}

impl<T> Context<T> for Option<T> {
    fn with_context<C: Display, F: FnOnce() -> C>(self, context: F) -> Result<T> {
        self.ok_or_else(|| BenchError::Invalid(context().to_string()))
    }

    fn context<C: Display>(self, context: C) -> Result<T> {
        self.with_context(|| context)
    }
}

/// Returns early with [`BenchError::Invalid`] and a formatted message.
macro_rules! bail {
    ($($arg:tt)*) => {
        return Err($crate::BenchError::Invalid(format!($($arg)*)))
    };
}
pub(crate) use bail;
