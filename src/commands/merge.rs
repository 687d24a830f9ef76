//! `splatseg merge`: Multi-Cue-Guided Mask Merging of every view's SAM masks.

use anyhow::bail;
use clap::{Args as ClapArgs, ValueEnum};
use splatseg_cues::DepthKind;
use splatseg_pipeline::{merge_views, MergeRequest, PipelineConfig, RunConfig, Shard};
use splatseg_scene::load::LoadOptions;
use std::path::PathBuf;
use std::time::Instant;

/// What the `--depth` maps hold.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum DepthMeaning {
    /// Relative inverse depth (monocular models such as Depth Anything V2; larger = nearer).
    Inverse,
    /// Metric camera z (0 = no surface).
    Metric,
}

/// Merge each view's over-segmented SAM masks into objects (paper §4.2): `run`'s per-view merge
/// stage on its own, with `run`'s inputs, depth and cache (OUT/cache/merge/), so a later
/// `splatseg run` with the same arguments and --out reuses every view's merge.
///
/// Inputs are matched to views by image file stem: `MASKS/<stem>.json` (SAM JSON) or
/// `MASKS/<stem>/metadata.csv`, `FEATURES/<stem>.npy` (`[h, w, C]`), `DEPTH/<stem>.npy` (`[H, W]`).
/// Writes per view `OUT/masks/<stem>.png` (16-bit label map, 0 = unlabelled),
/// `OUT/overlays/<stem>.png` and `OUT/merge/<stem>.json` (regions before/after and every merge
/// decision with its score terms and the rule that decided it).
///
/// With `--shard K/N` only the views `v` with `v mod N = K`, and only into OUT/cache/merge/. Start
/// the N shards anywhere they see the same folders (a Slurm job array, a Kubernetes indexed Job,
/// Ray tasks), then `splatseg run` with the same arguments and `--out` does only the global steps
/// (matching, lifting); it names any missing shard.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Scene folder (COLMAP or transforms.json).
    pub scene: PathBuf,
    /// SAM masks folder.
    #[arg(long)]
    pub masks: PathBuf,
    /// Dense feature maps (e.g. DINOv2 patch tokens); without it, the model-free colour + texture
    /// descriptors are used.
    #[arg(long)]
    pub features: Option<PathBuf>,
    /// Depth maps folder; without it, depth is rendered from the Gaussians.
    #[arg(long)]
    pub depth: Option<PathBuf>,
    /// What the `--depth` maps hold.
    #[arg(long, value_enum, default_value = "inverse")]
    pub depth_kind: DepthMeaning,
    /// 3DGS PLY for rendered depth (default: SCENE/gaussians.ply when present).
    #[arg(long)]
    pub gaussians: Option<PathBuf>,
    /// `run`'s pipeline TOML (`splatseg config`; the merge settings are its [merge] table), the
    /// same file the later `run` gets.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Image down-scaling factor (1, 2, 4, 8) as 3DGS's `--resolution` (`run` and --shard: 1).
    #[arg(long, default_value_t = 1)]
    pub resolution: u32,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Shard `K/N` (0 ≤ K < N) of `run`'s merge stage: only the views `v` with `v mod N = K`, into
    /// OUT/cache/merge for a later `splatseg run --out OUT` (e.g. `--shard $SLURM_ARRAY_TASK_ID/8`).
    #[arg(long)]
    pub shard: Option<Shard>,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let started = Instant::now();
    if args.shard.is_some() && args.resolution != 1 {
        bail!("--shard runs `run`'s merge stage, which reads the images at --resolution 1");
    }
    let pipeline = match &args.config {
        Some(path) => PipelineConfig::from_file(path)?,
        None => PipelineConfig::default(),
    };
    let config = RunConfig {
        scene: args.scene,
        masks: args.masks,
        features: args.features,
        depth: args.depth,
        depth_kind: match args.depth_kind {
            DepthMeaning::Inverse => DepthKind::InverseRelative,
            DepthMeaning::Metric => DepthKind::MetricZ,
        },
        gaussians: args.gaussians,
        gt: None,
        pipeline,
        out: args.out,
        options: super::run_options(),
    };
    let load = LoadOptions { resolution: args.resolution, ..LoadOptions::default() };
    let summary = merge_views(&config, &MergeRequest { shard: args.shard, load })?;
    let cache = config.out.join("cache").join("merge");
    if let Some(shard) = args.shard {
        println!(
            "shard {shard}: {} of {} views merged ({} from the cache) into {}",
            summary.merged,
            summary.views,
            summary.cached,
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
