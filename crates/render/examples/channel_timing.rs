//! Cost of extra blended channels (the joint stage's 16-channel identity maps): times forward and
//! forward+backward of an RGB-only render and of RGB plus D feature channels on the same scene, side
//! by side in one run, and prints a table with the ratio to RGB only and the cost per extra channel.
//!
//! `cargo run --release -p splatseg-render --features bench --example channel_timing -- [N] [WIDTH] [HEIGHT] [THREADS] [D,D,...]`
//! (defaults: 100000 800 800, all threads, 1,2,4,8,16,32). Best of 3 runs per row; the loss of the
//! backward is `0.001·Σ rgb + 0.001·Σ features`.

#[path = "../benches/common/mod.rs"]
mod common;

use common::{bench_camera, bench_gaussians};
use splatseg_render::{render_bwd, render_with_state, FeatureInput, OutputGrads, RenderRequest};
use std::time::Instant;

/// Best-of-`reps` (forward, forward+backward) seconds for `dim` extra channels (0 = RGB only).
fn time(g: &splatseg_scene::Gaussians, camera: &splatseg_render::RenderCamera, dim: usize) -> (f64, f64) {
    let n = g.len();
    let pixels = camera.pixel_count();
    let features: Vec<f32> = (0..n * dim).map(|i| ((i * 7919) % 1000) as f32 / 1000.0 - 0.5).collect();
    let req = RenderRequest {
        features: (dim > 0).then_some(FeatureInput { values: &features, dim }),
        ..RenderRequest::default()
    };
    let d_rgb = vec![1e-3f32; pixels * 3];
    let d_feat = vec![1e-3f32; pixels * dim];
    let grads =
        OutputGrads { rgb: Some(&d_rgb), features: (dim > 0).then_some(&d_feat[..]), ..Default::default() };
    let (mut fwd, mut both) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..3 {
        let t0 = Instant::now();
        let (_, state) = render_with_state(g, camera, &req).expect("render");
        let t1 = Instant::now();
        let gr = render_bwd(g, camera, &req, &state, &grads).expect("backward");
        let t2 = Instant::now();
        std::hint::black_box(&gr);
        fwd = fwd.min((t1 - t0).as_secs_f64());
        both = both.min((t2 - t0).as_secs_f64());
    }
    (fwd, both)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let num = |i: usize, default: usize| args.get(i).and_then(|s| s.parse().ok()).unwrap_or(default);
    let (n, w, h, threads) = (num(0, 100_000), num(1, 800), num(2, 800), num(3, 0));
    let dims: Vec<usize> = args
        .get(4)
        .map(|s| s.split(',').filter_map(|d| d.parse().ok()).collect())
        .unwrap_or_else(|| vec![1, 2, 4, 8, 16, 32]);
    if threads > 0 {
        rayon::ThreadPoolBuilder::new().num_threads(threads).build_global().expect("thread pool");
    }
    let camera = bench_camera(w as u32, h as u32);
    let g = bench_gaussians(n, &camera, 1);
    println!("n={n} {w}x{h} threads={}", rayon::current_num_threads());
    println!(
        "| extra channels | forward | fwd + bwd | fwd ratio | fwd+bwd ratio | fwd+bwd per extra channel |"
    );
    println!("| ---: | ---: | ---: | ---: | ---: | ---: |");
    let (f0, b0) = time(&g, &camera, 0);
    println!("| 0 (RGB only) | {:.1} ms | {:.1} ms | 1.00 | 1.00 | — |", f0 * 1e3, b0 * 1e3);
    for d in dims {
        let (f, b) = time(&g, &camera, d);
        println!(
            "| {d} | {:.1} ms | {:.1} ms | {:.2} | {:.2} | {:.1} ms ({:.1} %) |",
            f * 1e3,
            b * 1e3,
            f / f0,
            b / b0,
            (b - b0) * 1e3 / d as f64,
            100.0 * (b - b0) / b0 / d as f64
        );
    }
}
