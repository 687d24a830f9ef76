//! SAM's JSON mask list (`amg.py --output-mode coco_rle`, also `uncompressed_rle` and
//! `binary_mask`).

use super::{check_declared_mask_size, check_same_size, recompute_area_bbox, SamFile, SamMask};
use crate::atomic::write_bytes_atomic;
use crate::error::{SceneError, SceneResult};
use crate::plane::Plane;
use crate::rle::Rle;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::path::Path;

const FORMAT: &str = "SAM mask JSON";

/// One entry as it appears in the file; everything but `segmentation` is optional.
#[derive(Deserialize)]
struct RawMask {
    segmentation: Value,
    area: Option<f64>,
    bbox: Option<[f64; 4]>,
    predicted_iou: Option<f64>,
    stability_score: Option<f64>,
    point_coords: Option<Vec<[f64; 2]>>,
    crop_box: Option<[f64; 4]>,
}

/// Reads SAM's JSON list of masks. `segmentation` may be a COCO RLE with compressed string
/// counts or uncompressed integer counts (`{"size": [h, w], "counts": ...}`), or a binary mask
/// (list of rows of booleans). `area` and `bbox` are recomputed from each mask (SAM's
/// conventions: pixel count, [`Rle::bbox_xywh_sam`]); [`SamFile::recomputed`] counts the masks
/// whose file values disagreed. Other missing optional fields get the
/// defaults of [`SamMask::from_rle`]. Malformed masks (declared size above
/// [`crate::rle::MAX_MASK_PIXELS`], counts not summing to `h · w`, masks of different sizes)
/// are errors naming the file and the mask index. Use [`read_sam_json_for_image`] when the
/// image size is known.
pub fn read_sam_json(path: &Path) -> SceneResult<SamFile> {
    read_json_sized(path, None)
}

/// [`read_sam_json`] for masks of a `width × height` image: a mask declaring another size is
/// an error naming the file, the mask and both sizes, raised before the mask is decoded.
pub fn read_sam_json_for_image(path: &Path, width: u32, height: u32) -> SceneResult<SamFile> {
    read_json_sized(path, Some((width, height)))
}

/// [`read_sam_json`] with an optional expected `(width, height)`.
pub(super) fn read_json_sized(path: &Path, expected: Option<(u32, u32)>) -> SceneResult<SamFile> {
    let text = std::fs::read_to_string(path).map_err(|e| SceneError::io("cannot read", path, e))?;
    parse_sam_json(&text, path, expected)
}

/// Parses the text of a SAM mask JSON file (see [`read_sam_json`]), with an optional expected
/// `(width, height)`; `path` is only named in errors. The fuzz targets' entry point.
pub fn parse_sam_json(text: &str, path: &Path, expected: Option<(u32, u32)>) -> SceneResult<SamFile> {
    let raw: Vec<RawMask> = serde_json::from_str(text)
        .map_err(|e| SceneError::invalid(FORMAT, path, format!("expected a JSON list of masks: {e}")))?;
    let mut disagreeing = 0;
    let masks = raw
        .into_iter()
        .enumerate()
        .map(|(i, r)| {
            let (mask, differs) = mask_from_raw(r, expected)
                .map_err(|e| SceneError::invalid(FORMAT, path, format!("mask {i}: {e}")))?;
            disagreeing += usize::from(differs);
            Ok(mask)
        })
        .collect::<SceneResult<Vec<_>>>()?;
    check_same_size(&masks).map_err(|e| SceneError::invalid(FORMAT, path, e))?;
    Ok(SamFile { masks, recomputed: disagreeing })
}

/// One mask, and whether the file's `area` / `bbox` disagreed with it.
fn mask_from_raw(raw: RawMask, expected: Option<(u32, u32)>) -> Result<(SamMask, bool), String> {
    let mut mask = SamMask::from_rle(segmentation_from_value(&raw.segmentation, expected)?);
    let differs = recompute_area_bbox(&mut mask, raw.area, raw.bbox);
    if let Some(v) = raw.predicted_iou {
        mask.predicted_iou = v;
    }
    if let Some(v) = raw.stability_score {
        mask.stability_score = v;
    }
    if let Some(points) = raw.point_coords {
        mask.point_coords = points;
    }
    if let Some(crop) = raw.crop_box {
        mask.crop_box_xywh = crop;
    }
    Ok((mask, differs))
}

