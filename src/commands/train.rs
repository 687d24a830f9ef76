//! `splatseg train`: 3DGS training on the CPU, and the paper's joint optimisation of object features.

use clap::Args as ClapArgs;
use splatseg_pipeline::train_stage::{run_training, InitOptions, TrainRun};
use splatseg_pipeline::PipelineConfig;
use std::path::PathBuf;

/// Train (or fine-tune) a scene's Gaussians on its images with splatseg's CPU rasteriser.
///
/// The photometric part follows 3DGS: `L = 0.8·L1 + 0.2·(1 − SSIM)`, Adam with 3DGS's learning rates
/// (positions decayed over 50k iterations, times the camera extent), one more SH degree every 1000
/// iterations, densification (clone / split / prune) every 100 iterations from 500 to 15k, opacity
/// resets every 3000. Every 8th view (0, 8, …) is held out and scored (PSNR / SSIM) before and after.
///
/// When the PLY carries `object_id` (the labelled `gaussians.ply` that `splatseg run` writes), the
/// paper's joint optimisation starts when densification ends: each Gaussian gets a 16-d object
/// feature, pulled towards its lifted object's code (λ_s = 0.1) and towards its 5 nearest neighbours'
/// features (λ_reg = 0.01); at the end every Gaussian takes the id of the closest code, which labels
/// the ones lifting left at −1 and corrects stray votes.
///
/// By default (the supplement's "16-channel identity feature maps for 3D-to-2D supervision"; off with
/// --no-identity-maps), the features are also rendered with the colour into a 16-channel identity map, a
/// learnable linear classifier (16 → objects + background) scores each pixel, and the cross-entropy
/// against the view's final label map from `splatseg run` (masks/<view>.png beside the --gaussians PLY,
/// or --label-maps; without them the 3D terms run alone, with a warning) joins the loss with weight
/// λ_s = 0.1; its gradients reach the features and, through α, the geometry. Each Gaussian's id is then
/// read back from the rendered, classified identity maps: the class it contributes most blending
/// weight α·T to over all training views (`[train.joint] readback`; every read-back's label maps go to
/// OUT/readback/<kind>/masks/).
///
/// Defaults are the paper's (100k iterations; `splatseg config` prints the `[train]` table). On a CPU,
/// pass `--iterations` (a few thousand) and, for large images, `--resolution 2` or `4`.
///
/// Writes OUT/gaussians.ply (opens in standard 3DGS viewers; `object_id` relabelled after a joint
/// stage), OUT/quality.json, OUT/renders/<view>.png (held-out views) and OUT/object_features.npy.
///
/// Examples:
///   splatseg train out/demo/scene --gaussians out/demo/run/gaussians.ply --out out/train --iterations 2000
///   splatseg train nerf_synthetic/lego --out lego_trained --resolution 4 --iterations 5000   # from scratch
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Scene folder (COLMAP `sparse/0` + `images/`, or `transforms.json`).
    pub scene: PathBuf,
    /// Starting Gaussians: a 3DGS PLY (with `object_id` for the joint stage). Without it, training
    /// starts as 3DGS does: one Gaussian per COLMAP sparse point, or, for scenes without points
    /// (Blender / transforms.json), random points in a cube (see --init-points, --init-cube).
    #[arg(long)]
    pub gaussians: Option<PathBuf>,
    /// Random starting points when there is neither a PLY nor sparse points (3DGS: 100000).
    #[arg(long, default_value_t = 100_000)]
    pub init_points: usize,
    /// Half side of the random cube around the origin (3DGS's NeRF-synthetic value: 1.3).
    #[arg(long, default_value_t = 1.3)]
    pub init_cube: f32,
    /// SH degree of Gaussians created here (3DGS: 3).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u8).range(0..=3))]
    pub sh_degree: u8,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Iterations (one view each); overrides the config's `[train] iterations`.
    #[arg(long)]
    pub iterations: Option<usize>,
    /// Also save the Gaussians after these iterations, as OUT/point_cloud/iteration_<N>/point_cloud.ply
    /// (3DGS's layout and default: 7000,30000); overrides `[train] save_iterations`.
    #[arg(long, value_delimiter = ',')]
    pub save_iterations: Option<Vec<usize>>,
    /// Iteration at which densification stops and the joint stage starts; overrides `[train.densify] until`.
    #[arg(long)]
    pub densify_until: Option<usize>,
    /// TOML settings (the `[train]` table of `splatseg config`'s output).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Image down-scaling factor (1, 2, 4, 8, …), as 3DGS's `--resolution`. Without it, images wider
    /// than 1600 px are scaled down by the smallest whole factor that brings them to 1600 px or less
    /// (3DGS rescales such images to 1600 px); pass 1 to train at full size.
    #[arg(long)]
    pub resolution: Option<u32>,
    /// Photometric training only, even if the PLY has object ids.
    #[arg(long)]
    pub no_joint: bool,
    /// Supervise the rendered 16-channel identity maps in 2D with each training view's label map (the
    /// default; sets `[train.joint] identity_maps = true`, and a missing label map is then an error).
    #[arg(long, conflicts_with = "no_identity_maps")]
    pub identity_maps: bool,
    /// Only the 3D terms of the joint stage (sets `[train.joint] identity_maps = false`).
    #[arg(long)]
    pub no_identity_maps: bool,
    /// Folder of the label maps (`<view stem>.png`, global ids) for --identity-maps; default: `masks/`
    /// beside the --gaussians PLY, where `splatseg run` writes them.
    #[arg(long)]
    pub label_maps: Option<PathBuf>,
    /// Composite RGBA images on white and render on white (3DGS's `--white_background`); the default
    /// background is the config's (black).
    #[arg(long, short = 'w')]
    pub white_background: bool,
}

/// Runs `splatseg train`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut config = match &args.config {
        Some(path) => PipelineConfig::from_file(path)?.train,
        None => PipelineConfig::default().train,
    };
    if let Some(n) = args.iterations {
        config.iterations = n;
    }
    if let Some(list) = args.save_iterations {
        config.save_iterations = list;
    }
    if let Some(n) = args.densify_until {
        config.densify.until = n;
    }
    if args.no_joint {
        config.joint.enabled = false;
    }
    if args.identity_maps {
        config.joint.identity_maps = true;
    }
    if args.no_identity_maps {
        config.joint.identity_maps = false;
    }
    if args.white_background {
        config.background = [1.0; 3];
    }
    // asked for explicitly: the label maps beside the PLY must be there (else the stage warns and skips)
    let label_maps = match (&args.label_maps, args.identity_maps, &args.gaussians) {
        (None, true, Some(ply)) => ply.parent().map(|dir| dir.join("masks")),
        _ => args.label_maps.clone(),
    };
    let resolution = match args.resolution {
        Some(factor) => factor,
        None => splatseg_pipeline::train_stage::automatic_resolution(&args.scene)?,
    };
    let summary = run_training(&TrainRun {
        scene: args.scene,
        gaussians: args.gaussians,
        init: InitOptions {
            random_points: args.init_points,
            cube_half_side: args.init_cube,
            sh_degree: args.sh_degree,
        },
        out: args.out,
        config,
        resolution,
        label_maps,
        options: super::run_options(),
    })?;
    println!("{}", summary.table());
    println!("outputs: {} (gaussians.ply, quality.json, renders/)", summary.out.display());
    Ok(())
}
