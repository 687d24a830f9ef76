//! SAM's PNG-folder output: `metadata.csv` (one row per mask) and `<id>.png` masks.

use super::{check_same_size, SamMask};
use crate::atomic::write_bytes_atomic;
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
            if x.is_finite() && y.is_finite() {
                mask.point_coords = vec![[x, y]];
            }
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

/// Writes masks in SAM's PNG-folder layout: `dir/<i>.png` (8-bit grey, 255 = inside) and
/// `dir/metadata.csv` with SAM's header, one row per mask (the first prompt point, or `nan`
/// when a mask has none). Every file is written atomically; the CSV last.
pub fn write_sam_png_folder(dir: &Path, masks: &[SamMask]) -> SceneResult<()> {
    let mut csv = COLUMNS.join(",");
    csv.push('\n');
    for (i, m) in masks.iter().enumerate() {
        let png = dir.join(format!("{i}.png"));
        let mask = m
            .segmentation
            .decode()
            .map_err(|e| SceneError::invalid("SAM mask", &png, format!("mask {i}: {e}")))?;
        let pixels: Vec<u8> = mask.data.iter().map(|&v| if v { 255 } else { 0 }).collect();
        let img = image::GrayImage::from_raw(mask.width as u32, mask.height as u32, pixels)
            .ok_or_else(|| SceneError::invalid("SAM mask", &png, "mask size disagrees with its data"))?;
        let mut bytes = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
            .map_err(|source| SceneError::Image { path: png.clone(), source })?;
        write_bytes_atomic(&png, &bytes)?;
        let [px, py] = m.point_coords.first().copied().unwrap_or([f64::NAN; 2]);
        let [bx, by, bw, bh] = m.bbox_xywh;
        let [cx, cy, cw, ch] = m.crop_box_xywh;
        let row = [
            i as f64,
            m.area as f64,
            bx,
            by,
            bw,
            bh,
            px,
            py,
            m.predicted_iou,
            m.stability_score,
            cx,
            cy,
            cw,
            ch,
        ];
        let row: Vec<String> = row.iter().map(|v| v.to_string()).collect();
        csv.push_str(&row.join(","));
        csv.push('\n');
    }
    write_bytes_atomic(&dir.join("metadata.csv"), csv.as_bytes())
}
