//! Times the models at real sizes (run with random-weight checkpoints; weights do not change speed):
//!
//! ```text
//! cargo run --release -p splatseg-models --features compare-candle --example bench_models -- dinov2 CHECKPOINT 518
//! cargo run --release -p splatseg-models --features compare-candle --example bench_models -- depth CHECKPOINT 518
//! cargo run --release -p splatseg-models --features compare-candle --example bench_models -- depth-vs-candle CHECKPOINT 518
//! cargo run --release -p splatseg-models --features compare-candle --example bench_models -- dinov2-vs-candle CHECKPOINT 518
//! cargo run --release -p splatseg-models --features compare-candle --example bench_models -- sam-encoder CHECKPOINT
//! cargo run --release -p splatseg-models --features compare-candle --example bench_models -- sam-vs-candle CHECKPOINT
//! cargo run --release -p splatseg-models --features compare-candle --example bench_models -- mobile-sam-vs-candle CHECKPOINT
//! cargo run --release -p splatseg-models --features compare-candle --example bench_models -- sam-decoder CHECKPOINT
//! cargo run --release -p splatseg-models --features compare-candle --example bench_models -- sam-amg CHECKPOINT 1024 [POINTS_PER_SIDE]
//! ```
//!
//! `depth-vs-candle` times ours against candle-transformers' Depth Anything V2-S (square inputs only;
//! its output is 520² for 518² from a padding bug) on the same weights. If CHECKPOINT (a `.safetensors`
//! path) does not exist, random weights at the released ViT-S size are written there first, under the
//! original `pretrained.*` / `depth_head.*` names that both implementations read.
//!
//! `dinov2-vs-candle` does the same for DINOv2 ViT-S/14 (the patch features after the final norm, on a
//! SIZE² input; the written checkpoint has the original facebookresearch names plus the classifier
//! `head.*` that candle-transformers requires and ours ignores), and `sam-vs-candle` for the SAM ViT-B
//! image encoder at 1024² (official `image_encoder.*` / `prompt_encoder.*` / `mask_decoder.*` names);
//! `mobile-sam-vs-candle` the same for MobileSAM's TinyViT-5M encoder (`mobile_sam.pt` names).

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use candle_core::{DType, Device, Module, Tensor};
use candle_nn::{VarBuilder, VarMap};
use candle_transformers::models::segment_anything::sam as ct_sam;
use candle_transformers::models::{depth_anything_v2, dinov2 as ct_dinov2};
use splatseg_models::depth_anything::DepthAnything;
use splatseg_models::dinov2::Dinov2;
use splatseg_models::sam::{generate_masks, AmgConfig, Sam};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        return Err("usage: bench_models dinov2|depth|depth-vs-candle|dinov2-vs-candle|sam-encoder|sam-vs-candle|mobile-sam-vs-candle|sam-amg CHECKPOINT [SIZE] [POINTS]".into());
    }
    let path = Path::new(&args[2]);
    let size: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(518);
    let start = Instant::now();
    match args[1].as_str() {
        "dinov2" => {
            let model = Dinov2::load(path)?;
            println!("load {:.2?}", start.elapsed());
            let x = Tensor::randn(0f32, 1.0, (3, size, size), &Device::Cpu)?;
            for run in 0..2 {
                let t = Instant::now();
                let f = model.patch_features(&x)?;
                println!("run {run}: {:?} in {:.2?}", f.dims(), t.elapsed());
            }
        }
        "depth" => {
            let model = DepthAnything::load(path)?;
            let x = Tensor::randn(0f32, 1.0, (3, size, size), &Device::Cpu)?;
            for run in 0..2 {
                let t = Instant::now();
                let d = model.forward(&x)?;
                println!("run {run}: {:?} in {:.2?}", d.dims(), t.elapsed());
            }
        }
        "depth-vs-candle" => depth_vs_candle(path, size)?,
        "dinov2-vs-candle" => dinov2_vs_candle(path, size)?,
        "sam-vs-candle" => sam_vs_candle(path, false)?,
        "mobile-sam-vs-candle" => sam_vs_candle(path, true)?,
        "sam-encoder" => {
            let model = Sam::load(path)?;
            let rgb = Tensor::rand(0f32, 255.0, (1024 * 1024 * 3,), &Device::Cpu)?
                .to_dtype(DType::U8)?
                .to_vec1::<u8>()?;
            for run in 0..2 {
                let t = Instant::now();
                let e = model.embed_image(&rgb, 1024, 1024)?;
                println!("run {run}: {:?} in {:.2?}", e.features.dims(), t.elapsed());
            }
        }
        "sam-decoder" => {
            let model = Sam::load(path)?;
            let rgb = vec![128u8; 1024 * 1024 * 3];
            let embedded = model.embed_image(&rgb, 1024, 1024)?;
            let points: Vec<[f32; 2]> = (0..64).map(|i| [(i * 16) as f32, (i * 8) as f32]).collect();
            let t = Instant::now();
            for part in points.chunks(1) {
                model.predict_points(&embedded, part)?;
            }
            println!("one at a time: 64 points in {:.2?} (every mask upscaled)", t.elapsed());
            let t = Instant::now();
            let prepared = model.prepare_decoder(&embedded)?;
            println!("shared: per-image preparation {:.2?}", t.elapsed());
            for chunk in [1usize, 4, 16, 64] {
                let t = Instant::now();
                for part in points.chunks(chunk) {
                    model.decode_points(&embedded, &prepared, part)?;
                }
                let tokens = t.elapsed();
                let t = Instant::now();
                for part in points.chunks(chunk) {
                    let (decoded, _) = model.decode_points(&embedded, &prepared, part)?;
                    for p in 0..part.len() {
                        model.point_masks(&prepared, &decoded, p, &[0, 1, 2])?;
                    }
                }
                println!(
                    "shared, batches of {chunk}: 64 points in {tokens:.2?} (transformer + IoU only), {:.2?} with all masks upscaled",
                    t.elapsed()
                );
            }
        }
        "sam-amg" => {
            let model = Sam::load(path)?;
            let points: usize = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(32);
            let rgb: Vec<u8> = (0..size * size * 3).map(|i| ((i * 7 + i / 3000) % 251) as u8).collect();
            let config = AmgConfig {
                points_per_side: points,
                pred_iou_thresh: 0.0,
                stability_score_thresh: 0.0,
                // keep every mask (random weights give near-identical full-image boxes that NMS would
                // fold into one): the worst case for memory
                box_nms_thresh: 1.0,
                ..AmgConfig::default()
            };
            let t = Instant::now();
            let masks = generate_masks(&model, &rgb, (size, size), &config, &|_, _| {})?;
            println!("{} masks for {points}² points on {size}² in {:.2?}", masks.len(), t.elapsed());
        }
        other => return Err(format!("unknown model `{other}`").into()),
    }
    Ok(())
}

