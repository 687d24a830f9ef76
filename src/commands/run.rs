//! `splatseg run`: the whole pipeline on a scene with SAM masks (see `crate::pipeline`).

use crate::pipeline::{run_pipeline, PipelineConfig, RunConfig};
use clap::Args as ClapArgs;
use splatseg_cues::DepthKind;
use std::path::PathBuf;

/// Run cues → merge → match → lift (→ eval with --gt) on a scene and write per-view label maps
/// with global object ids, the labelled PLY, overlays, report.md and metrics.json.
///
/// Each stage's results are cached in OUT/cache keyed by the inputs and settings, so a rerun
/// resumes where it can.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Scene folder (COLMAP `sparse/0` + `images/`, or transforms.json).
    pub scene: PathBuf,
    /// Folder of SAM automatic masks, `<image stem>.json` (COCO RLE) per view.
    #[arg(long)]
    pub masks: PathBuf,
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
    /// TOML settings with optional tables [regions], [merge], [matching], [lift], [eval].
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
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
    let config = RunConfig {
        scene: args.scene,
        masks: args.masks,
        features: args.features,
        depth: args.depth,
        depth_kind: args.depth_kind,
        gaussians: args.gaussians,
        gt: args.gt,
        pipeline,
        out: args.out,
    };
    let summary = run_pipeline(&config)?;
    if summary.resumed {
        println!("outputs in {} are up to date (nothing recomputed)", summary.out.display());
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
