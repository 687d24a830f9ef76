//! `splatseg cues`: run the foundation models on every view of a scene and cache their outputs
//! (`splatseg_model_cues`).

use splatseg_model_cues::CuesArgs;

/// Runs the chosen models on every view.
pub fn run(args: CuesArgs) -> anyhow::Result<()> {
    args.refuse_overwrite()?;
    let out = args.out.clone();
    let done = args.compute(!super::logging::quiet(), log_every()?)?;
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

/// The interval of progress lines in a piped log: `SPLATSEG_LOG_EVERY_SECS` when set (a number of
/// seconds, 0 = a line at every redraw, at most one a second), else every 30 s.
fn log_every() -> anyhow::Result<std::time::Duration> {
    match std::env::var("SPLATSEG_LOG_EVERY_SECS") {
        Err(_) => Ok(splatseg_pipeline::progress_log::LOG_EVERY),
        Ok(text) => text
            .trim()
            .parse::<f64>()
            .ok()
            .and_then(|secs| std::time::Duration::try_from_secs_f64(secs).ok())
            .ok_or_else(|| {
                anyhow::anyhow!("SPLATSEG_LOG_EVERY_SECS: expected seconds (0 or more), got `{text}`")
            }),
    }
}
