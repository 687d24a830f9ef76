//! The one error type of the `view` crate.

use std::path::PathBuf;

/// What can go wrong starting or running the viewer. Messages say what is wrong and what to do,
/// with the file last.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    /// The given path does not exist.
    #[error("nothing to view: the path does not exist: {0}")]
    Missing(PathBuf),
    /// A folder without a Gaussians PLY.
    #[error(
        "no 3DGS PLY in the folder (expected gaussians.ply as `splatseg run` / `train` write it, \
         or point_cloud.ply); give the folder of a run or a .ply file: {0}"
    )]
    NoPly(PathBuf),
    /// The PLY could not be read or is not a 3DGS PLY (the message names the file).
    #[error("cannot view the PLY: {0}")]
    BadPly(splatseg_scene::SceneError),
    /// The PLY holds no Gaussians.
    #[error("cannot view the PLY: it has no Gaussians: {0}")]
    EmptyPly(PathBuf),
    /// The scene (cameras) could not be loaded.
    #[error("cannot load the scene's cameras ({reason}); give --scene or leave it out: {path}")]
    Scene {
        /// What is wrong.
        reason: String,
        /// The scene folder.
        path: PathBuf,
    },
    /// The address could not be bound (e.g. the port is in use).
    #[error("cannot listen on {addr}: {reason} (is another program using the port? try --listen 127.0.0.1:0 for any free port)")]
    Bind {
        /// `host:port`.
        addr: String,
        /// The system's message.
        reason: String,
    },
    /// Exporting a selection failed.
    #[error("cannot export the selection: {0}")]
    Export(String),
    /// Driving the headless browser failed (tests, benchmarks, screenshots).
    #[error("browser: {0}")]
    Browser(String),
    /// Reading or writing a file failed.
    #[error(transparent)]
    SceneIo(#[from] splatseg_scene::SceneError),
}

/// `Result` with [`ViewError`].
pub type ViewResult<T> = Result<T, ViewError>;
