//! Times forward and forward+backward renders of a synthetic scene and reports blends and peak
//! memory (what `BENCHMARKS.md` records; criterion benches in `benches/` do the routine runs).
//!
//! `cargo run --release -p splatseg-render --features bench --example render_timing -- N WIDTH HEIGHT [THREADS] [--gsplat] [--dump DIR]`
//! `--gsplat` uses gsplat 1.5's rules (as `tools/bench_gsplat_torch.py`) instead of 3DGS's.
//! `--dump DIR` writes the scene as `.npy` files for `tools/bench_gsplat_torch.py`.

#[path = "../benches/common/mod.rs"]
mod common;

use common::{bench_camera, bench_gaussians};
use splatseg_render::{render_bwd, render_with_state, OutputGrads, RenderRequest};
use splatseg_scene::npy::write_npy_f32;
use std::time::Instant;

fn peak_rss_mib() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let num = |i: usize, default: usize| args.get(i).and_then(|s| s.parse().ok()).unwrap_or(default);
    let (n, w, h, threads) = (num(0, 100_000), num(1, 800), num(2, 800), num(3, 0));
    let dump =
        args.iter().position(|a| a == "--dump").and_then(|i| args.get(i + 1)).map(std::path::PathBuf::from);
    if threads > 0 {
        rayon::ThreadPoolBuilder::new().num_threads(threads).build_global().expect("thread pool");
    }
    let camera = bench_camera(w as u32, h as u32);
    let g = bench_gaussians(n, &camera, 1);
    if let Some(dir) = dump {
        let flat = |v: &[[f32; 3]]| v.iter().flatten().copied().collect::<Vec<f32>>();
        write_npy_f32(&dir.join("means.npy"), &[n, 3], &flat(&g.means)).expect("dump");
        write_npy_f32(&dir.join("log_scales.npy"), &[n, 3], &flat(&g.log_scales)).expect("dump");
        let rot: Vec<f32> = g.rotations.iter().flatten().copied().collect();
        write_npy_f32(&dir.join("quats.npy"), &[n, 4], &rot).expect("dump");
        write_npy_f32(&dir.join("raw_opacities.npy"), &[n], &g.raw_opacities).expect("dump");
        write_npy_f32(&dir.join("sh_dc.npy"), &[n, 3], &flat(&g.sh_dc)).expect("dump");
        write_npy_f32(&dir.join("sh_rest.npy"), &[n, 3, 15], &g.sh_rest).expect("dump");
        let k = [camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0];
        write_npy_f32(&dir.join("K.npy"), &[3, 3], &k).expect("dump");
        write_npy_f32(&dir.join("size.npy"), &[2], &[w as f32, h as f32]).expect("dump");
    }
    let settings = if args.iter().any(|a| a == "--gsplat") {
        splatseg_render::RasterSettings::gsplat_1_5()
    } else {
        splatseg_render::RasterSettings::default()
    };
    let req = RenderRequest { rgb: true, depth: true, alpha: true, settings, ..RenderRequest::default() };
    let t0 = Instant::now();
    let splats = splatseg_render::project::project(&g, &camera, &req.settings);
    let t1 = Instant::now();
    let bins = splatseg_render::bin::bin(&splats, w, h);
    let t2 = Instant::now();
    let channels = vec![0.5f32; n * 4];
    let inputs = splatseg_render::rasterise::RasterInputs {
        splats: &splats,
        channels: &channels,
        channel_count: 4,
        background: &[0.0; 4],
        width: w,
        height: h,
        settings: &req.settings,
    };
    let raster = splatseg_render::rasterise::rasterise(&inputs, &bins);
    let t3 = Instant::now();
    println!(
        "phases: project {:.1} ms, bin {:.1} ms ({} intersections), rasterise {:.1} ms ({} blends)",
        (t1 - t0).as_secs_f64() * 1e3,
        (t2 - t1).as_secs_f64() * 1e3,
        bins.intersection_count(),
        (t3 - t2).as_secs_f64() * 1e3,
        raster.blends
    );
    let reps = 3;
    let mut fwd = f64::INFINITY;
    let mut both = f64::INFINITY;
    let mut stats = Default::default();
    for _ in 0..reps {
        let t0 = Instant::now();
        let (out, state) = render_with_state(&g, &camera, &req).expect("render");
        let t1 = Instant::now();
        let d_rgb = vec![1e-3f32; w * h * 3];
        let d_depth = vec![1e-4f32; w * h];
        let grads = OutputGrads { rgb: Some(&d_rgb), depth: Some(&d_depth), ..Default::default() };
        let gr = render_bwd(&g, &camera, &req, &state, &grads).expect("backward");
        let t2 = Instant::now();
        std::hint::black_box(&gr);
        stats = out.stats;
        fwd = fwd.min((t1 - t0).as_secs_f64());
        both = both.min((t2 - t0).as_secs_f64());
    }
    println!(
        "n={n} {w}x{h} threads={} | forward {:.1} ms, forward+backward {:.1} ms | visible {}, intersections {}, blends {} \
         | forward {:.2} ns/blend, fwd+bwd {:.2} ns/blend | peak RSS {:.0} MiB",
        rayon::current_num_threads(),
        fwd * 1e3,
        both * 1e3,
        stats.visible,
        stats.intersections,
        stats.blends,
        fwd * 1e9 / stats.blends as f64,
        both * 1e9 / stats.blends as f64,
        peak_rss_mib()
    );
}
