//! Reading a labelled PLY and writing an edited one, in the format the output's extension names
//! (`.spz`, `.splat`, else a PLY).

use crate::error::EditError;
use crate::select::object_ids;
use crate::viewer::{for_output, ExtraFields};
use splatseg_scene::splats::SplatFormat;
use splatseg_scene::Gaussians;
use std::path::Path;

/// Reads Gaussians (any format `splatseg_scene::splats` reads) that must carry `object_id`, which
/// only a PLY holds; the error says to run `splatseg run` if not.
pub fn read_labelled_ply(path: &Path) -> Result<Gaussians, EditError> {
    require_labels(splatseg_scene::splats::read_gaussians(path)?, path)
}

/// `g` (read from `path`) if it carries `object_id`; the error says to run `splatseg run` if not,
/// and for a file of a format that cannot hold ids (SPZ, `.splat`, `.ksplat`, compressed PLY) names
/// the format and where the ids go ([`EditError::IdsNotHeld`]).
pub fn require_labels(g: Gaussians, path: &Path) -> Result<Gaussians, EditError> {
    if g.object_ids.is_none() {
        let format = splatseg_scene::splats::detect_file_format(path)?;
        if format != SplatFormat::Ply {
            return Err(EditError::IdsNotHeld { format, path: path.to_path_buf() });
        }
    }
    object_ids(&g).map_err(|e| e.with_path(path))?;
    Ok(g)
}

/// Writes `g` atomically in the format `path`'s extension names (`.spz`, `.splat`; a binary 3DGS
/// PLY otherwise), with non-INRIA properties handled per `extras`. Keeping them in a format that
/// cannot hold them (every one but the PLY) is an error, before anything is written. The
/// temporary file is `.splatseg-partial-<pid>-…` beside `path`; one that a killed write left there
/// is removed by the next write into that folder (`splatseg_scene::atomic::write_atomic_sweeping`).
pub fn write_edited_ply(path: &Path, g: Gaussians, extras: ExtraFields) -> Result<(), EditError> {
    let format = SplatFormat::from_extension(path).unwrap_or(SplatFormat::Ply);
    let g = for_output(g, extras);
    let has_extras = g.object_ids.is_some() || g.features.is_some() || !g.extra.is_empty();
    if format != SplatFormat::Ply && has_extras {
        return Err(EditError::ExtrasNotHeld { format: format.name(), path: path.to_path_buf() });
    }
    splatseg_scene::splats::write_gaussians_swept_as(format, path, &g)?;
    Ok(())
}
