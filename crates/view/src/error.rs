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
    /// `--out` names something that is not a folder.
    #[error("--out must be a folder for the exports (it is created when missing), not a file: {0}")]
    OutNotAFolder(PathBuf),
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
    /// The `--listen` host name does not resolve to an address.
    #[error("cannot listen on host `{host}`: the name does not resolve ({reason}); give an IP address such as 127.0.0.1, or a name this machine resolves")]
    Resolve {
        /// The host as given.
        host: String,
        /// The resolver's message.
        reason: String,
    },
    /// The address could not be bound (e.g. the port is in use).
    #[error("cannot listen on {addr}: {reason} ({hint})")]
    Bind {
        /// `host:port`.
        addr: String,
        /// The system's message.
        reason: String,
        /// What to try, by the kind of failure.
        hint: &'static str,
    },
    /// The operating system gave no random bytes for the page's token.
    #[error("cannot draw the viewer's random token: {0}")]
    Random(String),
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

impl ViewError {
    /// A bind failure on `addr`, with a hint that fits its kind.
    pub fn bind(addr: &str, e: &std::io::Error) -> ViewError {
        let hint = match e.kind() {
            std::io::ErrorKind::AddrInUse => {
                "is another program using the port? try --listen 127.0.0.1:0 for any free port"
            }
            std::io::ErrorKind::AddrNotAvailable => "is it an address of this machine? 127.0.0.1 is",
            std::io::ErrorKind::PermissionDenied => "ports below 1024 need privileges; try a port above 1024",
            _ => "try --listen 127.0.0.1:0 for any free port on this machine only",
        };
        ViewError::Bind { addr: addr.to_string(), reason: e.to_string(), hint }
    }
}

/// `Result` with [`ViewError`].
pub type ViewResult<T> = Result<T, ViewError>;
