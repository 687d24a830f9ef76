//! `splatseg apply`'s argument.

use std::path::PathBuf;

/// Apply a run's edits (OUT/edits.json) to its outputs: merge, split, reassign and name objects.
///
/// OUT/edits.json lists corrections to the automatic result in order (the viewer saves them, or
/// write them by hand; the format is in README.md): `merge` object ids into one, `split_box` an
/// object by a 3D box, `split_lasso` it by a polygon drawn in a view, `assign` Gaussian index
/// ranges to an object, `move` the Gaussians a selection holds (brush strokes in a view, grown or
/// shrunk by 3D neighbours) to an object, `rename` an object. apply rewrites gaussians.ply's object_id, every
/// view's label map and overlay (rendered from the edited Gaussians, so a fix made in one view
/// holds in all), objects.json (the objects with their names) and report.md, staged and moved in
/// together as `run` writes them. The edits always start from the run's own result (kept in
/// OUT/cache/edits/): applying the same edits again gives the same bytes. Edits made on another
/// PLY or run, an unknown id or rows out of range are refused, naming the operation, and nothing
/// is changed. A run made with --clip has its objects embedded again (OUT/objects/, with the
/// checkpoint it names), so `find` and `--query` rank the edited objects and show their names.
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct ApplyArgs {
    /// The output folder of `splatseg run` holding edits.json.
    pub out: PathBuf,
}
