//! Times the models at real sizes (run with random-weight checkpoints; weights do not change speed):
//!
//! ```text
//! cargo run --release -p splatseg-models --example bench_models -- dinov2 CHECKPOINT 518
//! cargo run --release -p splatseg-models --example bench_models -- depth CHECKPOINT 518
//! cargo run --release -p splatseg-models --example bench_models -- sam-encoder CHECKPOINT
//! cargo run --release -p splatseg-models --example bench_models -- sam-amg CHECKPOINT 1024 [POINTS_PER_SIDE]
//! ```

use std::path::Path;
use std::time::Instant;

use candle_core::{DType, Device, Tensor};
use splatseg_models::depth_anything::DepthAnything;
use splatseg_models::dinov2::Dinov2;
use splatseg_models::sam::{generate_masks, AmgConfig, Sam};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        return Err("usage: bench_models dinov2|depth|sam-encoder|sam-amg CHECKPOINT [SIZE] [POINTS]".into());
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
            for chunk in [1usize] {
                let t = Instant::now();
                for part in points.chunks(chunk) {
                    model.predict_points(&embedded, part)?;
                }
                println!("64 points in chunks of {chunk}: {:.2?}", t.elapsed());
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
