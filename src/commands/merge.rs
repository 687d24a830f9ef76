//! `splatseg merge`: Multi-Cue-Guided Mask Merging of every view's SAM masks.

use splatseg_pipeline::args::MergeArgs;
use std::time::Instant;

/// Runs the command.
pub fn run(args: MergeArgs) -> anyhow::Result<()> {
    args.refuse_overwrite()?;
    let started = Instant::now();
    let (config, request) = args.into_request(super::run_options())?;
    let summary = splatseg_pipeline::merge_views(&config, &request)?;
    if let Some(shard) = request.shard {
        let cache = config.out.join("cache").join("merge");
        let (merged, views, cached) = (summary.merged, summary.views, summary.cached);
        println!(
            "shard {shard}: {merged} of {views} views merged ({cached} from the cache) into {}",
            cache.display()
        );
        return Ok(());
    }
    let n = summary.merged as f64;
    println!(
        "merged {} views ({:?} profile): {:.1} → {:.1} regions per view, in {:.2} s; wrote {}/{{masks,overlays,merge}}/",
        summary.merged,
        config.pipeline.merge.profile,
        summary.regions_before as f64 / n,
        summary.regions_after as f64 / n,
        started.elapsed().as_secs_f64(),
        config.out.display()
    );
    Ok(())
}
