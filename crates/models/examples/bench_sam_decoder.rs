//! Times SAM's prompt decoding as the automatic mask generator runs it, without the image encoder (a
//! random image embedding stands in; speed does not depend on the values):
//!
//! ```text
//! cargo run --release -p splatseg-models --features bench --example bench_sam_decoder -- CHECKPOINT [PROMPTS] [UPSCALED] [CHUNK]
//! ```
//!
//! Prepares the decoder's per-image work, decodes PROMPTS single-point prompts (transformer and IoU
//! head, 64 by default) in chunks of CHUNK (the automatic mask generator's, by default) in parallel
//! over the rayon pool, then upscales all three multimask outputs of
//! the first UPSCALED prompts (8 by default) to the low-resolution logits, then runs the automatic mask
//! generator's per-mask post-processing on those masks, timing each part: the low-resolution stability
//! bound, then the plain steps (upscale to a stored 1280×960 plane, stability score, box, RLE down the
//! columns) and the generator's row pass (upscale row by row with stability, box and mask, RLE by
//! rows) on the same masks, side by side, asserting they agree. Prints the time of each step and a
//! checksum of the outputs (to compare two builds; the inputs are deterministic).

use std::path::Path;
use std::time::Instant;

use candle_core::{Device, Tensor};
use rayon::prelude::*;
use splatseg_models::sam::amg::DECODER_CHUNK;
use splatseg_models::sam::mask_output::{positive_box, positive_rle, MaskScratch};
use splatseg_models::sam::masks::stability_score;
use splatseg_models::sam::stability_bound::StabilityBound;
use splatseg_models::sam::{ImageEmbedding, Sam};

