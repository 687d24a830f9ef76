//! `OUT/edits.json`: a run's corrections as data (issue 60). A small, versioned, human-readable
//! file: the identity of the run it was made on, then the operations in order, each naming what
//! it selects (object ids, Gaussian index ranges, a box or a lasso with its camera), never a
//! rewritten input.
//!
//! ```json
//! {
//!   "version": 1,
//!   "inputs": { "gaussians": 52311, "ply_digest": "9f0c…", "run": "4be1…" },
//!   "operations": [
//!     { "op": "merge", "ids": [3, 7] },
//!     { "op": "split_box", "object": 5, "box": { "centre": [0, 0.2, 1], "half_size": [0.3, 0.3, 0.5] } },
//!     { "op": "split_lasso", "object": 2, "camera": { "view": 0 }, "polygon_px": [[10, 10], [80, 12], [40, 70]] },
//!     { "op": "assign", "ranges": [[100, 200]], "id": 9 },
//!     { "op": "rename", "id": 3, "name": "chair" }
//!   ]
//! }
//! ```
//!
//! Version 2 adds `move`: the Gaussians a [`Selection`] holds (brush strokes, lassos, boxes, rows,
//! then grown or shrunk by 3D neighbours) go to an object, e.g.
//! `{ "op": "move", "select": { "objects": [4], "parts": [{ "by": "brush", "camera": { "view": 0 },
//! "stroke_px": [[10, 10], [40, 12]], "radius_px": 6 }], "neighbours": [{ "grow": 0.02 }] }, "to": "new" }`.
//! A file is written with the lowest version its operations need ([`Edits::new`]), so a file
//! without `move` stays version 1 and older splatseg reads it.
//!
//! Reading checks the syntax and the version ([`read_edits`]); what the operations select is
//! checked when they are applied to the run's ids ([`crate::edit_ops::apply_operations`]), in
//! order, so an id a split made may be used by a later operation.

use crate::error::EditError;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The file's name in a run's output folder.
pub const EDITS_FILE: &str = "edits.json";

/// The latest version this build reads and writes; a file of a later version is refused.
pub const EDITS_VERSION: u32 = 2;

/// Most grow and shrink steps one selection takes.
pub const MAX_NEIGHBOUR_STEPS: usize = 64;

/// A run's edits.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Edits {
    /// Version of the format ([`EDITS_VERSION`]).
    pub version: u32,
    /// The run the edits were made on. Left out of a file written by hand, it is empty, and
    /// [`check_inputs`] refuses it naming this run's, to copy in.
    #[serde(default)]
    pub inputs: EditInputs,
    /// The operations, applied in order to the run's own ids (never to already edited ones).
    pub operations: Vec<Operation>,
}

impl Edits {
    /// Edits of `operations` on `inputs`, of the lowest version that holds them.
    pub fn new(inputs: EditInputs, operations: Vec<Operation>) -> Edits {
        let version = operations.iter().map(Operation::version).max().unwrap_or(1);
        Edits { version, inputs, operations }
    }
}

/// Which run the edits were made on: ids only mean something in the run that numbered them,
/// index ranges only in the PLY whose rows they count.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EditInputs {
    /// Rows of the run's `gaussians.ply` (every row, skipped ones included).
    pub gaussians: u64,
    /// [`centres_digest`] of those rows.
    pub ply_digest: String,
    /// The key of the run's inputs and settings (`OUT/cache/run.json`).
    pub run: String,
}

/// One correction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case", deny_unknown_fields)]
pub enum Operation {
    /// The objects `ids` become one, `into` (default: the smallest of `ids`).
    Merge {
        /// At least two existing object ids.
        ids: Vec<i32>,
        /// The id they all take, one of `ids`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        into: Option<i32>,
    },
    /// The Gaussians of `object` whose centres lie inside `box` become a new object.
    SplitBox {
        /// An existing object id.
        object: i32,
        /// The box, in world units.
        #[serde(rename = "box")]
        region: Box3,
        /// The new object's id (default: one more than the largest id in use); must be unused.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        new_id: Option<i32>,
    },
    /// The Gaussians of `object` whose centres project inside `polygon_px` in `camera` become a
    /// new object.
    SplitLasso {
        /// An existing object id.
        object: i32,
        /// The camera the lasso was drawn in.
        camera: LassoCamera,
        /// At least three vertices, in pixels (x right, y down; pixel `i` covers `[i, i + 1)`).
        polygon_px: Vec<[f64; 2]>,
        /// As for `split_box`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        new_id: Option<i32>,
    },
    /// The Gaussians in `ranges` take `id` (an existing or a new object, or −1: none).
    Assign {
        /// `[start, end)` row ranges of `gaussians.ply`.
        ranges: Vec<[u64; 2]>,
        /// The id they take: ≥ 1, or −1.
        id: i32,
    },
    /// The Gaussians `select` holds take object `to` (version 2).
    Move {
        /// Which Gaussians.
        select: Selection,
        /// An existing object, −1 (none), or `"new"` (one more than the largest id in use).
        to: MoveTarget,
    },
    /// Object `id` is called `name`.
    Rename {
        /// An existing object id.
        id: i32,
        /// Any non-empty text.
        name: String,
    },
}

