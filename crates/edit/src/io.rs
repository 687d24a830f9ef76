//! Reading a labelled PLY and writing an edited one.

use crate::error::EditError;
use crate::select::object_ids;
use crate::viewer::{for_output, ExtraFields};
use splatseg_scene::Gaussians;
use std::path::Path;

/// Reads a 3DGS PLY that must carry `object_id`; the error says to run `splatseg run` if not.
pub fn read_labelled_ply(path: &Path) -> Result<Gaussians, EditError> {
    require_labels(splatseg_scene::ply::read_ply(path)?, path)
}

/// `g` (read from `path`) if it carries `object_id`; the error says to run `splatseg run` if not.
pub fn require_labels(g: Gaussians, path: &Path) -> Result<Gaussians, EditError> {
    object_ids(&g).map_err(|e| e.with_path(path))?;
    Ok(g)
}

/// Writes `g` atomically as a binary 3DGS PLY, with non-INRIA properties handled per `extras`. The
/// temporary file is `.splatseg-partial-<pid>-…` beside `path`; one that a killed write left there is
/// removed by the next write into that folder (`splatseg_scene::atomic::write_atomic_sweeping`).
pub fn write_edited_ply(path: &Path, g: Gaussians, extras: ExtraFields) -> Result<(), EditError> {
    splatseg_scene::ply::write_ply_swept(path, &for_output(g, extras))?;
    Ok(())
}
