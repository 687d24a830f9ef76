//! Lifting benchmark at full size (too slow for criterion's repeated samples):
//!
//! ```sh
//! cargo run --release -p splatseg-lift --features bench --example lift_bench -- 1000000 100 1000 1000
//! ```
//! Arguments: Gaussians, views, width, height (defaults: 1M, 100, 1000 × 1000). Prints the time
//! of each step and the peak resident memory (Linux `VmHWM`).

#[path = "../benches/data/mod.rs"]
mod data;

use rayon::prelude::*;
use splatseg_lift::{
    render_label_map, render_votes, view_visibility, LiftConfig, ObjectFeatures, PreparedGaussians,
    VoteAccumulator,
};
use std::time::Instant;

fn arg(k: usize, default: usize) -> usize {
    std::env::args().nth(k).and_then(|a| a.parse().ok()).unwrap_or(default)
}

fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// CPU seconds (user + system) used by this process so far, from `/proc/self/stat`.
fn cpu_secs() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let ticks = |i: usize| fields.get(i).and_then(|f| f.parse::<f64>().ok()).unwrap_or(f64::NAN);
    (ticks(11) + ticks(12)) / 100.0
}

fn main() {
    let (n, views, width, height) = (arg(1, 1_000_000), arg(2, 100), arg(3, 1000), arg(4, 1000));
    println!("{n} Gaussians, {views} views at {width}×{height}, {} threads", rayon::current_num_threads());
    let g = data::gaussians(n, 1);
    let camera = data::camera(width as u32, height as u32);
    let poses = data::poses(views);
    let maps = data::id_maps(&camera, &poses);
    let features = data::object_features();
    let config = LiftConfig::default();
    println!("inputs ready, peak RSS so far {:.0} MB", peak_rss_mb().unwrap_or(f64::NAN));

    let (t, cpu) = (Instant::now(), cpu_secs());
    let prepared = PreparedGaussians::new(&g).expect("finite Gaussians");
    let t_prepare = t.elapsed().as_secs_f64();
    // Each view's visibility pass and votes, in view order (as the pipeline adds them).
    let (mut t_vis, mut t_vote, mut observations) = (0.0, 0.0, 0usize);
    let mut votes = VoteAccumulator::new(n);
    for (pose, map) in poses.iter().zip(&maps) {
        let t = Instant::now();
        let vis = view_visibility(&prepared, &camera, pose, None, &config).visible;
        t_vis += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let ids: Vec<u32> = vis.pixels.iter().map(|&p| map.data[p as usize]).collect();
        votes.add_view(&vis.gaussians, &vis.weights, &ids).expect("a valid list");
        observations += vis.gaussians.len();
        t_vote += t.elapsed().as_secs_f64();
    }
    let t = Instant::now();
    let lifted = votes.finish(ObjectFeatures { dim: 8, values: &features }, &config).expect("known ids");
    let t_lift = t_vote + t.elapsed().as_secs_f64();
    println!(
        "lifting: prepare {t_prepare:.2} s + visibility {t_vis:.2} s + vote/fuse {t_lift:.2} s = {:.2} s",
        t_prepare + t_vis + t_lift
    );
    println!(
        "  CPU time of lifting {:.2} s (wall time above is inflated when other jobs share the cores)",
        cpu_secs() - cpu
    );
    println!("  {observations} (Gaussian, view) observations; {:?}", lifted.stats);
    println!("  peak RSS {:.0} MB", peak_rss_mb().unwrap_or(f64::NAN));
    let (t, cpu) = (Instant::now(), cpu_secs());
    let votes = render_votes(&lifted, &config);
    let back: Vec<_> = poses
        .par_iter()
        .map(|pose| render_label_map(&prepared, &votes, &camera, pose, &config, None).expect("no kept lists"))
        .collect();
    println!(
        "render-back of {} label maps: {:.2} s ({:.2} CPU s)",
        back.len(),
        t.elapsed().as_secs_f64(),
        cpu_secs() - cpu
    );
    println!("peak RSS {:.0} MB", peak_rss_mb().unwrap_or(f64::NAN));
}
