//! `splatseg find`: a finished run's objects ranked against a text query (`splatseg_model_cues`).

use splatseg_model_cues::clip_objects::found_table;
use splatseg_model_cues::FindArgs;

/// Ranks the objects and prints them.
pub fn run(args: FindArgs) -> anyhow::Result<()> {
    print!("{}", found_table(&args.query, &args.find()?));
    Ok(())
}
