//! `edit` stage: acting on a labelled PLY (one whose Gaussians carry `object_id`, as
//! `splatseg run` writes it).
//!
//! - [`select`]: [`extract`] and [`remove`] objects by id; [`crop`](mod@crop): the Gaussians in a box.
//! - [`recolor`](mod@recolor): flat palette colours per object, for viewing a segmentation.
//! - [`objects`](mod@objects): the object table (id, Gaussian count, bounding box, colour, views).
//! - [`edits`]: `OUT/edits.json`, a run's corrections as versioned data; [`edit_ops`]: applying
//!   its operations (merge, split by a box or a lasso, assign, move a selection, rename) to a run's
//!   object ids; [`neighbours`]: growing and shrinking a selection by 3D neighbours.
//! - [`viewer`]: stripping splatseg's extra properties so standard viewers open the output.
//! - [`args`]: the commands' arguments (clap's `Args` with the `cli` feature).
//! - [`io`]: reading a labelled PLY with a helpful error, writing an edited one atomically.

pub mod args;
pub mod crop;
pub mod edit_ops;
pub mod edits;
#[cfg(test)]
mod edits_tests;
pub mod error;
pub mod io;
pub mod neighbours;
pub mod objects;
pub mod recolor;
#[cfg(test)]
mod round_trip_tests;
pub mod select;
mod selection;
#[cfg(test)]
mod testing;
pub mod viewer;

pub use args::{ExtractArgs, ObjectsArgs, RecolorArgs, RemoveArgs};
pub use crop::crop;
pub use edit_ops::{apply_operations, selection_of, EditBase, Edited};
pub use edits::{
    read_edits, EditInputs, Edits, MoveTarget, NeighbourStep, Operation, SelectPart, Selection, EDITS_FILE,
    EDITS_VERSION,
};
pub use error::EditError;
pub use objects::{ids_in_label_map, names_beside, objects, ObjectInfo, ObjectTable, OBJECTS_FILE};
pub use recolor::{palette_colour, recolor, UnlabelledStyle};
pub use select::{extract, ids_present, remove};
pub use viewer::{for_output, ExtraFields};
