//! `splatseg demo`: the whole pipeline on a generated synthetic scene with ground truth, end to
//! end — the scene into `OUT/scene/`, [`crate::run_pipeline`] into `OUT/run/`, then the train stage
//! into `OUT/train/` (or, with [`DemoRequest::identity_study`], [`crate::identity_study`], as `splatseg
//! bench identity` runs it) — with
//! what a person reads on the way (the metrics tables) handed to a callback line by line.

use crate::error::{bail, Context};
use crate::train_stage::{run_training, TrainRun};
use crate::{run_pipeline, PipelineConfig, RunConfig};
use splatseg_cues::DepthKind;
use std::path::{Path, PathBuf};

/// What the demo runs on.
#[derive(Clone, Debug)]
pub struct DemoRequest {
    /// Output folder.
    pub out: PathBuf,
    /// Seed of the synthetic scene.
    pub seed: u64,
    /// Number of views.
    pub views: usize,
    /// Image size `(width, height)`.
    pub size: (u32, u32),
    /// Iterations of the train stage after the pipeline (0 = skip).
    pub train_iterations: usize,
    /// Compare the joint optimisation's 3D terms alone with 3D + 2D identity maps instead.
    pub identity_study: bool,
    /// `--strict` and `--quiet`.
    pub options: crate::RunOptions,
}

impl DemoRequest {
    /// The request with the identity study in place of the train stage.
    pub fn with_identity_study(self) -> Self {
        Self { identity_study: true, ..self }
    }
}

/// Runs the demo; `say` gets each block of the text the demo prints (one `println!` each).
pub fn run_demo(args: &DemoRequest, say: &mut dyn FnMut(&str)) -> crate::Result<()> {
    let config = splatseg_synth::SynthConfig {
        seed: args.seed,
        views: args.views,
        width: args.size.0,
        height: args.size.1,
        ..Default::default()
    };
    let scene_dir = args.out.join("scene");
    tracing::info!("generating the synthetic scene (seed {}) into {}", args.seed, scene_dir.display());
    let scene = splatseg_synth::generate(&config).context("generating the synthetic scene")?;
    let summary = splatseg_synth::write(&scene_dir, &scene)
        .with_context(|| format!("writing the synthetic scene to {}", scene_dir.display()))?;
    say(&format!(
        "synthetic scene: {} views, {} ground-truth instances, {} Gaussians, {} simulated SAM masks",
        summary.views, summary.instances, summary.gaussians, summary.sam_masks
    ));

    let run = RunConfig {
        scene: scene_dir.clone(),
        masks: scene_dir.join("sam"),
        features: Some(scene_dir.join("features")),
        depth: None, // rendered from the Gaussians (metric z)
        depth_kind: DepthKind::MetricZ,
        resize_depth: false,
        gaussians: Some(scene_dir.join("gaussians.ply")),
        gt: Some(scene_dir.join("gt")),
        pipeline: PipelineConfig::default(),
        out: args.out.join("run"),
        options: args.options,
    };
    let result = run_pipeline(&run).context("running the pipeline on the synthetic scene")?;
    say(&format!(
        "{} views: {} SAM regions → {} merged → {} global objects → {} objects in the final maps",
        result.views, result.raw_masks, result.merged_masks, result.matched_objects, result.final_objects
    ));
    match result.table() {
        Some(table) => say(&format!("\n{table}")),
        None => {
            bail!("the demo ran without ground truth metrics (expected {})", scene_dir.join("gt").display())
        }
    }
    say(&format!("outputs: {} (report.md, masks/, overlays/, gaussians.ply)", result.out.display()));
    if args.train_iterations > 0 {
        let lifted = result
            .report
            .as_ref()
            .and_then(|r| r.sets.iter().find(|s| s.name == "lifted"))
            .map(|s| s.metrics.clone())
            .context("the pipeline's report has no `lifted` metrics")?;
        if args.identity_study {
            let table = crate::identity_study::identity_study(
                &scene_dir,
                &result.out,
                &lifted,
                &args.out.join("study"),
                &demo_train_config(args.train_iterations),
                args.options,
            )?;
            say(&format!(
                "\nidentity study, seed {} ({} iterations, joint from 100):\n{table}",
                args.seed, args.train_iterations
            ));
        } else {
            train_after_pipeline(&scene_dir, &result.out, &lifted, args, say)?;
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
    scene_dir: &Path,
    run_out: &Path,
    lifted: &splatseg_eval::Metrics,
    args: &DemoRequest,
    say: &mut dyn FnMut(&str),
) -> crate::Result<()> {
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
        options: args.options,
    })
    .context("training the synthetic scene's Gaussians")?;
    say(&format!(
        "\ntrain stage (3DGS loss on the CPU, then the paper's joint optimisation):\n{}",
        summary.table()
    ));
    // the label maps rendered from the relabelled Gaussians, scored like the pipeline's
    let gt_ids = scene_dir.join("gt").join("gaussian_ids.npy");
    let gt_maps = scene_dir.join("gt").join("instance");
    let mut joint =
        splatseg_eval::evaluate_folders(&gt_maps, &train_out.join("masks"), &PipelineConfig::default().eval)?;
    joint.label_accuracy_3d =
        Some(splatseg_eval::label_accuracy_3d_files(&gt_ids, &train_out.join("gaussians.ply"))?);
    say(&format!(
        "\n{}",
        splatseg_eval::summary_table(&[
            ("lifted (run)", lifted),
            ("joint (rendered from the trained Gaussians)", &joint)
        ])
    ));
    let unlabelled =
        |m: &splatseg_eval::Metrics| m.label_accuracy_3d.as_ref().map_or(0, |a| a.unlabelled_predictions);
    say(&format!(
        "(joint = label maps rendered from the trained Gaussians' new ids, not snapped; {} → {} Gaussians without an id)",
        unlabelled(lifted),
        unlabelled(&joint)
    ));
    say(&format!(
        "outputs: {} (gaussians.ply, quality.json, renders/, masks/, overlays/)",
        train_out.display()
    ));
    Ok(())
}
