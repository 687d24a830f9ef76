//! `splatseg demo`: the whole pipeline on the embedded synthetic scene, end to end.

use anyhow::Context;
use clap::Args as ClapArgs;
use splatseg_cues::DepthKind;
use splatseg_pipeline::train_stage::{run_training, TrainRun};
use splatseg_pipeline::{run_pipeline, PipelineConfig, RunConfig};
use std::path::PathBuf;

/// Generate the synthetic benchmark scene (with ground truth), run every pipeline stage on it and
/// print the metrics table.
///
/// Writes `OUT/scene/` (the capture: COLMAP model, images, gaussians.ply, simulated SAM masks and
/// cues, ground truth) and `OUT/run/` (the pipeline's outputs: masks, overlays, labelled PLY,
/// report.md) and `OUT/train/` (the Gaussians after the train stage and its joint optimisation, with
/// held-out renders). Open `OUT/run/report.md` or the PNGs in `OUT/run/overlays/` to look at the result.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Output folder.
    #[arg(long, default_value = "out/demo")]
    pub out: PathBuf,
    /// Seed of the synthetic scene.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Iterations of the train stage after the pipeline (0 = skip): the first 100 photometric only,
    /// the rest the joint optimisation of object features seeded by the lifted ids.
    #[arg(long, default_value_t = 300)]
    pub train_iterations: usize,
    /// Instead of the train stage, compare its joint optimisation with the 3D terms only and with the
    /// 3D terms plus the 2D identity maps (every read-back) against the ground truth, as one table
    /// (trains twice; `BENCHMARKS.md` records it over several seeds).
    #[arg(long)]
    pub identity_study: bool,
}

/// Runs the demo.
pub fn run(args: Args) -> anyhow::Result<()> {
    let config = splatseg_synth::SynthConfig {
        seed: args.seed, // 12 views of 320×240: the demo's scene (`synth` + `run` for others)
        ..Default::default()
    };
    let scene_dir = args.out.join("scene");
    tracing::info!("generating the synthetic scene (seed {}) into {}", args.seed, scene_dir.display());
    let scene = splatseg_synth::generate(&config).context("generating the synthetic scene")?;
    let summary = splatseg_synth::write(&scene_dir, &scene)
        .with_context(|| format!("writing the synthetic scene to {}", scene_dir.display()))?;
    println!(
        "synthetic scene: {} views, {} ground-truth instances, {} Gaussians, {} simulated SAM masks",
        summary.views, summary.instances, summary.gaussians, summary.sam_masks
    );

    let run = RunConfig {
        scene: scene_dir.clone(),
        masks: scene_dir.join("sam"),
        features: Some(scene_dir.join("features")),
        depth: None, // rendered from the Gaussians (metric z)
        depth_kind: DepthKind::MetricZ,
        gaussians: Some(scene_dir.join("gaussians.ply")),
        gt: Some(scene_dir.join("gt")),
        pipeline: PipelineConfig::default(),
        out: args.out.join("run"),
    };
    let result = run_pipeline(&run).context("running the pipeline on the synthetic scene")?;
    println!(
        "{} views: {} SAM regions → {} merged → {} global objects → {} objects in the final maps",
        result.views, result.raw_masks, result.merged_masks, result.matched_objects, result.final_objects
    );
    match result.table() {
        Some(table) => println!("\n{table}"),
        None => anyhow::bail!(
            "the demo ran without ground truth metrics (expected {})",
            scene_dir.join("gt").display()
        ),
    }
    println!("outputs: {} (report.md, masks/, overlays/, gaussians.ply)", result.out.display());
    if args.train_iterations > 0 {
        let lifted = result
            .report
            .as_ref()
            .and_then(|r| r.sets.iter().find(|s| s.name == "lifted"))
            .map(|s| s.metrics.clone())
            .context("the pipeline's report has no `lifted` metrics")?;
        if args.identity_study {
            let table = splatseg_pipeline::identity_study::identity_study(
                &scene_dir,
                &result.out,
                &lifted,
                &args.out.join("study"),
                &demo_train_config(args.train_iterations),
            )?;
            println!(
                "\nidentity study, seed {} ({} iterations, joint from 100):\n{table}",
                args.seed, args.train_iterations
            );
        } else {
            train_after_pipeline(&scene_dir, &result.out, &lifted, &args)?;
        }
    }
    Ok(())
}

/// The demo's training settings: `iterations`, the first 100 photometric only (densification, from
/// iteration 500, never runs), the paper's values otherwise.
fn demo_train_config(iterations: usize) -> splatseg_train::TrainConfig {
    let mut config = splatseg_train::TrainConfig { iterations, ..Default::default() };
    config.densify.until = 100.min(iterations);
    config
}

/// The train stage on the lifted Gaussians: photometric fine-tuning, then the joint optimisation.
/// Densification is left out (the synthetic Gaussians are already dense and its start, iteration
/// 500, is past the end) so the Gaussians stay row-aligned with the ground-truth ids. `lifted`: the
/// pipeline's own metrics of its final maps (with the 3D label accuracy).
fn train_after_pipeline(
    scene_dir: &std::path::Path,
    run_out: &std::path::Path,
    lifted: &splatseg_eval::Metrics,
    args: &Args,
) -> anyhow::Result<()> {
    let config = demo_train_config(args.train_iterations);
    let lifted_ply = run_out.join("gaussians.ply");
    let train_out = args.out.join("train");
    tracing::info!(
        "training {} iterations (joint stage from iteration {})",
        config.iterations,
        config.densify.until
    );
    let summary = run_training(&TrainRun {
        scene: scene_dir.to_path_buf(),
        gaussians: Some(lifted_ply),
        init: Default::default(),
        out: train_out.clone(),
        config,
        resolution: 1,
        label_maps: None,
    })
    .context("training the synthetic scene's Gaussians")?;
    println!(
        "\ntrain stage (3DGS loss on the CPU, then the paper's joint optimisation):\n{}",
        summary.table()
    );
    // the label maps rendered from the relabelled Gaussians, scored like the pipeline's
    let gt_ids = scene_dir.join("gt").join("gaussian_ids.npy");
    let gt_maps = scene_dir.join("gt").join("instance");
    let mut joint =
        splatseg_eval::evaluate_folders(&gt_maps, &train_out.join("masks"), &PipelineConfig::default().eval)?;
    joint.label_accuracy_3d =
        Some(splatseg_eval::label_accuracy_3d_files(&gt_ids, &train_out.join("gaussians.ply"))?);
    println!(
        "\n{}",
        splatseg_eval::summary_table(&[
            ("lifted (run)", lifted),
            ("joint (rendered from the trained Gaussians)", &joint)
        ])
    );
    let unlabelled =
        |m: &splatseg_eval::Metrics| m.label_accuracy_3d.as_ref().map_or(0, |a| a.unlabelled_predictions);
    println!(
        "(joint = label maps rendered from the trained Gaussians' new ids, not snapped; {} → {} Gaussians without an id)",
        unlabelled(lifted),
        unlabelled(&joint)
    );
    println!("outputs: {} (gaussians.ply, quality.json, renders/, masks/, overlays/)", train_out.display());
    Ok(())
}
