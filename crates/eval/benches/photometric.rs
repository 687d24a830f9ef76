//! Speed of the photometric metrics on one 1 MP RGB pair (1000×1000×3): PSNR, SSIM and SSIM with
//! its gradient (what a training step calls). Target: SSIM well under 100 ms on 2 threads
//! (`RAYON_NUM_THREADS=2 cargo bench -p splatseg-eval --features bench --bench photometric`).
//!
//! Measured 2026-11-22 on the idle 2-core AMD EPYC dev VM (AVX path): 2 threads: PSNR 1.0 ms,
//! SSIM 13.7 ms, SSIM + gradient 29.7 ms; 1 thread: 2.0 ms, 25.2 ms, 56.9 ms.

use criterion::{criterion_group, criterion_main, Criterion};
use rand::{Rng, SeedableRng};
use splatseg_eval::{psnr, ssim, ssim_with_grad};

/// A textured image and a noisy, slightly darker copy: `[1000, 1000, 3]` each.
fn pair() -> (Vec<f32>, Vec<f32>, usize, usize) {
    let (w, h) = (1000usize, 1000usize);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let a: Vec<f32> = (0..w * h * 3)
        .map(|i| {
            let (x, y) = ((i / 3) % w, i / 3 / w);
            (0.5 + 0.25 * (x as f32 / 17.0).sin() * (y as f32 / 23.0).cos() + rng.gen_range(-0.1..0.1))
                .clamp(0.0, 1.0)
        })
        .collect();
    let b: Vec<f32> = a.iter().map(|&v| (0.9 * v + rng.gen_range(-0.05..0.05)).clamp(0.0, 1.0)).collect();
    (a, b, w, h)
}

fn bench(c: &mut Criterion) {
    let (a, b, w, h) = pair();
    let mut group = c.benchmark_group("photometric_1mp_rgb");
    group.sample_size(20);
    group.bench_function("psnr", |bench| bench.iter(|| psnr(&a, &b, w, h, 3)));
    group.bench_function("ssim", |bench| bench.iter(|| ssim(&a, &b, w, h, 3)));
    group.bench_function("ssim_with_grad", |bench| {
        bench.iter(|| ssim_with_grad(&a, &b, w, h, 3).map(|r| r.0))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
