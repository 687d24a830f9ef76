//! `splatseg apply OUT`: a run's edits applied to its outputs, and with `run --clip`'s object
//! embeddings the edited objects embedded again (`splatseg_model_cues::apply_edits`).

use splatseg_pipeline::args::ApplyArgs;

/// Applies the edits and prints what changed.
pub fn run(args: ApplyArgs) -> anyhow::Result<()> {
    let done = splatseg_model_cues::apply_edits::apply_edits(
        &args.out,
        super::run_options(),
        !super::logging::quiet(),
    )?;
    if let Some(warning) = &done.warning {
        tracing::warn!("{warning}");
    }
    print!("{}", done.to_text(&args.out));
    Ok(())
}
