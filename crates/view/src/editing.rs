//! Editing a run's objects in the viewer (issue 60): the page keeps the list of operations
//! (`splatseg_edit::edits::Operation`: merge, split by a box or a lasso, assign, move a
//! selection, rename), asks
//! for their effect ([`Editing::preview`]: the same `apply_operations` as `splatseg apply`, on the
//! run's own ids) and saves them as `OUT/edits.json` ([`Editing::save`]), the file `splatseg
//! apply OUT` reads.
//!
//! What only the caller knows comes in an [`EditSetup`]: the run's identity (`inputs.run`, the
//! key of `OUT/cache/run.json`), the run's own ids when the served PLY was already edited, and a
//! function telling the run's identity again at save time (a run made meanwhile is refused). This
//! crate does not depend on the pipeline: `splatseg view` wires
//! `splatseg_pipeline::viewer_edits`.
//!
//! Saving is refused (never written) when: the body is not `{"inputs": …, "operations": […]}`;
//! its `inputs` are not this run's (a page of another run); an operation selects something
//! absent; the run on disk changed since the viewer opened it; or `edits.json` changed on disk
//! since the viewer read (or last wrote) it, or is not this run's and was there first (a file
//! the viewer would replace without having shown it).

use crate::manifest::{slots_of_ids, ObjectEntry};
use serde::{Deserialize, Serialize};
use splatseg_edit::edits::{centres_digest, parse_edits, write_edits};
use splatseg_edit::{apply_operations, selection_of, EditBase, EditInputs, Edits, Operation, Selection};
use splatseg_scene::{Camera, Gaussians, Pose};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The run's identity now, or why it cannot be told.
pub type RunIdentity = Box<dyn Fn() -> Result<EditInputs, String> + Send + Sync>;

/// What the caller gives for editing.
pub struct EditSetup {
    /// The run's identity when the viewer starts.
    pub inputs: EditInputs,
    /// `[N]` the run's own ids (before any applied edit), when the served PLY's are edited ones;
    /// `None`: the served PLY's ids are the run's.
    pub base_ids: Option<Vec<i32>>,
    /// Ids the run's label maps show that no Gaussian carries (edits may name them, and a
    /// split's new id comes after them, as in `splatseg apply`).
    pub map_only_ids: BTreeSet<i32>,
    /// `OUT/edits.json`.
    pub edits_path: PathBuf,
    /// The run's identity at save time.
    pub identity_now: RunIdentity,
}

/// Editing state of a served run.
pub struct Editing {
    inputs: EditInputs,
    base_ids: Vec<i32>,
    map_only_ids: BTreeSet<i32>,
    edits_path: PathBuf,
    identity_now: RunIdentity,
    neighbour_radius: Option<f64>,
    /// The operations of `edits.json` when the viewer started, then as last saved (a page opened
    /// starts from them).
    start: Mutex<Vec<Operation>>,
    /// `edits.json`'s bytes as the viewer last read or wrote them (`None`: no file).
    on_disk: Mutex<Option<Vec<u8>>>,
    /// An `edits.json` there at start that the page could not start from (malformed, of a later
    /// version or another run): why, and its bytes, which a save never replaces.
    foreign_file: Option<(String, Vec<u8>)>,
}

/// What the page learns about editing in the manifest.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EditingEntry {
    /// The run's identity, sent back with a save.
    pub inputs: EditInputs,
    /// The operations of `edits.json` the page starts from.
    pub operations: Vec<Operation>,
    /// Where a save writes.
    pub path: String,
    /// The id a new object takes before any operation (the page's preview says it after).
    pub next_id: i32,
    /// The radius (world units) the page suggests for growing and shrinking a selection: twice
    /// the median distance between neighbouring centres (`splatseg_edit::neighbours::typical_spacing`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub neighbour_radius: Option<f64>,
    /// Something to tell the user (e.g. an `edits.json` the viewer cannot use).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// A save request (`POST /api/edits`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SaveRequest {
    /// The run the page edits (from the manifest).
    pub inputs: EditInputs,
    /// The operations, in order.
    pub operations: Vec<Operation>,
}

/// A preview request (`POST /api/edits/preview`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PreviewRequest {
    /// The operations, in order.
    pub operations: Vec<Operation>,
}

/// The ids after some operations: objects by slot and each Gaussian's slot.
#[derive(Debug)]
pub struct Preview {
    /// Objects by slot (ids ascending, −1 first), with the names given.
    pub objects: Vec<ObjectEntry>,
    /// `[N]` slot of every Gaussian.
    pub slots: Vec<u32>,
    /// Gaussians whose id differs from the run's.
    pub changed: usize,
    /// The id a new object takes now (one more than every id in use, those only the maps show
    /// included): what the page gives an `assign` to a new object.
    pub next_id: i32,
}

