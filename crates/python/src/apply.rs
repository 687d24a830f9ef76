//! `splatseg.apply_edits` and `splatseg.edit_inputs`: a run's `OUT/edits.json` applied to its
//! outputs as `splatseg apply OUT` applies it ([`splatseg_pipeline::apply::apply_edits`]), then the
//! edited outputs read back ([`crate::outputs`]); and the identity of a run that edits must carry.

use crate::errors;
use pyo3::exceptions::PyFileNotFoundError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use splatseg_edit::EDITS_FILE;
use splatseg_pipeline::{PipelineError, RunOptions};
use std::path::PathBuf;

/// The native `apply_edits`: the dict of `run` (the edited outputs) plus `applied_json`, what
/// `splatseg apply` did (operations, changed Gaussians, objects, names, views).
#[pyfunction]
#[pyo3(signature = (out, strict))]
pub fn apply_edits(py: Python<'_>, out: PathBuf, strict: bool) -> PyResult<Bound<'_, PyDict>> {
    crate::log_bridge::follow_python_level(py);
    let edits = out.join(EDITS_FILE);
    if !edits.is_file() {
        return Err(PyFileNotFoundError::new_err(format!(
            "no edits to apply: write the run's corrections into {EDITS_FILE} in its output folder \
             (see splatseg.edit_inputs for its \"inputs\"): {}",
            edits.display()
        )));
    }
    let (summary, finished) = py
        .detach(|| -> Result<_, PipelineError> {
            let summary = splatseg_pipeline::apply::apply_edits(&out, RunOptions { strict, quiet: true })?;
            Ok((summary, crate::outputs::read_outputs(&out)?))
        })
        .map_err(errors::from_pipeline)?;
    let result = finished.into_dict(py)?;
    result.set_item(
        "applied_json",
        serde_json::to_string(&summary).map_err(|e| errors::value(e.to_string()))?,
    )?;
    Ok(result)
}

/// The native `edit_inputs`: the run's identity as the JSON of `edits.json`'s `inputs`.
#[pyfunction]
#[pyo3(signature = (out,))]
pub fn edit_inputs(py: Python<'_>, out: PathBuf) -> PyResult<String> {
    crate::log_bridge::follow_python_level(py);
    let inputs = py.detach(|| splatseg_pipeline::apply::edit_inputs(&out)).map_err(errors::from_pipeline)?;
    serde_json::to_string(&inputs).map_err(|e| errors::value(e.to_string()))
}
