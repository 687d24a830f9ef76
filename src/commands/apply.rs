//! `splatseg apply OUT`: a run's edits applied to its outputs (`splatseg_pipeline::apply`).

use splatseg_pipeline::args::ApplyArgs;

/// Applies the edits and prints what changed.
pub fn run(args: ApplyArgs) -> anyhow::Result<()> {
    let summary = splatseg_pipeline::apply::apply_edits(&args.out, super::run_options())?;
    print!("{}", summary.to_text(&args.out));
    Ok(())
}