/// Deterministic values in (−1, 1) (the same in every build, so checksums compare).
fn pseudo_random(shape: (usize, usize, usize), seed: u64) -> candle_core::Result<Tensor> {
    let n = shape.0 * shape.1 * shape.2;
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let values: Vec<f32> = (0..n)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 23) as f32 - 1.0
        })
        .collect();
    Tensor::from_vec(values, shape, &Device::Cpu)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        return Err("usage: bench_sam_decoder CHECKPOINT [PROMPTS] [UPSCALED] [CHUNK]".into());
    };
    let prompts: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(64);
    let upscaled: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(8);
    let chunk: usize = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(DECODER_CHUNK).max(1);
    let model = Sam::load(Path::new(path))?;
    let (height, width) = (960usize, 1280usize);
    let embedding = pseudo_random((256, 64, 64), 1)?;
    let image = ImageEmbedding {
        features: embedding.clone(),
        embedding,
        dense_pe: pseudo_random((256, 64, 64), 2)?,
        input_size: (768, 1024),
        original_size: (height, width),
    };
    let side = (prompts as f64).sqrt().ceil() as usize;
    let points: Vec<[f32; 2]> = (0..prompts)
        .map(|i| {
            let (x, y) = (i % side, i / side);
            [(x as f32 + 0.5) * width as f32 / side as f32, (y as f32 + 0.5) * height as f32 / side as f32]
        })
        .collect();
    let t = Instant::now();
    let prepared = model.prepare_decoder(&image)?;
    println!("per-image preparation {:.3?}", t.elapsed());
    let t = Instant::now();
    let ious: Vec<Vec<f32>> = points
        .par_chunks(chunk)
        .map(|chunk| Ok(model.decode_points(&image, &prepared, chunk)?.1))
        .collect::<Result<_, splatseg_models::ModelsError>>()?;
    let decode = t.elapsed();
    println!(
        "decode {prompts} prompts (transformer + IoU head): {decode:.3?}, {:.2} ms per prompt",
        decode.as_secs_f64() * 1e3 / prompts as f64
    );
    let t = Instant::now();
    let lows: Vec<Vec<f32>> = points[..upscaled.min(prompts)]
        .par_iter()
        .map(|p| {
            let (decoded, _) = model.decode_points(&image, &prepared, &[*p])?;
            let low = model.point_masks(&prepared, &decoded, 0, &[0, 1, 2])?;
            Ok(low.flatten_all()?.to_vec1::<f32>()?)
        })
        .collect::<Result<_, splatseg_models::ModelsError>>()?;
    let masks = t.elapsed();
    println!(
        "decode + 3 low-res masks for {} prompts: {masks:.3?}, {:.2} ms per prompt",
        lows.len(),
        masks.as_secs_f64() * 1e3 / lows.len().max(1) as f64
    );
    // the automatic mask generator's per-mask steps: the low-resolution stability bound, upscale to the
    // image, stability score, threshold and box, run-length encoding; each timed on its own
    let (rows, cols) = model.upscale_taps(&image, (256, 256));
    let bound = StabilityBound::new(&rows, &cols, (256, 256));
    let nanos = |t: Instant| t.elapsed().as_nanos() as u64;
    let t = Instant::now();
    // per mask: the plain steps (bound, upscale into a stored plane, stability, box, RLE down the
    // columns), then the generator's (upscale row by row with stability, box and mask, RLE by rows)
    // on the same mask, checked equal
    let per_mask: Vec<[u64; 8]> = lows
        .par_iter()
        .flat_map(|low| low.par_chunks(256 * 256))
        .map_init(
            || (MaskScratch::default(), MaskScratch::default()),
            |(scratch, rows_scratch), low| {
                let s = Instant::now();
                let surely_unstable = bound.as_ref().is_some_and(|b| b.surely_unstable(low, 1.0, 0.95));
                let bound_ns = nanos(s);
                let s = Instant::now();
                let logits = scratch.upscale(low, &rows, &cols, (256, 256));
                let upscale_ns = nanos(s);
                let s = Instant::now();
                let stability = stability_score(logits, 0.0, 1.0);
                let stability_ns = nanos(s);
                let s = Instant::now();
                let bbox = positive_box(logits, width);
                let box_ns = nanos(s);
                let s = Instant::now();
                let rle = positive_rle(logits, &[0, 0, width, height], (height, width));
                let rle_ns = nanos(s);
                let s = Instant::now();
                let measures = rows_scratch.upscale_and_measure(low, &rows, &cols, (256, 256), 1.0);
                let measure_ns = nanos(s);
                let s = Instant::now();
                let by_rows = rows_scratch.positive_rle(&[0, 0, width, height], (height, width));
                let row_rle_ns = nanos(s);
                let same = by_rows == rle
                    && measures.box_xyxy == bbox
                    && measures.stability().to_bits() == stability.to_bits();
                assert!(same, "the row pass differs from the plain steps");
                let checksum =
                    rle.area() + (stability.is_nan() as u64) + bbox[0] as u64 + surely_unstable as u64;
                [bound_ns, upscale_ns, stability_ns, box_ns, rle_ns, measure_ns, row_rle_ns, checksum]
            },
        )
        .collect();
    let post = t.elapsed();
    let n = per_mask.len().max(1) as f64;
    let mean_ms = |i: usize| per_mask.iter().map(|p| p[i]).sum::<u64>() as f64 / n / 1e6;
    let plain = mean_ms(1) + mean_ms(2) + mean_ms(3) + mean_ms(4);
    let by_rows = mean_ms(5) + mean_ms(6);
    println!(
        "post-processing of {} masks at {width}x{height}, both ways: {post:.3?}; per mask (thread time): \
         low-resolution stability bound {:.3} ms; plain: upscaling {:.3} ms, stability {:.3} ms, box {:.3} ms, \
         RLE down the columns {:.3} ms, sum {plain:.3} ms; row pass: upscaling with stability, box and mask \
         {:.3} ms, RLE by rows {:.3} ms, sum {by_rows:.3} ms; ratio {:.2}x (RLE {:.2}x); same masks",
        per_mask.len(),
        mean_ms(0),
        mean_ms(1),
        mean_ms(2),
        mean_ms(3),
        mean_ms(4),
        mean_ms(5),
        mean_ms(6),
        plain / by_rows,
        mean_ms(4) / mean_ms(6)
    );
    let areas: Vec<u64> = per_mask.iter().map(|p| p[7]).collect();
    let iou_sum: f64 = ious.iter().flatten().map(|&v| v as f64).sum();
    let logit_sum: f64 = lows.iter().flatten().map(|&v| v as f64).sum();
    println!("checksum: IoU sum {iou_sum:.6}, logit sum {logit_sum:.4}, areas {}", areas.iter().sum::<u64>());
    Ok(())
}
