//! Segment Anything automatic-mask output: the JSON list SAM's `amg.py` writes with
//! `--output-mode coco_rle` (or `uncompressed_rle` / `binary_mask`), and its PNG-folder output
//! (`metadata.csv` plus one `<id>.png` per mask, 255 = inside).
//!
//! One file (or folder) per image, named after the image stem: [`read_view_masks`] finds
//! `<dir>/<stem>.json` or `<dir>/<stem>/metadata.csv`.

mod json;
mod png_folder;

pub use json::{parse_sam_json, read_sam_json, read_sam_json_for_image, write_sam_json};
pub use png_folder::{
    parse_metadata_csv, read_sam_png_folder, read_sam_png_folder_for_image, write_sam_png_folder,
};

use crate::error::{SceneError, SceneResult};
use crate::rle::Rle;
use std::path::Path;

/// One automatic mask, with SAM's per-mask metadata.
#[derive(Clone, Debug, PartialEq)]
pub struct SamMask {
    /// The mask, COCO RLE over the image.
    pub segmentation: Rle,
    /// Bounding box `[x, y, w, h]` in pixels in SAM's convention (`w = x_max - x_min`, see
    /// [`Rle::bbox_xywh_sam`]). The readers always recompute it from the mask: a file's own
    /// value is not trusted.
    pub bbox_xywh: [f64; 4],
    /// Number of pixels inside; the readers recompute it from the mask.
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
    /// A mask whose metadata is derived from the RLE: area and bbox (SAM's convention) from the
    /// mask, predicted IoU and stability 1, no prompt points, the whole image as crop box.
    pub fn from_rle(segmentation: Rle) -> SamMask {
        let bbox = segmentation.bbox_xywh_sam().map(f64::from);
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

/// Checks a mask's declared size (`height × width` as the file states it, before anything of
/// that size is allocated) against the image it belongs to when `expected` (`(width, height)`)
/// is known, and in any case against [`crate::rle::MAX_MASK_PIXELS`].
pub(crate) fn check_declared_mask_size(
    height: u64,
    width: u64,
    expected: Option<(u32, u32)>,
) -> Result<(), String> {
    if let Some((image_w, image_h)) = expected {
        if (height, width) != (image_h as u64, image_w as u64) {
            return Err(format!(
                "declared size [{height}, {width}] (height, width) does not match the image, which is \
                 [{image_h}, {image_w}]"
            ));
        }
    }
    crate::rle::check_declared_size(height, width)
}

/// What a reader read from one SAM file or folder: its masks, and how many of them carried an
/// `area` or `bbox` that disagreed with the mask itself (the readers always use the values
/// recomputed from the mask). The count is data, not a log line: a caller reading many views
/// says it once, with the views it came from (`splatseg run` and `splatseg merge` do).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SamFile {
    /// The masks, in file order.
    pub masks: Vec<SamMask>,
    /// Masks whose file `area` / `bbox` disagreed with the mask and were recomputed.
    pub recomputed: usize,
}

/// Replaces `mask`'s area and bbox by those of its segmentation. Returns whether the values
/// given (`None` = absent, not a disagreement) differed.
pub(crate) fn recompute_area_bbox(mask: &mut SamMask, area: Option<f64>, bbox: Option<[f64; 4]>) -> bool {
    mask.area = mask.segmentation.area();
    mask.bbox_xywh = mask.segmentation.bbox_xywh_sam().map(f64::from);
    let area_differs = area.is_some_and(|a| a != mask.area as f64);
    let bbox_differs = bbox.is_some_and(|b| b != mask.bbox_xywh);
    area_differs || bbox_differs
}

/// Like [`read_view_masks`] for the view whose image is `width × height`: every mask's size is
/// checked against it while reading, before a mask of a declared size is allocated, and the
/// error names the mask file.
pub fn read_view_masks_for_image(
    dir: &Path,
    stem: &str,
    width: u32,
    height: u32,
) -> SceneResult<Option<SamFile>> {
    read_view_masks_sized(dir, stem, Some((width, height)))
}

/// Loads the masks of one view from a per-view folder: `<dir>/<stem>.json` (SAM JSON) or
/// `<dir>/<stem>/metadata.csv` (SAM PNG folder), in that order of preference.
/// `Ok(None)` if neither exists; an error if `dir` itself does not exist. Mask sizes are only
/// checked against [`crate::rle::MAX_MASK_PIXELS`]: prefer [`read_view_masks_for_image`] when
/// the image size is known.
pub fn read_view_masks(dir: &Path, stem: &str) -> SceneResult<Option<SamFile>> {
    read_view_masks_sized(dir, stem, None)
}

/// [`read_view_masks`] with an optional expected `(width, height)`.
fn read_view_masks_sized(
    dir: &Path,
    stem: &str,
    expected: Option<(u32, u32)>,
) -> SceneResult<Option<SamFile>> {
    if !dir.is_dir() {
        return Err(SceneError::missing("SAM mask folder", dir));
    }
    let json = dir.join(format!("{stem}.json"));
    if json.is_file() {
        return json::read_json_sized(&json, expected).map(Some);
    }
    let folder = dir.join(stem);
    if folder.join("metadata.csv").is_file() {
        return png_folder::read_folder_sized(&folder, expected).map(Some);
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
