//! The compositor passes of `splatseg run` on a real scene folder (e.g. one written by
//! `splatseg bench scale`), one view at a time on one thread, so each pass's cost can be compared
//! before / after a change without the rest of the pipeline:
//!
//! ```sh
//! cargo run --release -p splatseg-lift --features bench --example scene_passes -- SCENE_DIR [VIEWS]
//! ```
//! Reads `SCENE_DIR/gaussians.ply` and the cameras, and, for the first VIEWS views (default 3),
//! times the visibility pass (projection and binning, surface depth, visibility test) and the label
//! map rendered back with the pass's tile lists, as `run` does (votes: the scene's
//! `gt/gaussian_ids.npy` when present, else index / 997). Prints
//! per pass the seconds per view and a checksum of the outputs, so two builds can be compared
//! for equal results as well as speed. With `STATS=1` it also prints, per view, the visible
//! splats, the (splat, tile) pairs and the blends per pixel (all, until T < 0.5, until T < 0.1).

use splatseg_lift::{
    project_view, render_label_map, view_visibility, LiftConfig, PreparedGaussians, RenderVotes,
};
use splatseg_scene::load::LoadOptions;
use std::path::PathBuf;
use std::time::Instant;

/// FNV-1a over 32-bit words.
fn checksum(words: impl Iterator<Item = u32>) -> u64 {
    words.fold(0xcbf2_9ce4_8422_2325u64, |h, w| (h ^ w as u64).wrapping_mul(0x100_0000_01b3))
}

fn main() {
    // Unlike `splatseg`, this example keeps glibc's allocator defaults (the binary alone sets
    // them, src/memory.rs): per-view buffers may come back as fresh pages, so its times include
    // those page faults.
    let mut args = std::env::args().skip(1);
    let Some(dir) = args.next().map(PathBuf::from) else {
        eprintln!("usage: scene_passes SCENE_DIR [VIEWS]");
        std::process::exit(2);
    };
    let views: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(3);
    let scene = splatseg_scene::load_scene(&dir, &LoadOptions::default()).expect("a readable scene");
    let g = splatseg_scene::ply::read_ply(&dir.join("gaussians.ply")).expect("a readable PLY");
    let prepared = PreparedGaussians::new(&g).expect("finite Gaussians");
    let n = prepared.len();
    let labels: Vec<u32> = match splatseg_scene::npy::read_npy(&dir.join("gt").join("gaussian_ids.npy")) {
        Ok(ids) if ids.len() == n => {
            ids.data.iter().map(|&v| if v >= 0.0 { v as u32 + 1 } else { 0 }).collect()
        }
        _ => (0..n as u32).map(|i| i / 997).collect(),
    };
    let votes = RenderVotes::uniform(labels);
    let config = LiftConfig::default();
    let mut secs = [0f64; 2];
    let mut sums = [0u64; 3];
    let views = views.min(scene.views.len());
    for view in &scene.views[..views] {
        let camera = scene.camera(view);
        if std::env::var_os("STATS").is_some() {
            stats::report(&project_view(&prepared, camera, &view.world_from_cam, &config));
        }
        let t = Instant::now();
        let pass = view_visibility(&prepared, camera, &view.world_from_cam, None, &config);
        secs[0] += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let map =
            render_label_map(&prepared, &votes, camera, &view.world_from_cam, &config, Some(pass.tile_lists))
                .expect("the pass's own tile lists fit");
        secs[1] += t.elapsed().as_secs_f64();
        let depth = pass.surface_depth.expect("the Gaussians' own surface depth");
        let vis = pass.visible;
        sums[0] ^= checksum(depth.data.iter().map(|d| d.to_bits()));
        sums[1] ^= checksum(vis.gaussians.iter().copied().chain(vis.weights.iter().map(|w| w.to_bits())));
        sums[2] ^= checksum(map.data.iter().copied());
    }
    let per = |s: f64| s / views.max(1) as f64;
    println!("{n} Gaussians, {views} views, {} threads; seconds per view:", rayon::current_num_threads());
    println!(
        "  visibility pass {:.3}  checksums: depth {:016x}, visible {:016x}",
        per(secs[0]),
        sums[0],
        sums[1]
    );
    println!("  render back     {:.3}  checksum {:016x}", per(secs[1]), sums[2]);
}

/// The per-view counts printed with `STATS=1`.
mod stats {
    use splatseg_render::{visit_contributions, Contribution, ContributionVisitor, ProjectedView};
    /// Blends (all, until T < 0.5, until T < 0.1) and pixels.
    #[derive(Default)]
    pub struct Count {
        blends: u64,
        half: u64,
        tenth: u64,
        pixels: u64,
    }
    impl ContributionVisitor for Count {
        fn contribution(&mut self, c: Contribution) -> bool {
            self.blends += 1;
            if c.t_after >= 0.5 {
                self.half += 1;
            }
            if c.t_after >= 0.1 {
                self.tenth += 1;
            }
            true
        }
        fn pixel_done(&mut self, _p: usize, _t: f32) {
            self.pixels += 1;
        }
    }
    /// Prints the counts of `view`.
    pub fn report(view: &ProjectedView) {
        let bands =
            visit_contributions(view, &splatseg_render::RasterSettings::default(), |_| Count::default());
        let (mut b, mut h, mut p, mut t) = (0, 0, 0, 0);
        for c in bands {
            b += c.blends;
            h += c.half;
            p += c.pixels;
            t += c.tenth;
        }
        let visible = view.splats.iter().filter(|s| !s.is_culled()).count();
        let lens: Vec<usize> =
            (0..view.bins.tiles_x * view.bins.tiles_y).map(|t| view.bins.tile(t).len()).collect();
        let maxlen = lens.iter().max().copied().unwrap_or(0);
        println!("visible splats {visible}, intersections {}, max tile list {maxlen}, blends/px {:.1}, until T<0.5 {:.1}, T<0.1 {:.1}",
            view.bins.intersection_count(), b as f64 / p as f64, h as f64 / p as f64, t as f64 / p as f64);
    }
}
