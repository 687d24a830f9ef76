//! Gaussians between Python and Rust: a dict of NumPy arrays in the INRIA 3DGS layout
//! (`read_ply`, `write_ply`, `extract`, `remove`), the PLY code of `splatseg-scene` and the
//! selections of `splatseg-edit` (the same code as `splatseg extract` / `remove`).
//!
//! The dict: `means` `float32[N, 3]`, `log_scales` `float32[N, 3]`, `rotations_wxyz`
//! `float32[N, 4]`, `raw_opacities` `float32[N]`, `sh` `float32[N, K, 3]` (`K = (degree + 1)²`
//! coefficients, channels last: `sh[:, 0]` is `f_dc_*`, `sh[n, k, c]` for `k ≥ 1` is
//! `f_rest_{c·(K−1) + k − 1}`), and when present `normals` `float32[N, 3]`, `object_ids`
//! `int32[N]` (−1 = no object), `features` `float32[N, D]` (`feat_*`), `extra` (every other
//! property, name → `[N]` array of its PLY type: int8 uint8 int16 uint16 int32 uint32 float32
//! float64).

use crate::arrays::{c_order, owned_array};
use crate::errors;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyAnyMethods, PyDict, PyDictMethods};
use splatseg_scene::gaussians::{sh_coeffs_for_degree, ExtraProperty, FeatureBlock};
use splatseg_scene::Gaussians;

/// `g` as the dict described in the module docs. Moves every buffer that has the dict's layout
/// into its array; `sh` is the only array made anew (the PLY keeps channels first).
pub fn to_dict<'py>(py: Python<'py>, g: Gaussians) -> PyResult<Bound<'py, PyDict>> {
    let n = g.len();
    let k = sh_coeffs_for_degree(g.sh_degree);
    let rest = k - 1;
    let mut sh = vec![0f32; n * k * 3];
    for i in 0..n {
        for c in 0..3 {
            sh[(i * k) * 3 + c] = g.sh_dc[i][c];
            for j in 0..rest {
                sh[(i * k + j + 1) * 3 + c] = g.sh_rest[i * 3 * rest + c * rest + j];
            }
        }
    }
    let dict = PyDict::new(py);
    dict.set_item("means", owned_array(py, g.means.into_flattened(), &[n, 3])?)?;
    dict.set_item("log_scales", owned_array(py, g.log_scales.into_flattened(), &[n, 3])?)?;
    dict.set_item("rotations_wxyz", owned_array(py, g.rotations.into_flattened(), &[n, 4])?)?;
    dict.set_item("raw_opacities", owned_array(py, g.raw_opacities, &[n])?)?;
    dict.set_item("sh", owned_array(py, sh, &[n, k, 3])?)?;
    if let Some(normals) = g.normals {
        dict.set_item("normals", owned_array(py, normals.into_flattened(), &[n, 3])?)?;
    }
    if let Some(ids) = g.object_ids {
        dict.set_item("object_ids", owned_array(py, ids, &[n])?)?;
    }
    if let Some(f) = g.features {
        dict.set_item("features", owned_array(py, f.values, &[n, f.dim])?)?;
    }
    let extra = PyDict::new(py);
    for p in g.extra {
        extra.set_item(&p.name, extra_array(py, &p)?)?;
    }
    dict.set_item("extra", extra)?;
    Ok(dict)
}

/// An extra property's values as an array of its PLY type.
fn extra_array<'py>(py: Python<'py>, p: &ExtraProperty) -> PyResult<Bound<'py, PyAny>> {
    let n = [p.values.len()];
    macro_rules! typed {
        ($t:ty) => {
            owned_array(py, p.values.iter().map(|&v| v as $t).collect::<Vec<$t>>(), &n)
        };
    }
    match p.ply_type.as_str() {
        "char" | "int8" => typed!(i8),
        "uchar" | "uint8" => typed!(u8),
        "short" | "int16" => typed!(i16),
        "ushort" | "uint16" => typed!(u16),
        "int" | "int32" => typed!(i32),
        "uint" | "uint32" => typed!(u32),
        "float" | "float32" => typed!(f32),
        _ => owned_array(py, p.values.clone(), &n),
    }
}

/// The PLY type name of an extra property's NumPy dtype.
fn ply_type_of(name: &str, dtype: &str) -> PyResult<&'static str> {
    Ok(match dtype {
        "int8" => "char",
        "uint8" => "uchar",
        "int16" => "short",
        "uint16" => "ushort",
        "int32" => "int",
        "uint32" => "uint",
        "float32" => "float",
        "float64" => "double",
        other => {
            return Err(errors::value(format!(
                "gaussians['extra']['{name}'] has dtype {other}: expected one of int8, uint8, int16, uint16, \
                 int32, uint32, float32, float64"
            )))
        }
    })
}

