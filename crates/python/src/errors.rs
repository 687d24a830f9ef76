//! Rust errors as Python exceptions carrying the command line's messages (the whole chain of
//! causes, as `splatseg` prints it): `FileNotFoundError` when an input is missing, `OSError` for
//! other file-system failures, `ValueError` for everything else (bad input, refused requests).

use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyValueError};
use pyo3::PyErr;
use splatseg_cues::CuesError;
use splatseg_edit::EditError;
use splatseg_pipeline::PipelineError;
use splatseg_scene::SceneError;
use std::io::ErrorKind;

/// What kind of failure an error is, for its Python exception.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    NotFound,
    Os,
    Value,
}

fn io_kind(e: &std::io::Error) -> Kind {
    match e.kind() {
        ErrorKind::NotFound => Kind::NotFound,
        _ => Kind::Os,
    }
}

fn scene_kind(e: &SceneError) -> Kind {
    match e {
        SceneError::Missing { .. } => Kind::NotFound,
        SceneError::Io { source, .. } => io_kind(source),
        _ => Kind::Value,
    }
}

fn pipeline_kind(e: &PipelineError) -> Kind {
    match e {
        PipelineError::Context { source, .. } => pipeline_kind(source),
        PipelineError::Io(e) => io_kind(e),
        PipelineError::Scene(e) => scene_kind(e),
        PipelineError::Cues(CuesError::Missing { .. }) => Kind::NotFound,
        _ => Kind::Value,
    }
}

fn exception(kind: Kind, message: String) -> PyErr {
    match kind {
        Kind::NotFound => PyFileNotFoundError::new_err(message),
        Kind::Os => PyOSError::new_err(message),
        Kind::Value => PyValueError::new_err(message),
    }
}

/// A pipeline error as a Python exception.
pub fn from_pipeline(e: PipelineError) -> PyErr {
    exception(pipeline_kind(&e), e.report())
}

/// A scene error (PLY, label maps, paths) as a Python exception.
pub fn from_scene(e: SceneError) -> PyErr {
    exception(scene_kind(&e), e.to_string())
}

/// An edit error (extract, remove, objects) as a Python exception.
pub fn from_edit(e: EditError) -> PyErr {
    match e {
        EditError::Scene(e) => from_scene(e),
        other => PyValueError::new_err(other.to_string()),
    }
}

/// A `ValueError` with `message`.
pub fn value(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}
