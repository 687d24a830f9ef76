//! Times training iterations on the synthetic scene (the numbers in BENCHMARKS.md):
//!
//! ```text
//! cargo run --release -p splatseg-train --features bench --example train_timing -- WIDTHxHEIGHT ITERATIONS [joint|identity]
//! ```
//!
//! Prints the Gaussian count, the mean wall time per iteration of the photometric stage, with `joint`
//! of the joint stage with the 3D terms only (object features, kNN regulariser), with `identity` of
//! the joint stage with the 16-channel identity maps too (ground-truth instance maps as label maps;
//! the final read-backs are timed apart).

use std::time::Instant;

use splatseg_render::RenderCamera;
use splatseg_synth::{generate, SynthConfig};
use splatseg_train::{train, TrainConfig, TrainView};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let size = args.get(1).map_or("320x240", String::as_str);
    let (w, h) = size.split_once('x').ok_or("size as WIDTHxHEIGHT")?;
    let (width, height): (u32, u32) = (w.parse()?, h.parse()?);
    let iterations: usize = args.get(2).map_or(Ok(200), |s| s.parse())?;
    let mode = args.get(3).map_or("photometric", String::as_str);
    let (joint, identity) = (mode == "joint" || mode == "identity", mode == "identity");
    let scene = generate(&SynthConfig { width, height, views: 12, ..SynthConfig::default() })?;
    let views: Vec<TrainView> = scene
        .scene
        .views
        .iter()
        .zip(&scene.views)
        .map(|(view, synth)| TrainView {
            name: synth.stem.clone(),
            camera: RenderCamera::from_scene(scene.scene.camera(view), &view.world_from_cam),
            image: synth.image.data.iter().flat_map(|p| p.map(|c| f32::from(c) / 255.0)).collect(),
            labels: identity.then(|| synth.gt_instance.data.clone()),
        })
        .collect();
    let mut gaussians = scene.gaussians.clone();
    if joint {
        gaussians.object_ids = Some(scene.gaussian_ids.iter().map(|&id| id as i32).collect());
    }
    println!(
        "{width}×{height}, {} views, {} Gaussians, {iterations} iterations, rayon threads {}",
        views.len(),
        gaussians.len(),
        rayon::current_num_threads()
    );
    let mut config = TrainConfig { iterations, ..TrainConfig::default() };
    config.joint.identity_maps = identity;
    // no densification (it would change the count being timed); joint stage from the first iteration
    config.densify.until = if joint { 1 } else { iterations + 1 };
    let start = Instant::now();
    let last_iteration = std::sync::Mutex::new(None);
    let trained = train(gaussians, &views, &config, &|p| {
        if p.iteration == iterations {
            *last_iteration.lock().expect("lock") = Some(Instant::now());
        }
    })?;
    let end = Instant::now();
    let loop_end = last_iteration.into_inner()?.unwrap_or(end);
    let total = loop_end - start;
    println!(
        "{mode} stage: {:.1} ms per iteration ({:.2?} in all), final L_render {:.4}, read-backs {:.2?}",
        total.as_secs_f64() * 1e3 / iterations as f64,
        total,
        trained.last.map_or(f64::NAN, |p| p.render_loss),
        end - loop_end
    );
    Ok(())
}
