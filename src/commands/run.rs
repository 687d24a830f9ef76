//! `splatseg run`: the whole pipeline on a scene with SAM masks (`splatseg_pipeline`), with the
//! models first when checkpoints are given and the objects' CLIP embeddings after it with `--clip`
//! (`splatseg_model_cues`).

use anyhow::Context;
use splatseg_model_cues::RunArgs;

/// Runs the pipeline and prints the summary.
pub fn run(args: RunArgs) -> anyhow::Result<()> {
    args.refuse_overwrite()?;
    // the stages' wall time and peak memory, beside the run's other caches (not an output)
    let profile = args.out.join("cache").join("profile.json");
    let clip = args.clip_request(!super::logging::quiet());
    if let Some(request) = &clip {
        request.check()?;
    }
    let summary =
        splatseg_pipeline::run_pipeline(&args.into_config(super::run_options(), !super::logging::quiet())?)?;
    let json = serde_json::to_vec_pretty(&summary.stages)?;
    splatseg_scene::atomic::write_bytes_atomic(&profile, &json)
        .with_context(|| format!("writing the stage profile {}", profile.display()))?;
    print!("{}", summary.to_text());
    if let Some(request) = clip {
        print!("{}", splatseg_model_cues::clip_objects::embed_objects(&request)?.to_text());
    }
    Ok(())
}
