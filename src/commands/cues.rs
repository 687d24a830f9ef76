//! `splatseg cues`: run the foundation models on every view of a scene and cache their outputs
//! (`splatseg_model_cues`).

use clap::Args as ClapArgs;
use splatseg_model_cues::{compute_cues, CuesRequest};
use std::path::PathBuf;

/// Compute per-view cues with in-process models: SAM automatic masks (`OUT/sam/<stem>.json`),
/// DINOv2 patch features (`OUT/features/<stem>.npy`, `[h/14, w/14, C]`, L2-normalised),
/// Depth Anything V2 relative inverse depth (`OUT/depth/<stem>.npy`, `[H, W]`) and the LoG edge map
/// (`OUT/log/<stem>.npy`). Feed them to `splatseg run --masks OUT/sam --features OUT/features
/// --depth OUT/depth`.
///
/// Models are given as a checkpoint file, a Hugging Face snapshot folder, or a model id found in the
/// local Hugging Face cache (`facebook/dinov2-small`); nothing is downloaded. Outputs are cached by
/// model, settings and image content: a rerun only computes what changed.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Scene folder (COLMAP `sparse/0` + `images/`, or transforms.json).
    pub scene: PathBuf,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// DINOv2 checkpoint (`.safetensors`/`.pth`, HF folder or model id).
    #[arg(long)]
    pub dinov2: Option<PathBuf>,
    /// Depth Anything V2 checkpoint.
    #[arg(long = "depth-model")]
    pub depth_model: Option<PathBuf>,
    /// Segment Anything checkpoint (`sam_vit_{b,l,h}_*.pth`).
    #[arg(long)]
    pub sam: Option<PathBuf>,
    /// Long side (px) of the image DINOv2 sees, rounded to multiples of 14.
    #[arg(long, default_value_t = 518)]
    pub dinov2_size: usize,
    /// Short side (px) of the image Depth Anything sees, rounded to multiples of 14.
    #[arg(long, default_value_t = 518)]
    pub depth_size: usize,
    /// SAM prompt grid points per side.
    #[arg(long, default_value_t = 32)]
    pub points_per_side: usize,
    /// SAM crop layers (0 = whole image only).
    #[arg(long, default_value_t = 0)]
    pub crop_layers: usize,
    /// SAM: holes and islands smaller than this many pixels are removed (0 = off).
    #[arg(long, default_value_t = 0)]
    pub min_region_area: usize,
    /// Skip the LoG edge maps.
    #[arg(long)]
    pub no_log: bool,
    /// Image down-scaling factor (as 3DGS `--resolution`).
    #[arg(long, default_value_t = 1)]
    pub resolution: u32,
    /// Blender split to read.
    #[arg(long, default_value = "train")]
    pub split: String,
    /// Only the first N views.
    #[arg(long)]
    pub max_views: Option<usize>,
    /// Shard `K/N` (0 ≤ K < N): only the views `v` with `v mod N = K` (after --max-views). Shards
    /// may run at once on the same --out (a Slurm job array, a Kubernetes indexed Job); together
    /// they write exactly what one unsharded run writes.
    #[arg(long)]
    pub shard: Option<splatseg_pipeline::Shard>,
}

/// Runs the chosen models on every view.
pub fn run(args: Args) -> anyhow::Result<()> {
    let request = CuesRequest {
        scene: args.scene,
        out: args.out.clone(),
        dinov2: args.dinov2,
        depth_model: args.depth_model,
        sam: args.sam,
        dinov2_size: args.dinov2_size,
        depth_size: args.depth_size,
        points_per_side: args.points_per_side,
        crop_layers: args.crop_layers,
        min_region_area: args.min_region_area,
        log: !args.no_log,
        resolution: args.resolution,
        split: args.split,
        max_views: args.max_views,
        shard: args.shard,
        show_progress: !super::logging::quiet(),
    };
    let done = compute_cues(&request)?;
    println!(
        "{} views × {} cues: {} computed, {} cached, in {}",
        done.views,
        done.cues,
        done.computed,
        done.views * done.cues - done.computed,
        args.out.display()
    );
    Ok(())
}