impl Operation {
    /// The operation's name as written in the file (`"merge"`, …).
    pub fn kind(&self) -> &'static str {
        match self {
            Operation::Merge { .. } => "merge",
            Operation::SplitBox { .. } => "split_box",
            Operation::SplitLasso { .. } => "split_lasso",
            Operation::Assign { .. } => "assign",
            Operation::Move { .. } => "move",
            Operation::Rename { .. } => "rename",
        }
    }

    /// The first version of the format that has this operation.
    pub fn version(&self) -> u32 {
        match self {
            Operation::Move { .. } => 2,
            _ => 1,
        }
    }
}

/// A selection of Gaussians, as the viewer builds it: the union of `parts` among the Gaussians of
/// `objects`, then grown or shrunk by 3D neighbours, step by step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Selection {
    /// Only Gaussians of these objects (as the operations before left them; −1: those of no
    /// object) are selected, grown into included. Absent: any Gaussian.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub objects: Option<Vec<i32>>,
    /// At least one; a Gaussian any of them selects is selected.
    pub parts: Vec<SelectPart>,
    /// Applied in order after the parts.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub neighbours: Vec<NeighbourStep>,
}

/// What one part of a [`Selection`] selects.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "by", rename_all = "snake_case", deny_unknown_fields)]
pub enum SelectPart {
    /// The Gaussians whose centres project within `radius_px` of the stroke (the polyline through
    /// `stroke_px`; one point: a disc) in `camera`.
    Brush {
        /// The camera the stroke was painted in.
        camera: LassoCamera,
        /// At least one point, pixels (as a lasso's).
        stroke_px: Vec<[f64; 2]>,
        /// The brush's radius, pixels (> 0).
        radius_px: f64,
    },
    /// The Gaussians whose centres project inside the polygon (as `split_lasso`).
    Lasso {
        /// The camera the lasso was drawn in.
        camera: LassoCamera,
        /// At least three vertices, pixels.
        polygon_px: Vec<[f64; 2]>,
    },
    /// The Gaussians whose centres lie in the box (as `split_box`).
    Box {
        /// The box, world units.
        #[serde(rename = "box")]
        region: Box3,
    },
    /// Rows of `gaussians.ply` (`[start, end)`): what the viewer found itself, e.g. the Gaussians
    /// drawn in front under a stroke (*front-most only*) or those passing an opacity filter.
    Rows {
        /// `[start, end)` row ranges.
        ranges: Vec<[u64; 2]>,
    },
}

/// One step of growing or shrinking a selection by 3D neighbours: two Gaussians are neighbours
/// when their centres lie within the step's radius (world units) of each other.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum NeighbourStep {
    /// Adds every Gaussian the selection may hold (its `objects`) with a selected neighbour.
    Grow(f64),
    /// Drops every selected Gaussian with an unselected neighbour (any Gaussian).
    Shrink(f64),
}

/// Where a `move` sends its Gaussians.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum MoveTarget {
    /// An object id in use, or −1 (none).
    Id(i32),
    /// A new object.
    New(NewObject),
}

/// `"new"`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NewObject {
    /// A new object: one more than the largest id in use.
    New,
}

/// An oriented box: a point `p` is inside when `rotation⁻¹ · (p − centre)` lies within
/// `±half_size` on every axis (axis-aligned without `rotation`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Box3 {
    /// Centre, world units.
    pub centre: [f64; 3],
    /// Half the side along each of the box's axes, world units.
    pub half_size: [f64; 3],
    /// The box's axes in the world, as a quaternion `w, x, y, z` (normalised when read).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<[f64; 4]>,
}

