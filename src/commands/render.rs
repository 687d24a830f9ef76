//! `splatseg render`: render every view of a scene from a 3DGS PLY with the CPU rasteriser.

use splatseg_pipeline::args::RenderArgs;

/// Runs the command.
pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    args.refuse_overwrite()?;
    let out = args.out.clone();
    let views = splatseg_pipeline::render_views::render_views(&args.job(super::run_options()))?;
    tracing::info!("wrote {views} views to {}", out.display());
    Ok(())
}
