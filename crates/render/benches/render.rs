//! Criterion benchmarks: forward and forward+backward at 800×800 for 100k Gaussians, on 1 and 2
//! threads. The large cases (1M Gaussians, 1080p) run only with `SPLATSEG_BENCH_LARGE=1`.
//! Results with dates: `BENCHMARKS.md` (section render).

mod common;

use common::{bench_camera, bench_gaussians};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use splatseg_render::{render, render_bwd, render_with_state, OutputGrads, RenderRequest};

fn cases() -> Vec<(usize, u32, u32)> {
    let mut cases = vec![(100_000, 800, 800)];
    if std::env::var("SPLATSEG_BENCH_LARGE").is_ok_and(|v| v == "1") {
        cases.extend([(100_000, 1920, 1080), (1_000_000, 800, 800), (1_000_000, 1920, 1080)]);
    }
    cases
}

fn bench(c: &mut Criterion) {
    let req = RenderRequest { rgb: true, depth: true, alpha: true, ..RenderRequest::default() };
    for (n, w, h) in cases() {
        let camera = bench_camera(w, h);
        let g = bench_gaussians(n, &camera, 1);
        let blends = render(&g, &camera, &req).expect("render").stats.blends;
        let d_rgb = vec![1e-3f32; (w * h * 3) as usize];
        let grads = OutputGrads { rgb: Some(&d_rgb), ..Default::default() };
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
            let mut group = c.benchmark_group(format!("render_{n}_{w}x{h}_t{threads}"));
            group.sample_size(10);
            // Elements = (pixel, Gaussian) blends, so criterion reports blends per second.
            group.throughput(Throughput::Elements(blends));
            group.bench_function("forward", |b| {
                b.iter(|| pool.install(|| render(&g, &camera, &req).expect("render")))
            });
            group.bench_function("forward_backward", |b| {
                b.iter(|| {
                    pool.install(|| {
                        let (_, state) = render_with_state(&g, &camera, &req).expect("render");
                        render_bwd(&g, &camera, &req, &state, &grads).expect("backward")
                    })
                })
            });
            group.finish();
        }
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