/// The camera a lasso was drawn in: a view of the run's scene, or one of its own.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum LassoCamera {
    /// The capture's view with this index (in the scene's view order).
    View {
        /// View index.
        view: usize,
    },
    /// A pinhole camera (no distortion) at a pose: the viewer's free camera.
    Pinhole {
        /// Focal lengths and principal point, pixels.
        fx: f64,
        /// Vertical focal length, pixels.
        fy: f64,
        /// Principal point x, pixels.
        cx: f64,
        /// Principal point y, pixels.
        cy: f64,
        /// Camera-to-world, 4×4 row-major (OpenCV axes: x right, y down, z forward).
        world_from_cam: [[f64; 4]; 4],
    },
}

/// The digest of the Gaussians' centres (`[N, 3]`, every row in file order): which PLY edits
/// were made on, unchanged by the ids and features `apply` rewrites. 16 hex digits of a 64-bit
/// FNV-1a over the centres' little-endian bits and the row count.
pub fn centres_digest(means: &[[f32; 3]]) -> String {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    let mut add = |bytes: &[u8]| {
        for &b in bytes {
            hash = (hash ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    };
    add(&(means.len() as u64).to_le_bytes());
    for m in means {
        for v in m {
            add(&v.to_bits().to_le_bytes());
        }
    }
    format!("{hash:016x}")
}

/// Reads and parses `path`; a malformed file or a later version is an error naming the file.
pub fn read_edits(path: &Path) -> Result<Edits, EditError> {
    let text = std::fs::read_to_string(path).map_err(|e| EditError::EditsFile {
        message: format!("cannot read the edits ({e})"),
        path: path.to_path_buf(),
    })?;
    parse_edits(&text, path)
}

/// Parses the text of `path` (see [`read_edits`]).
pub fn parse_edits(text: &str, path: &Path) -> Result<Edits, EditError> {
    let invalid = |message: String| EditError::EditsFile { message, path: path.to_path_buf() };
    // The version first, so a later format is named as such rather than as unknown fields.
    #[derive(Deserialize)]
    struct VersionOnly {
        version: Option<u32>,
    }
    let version = serde_json::from_str::<VersionOnly>(text)
        .map_err(|e| invalid(format!("not a valid edits file ({e})")))?
        .version
        .ok_or_else(|| invalid(format!("no \"version\" (this splatseg writes version {EDITS_VERSION})")))?;
    if version > EDITS_VERSION {
        return Err(invalid(format!(
            "edits of version {version} were written by a later splatseg; this one reads version \
             {EDITS_VERSION}: update splatseg"
        )));
    }
    let edits: Edits =
        serde_json::from_str(text).map_err(|e| invalid(format!("not a valid edits file ({e})")))?;
    if let Some((index, op)) = edits.operations.iter().enumerate().find(|(_, op)| op.version() > version) {
        return Err(invalid(format!(
            "operation {index} ({}) needs version {} of the format, the file says version {version}",
            op.kind(),
            op.version()
        )));
    }
    Ok(edits)
}

/// Writes `edits` as indented JSON to `path` (atomically).
pub fn write_edits(path: &Path, edits: &Edits) -> Result<(), EditError> {
    let mut text = serde_json::to_string_pretty(edits)
        .map_err(|e| EditError::EditsFile { message: e.to_string(), path: path.to_path_buf() })?;
    text.push('\n');
    splatseg_scene::atomic::write_bytes_atomic(path, text.as_bytes())?;
    Ok(())
}

/// Refuses edits made on another run than `current` (or naming none), naming what changed and
/// `current`'s inputs as JSON, to copy into a file written by hand.
pub fn check_inputs(edits: &Edits, current: &EditInputs, path: &Path) -> Result<(), EditError> {
    let made = &edits.inputs;
    let changed = if *made == EditInputs::default() {
        Some("the edits do not name the run they were made on (no \"inputs\")".to_string())
    } else if made.ply_digest != current.ply_digest {
        Some(format!(
            "the edits were made on a PLY with digest {}, this run's is {}",
            made.ply_digest, current.ply_digest
        ))
    } else if made.gaussians != current.gaussians {
        Some(format!(
            "the edits were made on {} Gaussians, this run has {}",
            made.gaussians, current.gaussians
        ))
    } else if made.run != current.run {
        Some(format!(
            "the edits were made on run {}, this run is {} (its inputs or settings changed, so its \
             object ids may mean other objects)",
            made.run, current.run
        ))
    } else {
        None
    };
    match changed {
        Some(message) => {
            let this_run = serde_json::to_string(current).unwrap_or_default();
            let message = format!("{message}; this run's inputs are \"inputs\": {this_run}");
            Err(EditError::EditsFile { message, path: path.to_path_buf() })
        }
        None => Ok(()),
    }
}
