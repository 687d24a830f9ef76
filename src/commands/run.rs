//! `splatseg run`: the whole pipeline on a scene with SAM masks (see `crate::pipeline`).

use anyhow::Context;
use clap::Args as ClapArgs;
use splatseg_cues::DepthKind;
use splatseg_pipeline::{run_pipeline, PipelineConfig, RunConfig};
use std::path::PathBuf;

/// Run cues → merge → match → lift (→ eval with --gt) on a scene and write per-view label maps
/// with global object ids, the labelled PLY, overlays, report.md and metrics.json.
///
/// Cues come from files you already have (--masks, --features, --depth) or are computed in-process
/// from model checkpoints (--sam, --dinov2, --depth-model; as `splatseg cues`, into OUT/cues).
/// Without features the model-free colour/texture descriptors are used; without depth it is
/// rendered from the Gaussians.
///
/// Each stage's results are cached in OUT/cache keyed by the inputs and settings, so a rerun
/// resumes where it can. After `splatseg merge --shard K/N` ran for every K with the same
/// arguments and --out (a cluster job array), run does only the global steps (matching,
/// lifting) and names any shard whose results are missing.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Scene folder (COLMAP `sparse/0` + `images/`, or transforms.json).
    pub scene: PathBuf,
    /// Folder of SAM automatic masks, `<image stem>.json` (COCO RLE) per view. Not needed with
    /// --sam (the masks are then computed into OUT/cues/sam).
    #[arg(long, required_unless_present = "sam")]
    pub masks: Option<PathBuf>,
    /// Segment Anything checkpoint: compute the masks in-process with the automatic mask
    /// generator (as `splatseg cues --sam`) instead of reading --masks.
    #[arg(long, conflicts_with = "masks")]
    pub sam: Option<PathBuf>,
    /// DINOv2 checkpoint: compute the dense features in-process instead of reading --features.
    #[arg(long, conflicts_with = "features")]
    pub dinov2: Option<PathBuf>,
    /// Depth Anything V2 checkpoint: compute relative depth in-process instead of reading
    /// --depth or rendering it from the Gaussians.
    #[arg(long = "depth-model", conflicts_with = "depth")]
    pub depth_model: Option<PathBuf>,
    /// Folder of dense feature maps `<image stem>.npy` (`[h, w, C]`, e.g. DINOv2 patches);
    /// without it, the model-free colour/texture descriptors are used.
    #[arg(long)]
    pub features: Option<PathBuf>,
    /// Folder of depth maps `<image stem>.npy`; without it depth is rendered from the Gaussians.
    #[arg(long)]
    pub depth: Option<PathBuf>,
    /// What --depth holds: `inverse` (relative inverse depth from monocular models such as Depth
    /// Anything V2; larger = nearer) or `metric` (camera z, 0 = no surface), as in `splatseg merge`.
    #[arg(long, default_value = "inverse", value_parser = parse_depth_kind)]
    pub depth_kind: DepthKind,
    /// 3DGS PLY (default: SCENE/gaussians.ply when present).
    #[arg(long)]
    pub gaussians: Option<PathBuf>,
    /// Ground truth: a folder of `<image stem>.png` instance maps, or a synthetic scene's `gt/`
    /// (adds `gaussian_ids.npy` for the 3D label accuracy).
    #[arg(long)]
    pub gt: Option<PathBuf>,
    /// TOML settings (`splatseg config` prints them): tables [merge], [match], [lift], [objects],
    /// [final_maps], [eval], each optional.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Write the wall time and peak resident memory of every stage to this JSON file (Linux:
    /// each stage's own peak, from /proc/self/status VmHWM); `splatseg bench scale` uses it.
    #[arg(long)]
    pub profile: Option<PathBuf>,
}

fn parse_depth_kind(text: &str) -> Result<DepthKind, String> {
    match text {
        "inverse" | "inverse-relative" => Ok(DepthKind::InverseRelative),
        "metric" | "metric-z" => Ok(DepthKind::MetricZ),
        other => Err(format!("`{other}`: expected `inverse` (relative inverse depth, e.g. Depth Anything) or `metric` (camera z)")),
    }
}

/// Runs the pipeline and prints the summary.
pub fn run(args: Args) -> anyhow::Result<()> {
    let pipeline = match &args.config {
        Some(path) => PipelineConfig::from_file(path)?,
        None => PipelineConfig::default(),
    };
    let computed = splatseg_model_cues::models_for_run(
        &args.scene,
        &args.out,
        args.sam.as_deref(),
        args.dinov2.as_deref(),
        args.depth_model.as_deref(),
        !super::logging::quiet(),
    )?;
    let config = RunConfig {
        masks: computed.masks.or(args.masks).context("either --masks or --sam is needed")?,
        features: computed.features.or(args.features),
        depth_kind: if computed.depth.is_some() { DepthKind::InverseRelative } else { args.depth_kind },
        depth: computed.depth.or(args.depth),
        scene: args.scene,
        gaussians: args.gaussians,
        gt: args.gt,
        pipeline,
        out: args.out.clone(),
        options: super::run_options(),
    };
    let summary = run_pipeline(&config)?;
    if let Some(path) = &args.profile {
        let json = serde_json::to_vec_pretty(&summary.stages)?;
        splatseg_scene::atomic::write_bytes_atomic(path, &json)
            .with_context(|| format!("writing the stage profile {}", path.display()))?;
    }
    if summary.resumed {
        println!("outputs in {} are up to date (nothing recomputed)", summary.out.display());
    } else if summary.cached_views > 0 {
        println!(
            "{} of {} views' merges came from the cache",
            summary.cached_views, summary.views_with_masks
        );
    }
    println!(
        "{} views: {} SAM regions → {} merged → {} global objects → {} objects in the final maps",
        summary.views,
        summary.raw_masks,
        summary.merged_masks,
        summary.matched_objects,
        summary.final_objects
    );
    if let Some(table) = summary.table() {
        println!("\n{table}");
    }
    println!("report: {}", summary.out.join("report.md").display());
    Ok(())
}
