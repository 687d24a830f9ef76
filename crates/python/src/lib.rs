//! `splatseg._native`, the extension module of the Python package `splatseg` (see
//! `python/splatseg/__init__.py` for the documented API and `__init__.pyi` for its types):
//! the pipeline (`run`), one view's merge (`merge_view`), a run's edits applied (`apply_edits`,
//! `edit_inputs`), and PLY reading, writing and editing,
//! on NumPy arrays, calling the workspace's libraries, never the binary.
//!
//! Every call releases the GIL while it works and sends the pipeline's log events to Python's
//! `logging` (logger `splatseg`, [`log_bridge`]). Errors become `FileNotFoundError`, `OSError` or
//! `ValueError` with the command line's messages ([`errors`]). Arrays in C order with the
//! expected dtype are read in place; every returned array owns the Rust buffer it was made from.

mod apply;
mod arrays;
mod config;
mod errors;
mod gaussians;
mod log_bridge;
mod merge;
mod outputs;
mod run;

use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// The native `read_ply`: the finite Gaussians of a 3DGS PLY as a dict of arrays.
#[pyfunction]
#[pyo3(signature = (path, strict))]
fn read_ply<'py>(py: Python<'py>, path: PathBuf, strict: bool) -> PyResult<Bound<'py, PyDict>> {
    log_bridge::follow_python_level(py);
    let g = py
        .detach(|| splatseg_pipeline::ply_input::read_finite(&path, strict))
        .map_err(errors::from_pipeline)?;
    gaussians::to_dict(py, g)
}

/// The native `write_ply`: a dict of arrays written as a binary 3DGS PLY (atomically).
#[pyfunction]
#[pyo3(signature = (path, gaussians, keep_extras))]
fn write_ply(
    py: Python<'_>,
    path: PathBuf,
    gaussians: &Bound<'_, PyDict>,
    keep_extras: bool,
) -> PyResult<()> {
    log_bridge::follow_python_level(py);
    let g = gaussians::from_dict(gaussians)?;
    let extras =
        if keep_extras { splatseg_edit::ExtraFields::Keep } else { splatseg_edit::ExtraFields::Strip };
    py.detach(|| splatseg_edit::io::write_edited_ply(&path, g, extras)).map_err(errors::from_edit)
}

/// The native `extract` / `remove`: the Gaussians of objects `ids`, or all but them.
#[pyfunction]
#[pyo3(signature = (gaussians, ids, keep))]
fn select<'py>(
    py: Python<'py>,
    gaussians: &Bound<'py, PyDict>,
    ids: Vec<i32>,
    keep: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let g = gaussians::from_dict(gaussians)?;
    let picked = py
        .detach(|| if keep { splatseg_edit::extract(&g, &ids) } else { splatseg_edit::remove(&g, &ids) })
        .map_err(errors::from_edit)?;
    gaussians::to_dict(py, picked)
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    log_bridge::install();
    m.add_function(wrap_pyfunction!(run::run, m)?)?;
    m.add_function(wrap_pyfunction!(merge::merge_view, m)?)?;
    m.add_function(wrap_pyfunction!(read_ply, m)?)?;
    m.add_function(wrap_pyfunction!(write_ply, m)?)?;
    m.add_function(wrap_pyfunction!(select, m)?)?;
    m.add_function(wrap_pyfunction!(apply::apply_edits, m)?)?;
    m.add_function(wrap_pyfunction!(apply::edit_inputs, m)?)?;
    Ok(())
}
