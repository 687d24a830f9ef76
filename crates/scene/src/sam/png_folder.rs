//! SAM's PNG-folder output: `metadata.csv` (one row per mask) and `<id>.png` masks.

use super::{check_declared_mask_size, check_same_size, recompute_area_bbox, SamFile, SamMask};
use crate::atomic::write_bytes_atomic;
use crate::error::{SceneError, SceneResult};
use crate::image_io::{image_size, read_grey8, write_png_luma8};
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
/// `dir/<id>.png` (grey, non-zero = inside). Masks come in the order of the rows. `area` and
/// the bbox columns are recomputed from the PNGs, as [`super::read_sam_json`] does
/// ([`SamFile::recomputed`] counts the rows whose values disagreed). A PNG whose header declares more than
/// [`crate::rle::MAX_MASK_PIXELS`] pixels is refused before it is decoded.
pub fn read_sam_png_folder(dir: &Path) -> SceneResult<SamFile> {
    read_folder_sized(dir, None)
}

/// [`read_sam_png_folder`] for masks of a `width × height` image: a PNG of another size is an
/// error naming it and both sizes, raised from its header before it is decoded.
pub fn read_sam_png_folder_for_image(dir: &Path, width: u32, height: u32) -> SceneResult<SamFile> {
    read_folder_sized(dir, Some((width, height)))
}

/// [`read_sam_png_folder`] with an optional expected `(width, height)`.
pub(super) fn read_folder_sized(dir: &Path, expected: Option<(u32, u32)>) -> SceneResult<SamFile> {
    let csv_path = dir.join("metadata.csv");
    if !csv_path.is_file() {
        return Err(SceneError::missing("SAM metadata.csv", csv_path));
    }
    let text = std::fs::read_to_string(&csv_path).map_err(|e| SceneError::io("cannot read", &csv_path, e))?;
    parse_metadata_csv(&text, &csv_path, |id| read_binary_png(&dir.join(format!("{id}.png")), expected))
}

/// Parses the text of a SAM `metadata.csv` (see [`read_sam_png_folder`]); `mask_of(id)` gives
/// the mask of the row with that `id` (the folder reader decodes `<id>.png`). `csv_path` is only
/// named in errors. The fuzz targets' entry point.
pub fn parse_metadata_csv(
    text: &str,
    csv_path: &Path,
    mut mask_of: impl FnMut(&str) -> SceneResult<Plane<bool>>,
) -> SceneResult<SamFile> {
    let invalid = |reason: String| SceneError::invalid(FORMAT, csv_path, reason);
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines.next().ok_or_else(|| invalid("the file is empty".to_string()))?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let column: Vec<Option<usize>> = COLUMNS.iter().map(|c| names.iter().position(|n| n == c)).collect();
    if column[0].is_none() {
        return Err(invalid(format!("the header has no 'id' column: '{header}'")));
    }
    let mut masks = Vec::new();
    let mut disagreeing = 0;
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
        if id.is_empty() || id.contains(['/', '\\']) || id == ".." {
            return Err(invalid(format!("line {line_no}: id '{id}' is not a plain file name")));
        }
        let mut mask = SamMask::from_rle(Rle::encode(&mask_of(id)?));
        let area = value(1)?;
        let bbox = match (value(2)?, value(3)?, value(4)?, value(5)?) {
            (Some(x), Some(y), Some(w), Some(h)) => Some([x, y, w, h]),
            _ => None,
        };
        disagreeing += usize::from(recompute_area_bbox(&mut mask, area, bbox));
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
    Ok(SamFile { masks, recomputed: disagreeing })
}

/// Reads a mask PNG as booleans (non-zero grey = inside). Its header's size is checked first
/// (against `expected` `(width, height)` when known, and against
/// [`crate::rle::MAX_MASK_PIXELS`]), so an oversized PNG is never decoded. A mask must be grey
/// (one channel, or colour channels all equal, as [`read_grey8`] reads it): a PNG with colour
/// pixels is an image, not a mask (every non-black pixel would count as inside), and is an
/// error naming the file and its first colour pixel.
fn read_binary_png(path: &Path, expected: Option<(u32, u32)>) -> SceneResult<Plane<bool>> {
    if !path.is_file() {
        return Err(SceneError::missing("SAM mask PNG listed in metadata.csv", path));
    }
    let (w, h) = image_size(path)?;
    check_declared_mask_size(h as u64, w as u64, expected)
        .map_err(|e| SceneError::invalid("SAM mask PNG", path, e))?;
    match read_grey8(path)? {
        Ok(grey) => Ok(grey.map(|&v| v != 0)),
        Err(c) => Err(SceneError::invalid(
            "SAM mask PNG",
            path,
            format!(
                "pixel ({}, {}) has the colour ({}, {}, {}): a mask must be grey (one channel, \
                 non-zero = inside; SAM writes 0 and 255)",
                c.x, c.y, c.rgb[0], c.rgb[1], c.rgb[2]
            ),
        )),
    }
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
        let pixels = mask.map(|&v| if v { 255u8 } else { 0 });
        write_png_luma8(&png, &pixels)?;
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