/// A selection of Gaussians (`POST /api/edits/select`), after `operations`: by their own
/// properties, the rows of `objects` whose opacity and size lie in the bounds given; or the rows
/// a `move`'s `selection` holds (brush strokes, grown or shrunk: the page's highlight).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelectRequest {
    /// The page's operations so far.
    pub operations: Vec<Operation>,
    /// The objects whose Gaussians are looked at (with a filter).
    #[serde(default)]
    pub objects: Vec<i32>,
    /// A `move`'s selection, instead of a filter.
    #[serde(default)]
    pub selection: Option<Selection>,
    /// Opacity (after the sigmoid) below this.
    #[serde(default)]
    pub opacity_below: Option<f32>,
    /// Largest of the three scales (world units) above this.
    #[serde(default)]
    pub size_above: Option<f32>,
}

/// Why a save or a preview was refused: the HTTP status and the words.
#[derive(Debug, PartialEq, Eq)]
pub struct Refused {
    /// 400 (the request) or 409 (the files changed).
    pub status: u16,
    /// What is wrong and what to do.
    pub message: String,
}

fn refused(status: u16, message: impl Into<String>) -> Refused {
    Refused { status, message: message.into() }
}

impl Editing {
    /// Editing of `g` (the served PLY, every row) with `setup`; `Err` says why it is off (the
    /// PLY is not the run's).
    pub fn new(g: &Gaussians, setup: EditSetup) -> Result<Editing, String> {
        let EditSetup { inputs, base_ids, map_only_ids, edits_path, identity_now } = setup;
        if inputs.gaussians != g.len() as u64 || inputs.ply_digest != centres_digest(&g.means) {
            return Err(format!(
                "the served Gaussians are not the run's ({} rows, digest {}; the run's: {} rows, digest {})",
                g.len(),
                centres_digest(&g.means),
                inputs.gaussians,
                inputs.ply_digest
            ));
        }
        let base_ids = match base_ids {
            Some(ids) if ids.len() == g.len() => ids,
            Some(ids) => return Err(format!("the run's ids are {} for {} Gaussians", ids.len(), g.len())),
            None => g.object_ids.clone().ok_or("the PLY has no object_id")?,
        };
        let bytes = std::fs::read(&edits_path).ok();
        let (start, foreign_file) = match bytes.as_deref().map(|b| read_start(b, &edits_path, &inputs)) {
            None => (Vec::new(), None),
            Some(Ok(operations)) => (operations, None),
            Some(Err(why)) => (Vec::new(), Some((why, bytes.clone().unwrap_or_default()))),
        };
        let neighbour_radius = splatseg_edit::neighbours::typical_spacing(&g.means).map(|s| 2.0 * s);
        Ok(Editing {
            inputs,
            base_ids,
            map_only_ids,
            edits_path,
            identity_now,
            neighbour_radius,
            start: Mutex::new(start),
            on_disk: Mutex::new(bytes),
            foreign_file,
        })
    }

    /// The manifest's part.
    pub fn entry(&self) -> EditingEntry {
        EditingEntry {
            inputs: self.inputs.clone(),
            operations: self.start.lock().map(|s| s.clone()).unwrap_or_default(),
            path: self.edits_path.display().to_string(),
            next_id: self.base_ids.iter().chain(&self.map_only_ids).copied().max().unwrap_or(0).max(0) + 1,
            neighbour_radius: self.neighbour_radius,
            note: self.foreign_file.as_ref().map(|(why, _)| why.clone()),
        }
    }

    /// `operations` applied to the run's ids (`means`: the served centres; `views`: the scene's
    /// cameras for lassos drawn in a view).
    pub fn preview(
        &self,
        means: &[[f32; 3]],
        views: &[(&Camera, &Pose)],
        operations: &[Operation],
    ) -> Result<Preview, Refused> {
        let base = EditBase { ids: &self.base_ids, means, map_only_ids: &self.map_only_ids, views };
        let edited =
            apply_operations(&base, operations, &self.edits_path).map_err(|e| refused(400, e.to_string()))?;
        let (slots, mut objects) = slots_of_ids(&edited.ids, means);
        for o in &mut objects {
            o.name = edited.names.get(&o.id).cloned();
        }
        let largest = edited.ids.iter().chain(&self.map_only_ids).copied().max().unwrap_or(0);
        Ok(Preview { objects, slots, changed: edited.changed_rows, next_id: largest.max(0) + 1 })
    }

    /// The rows `request` selects, as `[start, end)` ranges (for an `assign`).
    pub fn select(
        &self,
        g: &Gaussians,
        views: &[(&Camera, &Pose)],
        request: &SelectRequest,
    ) -> Result<Vec<[u64; 2]>, Refused> {
        let base = EditBase { ids: &self.base_ids, means: &g.means, map_only_ids: &self.map_only_ids, views };
        let filtered = request.opacity_below.is_some() || request.size_above.is_some();
        if let Some(selection) = &request.selection {
            if filtered || !request.objects.is_empty() {
                return Err(refused(
                    400,
                    "give a selection, or objects with opacity_below or size_above, not both",
                ));
            }
            let rows = selection_of(&base, &request.operations, selection, &self.edits_path)
                .map_err(|e| refused(400, e.to_string()))?;
            return Ok(row_ranges(rows.iter().enumerate().filter(|(_, &s)| s).map(|(i, _)| i)));
        }
        if !filtered {
            return Err(refused(400, "give opacity_below or size_above (or both), or a selection"));
        }
        let edited = apply_operations(&base, &request.operations, &self.edits_path)
            .map_err(|e| refused(400, e.to_string()))?;
        let objects: BTreeSet<i32> = request.objects.iter().copied().collect();
        let picked = |i: usize| {
            let opacity = 1.0 / (1.0 + (-g.raw_opacities[i]).exp());
            let size = g.log_scales[i].iter().fold(f32::NEG_INFINITY, |m, &s| m.max(s.exp()));
            objects.contains(&edited.ids[i])
                && request.opacity_below.is_none_or(|t| opacity < t)
                && request.size_above.is_none_or(|t| size > t)
        };
        Ok(row_ranges((0..g.len()).filter(|&i| picked(i))))
    }

