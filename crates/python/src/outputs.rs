//! A finished run's outputs read back as arrays (for `splatseg.run` and `splatseg.apply_edits`):
//! the final label maps, every row's object id, the object table (as `splatseg objects --json
//! OUT/gaussians.ply` prints it, with the names `splatseg apply` gave), the report and the summary.

use crate::arrays::owned_array;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use splatseg_pipeline::{PipelineError, RunOutputs};
use splatseg_scene::Plane;
use std::path::Path;

/// What a finished (or edited) run's folder holds.
pub struct Finished {
    /// `(stem, [H, W] final label map)`, by stem.
    label_maps: Vec<(String, Plane<u16>)>,
    /// `[N]` object id of every row of the input PLY (−1 = none); `None` without Gaussians.
    object_ids: Option<Vec<i32>>,
    /// The object table's rows as JSON (`splatseg objects --json`'s `objects`, names included).
    objects_json: String,
    /// `OUT/report.md`.
    report: String,
    /// `OUT/metrics.json`.
    summary_json: String,
}

/// Reads the outputs in `out`.
pub fn read_outputs(out: &Path) -> Result<Finished, PipelineError> {
    let outputs = RunOutputs::open(out)?;
    let masks = out.join("masks");
    let maps = splatseg_eval::list_label_maps(&masks)?;
    let mut label_maps = Vec::with_capacity(maps.len());
    for stem in maps.keys() {
        let map = outputs.label_map(stem)?;
        let data = map
            .data
            .iter()
            .map(|&id| u16::try_from(id))
            .collect::<Result<Vec<u16>, _>>()
            .map_err(|_| PipelineError::Invalid(format!("label map `{stem}` holds an id above 65535")))?;
        label_maps.push((stem.clone(), Plane { width: map.width, height: map.height, data }));
    }
    let ply = out.join("gaussians.ply");
    let (object_ids, objects_json) = if ply.is_file() {
        // Every row, non-finite ones included (kept in place with id −1), so the ids stay
        // aligned with the input PLY.
        let rows = splatseg_scene::ply::read_ply_rows(&ply)?.gaussians;
        let ids = rows
            .object_ids
            .clone()
            .ok_or_else(|| PipelineError::Invalid(format!("no object_id in {}", ply.display())))?;
        let mut table = splatseg_edit::objects(&rows)
            .map_err(|e| PipelineError::Invalid(format!("{}: {}", e, ply.display())))?;
        let per_view: Vec<Vec<u32>> =
            label_maps.iter().map(|(_, m)| splatseg_edit::ids_in_label_map(&m.map(|&v| v as u32))).collect();
        table.set_views_seen(&per_view);
        // The names `splatseg apply` gave (objects.json beside the PLY), as `splatseg objects` shows.
        table.set_names(&splatseg_edit::names_beside(&ply)?);
        (Some(ids), serde_json::to_string(&table.objects)?)
    } else {
        (None, "[]".to_string())
    };
    let report_path = out.join("report.md");
    let report = std::fs::read_to_string(&report_path).map_err(PipelineError::Io)?;
    Ok(Finished {
        label_maps,
        object_ids,
        objects_json,
        report,
        summary_json: serde_json::to_string(&outputs.summary)?,
    })
}

impl Finished {
    /// The dict the Python side makes a `RunResult` of: `label_maps`, `object_ids`,
    /// `objects_json`, `report`, `summary_json`.
    pub fn into_dict(self, py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
        let result = PyDict::new(py);
        let maps = PyDict::new(py);
        for (stem, map) in self.label_maps {
            maps.set_item(stem, owned_array(py, map.data, &[map.height, map.width])?)?;
        }
        result.set_item("label_maps", maps)?;
        match self.object_ids {
            Some(ids) => {
                let n = ids.len();
                result.set_item("object_ids", owned_array(py, ids, &[n])?)?
            }
            None => result.set_item("object_ids", py.None())?,
        }
        result.set_item("objects_json", self.objects_json)?;
        result.set_item("report", self.report)?;
        result.set_item("summary_json", self.summary_json)?;
        Ok(result)
    }
}
