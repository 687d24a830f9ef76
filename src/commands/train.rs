//! `splatseg train`: 3DGS training on the CPU, and the paper's joint optimisation of object features.

use splatseg_pipeline::args::TrainArgs;

/// Runs `splatseg train`.
pub fn run(args: TrainArgs) -> anyhow::Result<()> {
    args.refuse_overwrite()?;
    let summary = splatseg_pipeline::train_stage::run_training(&args.into_run(super::run_options())?)?;
    println!("{}", summary.table());
    println!("outputs: {} (gaussians.ply, quality.json, renders/)", summary.out.display());
    Ok(())
}
