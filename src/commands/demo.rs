//! `splatseg demo`: the whole pipeline on the embedded synthetic scene, end to end.

use clap::Args as ClapArgs;
use splatseg_pipeline::demo::{run_demo, DemoRequest};
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
    let request = DemoRequest {
        out: args.out,
        seed: args.seed,
        views: 12, // 12 views of 320×240: the demo's scene (`synth` + `run` for others)
        size: (320, 240),
        train_iterations: args.train_iterations,
        identity_study: args.identity_study,
        options: super::run_options(),
    };
    run_demo(&request, &mut |text| println!("{text}"))?;
    Ok(())
}
