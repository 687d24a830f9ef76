//! Real images: the NeRF-synthetic lego views (`../shared/data`, skipped with a message when absent),
//! trained from 3DGS's random-cube start with densification, at 1/8 resolution.

use std::path::Path;

use splatseg_render::RenderCamera;
use splatseg_scene::images::load_image_rgb;
use splatseg_scene::{load_scene, LoadOptions};
use splatseg_train::{evaluate_views, random_gaussians_in_cube, train, TrainConfig, TrainView};

const LEGO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/nerf_synthetic_lego");

#[test]
fn lego_trains_from_a_random_cube_with_densification() {
    if !Path::new(LEGO).join("transforms_train.json").is_file() {
        eprintln!("skipping lego_trains_from_a_random_cube_with_densification: {LEGO} is absent");
        return;
    }
    let options = LoadOptions { resolution: 8, background: [1.0; 3], ..LoadOptions::default() };
    let scene = load_scene(Path::new(LEGO), &options).expect("lego loads");
    let views: Vec<TrainView> = scene
        .views
        .iter()
        .map(|view| {
            let image = load_image_rgb(&scene, view, &options).expect("image");
            TrainView {
                name: view.stem.clone(),
                camera: RenderCamera::from_scene(scene.camera(view), &view.world_from_cam),
                image: image.data.iter().map(|&c| f32::from(c) / 255.0).collect(),
                labels: None,
            }
        })
        .collect();
    let (test, train_views): (Vec<_>, Vec<_>) = views.into_iter().enumerate().partition(|(i, _)| i % 8 == 0);
    let test: Vec<TrainView> = test.into_iter().map(|(_, v)| v).collect();
    let train_views: Vec<TrainView> = train_views.into_iter().map(|(_, v)| v).collect();
    let start = random_gaussians_in_cube(20_000, [0.0; 3], 1.3, 0, 0);
    let mut config = TrainConfig { iterations: 800, background: [1.0; 3], ..TrainConfig::default() };
    config.densify.from = 100;
    config.densify.until = 600;
    config.densify.opacity_reset_interval = 400;
    let mean_psnr = |g: &splatseg_scene::Gaussians| {
        let q = evaluate_views(g, &test, [1.0; 3]).expect("evaluate");
        q.iter().map(|v| v.psnr).sum::<f64>() / q.len() as f64
    };
    let before = mean_psnr(&start);
    let trained = train(start, &train_views, &config, &|_| {}).expect("train");
    let after = mean_psnr(&trained.gaussians);
    let (cloned, split, pruned) = trained
        .densify_reports
        .iter()
        .fold((0, 0, 0), |acc, (_, r)| (acc.0 + r.cloned, acc.1 + r.split, acc.2 + r.pruned));
    println!(
        "lego 100×100, {} held-out views: PSNR {before:.2} → {after:.2} dB; Gaussians 20000 → {} \
         (cloned {cloned}, split {split}, pruned {pruned})",
        test.len(),
        trained.gaussians.len()
    );
    assert!(cloned + split > 0 && pruned > 0, "densification ran");
    // measured: 7.25 → 30.17 dB, 20000 → 6637 Gaussians
    assert!(after > before + 15.0 && after > 27.0, "PSNR {before:.2} → {after:.2} dB");
}
