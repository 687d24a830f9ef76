//! SAM's automatic mask generator (`SamAutomaticMaskGenerator`): a grid of single-point prompts per
//! crop, three masks per point, filtered by predicted IoU and stability, de-duplicated by box NMS
//! within and across crops, optional small-region clean-up, masks at full image resolution.
//!
//! Only the work that survives is done: points go through the decoder in chunks, a mask's
//! predicted IoU is read before the mask is formed, its stability is bounded from the
//! low-resolution logits before upscaling ([`super::stability_bound`]), and a mask that may pass is
//! upscaled one row at a time with its stability, box and mask read off each row
//! ([`MaskScratch::upscale_and_measure`]); only masks kept are run-length encoded, by rows. No
//! full-resolution image of logits is stored.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use splatseg_scene::rle::Rle;
use splatseg_scene::sam::SamMask;
use splatseg_scene::Plane;

use super::mask_output::MaskScratch;
use super::masks::{mask_box, near_crop_edge, nms, remove_small_regions, RegionKind};
use super::shared_decoder::DecoderImage;
use super::stability_bound::StabilityBound;
use super::{ImageEmbedding, Sam};
use crate::error::{ModelsError, ModelsResult};

/// Prompts sent through the shared-work decoder at once (fixed, so results do not depend on the thread
/// count; on AVX-512 they do not depend on the chunk either, elsewhere `gemm` rounds by its row count,
/// within 1e-4 — tested); chunks run in parallel. The decoder runs a chunk's token-side layers and its products with the per-image panels
/// on all of its prompts' rows together (each weight matrix and panel read once per chunk), and the
/// rest prompt by prompt. Two to four prompts per chunk measured best, eight slower (a chunk keeps
/// each prompt's `[4096, 256]` image tokens, 4 MB, until its masks are taken).
pub const DECODER_CHUNK: usize = 4;

/// Parameters of the automatic mask generator; defaults are the reference's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct AmgConfig {
    /// Points per side of the prompt grid (32).
    pub points_per_side: usize,
    /// Points per batch (64): masks of a batch are filtered together.
    pub points_per_batch: usize,
    /// Keep masks whose predicted IoU exceeds this (0.88).
    pub pred_iou_thresh: f32,
    /// Keep masks whose stability score reaches this (0.95).
    pub stability_score_thresh: f32,
    /// Logit offset of the stability score (1.0).
    pub stability_score_offset: f32,
    /// Box IoU above which a lower-scored mask of the same crop is dropped (0.7).
    pub box_nms_thresh: f32,
    /// Extra crop layers (0): layer i cuts the image into 2^i × 2^i overlapping crops.
    pub crop_n_layers: usize,
    /// Box IoU for de-duplication across crops (0.7; smaller crops lose).
    pub crop_nms_thresh: f32,
    /// Crop overlap as a fraction of the short side (512 / 1500).
    pub crop_overlap_ratio: f64,
    /// Points per side shrink by this factor per crop layer (1).
    pub crop_n_points_downscale_factor: usize,
    /// Holes and islands smaller than this many pixels are removed (0 = off).
    pub min_mask_region_area: usize,
}

impl Default for AmgConfig {
    fn default() -> Self {
        Self {
            points_per_side: 32,
            points_per_batch: 64,
            pred_iou_thresh: 0.88,
            stability_score_thresh: 0.95,
            stability_score_offset: 1.0,
            box_nms_thresh: 0.7,
            crop_n_layers: 0,
            crop_nms_thresh: 0.7,
            crop_overlap_ratio: 512.0 / 1500.0,
            crop_n_points_downscale_factor: 1,
            min_mask_region_area: 0,
        }
    }
}

/// A mask that survived the per-batch filters.
#[derive(Debug, Clone)]
struct Candidate {
    rle: Rle,
    /// xyxy, inclusive, in image pixels.
    box_xyxy: [f32; 4],
    iou: f32,
    stability: f32,
    /// Prompt point in image pixels.
    point: [f64; 2],
    /// `[x0, y0, x1, y1]`.
    crop_box: [usize; 4],
}

