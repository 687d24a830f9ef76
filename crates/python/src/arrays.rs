//! NumPy arrays in and out: inputs read in place when they are C-contiguous (gathered once in
//! row-major order otherwise, never modified), outputs made from Rust buffers they then own.

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::borrow::Cow;

/// An array's values in row-major (C) order: borrowed in place when the array is C-contiguous,
/// else gathered once (a Fortran-order or strided view).
pub fn c_order<'a, T: numpy::Element + Copy, D: numpy::ndarray::Dimension>(
    a: &'a PyReadonlyArray<'_, T, D>,
) -> Cow<'a, [T]> {
    if a.is_c_contiguous() {
        if let Ok(slice) = a.as_slice() {
            return Cow::Borrowed(slice);
        }
    }
    Cow::Owned(a.as_array().iter().copied().collect())
}

/// A flat row-major Rust buffer as a NumPy array of `shape`, owning the buffer (no copy).
pub fn owned_array<'py, T: numpy::Element>(
    py: Python<'py>,
    data: Vec<T>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    let flat = PyArray1::from_vec(py, data);
    Ok(flat.reshape(shape.to_vec())?.into_any())
}
