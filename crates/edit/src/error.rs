//! The one error type of the `edit` crate.

use std::path::PathBuf;

/// What can go wrong editing a labelled PLY. Messages say what is wrong and what to do, with
/// the file last.
#[derive(Debug, thiserror::Error)]
pub enum EditError {
    /// The Gaussians carry no `object_id`.
    #[error(
        "the PLY has no `object_id` property, so there are no objects to edit (SPZ and .splat files never have one): run `splatseg run` first and use its gaussians.ply{}",
        location(.path)
    )]
    NoObjectIds {
        /// The PLY, when known.
        path: Option<PathBuf>,
    },
    /// A file of a format that holds no `object_id` (SPZ, `.splat`, `.ksplat`, compressed PLY)
    /// given where objects are needed.
    #[error(
        "{} is {}, which holds no `object_id`, so there are no objects to edit: label it with `splatseg run SCENE --gaussians {} --out OUT` and give OUT/gaussians.ply instead (the same Gaussians, row for row, with `object_id`; `--out NAME{}` writes {} again): {}",
        .path.display(), described(*.format), .path.display(), .format.extension(), described(*.format), .path.display()
    )]
    IdsNotHeld {
        /// The file's format.
        format: splatseg_scene::splats::SplatFormat,
        /// The file.
        path: PathBuf,
    },
    /// Requested ids that no Gaussian carries.
    #[error("no Gaussian has object id {}; ids present: {}{}", list(.missing), list(.available), location(.path))]
    UnknownIds {
        /// The requested ids that are absent.
        missing: Vec<i32>,
        /// Every id present, sorted (−1 = unlabelled).
        available: Vec<i32>,
        /// The PLY, when known.
        path: Option<PathBuf>,
    },
    /// An empty id list.
    #[error("no object id given (use e.g. `--ids 3,7`)")]
    NoIdsGiven,
    /// Per-Gaussian arrays of inconsistent lengths.
    #[error("{what} has {got} entries for {expected} Gaussians{}", location(.path))]
    LengthMismatch {
        /// Which array.
        what: &'static str,
        /// Its length.
        got: usize,
        /// The number of Gaussians.
        expected: usize,
        /// The PLY, when known.
        path: Option<PathBuf>,
    },
    /// `--keep-extras` asked for a format that holds no `object_id`, `feat_*` or other property.
    #[error(
        "--keep-extras: {format} holds no `object_id`, `feat_*` or other extra property; write a .ply to keep them, or leave out --keep-extras: {}",
        path.display()
    )]
    ExtrasNotHeld {
        /// The output's format.
        format: &'static str,
        /// The output file.
        path: PathBuf,
    },
    /// An edits file that cannot be used as a whole: unreadable, malformed, of a later
    /// version, or made on another run.
    #[error("{message}: {}", .path.display())]
    EditsFile {
        /// What is wrong.
        message: String,
        /// The edits file.
        path: PathBuf,
    },
    /// An operation of an edits file that selects something absent.
    #[error("operation {index} ({kind}): {message}: {}", .path.display())]
    EditOperation {
        /// Its index in `operations` (from 0).
        index: usize,
        /// Its `op`.
        kind: &'static str,
        /// What is wrong.
        message: String,
        /// The edits file.
        path: PathBuf,
    },
    /// A box that selects nothing or cannot be used (a crop).
    #[error("cannot crop by the box: {0}")]
    BadBox(String),
    /// Reading or writing a file failed.
    #[error(transparent)]
    Scene(#[from] splatseg_scene::SceneError),
}

impl EditError {
    /// Attaches the PLY path to errors that lack one.
    pub fn with_path(self, p: &std::path::Path) -> Self {
        match self {
            EditError::NoObjectIds { path: None } => EditError::NoObjectIds { path: Some(p.to_path_buf()) },
            EditError::UnknownIds { missing, available, path: None } => {
                EditError::UnknownIds { missing, available, path: Some(p.to_path_buf()) }
            }
            EditError::LengthMismatch { what, got, expected, path: None } => {
                EditError::LengthMismatch { what, got, expected, path: Some(p.to_path_buf()) }
            }
            other => other,
        }
    }
}

/// "an SPZ", "a .splat file", "a compressed PLY": a format as a sentence names a file of it.
fn described(format: splatseg_scene::splats::SplatFormat) -> String {
    let name = format.name();
    let article = if name.starts_with('S') { "an" } else { "a" };
    let file = if name.starts_with('.') { " file" } else { "" };
    format!("{article} {name}{file}")
}

fn location(path: &Option<PathBuf>) -> String {
    path.as_ref().map(|p| format!(": {}", p.display())).unwrap_or_default()
}

fn list(ids: &[i32]) -> String {
    if ids.is_empty() {
        return "none".to_string();
    }
    ids.iter().map(|i| i.to_string()).collect::<Vec<_>>().join(", ")
}
