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
    /// Image down-scaling factor (as 3DGS `--resolution`).
    #[arg(long, default_value_t = 1)]
    pub resolution: u32,
    /// Shard `K/N` (0 ≤ K < N): only the views `v` with `v mod N = K`. Shards
    /// may run at once on the same --out (a Slurm job array, a Kubernetes indexed Job); together
    /// they write exactly what one unsharded run writes.
    #[arg(long)]
    pub shard: Option<splatseg_pipeline::Shard>,
}

/// Runs the chosen models on every view.
pub fn run(args: Args) -> anyhow::Result<()> {
    // The library's defaults: the references' input sizes (518 px) and SAM's automatic mask
    // generator settings (32 points per side, no crops, no clean-up), the train split.
    let request = CuesRequest {
        dinov2: args.dinov2,
        depth_model: args.depth_model,
        sam: args.sam,
        resolution: args.resolution,
        shard: args.shard,
        show_progress: !super::logging::quiet(),
        ..CuesRequest::defaults_for(args.scene, args.out.clone())
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