/// Ours against candle-transformers' Depth Anything V2-S on the same (random, if `path` is missing) weights.
fn depth_vs_candle(path: &Path, size: usize) -> Result<(), Box<dyn std::error::Error>> {
    let device = Device::Cpu;
    let config = depth_anything_v2::DepthAnythingV2Config::vit_small();
    if !path.exists() {
        // Building candle-transformers' model on a VarMap creates every tensor it reads, at the
        // released shapes, randomly initialised; saving the map gives the shared checkpoint.
        let varmap = VarMap::new();
        let vb = VarBuilder::from_varmap(&varmap, DType::F32, &device);
        let backbone = Arc::new(ct_dinov2::vit_small(vb.pp("pretrained"))?);
        depth_anything_v2::DepthAnythingV2::new(
            backbone,
            depth_anything_v2::DepthAnythingV2Config::vit_small(),
            vb,
        )?;
        varmap.save(path)?;
        println!("wrote random weights to {}", path.display());
    }
    let x = Tensor::randn(0f32, 1.0, (3, size, size), &device)?;

    let t = Instant::now();
    let ours = DepthAnything::load(path)?;
    println!("ours: load {:.2?}", t.elapsed());
    for run in 0..2 {
        let t = Instant::now();
        let d = ours.forward(&x)?;
        println!("ours run {run}: {:?} in {:.2?}", d.dims(), t.elapsed());
    }
    drop(ours);

    let t = Instant::now();
    // SAFETY: the checkpoint is not modified while mapped.
    let vb = unsafe { VarBuilder::from_mmaped_safetensors(&[path], DType::F32, &device)? };
    let backbone = Arc::new(ct_dinov2::vit_small(vb.pp("pretrained"))?);
    let theirs = depth_anything_v2::DepthAnythingV2::new(backbone, config, vb)?;
    println!("candle-transformers: load {:.2?}", t.elapsed());
    let batch = x.unsqueeze(0)?;
    for run in 0..2 {
        let t = Instant::now();
        let d = theirs.forward(&batch)?;
        println!("candle-transformers run {run}: {:?} in {:.2?}", d.dims(), t.elapsed());
    }
    Ok(())
}

