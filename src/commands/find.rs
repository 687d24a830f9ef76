//! `splatseg find`: a finished run's objects ranked against a text query (`splatseg_model_cues`).

use splatseg_model_cues::FindArgs;

/// Ranks the objects and prints them (a table, or the JSON array of `--json`).
pub fn run(args: FindArgs) -> anyhow::Result<()> {
    print!("{}", args.report()?);
    Ok(())
}