/// Parses a `segmentation` value: RLE (string or integer counts) or a boolean row list. The
/// declared size is checked (against `expected` `(width, height)` when known, and against
/// [`crate::rle::MAX_MASK_PIXELS`]) before the counts are read.
fn segmentation_from_value(v: &Value, expected: Option<(u32, u32)>) -> Result<Rle, String> {
    match v {
        Value::Object(obj) => {
            let [h, w] = obj
                .get("size")
                .and_then(Value::as_array)
                .filter(|s| s.len() == 2)
                .and_then(|s| Some([s[0].as_u64()?, s[1].as_u64()?]))
                .ok_or("segmentation.size must be [height, width]")?;
            check_declared_mask_size(h, w, expected)?;
            let too_big = |_| format!("segmentation.size [{h}, {w}] does not fit in 32 bits");
            let (h, w) = (u32::try_from(h).map_err(too_big)?, u32::try_from(w).map_err(too_big)?);
            match obj.get("counts") {
                Some(Value::String(s)) => Rle::from_coco_string(h, w, s),
                Some(Value::Array(items)) => {
                    let counts = items
                        .iter()
                        .map(|c| c.as_u64().and_then(|c| u32::try_from(c).ok()))
                        .collect::<Option<Vec<u32>>>()
                        .ok_or("segmentation.counts must be non-negative integers")?;
                    let rle = Rle { height: h, width: w, counts };
                    rle.check()?;
                    Ok(rle)
                }
                _ => Err("segmentation.counts must be a string or a list of integers".to_string()),
            }
        }
        Value::Array(rows) => {
            let width = rows.first().and_then(Value::as_array).map_or(0, Vec::len);
            check_declared_mask_size(rows.len() as u64, width as u64, expected)?;
            binary_mask_from_rows(rows).map(|m| Rle::encode(&m))
        }
        _ => Err("segmentation must be an RLE {size, counts} or a binary mask".to_string()),
    }
}

/// A `binary_mask` segmentation: `[h]` rows of `[w]` booleans (or 0/1).
fn binary_mask_from_rows(rows: &[Value]) -> Result<Plane<bool>, String> {
    let width = rows.first().and_then(Value::as_array).map_or(0, Vec::len);
    let mut data = Vec::with_capacity(width * rows.len());
    for (y, row) in rows.iter().enumerate() {
        let row = row.as_array().filter(|r| r.len() == width).ok_or_else(|| {
            format!("segmentation row {y} is not a list of {width} booleans (polygons are not supported)")
        })?;
        for v in row {
            data.push(match v {
                Value::Bool(b) => *b,
                Value::Number(n) if n.as_u64() == Some(0) => false,
                Value::Number(n) if n.as_u64() == Some(1) => true,
                _ => {
                    return Err(format!(
                        "segmentation row {y} holds {v}, not a boolean (polygons are not supported)"
                    ))
                }
            });
        }
    }
    Ok(Plane { width, height: rows.len(), data })
}

/// The `{size, counts}` object SAM writes.
#[derive(Serialize)]
struct OutRle {
    size: [u32; 2],
    counts: String,
}

/// One entry in SAM's field order.
#[derive(Serialize)]
struct OutMask<'a> {
    segmentation: OutRle,
    area: u64,
    bbox: [f64; 4],
    predicted_iou: f64,
    point_coords: &'a [[f64; 2]],
    stability_score: f64,
    crop_box: [f64; 4],
}

/// Writes masks as SAM's `coco_rle` JSON (compressed string counts), atomically.
pub fn write_sam_json(path: &Path, masks: &[SamMask]) -> SceneResult<()> {
    let out: Vec<OutMask<'_>> = masks
        .iter()
        .map(|m| OutMask {
            segmentation: OutRle {
                size: [m.segmentation.height, m.segmentation.width],
                counts: m.segmentation.to_coco_string(),
            },
            area: m.area,
            bbox: m.bbox_xywh,
            predicted_iou: m.predicted_iou,
            point_coords: &m.point_coords,
            stability_score: m.stability_score,
            crop_box: m.crop_box_xywh,
        })
        .collect();
    let bytes = serde_json::to_vec(&out)
        .map_err(|e| SceneError::invalid(FORMAT, path, format!("cannot encode: {e}")))?;
    write_bytes_atomic(path, &bytes)
}
