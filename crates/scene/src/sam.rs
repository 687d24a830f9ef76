//! Segment Anything automatic-mask output: the JSON list SAM's `amg.py` writes with
//! `--output-mode coco_rle` (or `uncompressed_rle` / `binary_mask`), and its PNG-folder output
//! (`metadata.csv` plus one `<id>.png` per mask, 255 = inside).
//!
//! One file (or folder) per image, named after the image stem: [`read_view_masks`] finds
//! `<dir>/<stem>.json` or `<dir>/<stem>/metadata.csv`.

mod json;
mod png_folder;

pub use json::{read_sam_json, write_sam_json};
pub use png_folder::{read_sam_png_folder, write_sam_png_folder};

use crate::error::{SceneError, SceneResult};
use crate::rle::Rle;
use std::path::Path;

/// One automatic mask, with SAM's per-mask metadata.
#[derive(Clone, Debug, PartialEq)]
pub struct SamMask {
    /// The mask, COCO RLE over the image.
    pub segmentation: Rle,
    /// Bounding box `[x, y, w, h]` in pixels as the file gave it (SAM's own boxes have
    /// `w = x_max - x_min`); from [`Rle::bbox_xywh`] when absent.
    pub bbox_xywh: [f64; 4],
    /// Number of pixels inside (from the mask when absent).
    pub area: u64,
    /// SAM's predicted IoU (1 when absent).
    pub predicted_iou: f64,
    /// SAM's stability score (1 when absent).
    pub stability_score: f64,
    /// `[P]` prompt points `(x, y)` in pixels that produced the mask (empty when absent).
    pub point_coords: Vec<[f64; 2]>,
    /// Crop box `[x, y, w, h]` the mask was predicted in (the whole image when absent).
    pub crop_box_xywh: [f64; 4],
}

impl SamMask {
    /// A mask whose metadata is derived from the RLE: area and bbox from the mask, predicted
    /// IoU and stability 1, no prompt points, the whole image as crop box.
    pub fn from_rle(segmentation: Rle) -> SamMask {
        let bbox = segmentation.bbox_xywh().map(f64::from);
        let crop = [0.0, 0.0, segmentation.width as f64, segmentation.height as f64];
        SamMask {
            area: segmentation.area(),
            bbox_xywh: bbox,
            predicted_iou: 1.0,
            stability_score: 1.0,
            point_coords: Vec::new(),
            crop_box_xywh: crop,
            segmentation,
        }
    }

    /// Mask size `(width, height)`.
    pub fn size(&self) -> (u32, u32) {
        (self.segmentation.width, self.segmentation.height)
    }
}

/// Checks that every mask is `width × height` (the image's size); the error names `path` and
/// the first mask that disagrees.
pub fn check_mask_sizes(masks: &[SamMask], width: u32, height: u32, path: &Path) -> SceneResult<()> {
    match masks.iter().position(|m| m.size() != (width, height)) {
        Some(i) => {
            let (w, h) = masks[i].size();
            Err(SceneError::invalid(
                "SAM masks",
                path,
                format!("mask {i} is {w}×{h} but the image is {width}×{height}"),
            ))
        }
        None => Ok(()),
    }
}

/// Loads the masks of one view from a per-view folder: `<dir>/<stem>.json` (SAM JSON) or
/// `<dir>/<stem>/metadata.csv` (SAM PNG folder), in that order of preference.
/// `Ok(None)` if neither exists; an error if `dir` itself does not exist.
pub fn read_view_masks(dir: &Path, stem: &str) -> SceneResult<Option<Vec<SamMask>>> {
    if !dir.is_dir() {
        return Err(SceneError::missing("SAM mask folder", dir));
    }
    let json = dir.join(format!("{stem}.json"));
    if json.is_file() {
        return read_sam_json(&json).map(Some);
    }
    let folder = dir.join(stem);
    if folder.join("metadata.csv").is_file() {
        return read_sam_png_folder(&folder).map(Some);
    }
    Ok(None)
}

/// Checks that all masks of one file share a size; the error names the first that differs.
pub(crate) fn check_same_size(masks: &[SamMask]) -> Result<(), String> {
    let Some(first) = masks.first() else { return Ok(()) };
    match masks.iter().position(|m| m.size() != first.size()) {
        Some(i) => {
            let (w0, h0) = first.size();
            let (w, h) = masks[i].size();
            Err(format!("mask {i} is {w}×{h} but mask 0 is {w0}×{h0}"))
        }
        None => Ok(()),
    }
}
