//! Times SAM's prompt decoding as the automatic mask generator runs it, without the image encoder (a
//! random image embedding stands in; speed does not depend on the values):
//!
//! ```text
//! cargo run --release -p splatseg-models --example bench_sam_decoder -- CHECKPOINT [PROMPTS] [UPSCALED]
//! ```
//!
//! Prepares the decoder's per-image work, decodes PROMPTS single-point prompts (transformer and IoU
//! head, 64 by default) in parallel over the rayon pool, then upscales all three multimask outputs of
//! the first UPSCALED prompts (8 by default) to the low-resolution logits. Prints the time of each step
//! and a checksum of the outputs (to compare two builds).

use std::path::Path;
use std::time::Instant;

use candle_core::{Device, Tensor};
use rayon::prelude::*;
use splatseg_models::sam::{ImageEmbedding, Sam};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        return Err("usage: bench_sam_decoder CHECKPOINT [PROMPTS] [UPSCALED]".into());
    };
    let prompts: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(64);
    let upscaled: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(8);
    let model = Sam::load(Path::new(path))?;
    let (height, width) = (960usize, 1280usize);
    let embedding = Tensor::randn(0f32, 1.0, (256, 64, 64), &Device::Cpu)?;
    let image = ImageEmbedding {
        features: embedding.clone(),
        embedding,
        dense_pe: Tensor::randn(0f32, 1.0, (256, 64, 64), &Device::Cpu)?,
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
        .par_iter()
        .map(|p| Ok(model.decode_points(&image, &prepared, &[*p])?.1))
        .collect::<Result<_, splatseg_models::ModelsError>>()?;
    let decode = t.elapsed();
    println!(
        "decode {prompts} prompts (transformer + IoU head): {decode:.3?}, {:.2} ms per prompt",
        decode.as_secs_f64() * 1e3 / prompts as f64
    );
    let t = Instant::now();
    let sums: Vec<f64> = points[..upscaled.min(prompts)]
        .par_iter()
        .map(|p| {
            let (decoded, _) = model.decode_points(&image, &prepared, &[*p])?;
            let low = model.point_masks(&prepared, &decoded, 0, &[0, 1, 2])?;
            let values = low.flatten_all()?.to_vec1::<f32>()?;
            Ok(values.iter().map(|&v| v as f64).sum::<f64>())
        })
        .collect::<Result<_, splatseg_models::ModelsError>>()?;
    let masks = t.elapsed();
    println!(
        "decode + 3 low-res masks for {} prompts: {masks:.3?}, {:.2} ms per prompt",
        sums.len(),
        masks.as_secs_f64() * 1e3 / sums.len().max(1) as f64
    );
    let iou_sum: f64 = ious.iter().flatten().map(|&v| v as f64).sum();
    println!("checksum: IoU sum {iou_sum:.6}, logit sum {:.4}", sums.iter().sum::<f64>());
    Ok(())
}
