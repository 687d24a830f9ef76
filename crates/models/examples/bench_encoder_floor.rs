//! How far SAM's ViT-B image encoder is from the f32 floor of the machine it runs on:
//!
//! ```text
//! cargo run --release -p splatseg-models --features bench --example bench_encoder_floor -- CHECKPOINT [RUNS]
//! ```
//!
//! Times, alternately and RUNS times (3 by default), a matrix product of the encoder's MLP shape
//! (`[4096, 768] × [768, 3072]`, candle on the rayon pool, so `gemm`'s best kernel for the CPU: the
//! f32 rate this machine reaches at this moment, under whatever load it carries) and
//! `Sam::embed_image` on a 1280×960 image (what `cues` runs per view: resized to 1024×768, padded to
//! 1024²). Prints the encoder's multiply-adds counted from its shapes (ViT-B: 12 blocks of width 768 on
//! 64×64 tokens, 8 in 14×14 windows, 4 global, MLP ×4; the patch embedding and the neck), the time it
//! would take at the measured product rate, and the ratio.

use std::path::Path;
use std::time::Instant;

use candle_core::{Device, Tensor};
use splatseg_models::sam::Sam;

/// Multiply-adds of ViT-B's encoder at 1024² (64×64 tokens of width 768).
fn vit_b_multiply_adds() -> f64 {
    let (tokens, dim, blocks) = (64.0 * 64.0, 768.0, 12.0);
    // qkv, output projection, MLP 768 → 3072 → 768
    let linear = tokens * (4.0 * dim * dim + 2.0 * dim * 4.0 * dim) * blocks;
    // 8 windowed blocks: 25 windows of 14² (the grid padded to 70²); 4 global blocks; scores and mixing
    let windowed = 8.0 * 25.0 * 2.0 * 196.0 * 196.0 * dim;
    let global = 4.0 * 2.0 * tokens * tokens * dim;
    let patch_embed = tokens * 16.0 * 16.0 * 3.0 * dim;
    let neck = tokens * (dim * 256.0 + 9.0 * 256.0 * 256.0);
    linear + windowed + global + patch_embed + neck
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        return Err("usage: bench_encoder_floor CHECKPOINT [RUNS]".into());
    };
    let runs: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(3).max(1);
    let model = Sam::load(Path::new(path))?;
    let (height, width) = (960usize, 1280usize);
    let rgb: Vec<u8> = (0..height * width * 3).map(|i| ((i * 2_654_435_761) >> 13) as u8).collect();
    let a = Tensor::rand(-1f32, 1.0, (4096, 768), &Device::Cpu)?;
    let b = Tensor::rand(-1f32, 1.0, (768, 3072), &Device::Cpu)?;
    let product_macs = 4096.0 * 768.0 * 3072.0;
    let encoder_macs = vit_b_multiply_adds();
    println!("encoder: {:.1} G multiply-adds ({:.2} TFLOP)", encoder_macs / 1e9, 2.0 * encoder_macs / 1e12);
    for run in 0..runs {
        let t = Instant::now();
        let mut products = 0;
        while t.elapsed().as_secs_f64() < 2.0 {
            a.matmul(&b)?;
            products += 1;
        }
        let rate = products as f64 * 2.0 * product_macs / t.elapsed().as_secs_f64();
        let t = Instant::now();
        model.embed_image(&rgb, height, width)?;
        let encoder = t.elapsed().as_secs_f64();
        let floor = 2.0 * encoder_macs / rate;
        println!(
            "run {run}: product {:.1} GFLOP/s; encoder {encoder:.2} s; at the product's rate {floor:.2} s; \
             encoder / floor {:.2}x",
            rate / 1e9,
            encoder / floor
        );
    }
    Ok(())
}
