//! `splatseg.run`: the whole pipeline of `splatseg run` ([`splatseg_pipeline::run_pipeline`]),
//! then its outputs read back as arrays: the final label maps, every input Gaussian's object id,
//! the object table (as `splatseg objects --json OUT/gaussians.ply` prints it) and the report
//! ([`crate::outputs`]).

use crate::errors;
use crate::outputs::Finished;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use splatseg_cues::parse_depth_kind;
use splatseg_pipeline::args::{pipeline_inputs, run_outputs};
use splatseg_pipeline::{run_pipeline, PipelineError, RunConfig, RunOptions};
use std::path::PathBuf;

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
            crate::outputs::read_outputs(&out_dir)
        })
        .map_err(errors::from_pipeline)?;
    drop(temporary);
    finished.into_dict(py)
}
