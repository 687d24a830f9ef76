//! [`ModelCuesError`], the one error type of the crate, with context added on the way up
//! ([`Context`]); [`ModelCuesError::report`] prints the whole chain.

use std::fmt::Display;

/// Everything the models stage can fail with.
#[derive(Debug, thiserror::Error)]
pub enum ModelCuesError {
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
        source: Box<ModelCuesError>,
    },
    /// A file-system error.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// The output lock and the shards.
    #[error(transparent)]
    Pipeline(#[from] splatseg_pipeline::PipelineError),
    /// Loading or running a model.
    #[error(transparent)]
    Models(#[from] splatseg_models::ModelsError),
    /// Reading the scene and images, writing `.npy` and SAM JSON.
    #[error(transparent)]
    Scene(#[from] splatseg_scene::SceneError),
    /// The LoG edge map.
    #[error(transparent)]
    Cues(#[from] splatseg_cues::CuesError),
}

/// The crate's result type.
pub type Result<T, E = ModelCuesError> = std::result::Result<T, E>;

impl ModelCuesError {
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

impl<T, E: Into<ModelCuesError>> Context<T> for std::result::Result<T, E> {
    fn with_context<C: Display, F: FnOnce() -> C>(self, context: F) -> Result<T> {
        self.map_err(|e| ModelCuesError::Context {
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
        self.ok_or_else(|| ModelCuesError::Invalid(context().to_string()))
    }

    fn context<C: Display>(self, context: C) -> Result<T> {
        self.with_context(|| context)
    }
}
