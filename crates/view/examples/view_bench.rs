//! Benchmarks of `splatseg view` in headless Chromium (SwiftShader, i.e. software WebGL on the
//! CPU): the worker's depth sort per frame for 100k and 1M Gaussians, the first frame for the
//! demo's result and for 1M random Gaussians, and the page's size. Prints a Markdown table for
//! BENCHMARKS.md.
//!
//! `cargo run --release -p splatseg-view --features bench --example view_bench -- [out/demo/run]`

use splatseg_scene::Gaussians;
use splatseg_view::browser::{find_chromium, Browser};
use splatseg_view::pack::BYTES_PER_GAUSSIAN;
use splatseg_view::{Site, SourceOptions, ViewServer, ViewSource};
use std::path::PathBuf;

/// `n` Gaussians with deterministic pseudo-random centres in a 2-unit cube, scales of 1–4 mm
/// (≈ 1–2 px σ at the overview camera, so the frame is not all overdraw),
/// random rotations, opacities and colours.
fn random_gaussians(n: usize) -> Gaussians {
    let mut seed = 0x2545_f491_u64;
    let mut next = move || {
        seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (seed >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut g = Gaussians::default();
    for _ in 0..n {
        g.means.push([2.0 * next() - 1.0, 2.0 * next() - 1.0, 2.0 * next() - 1.0]);
        let s = (0.001 + 0.003 * next()).ln();
        g.log_scales.push([s, s + 0.5 * next(), s - 0.5 * next()]);
        g.rotations.push([next() - 0.5, next() - 0.5, next() - 0.5, next() - 0.5]);
        g.raw_opacities.push(4.0 * next() - 1.0);
        g.sh_dc.push([4.0 * next() - 2.0, 4.0 * next() - 2.0, 4.0 * next() - 2.0]);
    }
    g
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// First-frame time (ms) of `source` in a fresh page at the start camera's size.
fn first_frame(browser: &Browser, source: ViewSource) -> Result<f64, Box<dyn std::error::Error>> {
    let server = ViewServer::start(Site::new(source), "127.0.0.1", 0)?;
    browser.goto(&format!("{}?canvas=native", server.url()))?;
    let ready = browser.await_promise("viewer.whenReady()")?;
    let ms = ready["firstFrameMs"].as_f64().ok_or_else(|| format!("page failed: {ready}"))?;
    server.stop();
    Ok(ms)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let paths = find_chromium().ok_or("install chromium and chromium-driver")?;
    let browser = Browser::launch(&paths, 1280, 900)?;
    let mut rows = Vec::new();

    // The sort, timed inside the worker on random centres.
    let tiny = ViewSource {
        ply_path: PathBuf::from("bench.ply"),
        gaussians: random_gaussians(1),
        scene: None,
        views: Vec::new(),
        export_dir: std::env::temp_dir(),
        warnings: Vec::new(),
    };
    let server = ViewServer::start(Site::new(tiny), "127.0.0.1", 0)?;
    browser.goto(server.url())?;
    browser.await_promise("viewer.whenReady()")?;
    for (n, repeats) in [(100_000usize, 20usize), (1_000_000, 10)] {
        let ms = browser.await_promise(&format!("viewer.benchSort({n}, {repeats})"))?;
        let ms: Vec<f64> = ms.as_array().ok_or("no timings")?.iter().filter_map(|v| v.as_f64()).collect();
        rows.push(format!(
            "| depth sort in the worker, {n} Gaussians | {:.1} ms median of {repeats} |",
            median(ms)
        ));
    }
    server.stop();

    if let Some(demo) = std::env::args().nth(1) {
        let source = ViewSource::open(&PathBuf::from(&demo), &SourceOptions::default())?;
        let (n, camera) =
            (source.gaussians.len(), source.scene.as_ref().map(|s| s.cameras[0].width).unwrap_or(0));
        let ms = first_frame(&browser, source)?;
        rows.push(format!("| first frame, demo ({demo}: {n} Gaussians, {camera} px wide) | {ms:.0} ms |"));
        eprintln!("{}", rows.last().map_or("", String::as_str));
    }
    let n = 1_000_000;
    let source = ViewSource {
        ply_path: PathBuf::from("random.ply"),
        gaussians: random_gaussians(n),
        scene: None,
        views: Vec::new(),
        export_dir: std::env::temp_dir(),
        warnings: Vec::new(),
    };
    let ms = first_frame(&browser, source)?;
    rows.push(format!("| first frame, {n} random Gaussians (960×720 canvas) | {ms:.0} ms |"));
    rows.push(format!(
        "| page + assets (HTML, JS, GLSL, CSS), embedded | {:.1} KiB |",
        splatseg_view::assets::total_bytes() as f64 / 1024.0
    ));
    rows.push(format!(
        "| Gaussians on the wire | {BYTES_PER_GAUSSIAN} B each ({:.1} MB for 1M; a degree-3 PLY row is 248 B) |",
        (BYTES_PER_GAUSSIAN * n) as f64 / 1e6
    ));
    println!("| what | result |\n| --- | --- |");
    for row in rows {
        println!("{row}");
    }
    Ok(())
}