/// How the automatic mask generator runs the mask decoder (same masks either way; tested).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DecoderPath {
    /// Per-image work shared by all prompts, prompts in batches, only masks that pass the
    /// predicted-IoU filter upscaled ([`super::shared_decoder`]).
    #[default]
    Shared,
    /// [`Sam::predict_points`] one point at a time, every mask upscaled: the plain reference-shaped
    /// computation, kept to check the shared one against.
    OneAtATime,
}

/// Runs the automatic mask generator on an 8-bit RGB image (`rgb`: `[height, width, 3]`).
/// `progress(done, total)` is called after each batch of points.
pub fn generate_masks(
    sam: &Sam,
    rgb: &[u8],
    size: (usize, usize),
    config: &AmgConfig,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> ModelsResult<Vec<SamMask>> {
    generate_masks_using(DecoderPath::Shared, sam, rgb, size, config, progress)
}

/// [`generate_masks`] with a chosen decoder path.
pub fn generate_masks_using(
    path: DecoderPath,
    sam: &Sam,
    rgb: &[u8],
    (height, width): (usize, usize),
    config: &AmgConfig,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> ModelsResult<Vec<SamMask>> {
    if rgb.len() != height * width * 3 || height == 0 || width == 0 {
        return Err(ModelsError::Input(format!("{} bytes for a {width}×{height} RGB image", rgb.len())));
    }
    if config.points_per_side == 0 || config.points_per_batch == 0 {
        return Err(ModelsError::Input("points_per_side and points_per_batch must be positive".into()));
    }
    let (crops, layers) = crop_boxes((height, width), config.crop_n_layers, config.crop_overlap_ratio);
    let grids: Vec<Vec<[f64; 2]>> = (0..=config.crop_n_layers)
        .map(|i| {
            point_grid(config.points_per_side / config.crop_n_points_downscale_factor.max(1).pow(i as u32))
        })
        .collect();
    let total: usize = layers.iter().map(|&l| grids[l].len().div_ceil(config.points_per_batch)).sum();
    let mut done = 0;
    let mut all = Vec::new();
    for (crop, layer) in crops.iter().zip(&layers) {
        let found = process_crop(path, sam, rgb, (height, width), crop, &grids[*layer], config, &mut |n| {
            done += n;
            progress(done, total);
        })?;
        all.extend(found);
    }
    if crops.len() > 1 {
        let boxes: Vec<[f32; 4]> = all.iter().map(|c| c.box_xyxy).collect();
        let scores: Vec<f32> = all
            .iter()
            .map(|c| 1.0 / ((c.crop_box[2] - c.crop_box[0]) * (c.crop_box[3] - c.crop_box[1])) as f32)
            .collect();
        all = take(all, &nms(&boxes, &scores, config.crop_nms_thresh));
    }
    if config.min_mask_region_area > 0 {
        all = clean_small_regions(all, config)?;
    }
    Ok(all.into_iter().map(to_sam_mask).collect())
}

fn take(items: Vec<Candidate>, keep: &[usize]) -> Vec<Candidate> {
    let mut slots: Vec<Option<Candidate>> = items.into_iter().map(Some).collect();
    keep.iter().filter_map(|&i| slots[i].take()).collect()
}

fn to_sam_mask(c: Candidate) -> SamMask {
    let b = c.box_xyxy;
    let crop = c.crop_box;
    SamMask {
        area: c.rle.area(),
        segmentation: c.rle,
        bbox_xywh: [b[0] as f64, b[1] as f64, (b[2] - b[0]) as f64, (b[3] - b[1]) as f64],
        predicted_iou: c.iou as f64,
        stability_score: c.stability as f64,
        point_coords: vec![c.point],
        crop_box_xywh: [
            crop[0] as f64,
            crop[1] as f64,
            (crop[2] - crop[0]) as f64,
            (crop[3] - crop[1]) as f64,
        ],
    }
}

/// One decoder chunk's kept low-resolution masks and the low-resolution size, when any.
type ChunkMasks = (Vec<LowResMask>, Option<(usize, usize)>);

/// Masks of one crop: embed, prompt every grid point in batches, filter, NMS.
#[allow(clippy::too_many_arguments)]
fn process_crop(
    path: DecoderPath,
    sam: &Sam,
    rgb: &[u8],
    (height, width): (usize, usize),
    crop: &[usize; 4],
    grid: &[[f64; 2]],
    config: &AmgConfig,
    on_batch: &mut dyn FnMut(usize),
) -> ModelsResult<Vec<Candidate>> {
    let (cw, ch) = (crop[2] - crop[0], crop[3] - crop[1]);
    let mut pixels = Vec::with_capacity(cw * ch * 3);
    for y in crop[1]..crop[3] {
        pixels.extend_from_slice(&rgb[(y * width + crop[0]) * 3..(y * width + crop[2]) * 3]);
    }
    let started = Instant::now();
    let image = sam.embed_image(&pixels, ch, cw)?;
    let prepared = match path {
        DecoderPath::Shared => Some(sam.prepare_decoder(&image)?),
        DecoderPath::OneAtATime => None,
    };
    let mut timing = StageTimes { encoder: started.elapsed().as_secs_f64(), ..StageTimes::default() };
    let points: Vec<[f64; 2]> = grid.iter().map(|p| [p[0] * cw as f64, p[1] * ch as f64]).collect();
    let mut found = Vec::new();
    for batch in points.chunks(config.points_per_batch) {
        found.extend(process_batch(
            sam,
            &image,
            prepared.as_ref(),
            batch,
            crop,
            (height, width),
            config,
            &mut timing,
        )?);
        on_batch(1);
    }
    let started = Instant::now();
    let boxes: Vec<[f32; 4]> = found.iter().map(|c| c.box_xyxy).collect();
    let scores: Vec<f32> = found.iter().map(|c| c.iou).collect();
    let found_count = found.len();
    let mut kept = take(found, &nms(&boxes, &scores, config.box_nms_thresh));
    timing.nms = started.elapsed().as_secs_f64();
    let parts = &timing.parts;
    tracing::debug!(
        "SAM crop {crop:?}: encoder {:.2} s, decoder {:.2} s ({} points in {} batches, {:.3} s per batch; {} \
         masks past the IoU filter), post-processing {:.2} s (thread-seconds: low-resolution stability bound {:.2}, \
         upscaling with stability, box and mask {:.2}, RLE {:.2}; {} dropped by the bound, {} stable, {} away \
         from crop edges), NMS {:.4} s ({} kept)",
        timing.encoder,
        timing.decoder,
        points.len(),
        timing.batches,
        timing.decoder / timing.batches.max(1) as f64,
        timing.upscaled,
        timing.post,
        MaskPartTimes::seconds(&parts.low_res_bound),
        MaskPartTimes::seconds(&parts.upscale_and_measure),
        MaskPartTimes::seconds(&parts.rle),
        timing.surely_unstable,
        timing.stable,
        found_count,
        timing.nms,
        kept.len()
    );
    for c in &mut kept {
        let (dx, dy) = (crop[0] as f32, crop[1] as f32);
        c.box_xyxy = [c.box_xyxy[0] + dx, c.box_xyxy[1] + dy, c.box_xyxy[2] + dx, c.box_xyxy[3] + dy];
        c.point = [c.point[0] + crop[0] as f64, c.point[1] + crop[1] as f64];
    }
    Ok(kept)
}

/// Seconds spent per stage of one crop, for the log (`RUST_LOG=splatseg_models=debug`): the profile
/// of issue 62. The per-mask parts run in parallel, so they are thread-seconds summed over the workers.
#[derive(Debug, Default)]
struct StageTimes {
    /// Image encoder and the decoder's per-image work.
    encoder: f64,
    /// Transformer, IoU head and the low-resolution masks that pass the predicted-IoU filter.
    decoder: f64,
    /// Batches of points decoded.
    batches: usize,
    /// Wall time of the per-mask work (upscaling, thresholds, stability, boxes, RLE).
    post: f64,
    /// The per-mask parts, in thread-seconds.
    parts: MaskPartTimes,
    /// Box NMS within the crop.
    nms: f64,
    /// Masks that passed the predicted-IoU filter.
    upscaled: usize,
    /// Masks the stability bound dropped before upscaling.
    surely_unstable: usize,
    /// Masks that also passed the stability filter.
    stable: usize,
}

/// Thread-nanoseconds of each per-mask part, summed by the workers.
#[derive(Debug, Default)]
struct MaskPartTimes {
    /// The stability bound read from the low-resolution logits.
    low_res_bound: AtomicU64,
    /// Upscaling the low-resolution logits to the image row by row, with the stability counts, the
    /// box and the mask read off each row, and the crop-edge test.
    upscale_and_measure: AtomicU64,
    /// The column-major RLE of the mask, read by rows.
    rle: AtomicU64,
}

impl MaskPartTimes {
    /// Adds the time since `since` to `part` and restarts the clock.
    fn lap(part: &AtomicU64, since: &mut Instant) {
        let now = Instant::now();
        part.fetch_add((now - *since).as_nanos() as u64, Ordering::Relaxed);
        *since = now;
    }

    fn seconds(part: &AtomicU64) -> f64 {
        part.load(Ordering::Relaxed) as f64 * 1e-9
    }
}

/// One batch of points: decode, keep confident and stable masks away from inner crop edges.
/// Boxes and points of the result are still in crop coordinates; masks are over the whole image.
///
/// The predicted-IoU filter runs on the decoder's IoU head before any mask is formed (the reference
/// drops those masks before looking at them, so the result is the same); of the masks that pass, those
/// whose stability score is surely below the threshold, read from the low-resolution logits
/// ([`StabilityBound`]), are dropped without being upscaled (the reference drops them after: same
/// result); the rest are upscaled and scored, and run-length encoded only if they are kept.
#[allow(clippy::too_many_arguments)]
fn process_batch(
    sam: &Sam,
    image: &ImageEmbedding,
    prepared: Option<&DecoderImage>,
    points: &[[f64; 2]],
    crop: &[usize; 4],
    (height, width): (usize, usize),
    config: &AmgConfig,
    timing: &mut StageTimes,
) -> ModelsResult<Vec<Candidate>> {
    let started = Instant::now();
    let (candidates, low_size) = decode_low_res(sam, image, prepared, points, config.pred_iou_thresh)?;
    timing.decoder += started.elapsed().as_secs_f64();
    timing.batches += 1;
    timing.upscaled += candidates.len();
    if candidates.is_empty() {
        return Ok(Vec::new());
    }
    let started = Instant::now();
    let (rows, cols) = sam.upscale_taps(image, low_size);
    let (ch, cw) = image.original_size;
    let image_box = [0, 0, width, height];
    let parts = &timing.parts;
    let bound = StabilityBound::new(&rows, &cols, low_size);
    let (stable, surely_unstable) = (AtomicU64::new(0), AtomicU64::new(0));
    let (offset, thresh) = (config.stability_score_offset, config.stability_score_thresh);
    let kept: Vec<Option<Candidate>> = candidates
        .par_iter()
        .map_init(MaskScratch::default, |scratch, (point, _, low, iou)| {
            let mut clock = Instant::now();
            let dropped = bound.as_ref().is_some_and(|b| b.surely_unstable(low, offset, thresh));
            MaskPartTimes::lap(&parts.low_res_bound, &mut clock);
            if dropped {
                surely_unstable.fetch_add(1, Ordering::Relaxed);
                return None;
            }
            let measures = scratch.upscale_and_measure(low, &rows, &cols, low_size, offset);
            let stability = measures.stability();
            // NaN (empty union) fails too, as in the reference
            let passes = stability >= thresh;
            let box_in_crop = measures.box_xyxy;
            let near_edge = passes && near_crop_edge(&box_in_crop, crop, &image_box, 20.0);
            MaskPartTimes::lap(&parts.upscale_and_measure, &mut clock);
            if !passes {
                return None;
            }
            stable.fetch_add(1, Ordering::Relaxed);
            if near_edge {
                return None;
            }
            debug_assert_eq!((rows.out_len(), cols.out_len()), (ch, cw));
            let rle = scratch.positive_rle(crop, (height, width));
            MaskPartTimes::lap(&parts.rle, &mut clock);
            Some(Candidate {
                rle,
                box_xyxy: box_in_crop,
                iou: *iou,
                stability,
                point: points[*point],
                crop_box: *crop,
            })
        })
        .collect();
    timing.post += started.elapsed().as_secs_f64();
    timing.stable += stable.into_inner() as usize;
    timing.surely_unstable += surely_unstable.into_inner() as usize;
    Ok(kept.into_iter().flatten().collect())
}

/// Masks that pass the predicted-IoU filter (only with a positive threshold, as in the reference), as
/// (point index, multimask output, low-res logits `[lh·lw]`, predicted IoU) in point-then-output order,
/// and the low-res size (lh, lw). Uses the shared-work decoder when `prepared` is given, otherwise
/// [`Sam::predict_points`] one point at a time.
type LowResMask = (usize, usize, Vec<f32>, f32);

fn decode_low_res(
    sam: &Sam,
    image: &ImageEmbedding,
    prepared: Option<&DecoderImage>,
    points: &[[f64; 2]],
    pred_iou_thresh: f32,
) -> ModelsResult<(Vec<LowResMask>, (usize, usize))> {
    let passes = |iou: f32| pred_iou_thresh <= 0.0 || iou > pred_iou_thresh;
    let Some(prepared) = prepared else {
        let mut candidates = Vec::new();
        let mut low_size = (0, 0);
        for (index, point) in points.iter().enumerate() {
            let (low, iou) = sam.predict_points(image, &[[point[0] as f32, point[1] as f32]])?;
            let (b, m, lh, lw) = low.dims4()?;
            low_size = (lh, lw);
            let low = low.flatten_all()?.to_vec1::<f32>()?;
            let iou = iou.flatten_all()?.to_vec1::<f32>()?;
            for i in (0..b * m).filter(|&i| passes(iou[i])) {
                candidates.push((index, i % m, low[i * lh * lw..(i + 1) * lh * lw].to_vec(), iou[i]));
            }
        }
        return Ok((candidates, low_size));
    };
    // chunks in parallel (each chunk's tensors stay small enough for the cache), results in point order
    let decode_chunk = |(chunk_index, chunk): (usize, &[[f64; 2]])| -> ModelsResult<ChunkMasks> {
        let as_f32: Vec<[f32; 2]> = chunk.iter().map(|p| [p[0] as f32, p[1] as f32]).collect();
        let (decoded, iou) = sam.decode_points(image, prepared, &as_f32)?;
        let per_point = iou.len() / chunk.len().max(1);
        let mut found = Vec::new();
        let mut low_size = None;
        for point in 0..chunk.len() {
            let scores = &iou[point * per_point..(point + 1) * per_point];
            let wanted: Vec<usize> = (0..per_point).filter(|&m| passes(scores[m])).collect();
            if wanted.is_empty() {
                continue;
            }
            let low = sam.point_masks(prepared, &decoded, point, &wanted)?;
            let (_, lh, lw) = low.dims3()?;
            low_size = Some((lh, lw));
            let low = low.flatten_all()?.to_vec1::<f32>()?;
            for (slot, &mask) in wanted.iter().enumerate() {
                let logits = low[slot * lh * lw..(slot + 1) * lh * lw].to_vec();
                found.push((chunk_index * DECODER_CHUNK + point, mask, logits, scores[mask]));
            }
        }
        Ok((found, low_size))
    };
    let per_chunk: Vec<ChunkMasks> =
        points.par_chunks(DECODER_CHUNK).enumerate().map(decode_chunk).collect::<ModelsResult<_>>()?;
    let low_size = per_chunk.iter().find_map(|(_, size)| *size).unwrap_or((0, 0));
    Ok((per_chunk.into_iter().flat_map(|(found, _)| found).collect(), low_size))
}

/// `postprocess_small_regions`: fill small holes, drop small islands, prefer unchanged masks in an NMS.
fn clean_small_regions(all: Vec<Candidate>, config: &AmgConfig) -> ModelsResult<Vec<Candidate>> {
    let cleaned: Vec<(Plane<bool>, bool)> = all
        .par_iter()
        .map(|c| {
            let mut mask = c.rle.decode().map_err(ModelsError::Input)?;
            let holes = remove_small_regions(&mut mask, config.min_mask_region_area, RegionKind::Holes);
            let islands = remove_small_regions(&mut mask, config.min_mask_region_area, RegionKind::Islands);
            Ok((mask, !(holes || islands)))
        })
        .collect::<ModelsResult<_>>()?;
    let boxes: Vec<[f32; 4]> = cleaned.iter().map(|(m, _)| mask_box(m)).collect();
    let scores: Vec<f32> = cleaned.iter().map(|(_, unchanged)| if *unchanged { 1.0 } else { 0.0 }).collect();
    let keep = nms(&boxes, &scores, config.box_nms_thresh.max(config.crop_nms_thresh));
    let mut slots: Vec<Option<Candidate>> = all.into_iter().map(Some).collect();
    Ok(keep
        .iter()
        .filter_map(|&i| {
            let mut c = slots[i].take()?;
            if scores[i] == 0.0 {
                c.rle = Rle::encode(&cleaned[i].0);
                c.box_xyxy = boxes[i];
            }
            Some(c)
        })
        .collect())
}

/// `build_point_grid`: `n × n` points (x, y) in (0, 1), cell centres, row by row.
pub fn point_grid(n: usize) -> Vec<[f64; 2]> {
    if n == 0 {
        return Vec::new();
    }
    let offset = 1.0 / (2.0 * n as f64);
    let step = if n > 1 { (1.0 - 2.0 * offset) / (n - 1) as f64 } else { 0.0 };
    let side: Vec<f64> = (0..n).map(|i| offset + step * i as f64).collect();
    side.iter().flat_map(|&y| side.iter().map(move |&x| [x, y])).collect()
}

/// `generate_crop_boxes`: the whole image, then per layer i a 2^(i+1) × 2^(i+1) grid of overlapping
/// crops (x-major order). Returns (`[x0, y0, x1, y1]` boxes, layer of each).
pub fn crop_boxes(
    (height, width): (usize, usize),
    n_layers: usize,
    overlap_ratio: f64,
) -> (Vec<[usize; 4]>, Vec<usize>) {
    let mut boxes = vec![[0, 0, width, height]];
    let mut layers = vec![0];
    let short = height.min(width) as f64;
    for layer in 0..n_layers {
        let n = 1usize << (layer + 1);
        let overlap = (overlap_ratio * short * (2.0 / n as f64)) as usize;
        let crop_len = |len: usize| ((overlap * (n - 1) + len) as f64 / n as f64).ceil() as usize;
        let (cw, ch) = (crop_len(width), crop_len(height));
        let x0s: Vec<usize> = (0..n).map(|i| (cw - overlap) * i).collect();
        let y0s: Vec<usize> = (0..n).map(|i| (ch - overlap) * i).collect();
        for &x0 in &x0s {
            for &y0 in &y0s {
                boxes.push([x0, y0, (x0 + cw).min(width), (y0 + ch).min(height)]);
                layers.push(layer + 1);
            }
        }
    }
    (boxes, layers)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_and_crops_match_the_reference_layout() {
        let g = point_grid(2);
        assert_eq!(g, vec![[0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75]]);
        // 48×64 image, one layer: overlap = int(512/1500·48) = 16, crops 40×32
        let (boxes, layers) = crop_boxes((48, 64), 1, 512.0 / 1500.0);
        assert_eq!(boxes[0], [0, 0, 64, 48]);
        assert_eq!(&boxes[1..], &[[0, 0, 40, 32], [0, 16, 40, 48], [24, 0, 64, 32], [24, 16, 64, 48]]);
        assert_eq!(layers, vec![0, 1, 1, 1, 1]);
        assert_eq!(AmgConfig::default().points_per_side, 32);
    }
}