    /// Writes `request` as `edits.json` (checked as the module doc says); the path written.
    pub fn save(
        &self,
        means: &[[f32; 3]],
        views: &[(&Camera, &Pose)],
        request: SaveRequest,
    ) -> Result<PathBuf, Refused> {
        if request.inputs != self.inputs {
            return Err(refused(
                409,
                format!(
                    "these edits were made on another run (inputs {}), this viewer shows {}: reload the page",
                    json(&request.inputs),
                    json(&self.inputs)
                ),
            ));
        }
        self.preview(means, views, &request.operations)?;
        let now = (self.identity_now)().map_err(|e| refused(409, e))?;
        if now != self.inputs {
            return Err(refused(
                409,
                format!(
                    "the run in {} changed since the viewer opened it (now {}): restart `splatseg view` \
                     on it and edit again",
                    self.edits_path.parent().unwrap_or(Path::new(".")).display(),
                    json(&now)
                ),
            ));
        }
        let mut on_disk = self.on_disk.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        let now = match std::fs::read(&self.edits_path) {
            Ok(bytes) => Some(bytes),
            // no file now: nothing is replaced
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => return Err(refused(500, format!("cannot read ({e}): {}", self.edits_path.display()))),
        };
        if let Some(now) = now {
            if Some(&now) != on_disk.as_ref() {
                return Err(refused(
                    409,
                    format!(
                        "{} changed since the viewer read it; nothing was written: move it away or \
                         restart the viewer to start from it: {}",
                        splatseg_edit::EDITS_FILE,
                        self.edits_path.display()
                    ),
                ));
            }
            if let Some((why, _)) = self.foreign_file.as_ref().filter(|(_, first)| *first == now) {
                return Err(refused(
                    409,
                    format!("{why}; the viewer does not replace it: move it away, then save again"),
                ));
            }
        }
        let edits = Edits::new(self.inputs.clone(), request.operations);
        write_edits(&self.edits_path, &edits).map_err(|e| refused(500, e.to_string()))?;
        *on_disk = std::fs::read(&self.edits_path).ok();
        if let Ok(mut start) = self.start.lock() {
            *start = edits.operations;
        }
        Ok(self.edits_path.clone())
    }
}

/// Ascending rows as `[start, end)` ranges.
fn row_ranges(rows: impl Iterator<Item = usize>) -> Vec<[u64; 2]> {
    let mut ranges: Vec<[u64; 2]> = Vec::new();
    for i in rows {
        match ranges.last_mut() {
            Some(last) if last[1] == i as u64 => last[1] += 1,
            _ => ranges.push([i as u64, i as u64 + 1]),
        }
    }
    ranges
}

/// The operations of an existing `edits.json` when they are this run's, else why not.
fn read_start(bytes: &[u8], path: &Path, inputs: &EditInputs) -> Result<Vec<Operation>, String> {
    let text = std::str::from_utf8(bytes).map_err(|_| format!("{} is not UTF-8 text", path.display()))?;
    let edits = parse_edits(text, path).map_err(|e| e.to_string())?;
    splatseg_edit::edits::check_inputs(&edits, inputs, path).map_err(|e| e.to_string())?;
    Ok(edits.operations)
}

fn json<T: Serialize>(value: &T) -> String {
    serde_json::to_string(value).unwrap_or_default()
}

/// The preview's reply body: a 4-byte little-endian length `L`, `L` bytes of JSON
/// (`{"objects": […], "changed": n, "next_id": id}`), zero bytes up to a multiple of 4, then `[N]` u32
/// little-endian slots.
pub fn preview_body(preview: &Preview) -> Vec<u8> {
    let head = serde_json::json!({
        "objects": preview.objects,
        "changed": preview.changed,
        "next_id": preview.next_id,
    });
    let head = serde_json::to_vec(&head).unwrap_or_default();
    let padded = (4 + head.len()).div_ceil(4) * 4;
    let mut body = Vec::with_capacity(padded + 4 * preview.slots.len());
    body.extend_from_slice(&(head.len() as u32).to_le_bytes());
    body.extend_from_slice(&head);
    body.resize(padded, 0);
    for s in &preview.slots {
        body.extend_from_slice(&s.to_le_bytes());
    }
    body
}