/// Ours against candle-transformers' DINOv2 ViT-S/14 on the same (random, if `path` is missing) weights:
/// normalised last-layer patch features of a `size`² input.
fn dinov2_vs_candle(path: &Path, size: usize) -> Result<(), Box<dyn std::error::Error>> {
    let device = Device::Cpu;
    if !path.exists() {
        // As in `depth_vs_candle`: the VarMap holds every tensor candle-transformers reads (including
        // its classifier head), at the released ViT-S/14 shapes.
        let varmap = VarMap::new();
        let vb = VarBuilder::from_varmap(&varmap, DType::F32, &device);
        ct_dinov2::vit_small(vb)?;
        varmap.save(path)?;
        println!("wrote random weights to {}", path.display());
    }
    let x = Tensor::randn(0f32, 1.0, (3, size, size), &device)?;

    let t = Instant::now();
    let ours = Dinov2::load(path)?;
    println!("ours: load {:.2?}", t.elapsed());
    for run in 0..2 {
        let t = Instant::now();
        let f = ours.patch_features(&x)?;
        println!("ours run {run}: {:?} in {:.2?}", f.dims(), t.elapsed());
    }
    drop(ours);

    let t = Instant::now();
    // SAFETY: the checkpoint is not modified while mapped.
    let vb = unsafe { VarBuilder::from_mmaped_safetensors(&[path], DType::F32, &device)? };
    let theirs = ct_dinov2::vit_small(vb)?;
    println!("candle-transformers: load {:.2?}", t.elapsed());
    let batch = x.unsqueeze(0)?;
    for run in 0..2 {
        let t = Instant::now();
        // Last block (of 12), final norm, reshaped to [1, C, h, w], no class token.
        let f = theirs.get_intermediate_layers(&batch, &[11], true, false, true)?;
        println!("candle-transformers run {run}: {:?} in {:.2?}", f.dims(), t.elapsed());
    }
    Ok(())
}

/// Ours against candle-transformers' SAM ViT-B (or, with `tiny`, MobileSAM's TinyViT-5M) image encoder at
/// 1024² on the same (random, if `path` is missing) weights.
fn sam_vs_candle(path: &Path, tiny: bool) -> Result<(), Box<dyn std::error::Error>> {
    let device = Device::Cpu;
    // ViT-B: 768 wide, 12 blocks, 12 heads, global attention in blocks 2, 5, 8, 11.
    let build = |vb: VarBuilder| {
        if tiny {
            ct_sam::Sam::new_tiny(vb)
        } else {
            ct_sam::Sam::new(768, 12, 12, &[2, 5, 8, 11], vb)
        }
    };
    if !path.exists() {
        let varmap = VarMap::new();
        build(VarBuilder::from_varmap(&varmap, DType::F32, &device))?;
        varmap.save(path)?;
        println!("wrote random weights to {}", path.display());
    }
    let rgb = Tensor::rand(0f32, 255.0, (1024 * 1024 * 3,), &device)?.to_dtype(DType::U8)?.to_vec1::<u8>()?;

    let t = Instant::now();
    let ours = Sam::load(path)?;
    println!("ours: load {:.2?}", t.elapsed());
    for run in 0..2 {
        let t = Instant::now();
        let e = ours.embed_image(&rgb, 1024, 1024)?;
        println!("ours run {run}: {:?} in {:.2?}", e.features.dims(), t.elapsed());
    }
    drop(ours);

    let t = Instant::now();
    // SAFETY: the checkpoint is not modified while mapped.
    let vb = unsafe { VarBuilder::from_mmaped_safetensors(&[path], DType::F32, &device)? };
    let theirs = build(vb)?;
    println!("candle-transformers: load {:.2?}", t.elapsed());
    // [3, 1024, 1024] u8; `embeddings` normalises with the same mean / std and pads (nothing here).
    let image = Tensor::from_vec(rgb, (1024, 1024, 3), &device)?.permute((2, 0, 1))?;
    for run in 0..2 {
        let t = Instant::now();
        let e = theirs.embeddings(&image)?;
        println!("candle-transformers run {run}: {:?} in {:.2?}", e.dims(), t.elapsed());
    }
    Ok(())
}
