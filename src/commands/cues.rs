//! `splatseg cues`: run the foundation models on every view of a scene and cache their outputs
//! (`splatseg_model_cues`).

use splatseg_model_cues::CuesArgs;

/// Runs the chosen models on every view.
pub fn run(args: CuesArgs) -> anyhow::Result<()> {
    args.refuse_overwrite()?;
    let out = args.out.clone();
    let done = args.compute(!super::logging::quiet())?;
    let cached = done.views * done.cues - done.computed;
    println!(
        "{} views × {} cues: {} computed, {cached} cached, in {}",
        done.views,
        done.cues,
        done.computed,
        out.display()
    );
    Ok(())
}
