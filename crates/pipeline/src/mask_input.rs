//! SAM masks as merge inputs, shared by `splatseg merge` and the pipeline's merge stage: each mask's
//! declared size checked against the image before decoding, row runs built from the COCO counts.

use crate::error::Context;
use splatseg_cues::regions::MaskInput;
use splatseg_scene::sam::SamMask;
use std::path::{Path, PathBuf};

/// One view's SAM masks as merge inputs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ViewMaskInputs {
    /// The masks, in file order.
    pub masks: Vec<MaskInput>,
    /// Masks whose file `area` / `bbox` disagreed with the mask (recomputed; see
    /// [`splatseg_scene::sam::SamFile::recomputed`]): a count for the caller's one warning.
    pub recomputed: usize,
}

/// The SAM masks of view `stem` (`DIR/<stem>.json`, else `DIR/<stem>/metadata.csv`) as merge
/// inputs for its `width × height` image, or `None` when the view has none. Each mask's
/// declared size is checked against the image before it is decoded (the error names the JSON
/// file or the mask PNG); the row runs are then built straight from the COCO counts
/// ([`mask_inputs`]), without a decoded image per mask. Shared by `splatseg merge` and the
/// pipeline's merge stage.
pub fn read_view_mask_inputs(
    dir: &Path,
    stem: &str,
    width: usize,
    height: usize,
) -> crate::Result<Option<ViewMaskInputs>> {
    let too_big = || format!("image of view `{stem}` is {width}×{height}, too large for SAM masks");
    let size =
        (u32::try_from(width).ok().with_context(too_big)?, u32::try_from(height).ok().with_context(too_big)?);
    let Some(file) = splatseg_scene::sam::read_view_masks_for_image(dir, stem, size.0, size.1)? else {
        return Ok(None);
    };
    let recomputed = file.recomputed;
    let inputs = |masks| Some(ViewMaskInputs { masks, recomputed });
    mask_inputs(&file.masks, width, height).map(inputs).map_err(|e| {
        crate::PipelineError::Invalid(format!(
            "SAM masks of view `{stem}`, {e}: {}",
            mask_source(dir, stem).display()
        ))
    })
}

/// `masks` (each `width × height`) as merge inputs, their row runs built from the COCO counts
/// with one reusable `[height · width]` scratch buffer (SAM's predicted IoU and stability score
/// carried over). Equal to `MaskInput::from_plane` of each decoded mask.
pub fn mask_inputs(masks: &[SamMask], width: usize, height: usize) -> Result<Vec<MaskInput>, String> {
    let mut scratch = Vec::new();
    masks
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let quality = (m.predicted_iou as f32, m.stability_score as f32);
            MaskInput::from_coco_counts(&m.segmentation.counts, width, height, &mut scratch, quality)
                .map_err(|e| format!("mask {i}: {e}"))
        })
        .collect()
}

/// The file [`read_view_mask_inputs`] reads the masks of `stem` from (for error messages).
fn mask_source(dir: &Path, stem: &str) -> PathBuf {
    let json = dir.join(format!("{stem}.json"));
    if json.is_file() {
        json
    } else {
        dir.join(stem).join("metadata.csv")
    }
}