/// `dict[key]` as a C-order array of `T` with `shape` (`None` = any length `N`), read in place.
fn column<'py, T: numpy::Element + Copy>(
    dict: &Bound<'py, PyDict>,
    key: &str,
    dtype: &str,
    width: &[usize],
    n: Option<usize>,
) -> PyResult<Option<Vec<T>>> {
    let Some(value) = dict.get_item(key)? else { return Ok(None) };
    let array = value
        .cast::<numpy::PyUntypedArray>()
        .map_err(|_| errors::value(format!("gaussians['{key}'] must be a NumPy array of {dtype}")))?;
    let shape = array.shape().to_vec();
    let expected = |n: &str| {
        let dims: Vec<String> =
            std::iter::once(n.to_string()).chain(width.iter().map(|w| w.to_string())).collect();
        format!("[{}]", dims.join(", "))
    };
    let rows = shape.first().copied().unwrap_or(0);
    if shape.len() != 1 + width.len() || shape[1..] != *width || n.is_some_and(|n| n != rows) {
        let n_text = n.map_or("N".to_string(), |n| n.to_string());
        return Err(errors::value(format!(
            "gaussians['{key}'] has shape {shape:?}: expected {} {dtype}",
            expected(&n_text)
        )));
    }
    let typed = value
        .cast::<numpy::PyArrayDyn<T>>()
        .map_err(|_| errors::value(format!("gaussians['{key}'] must have dtype {dtype}")))?;
    let readonly = typed.try_readonly().map_err(|e| errors::value(format!("gaussians['{key}']: {e}")))?;
    Ok(Some(c_order(&readonly).into_owned()))
}

fn required<T>(value: Option<T>, key: &str) -> PyResult<T> {
    value.ok_or_else(|| {
        errors::value(format!(
            "gaussians has no '{key}': expected the keys of splatseg.read_ply (means, log_scales, \
             rotations_wxyz, raw_opacities, sh)"
        ))
    })
}

fn triples<const K: usize>(flat: Vec<f32>) -> Vec<[f32; K]> {
    flat.chunks_exact(K).map(|c| std::array::from_fn(|i| c[i])).collect()
}

/// The dict described in the module docs as Gaussians; a `ValueError` naming the key whose
/// dtype or shape is wrong.
pub fn from_dict(dict: &Bound<'_, PyDict>) -> PyResult<Gaussians> {
    let means = required(column::<f32>(dict, "means", "float32", &[3], None)?, "means")?;
    let n = means.len() / 3;
    let log_scales = required(column::<f32>(dict, "log_scales", "float32", &[3], Some(n))?, "log_scales")?;
    let rotations =
        required(column::<f32>(dict, "rotations_wxyz", "float32", &[4], Some(n))?, "rotations_wxyz")?;
    let raw_opacities =
        required(column::<f32>(dict, "raw_opacities", "float32", &[], Some(n))?, "raw_opacities")?;
    let sh_value = required(dict.get_item("sh")?, "sh")?;
    let k = sh_value
        .getattr("shape")
        .and_then(|s| s.extract::<Vec<usize>>())
        .ok()
        .and_then(|s| s.get(1).copied())
        .unwrap_or(0);
    let degree = [1usize, 4, 9, 16].iter().position(|&c| c == k).ok_or_else(|| {
        errors::value(format!(
            "gaussians['sh'] has {k} coefficients per channel: expected [N, K, 3] float32 with K = 1, 4, 9 or 16 \
             (SH degree 0-3)"
        ))
    })?;
    let sh = required(column::<f32>(dict, "sh", "float32", &[k, 3], Some(n))?, "sh")?;
    let rest = k - 1;
    let mut sh_dc = Vec::with_capacity(n);
    let mut sh_rest = vec![0f32; n * 3 * rest];
    for i in 0..n {
        sh_dc.push([0, 1, 2].map(|c| sh[i * k * 3 + c]));
        for c in 0..3 {
            for j in 0..rest {
                sh_rest[i * 3 * rest + c * rest + j] = sh[(i * k + j + 1) * 3 + c];
            }
        }
    }
    let normals = column::<f32>(dict, "normals", "float32", &[3], Some(n))?.map(triples::<3>);
    let object_ids = column::<i32>(dict, "object_ids", "int32", &[], Some(n))?;
    let features = match dict.get_item("features")? {
        Some(f) => {
            let dim = f
                .getattr("shape")
                .and_then(|s| s.extract::<Vec<usize>>())
                .ok()
                .and_then(|s| s.get(1).copied());
            let dim = dim.unwrap_or(0);
            column::<f32>(dict, "features", "float32", &[dim], Some(n))?
                .map(|values| FeatureBlock { dim, values })
        }
        None => None,
    };
    let mut extra = Vec::new();
    if let Some(table) = dict.get_item("extra")? {
        let table = table
            .cast_into::<PyDict>()
            .map_err(|_| errors::value("gaussians['extra'] must be a dict: property name -> [N] array"))?;
        for (name, values) in table.iter() {
            let name: String = name.extract()?;
            let array =
                numpy::PyUntypedArrayMethods::shape(values.cast::<numpy::PyUntypedArray>().map_err(
                    |_| errors::value(format!("gaussians['extra']['{name}'] must be a NumPy array")),
                )?)
                .to_vec();
            if array != [n] {
                return Err(errors::value(format!(
                    "gaussians['extra']['{name}'] has shape {array:?}: expected [{n}]"
                )));
            }
            let dtype: String = values.getattr("dtype")?.str()?.extract()?;
            let ply_type = ply_type_of(&name, &dtype)?;
            let as_f64 = values.call_method1("astype", ("float64",))?;
            let as_f64 =
                as_f64.cast_into::<PyArray1<f64>>().map_err(|_| errors::value("internal: astype"))?;
            let values: PyReadonlyArray1<f64> = as_f64.readonly();
            extra.push(ExtraProperty {
                name,
                ply_type: ply_type.to_string(),
                values: values.as_array().to_vec(),
            });
        }
    }
    let g = Gaussians {
        means: triples::<3>(means),
        normals,
        sh_dc,
        sh_degree: degree as u8,
        sh_rest,
        raw_opacities,
        log_scales: triples::<3>(log_scales),
        rotations: triples::<4>(rotations),
        object_ids,
        features,
        extra,
    };
    g.validate_structure().map_err(errors::value)?;
    Ok(g)
}
