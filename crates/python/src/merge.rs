//! `splatseg.merge_view`: one view's SAM masks merged with its cues, on arrays, through the
//! pipeline's own per-view merge ([`splatseg_pipeline::merge_view_arrays`], the step `splatseg
//! merge` and `run` take for every view after reading its files).

use crate::arrays::{c_order, owned_array};
use crate::errors;
use numpy::{PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use splatseg_cues::{
    ColourTextureDescriptors, DenseFeatureDescriptors, DepthMap, DescriptorSource, FeatureGrid, FeatureGrids,
    Intrinsics, MaskInput,
};
use splatseg_scene::rle::Rle;
use splatseg_scene::Plane;

/// The name the view goes by inside the merge (its features are looked up under it).
const STEM: &str = "view";

/// `value` as an array of exactly `dtype` (`what` names it in the error).
fn typed<'py, T: numpy::Element, D: numpy::ndarray::Dimension>(
    value: &Bound<'py, PyAny>,
    what: &str,
    expected: &str,
) -> PyResult<numpy::PyReadonlyArray<'py, T, D>> {
    let shape = value.cast::<PyUntypedArray>().map(|a| a.shape().to_vec());
    let dtype = value.getattr("dtype").and_then(|d| d.str()).map(|s| s.to_string()).unwrap_or_default();
    let array = value.cast::<numpy::PyArray<T, D>>().map_err(|_| match &shape {
        Ok(shape) => {
            errors::value(format!("{what} is a {dtype} array of shape {shape:?}: expected {expected}"))
        }
        Err(_) => errors::value(format!("{what} must be a NumPy array: expected {expected}")),
    })?;
    array.try_readonly().map_err(|e| errors::value(format!("{what}: {e}")))
}

/// One mask given as a `bool[H, W]` array.
fn mask_from_array(
    value: &Bound<'_, PyAny>,
    what: &str,
    size: (usize, usize),
    quality: (f32, f32),
) -> PyResult<MaskInput> {
    let (w, h) = size;
    let expected = format!("bool[{h}, {w}] (the image's size)");
    let mask: PyReadonlyArray2<bool> = typed(value, what, &expected)?;
    if mask.shape() != [h, w] {
        return Err(errors::value(format!("{what} has shape {:?}: expected {expected}", mask.shape())));
    }
    Ok(MaskInput::from_row_major(&c_order(&mask), w, quality.0, quality.1))
}

/// One mask given as COCO RLE (`{"size": [H, W], "counts": str | list[int]}`), as SAM's
/// `output_mode="coco_rle"` and its JSON files hold it.
fn mask_from_rle(
    rle: &Bound<'_, PyDict>,
    what: &str,
    size: (usize, usize),
    quality: (f32, f32),
) -> PyResult<MaskInput> {
    let (w, h) = size;
    let bad = |reason: String| errors::value(format!("{what}: {reason}"));
    let declared: Vec<u64> = rle
        .get_item("size")?
        .ok_or_else(|| bad("an RLE needs 'size': [height, width]".into()))?
        .extract()
        .map_err(|_| bad("'size' must be [height, width]".into()))?;
    if declared != [h as u64, w as u64] {
        return Err(bad(format!("size {declared:?} is not the image's [{h}, {w}]")));
    }
    let counts = rle.get_item("counts")?.ok_or_else(|| bad("an RLE needs 'counts'".into()))?;
    let parsed = if let Ok(text) = counts.extract::<String>() {
        Rle::from_coco_string(h as u32, w as u32, &text)
    } else if let Ok(bytes) = counts.cast::<pyo3::types::PyBytes>() {
        // pycocotools' `encode` gives the counts as bytes.
        Rle::from_coco_string(h as u32, w as u32, &String::from_utf8_lossy(bytes.as_bytes()))
    } else {
        let counts: Vec<u32> = counts
            .extract()
            .map_err(|_| bad("'counts' must be a string or a list of non-negative integers".into()))?;
        let rle = Rle { height: h as u32, width: w as u32, counts };
        rle.check().map(|_| rle)
    };
    let rle = parsed.map_err(bad)?;
    MaskInput::from_coco_counts(&rle.counts, w, h, &mut Vec::new(), quality).map_err(bad)
}

