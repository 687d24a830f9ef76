//! SAM's PNG-folder output: `metadata.csv` (one row per mask) and `<id>.png` masks.

use super::{check_same_size, SamMask};
use crate::error::{SceneError, SceneResult};
use crate::plane::Plane;
use crate::rle::Rle;
use std::path::Path;

const FORMAT: &str = "SAM metadata.csv";

/// Columns of SAM's `metadata.csv` that this reader uses (only `id` is required).
const COLUMNS: [&str; 14] = [
    "id",
    "area",
    "bbox_x0",
    "bbox_y0",
    "bbox_w",
    "bbox_h",
    "point_input_x",
    "point_input_y",
    "predicted_iou",
    "stability_score",
    "crop_box_x0",
    "crop_box_y0",
    "crop_box_w",
    "crop_box_h",
];

/// Reads a SAM PNG folder: `dir/metadata.csv` with header
/// `id,area,bbox_x0,bbox_y0,bbox_w,bbox_h,point_input_x,point_input_y,predicted_iou,
/// stability_score,crop_box_x0,crop_box_y0,crop_box_w,crop_box_h` and, for each row, the mask
/// `dir/<id>.png` (grey, non-zero = inside). Masks come in the order of the rows.
pub fn read_sam_png_folder(dir: &Path) -> SceneResult<Vec<SamMask>> {
    let csv_path = dir.join("metadata.csv");
    if !csv_path.is_file() {
        return Err(SceneError::missing("SAM metadata.csv", csv_path));
    }
    let text = std::fs::read_to_string(&csv_path).map_err(|e| SceneError::io("cannot read", &csv_path, e))?;
    let invalid = |reason: String| SceneError::invalid(FORMAT, &csv_path, reason);
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines.next().ok_or_else(|| invalid("the file is empty".to_string()))?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let column: Vec<Option<usize>> = COLUMNS.iter().map(|c| names.iter().position(|n| n == c)).collect();
    if column[0].is_none() {
        return Err(invalid(format!("the header has no 'id' column: '{header}'")));
    }
    let mut masks = Vec::new();
    for (line_index, line) in lines {
        let line_no = line_index + 1;
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != names.len() {
            return Err(invalid(format!(
                "line {line_no} has {} fields but the header has {}",
                fields.len(),
                names.len()
            )));
        }
        let value = |k: usize| -> Result<Option<f64>, SceneError> {
            let Some(c) = column[k] else { return Ok(None) };
            fields[c].parse::<f64>().map(Some).map_err(|_| {
                invalid(format!("line {line_no}: {} '{}' is not a number", COLUMNS[k], fields[c]))
            })
        };
        let id = fields[column[0].unwrap_or(0)];
        let png = dir.join(format!("{id}.png"));
        let mut mask = SamMask::from_rle(Rle::encode(&read_binary_png(&png)?));
        if let Some(area) = value(1)? {
            mask.area = area.max(0.0) as u64;
        }
        if let (Some(x), Some(y), Some(w), Some(h)) = (value(2)?, value(3)?, value(4)?, value(5)?) {
            mask.bbox_xywh = [x, y, w, h];
        }
        if let (Some(x), Some(y)) = (value(6)?, value(7)?) {
            mask.point_coords = vec![[x, y]];
        }
        if let Some(v) = value(8)? {
            mask.predicted_iou = v;
        }
        if let Some(v) = value(9)? {
            mask.stability_score = v;
        }
        if let (Some(x), Some(y), Some(w), Some(h)) = (value(10)?, value(11)?, value(12)?, value(13)?) {
            mask.crop_box_xywh = [x, y, w, h];
        }
        masks.push(mask);
    }
    check_same_size(&masks).map_err(invalid)?;
    Ok(masks)
}

/// Reads a mask PNG as booleans (non-zero grey = inside).
fn read_binary_png(path: &Path) -> SceneResult<Plane<bool>> {
    if !path.is_file() {
        return Err(SceneError::missing("SAM mask PNG listed in metadata.csv", path));
    }
    let img = image::open(path)
        .map_err(|source| SceneError::Image { path: path.to_path_buf(), source })?
        .into_luma8();
    let (w, h) = img.dimensions();
    Ok(Plane {
        width: w as usize,
        height: h as usize,
        data: img.into_raw().into_iter().map(|v| v != 0).collect(),
    })
}
