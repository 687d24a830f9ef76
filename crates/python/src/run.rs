//! `splatseg.run`: the whole pipeline of `splatseg run` ([`splatseg_pipeline::run_pipeline`]),
//! then its outputs read back as arrays: the final label maps, every input Gaussian's object id,
//! the object table (as `splatseg objects --json OUT/gaussians.ply` prints it) and the report.

use crate::arrays::owned_array;
use crate::errors;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use splatseg_cues::parse_depth_kind;
use splatseg_pipeline::args::{pipeline_inputs, run_outputs};
use splatseg_pipeline::{run_pipeline, PipelineError, RunConfig, RunOptions, RunOutputs};
use splatseg_scene::Plane;
use std::path::{Path, PathBuf};

/// What a finished run gives back, read from its output folder.
struct Finished {
    /// `(stem, [H, W] final label map)`, by stem.
    label_maps: Vec<(String, Plane<u16>)>,
    /// `[N]` object id of every row of the input PLY (−1 = none); `None` without Gaussians.
    object_ids: Option<Vec<i32>>,
    /// The object table's rows as JSON (`splatseg objects --json`'s `objects`).
    objects_json: String,
    /// `OUT/report.md`.
    report: String,
    /// `OUT/metrics.json`.
    summary_json: String,
}

fn read_outputs(out: &Path) -> Result<Finished, PipelineError> {
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

/// The native `run` (see `python/splatseg/__init__.py` for the documented signature): a dict
/// with `label_maps`, `object_ids`, `objects_json`, `report`, `summary_json`.
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (scene, masks, gaussians, features, depth, depth_kind, out, config_path, config_json))]
pub fn run<'py>(
    py: Python<'py>,
    scene: PathBuf,
    masks: PathBuf,
    gaussians: Option<PathBuf>,
    features: Option<PathBuf>,
    depth: Option<PathBuf>,
    depth_kind: &str,
    out: Option<PathBuf>,
    config_path: Option<PathBuf>,
    config_json: Option<String>,
) -> PyResult<Bound<'py, PyDict>> {
    crate::log_bridge::follow_python_level(py);
    let depth_kind = parse_depth_kind(depth_kind).map_err(|e| errors::value(format!("depth_kind {e}")))?;
    // As `splatseg run`: no output may overwrite an input, checked before anything is read.
    if let Some(out) = &out {
        let inputs = pipeline_inputs(
            &scene,
            Some(&masks),
            features.as_deref(),
            depth.as_deref(),
            gaussians.as_deref(),
            config_path.as_deref(),
        );
        splatseg_scene::paths::refuse_overwrite(&inputs, &run_outputs(out)).map_err(errors::from_scene)?;
    }
    let pipeline = crate::config::pipeline_config(config_path, config_json)?;
    let temporary = match &out {
        Some(_) => None,
        None => Some(
            tempfile::Builder::new()
                .prefix("splatseg-run-")
                .tempdir()
                .map_err(|e| errors::from_pipeline(PipelineError::Io(e)))?,
        ),
    };
    let out_dir = match (&out, &temporary) {
        (Some(out), _) => out.clone(),
        (None, Some(t)) => t.path().to_path_buf(),
        (None, None) => unreachable!("a temporary folder when no `out` is given"),
    };
    let config = RunConfig {
        scene,
        masks,
        features,
        depth,
        depth_kind,
        // A map of another size than its image is refused, naming the file.
        resize_depth: false,
        gaussians,
        gt: None,
        pipeline,
        out: out_dir.clone(),
        // Progress goes to `logging`, never drawn as bars.
        options: RunOptions { strict: false, quiet: true },
    };
    let finished = py
        .detach(|| -> Result<Finished, PipelineError> {
            run_pipeline(&config)?;
            read_outputs(&out_dir)
        })
        .map_err(errors::from_pipeline)?;
    drop(temporary);
    let result = PyDict::new(py);
    let maps = PyDict::new(py);
    for (stem, map) in finished.label_maps {
        maps.set_item(stem, owned_array(py, map.data, &[map.height, map.width])?)?;
    }
    result.set_item("label_maps", maps)?;
    match finished.object_ids {
        Some(ids) => {
            let n = ids.len();
            result.set_item("object_ids", owned_array(py, ids, &[n])?)?
        }
        None => result.set_item("object_ids", py.None())?,
    }
    result.set_item("objects_json", finished.objects_json)?;
    result.set_item("report", finished.report)?;
    result.set_item("summary_json", finished.summary_json)?;
    Ok(result)
}