/// SAM's masks: a `bool[K, H, W]` array, or a list of `generate()` dicts.
fn mask_inputs(masks: &Bound<'_, PyAny>, size: (usize, usize)) -> PyResult<Vec<MaskInput>> {
    let (w, h) = size;
    if let Ok(list) = masks.cast::<PyList>() {
        return list
            .iter()
            .enumerate()
            .map(|(i, item)| {
                let what = format!("masks[{i}]");
                let dict = item.cast::<PyDict>().map_err(|_| {
                    errors::value(format!(
                        "{what} must be a dict of SAM's generate() output (with 'segmentation')"
                    ))
                })?;
                // SAM's quality fields; 1 when absent, as for a mask file without them.
                let quality = |key: &str| -> PyResult<f32> {
                    match dict.get_item(key)? {
                        Some(v) => Ok(v
                            .extract::<f64>()
                            .map_err(|_| errors::value(format!("{what}['{key}'] must be a number")))?
                            as f32),
                        None => Ok(1.0),
                    }
                };
                let quality = (quality("predicted_iou")?, quality("stability_score")?);
                let segmentation = dict
                    .get_item("segmentation")?
                    .ok_or_else(|| errors::value(format!("{what} has no 'segmentation'")))?;
                match segmentation.cast::<PyDict>() {
                    Ok(rle) => mask_from_rle(rle, &format!("{what}['segmentation']"), size, quality),
                    Err(_) => {
                        mask_from_array(&segmentation, &format!("{what}['segmentation']"), size, quality)
                    }
                }
            })
            .collect();
    }
    let expected =
        format!("bool[K, {h}, {w}] (K masks of the image's size) or a list of SAM generate() dicts");
    let stack: PyReadonlyArray3<bool> = typed(masks, "masks", &expected)?;
    let shape = stack.shape().to_vec();
    if shape[1..] != [h, w] {
        return Err(errors::value(format!("masks has shape {shape:?}: expected {expected}")));
    }
    let all = c_order(&stack);
    Ok(all
        .chunks_exact((w * h).max(1))
        .take(shape[0])
        .map(|m| MaskInput::from_row_major(m, w, 1.0, 1.0))
        .collect())
}

/// The native `merge_view` (see `python/splatseg/__init__.py` for the documented signature).
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (masks, image, features, depth, depth_kind, intrinsics, config_path, config_json))]
pub fn merge_view<'py>(
    py: Python<'py>,
    masks: &Bound<'py, PyAny>,
    image: &Bound<'py, PyAny>,
    features: Option<&Bound<'py, PyAny>>,
    depth: Option<&Bound<'py, PyAny>>,
    depth_kind: &str,
    intrinsics: Option<(f32, f32, f32, f32)>,
    config_path: Option<std::path::PathBuf>,
    config_json: Option<String>,
) -> PyResult<Bound<'py, PyAny>> {
    crate::log_bridge::follow_python_level(py);
    let config = crate::config::pipeline_config(config_path, config_json)?;
    let image: PyReadonlyArray3<u8> = typed(image, "image", "uint8[H, W, 3] (RGB)")?;
    let [h, w, c] = image.shape() else { unreachable!("a 3-d array") };
    let (h, w) = (*h, *w);
    if *c != 3 || h == 0 || w == 0 {
        return Err(errors::value(format!(
            "image has shape {:?}: expected uint8[H, W, 3] (RGB)",
            image.shape()
        )));
    }
    let masks = mask_inputs(masks, (w, h))?;
    let kind = splatseg_cues::depth::parse_depth_kind(depth_kind)
        .map_err(|e| errors::value(format!("depth_kind {e}")))?;
    let Some(depth) = depth else {
        return Err(errors::value(
            "no depth: give depth= (e.g. Depth Anything's output with depth_kind=\"inverse\", or metric z with \
             depth_kind=\"metric\"); merge_view has no Gaussians to render it from",
        ));
    };
    let depth: PyReadonlyArray2<f32> =
        typed(depth, "depth", "float32[H, W] (any size; resampled to the image)")?;
    let depth_plane =
        Plane { width: depth.shape()[1], height: depth.shape()[0], data: c_order(&depth).into_owned() };
    let depth = DepthMap::at_image_size(&depth_plane, kind, w, h)
        .map_err(|e| errors::value(format!("depth: {e}")))?;
    drop(depth_plane);
    let dense = match features {
        Some(f) => {
            let f: PyReadonlyArray3<f32> = typed(f, "features", "float32[h, w, C] (any grid)")?;
            let [fh, fw, fc] = f.shape() else { unreachable!("a 3-d array") };
            let grid = FeatureGrid::checked(*fh, *fw, *fc, c_order(&f).into_owned())
                .map_err(|e| errors::value(format!("features: {e}")))?;
            Some(DenseFeatureDescriptors { grids: FeatureGrids::InMemory(vec![(STEM.to_string(), grid)]) })
        }
        None => None,
    };
    let descriptors: &dyn DescriptorSource = match &dense {
        Some(d) => d,
        None => &ColourTextureDescriptors,
    };
    let intrinsics = intrinsics.map(|(fx, fy, cx, cy)| Intrinsics { fx, fy, cx, cy });
    let rgb = c_order(&image);
    let view = splatseg_pipeline::ViewArrays {
        stem: STEM,
        rgb: &rgb,
        width: w,
        height: h,
        masks: &masks,
        depth: &depth,
        metric: None,
        normals: None,
        descriptors,
        config: &config.merge,
        region_options: config.regions,
        intrinsics,
    };
    let merged = py.detach(|| splatseg_pipeline::merge_view_arrays(&view)).map_err(errors::from_pipeline)?;
    owned_array(py, merged.merged.data, &[h, w])
}
