//! `splatseg train`'s arguments.

use crate::train_stage::{automatic_resolution, InitOptions, TrainRun};
use crate::{PipelineConfig, RunOptions};
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
/// `[train.joint] identity_maps = false`), the features are also rendered with the colour into a 16-channel identity map, a
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
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct TrainArgs {
    /// Scene folder (COLMAP `sparse/0` + `images/`, or `transforms.json`).
    pub scene: PathBuf,
    /// Starting Gaussians: a 3DGS PLY (with `object_id` for the joint stage), a compressed PLY, an SPZ,
    /// a .splat or a .ksplat. Without it, training starts as 3DGS does: one Gaussian of SH degree 3
    /// per COLMAP sparse point, or, for scenes without points (Blender / transforms.json), 100,000
    /// random points in a cube of half side 1.3 around the origin (3DGS's NeRF-synthetic values).
    #[cfg_attr(feature = "cli", arg(long))]
    pub gaussians: Option<PathBuf>,
    /// Output folder.
    #[cfg_attr(feature = "cli", arg(long))]
    pub out: PathBuf,
    /// Iterations (one view each); overrides the config's `[train] iterations`.
    #[cfg_attr(feature = "cli", arg(long))]
    pub iterations: Option<usize>,
    /// TOML settings: the `[train]` table of `splatseg config`'s output (`save_iterations`,
    /// `background = [1, 1, 1]` for 3DGS's white background, `[train.densify] until`,
    /// `[train.joint] enabled` and `identity_maps`, …).
    #[cfg_attr(feature = "cli", arg(long))]
    pub config: Option<PathBuf>,
    /// Image down-scaling factor (1, 2, 4, 8, …), as 3DGS's `--resolution`. Without it, images wider
    /// than 1600 px are scaled down by the smallest whole factor that brings them to 1600 px or less
    /// (3DGS rescales such images to 1600 px); pass 1 to train at full size.
    #[cfg_attr(feature = "cli", arg(long))]
    pub resolution: Option<u32>,
    /// Folder of the label maps (`<view stem>.png`, global ids) for the identity maps; default:
    /// `masks/` beside the --gaussians PLY, where `splatseg run` writes them.
    #[cfg_attr(feature = "cli", arg(long))]
    pub label_maps: Option<PathBuf>,
}

impl TrainArgs {
    /// The training run: the `[train]` settings with `--iterations` over them, and without
    /// `--resolution` the factor that brings the widest image to 1600 px or less.
    pub fn into_run(self, options: RunOptions) -> crate::Result<TrainRun> {
        let mut config = PipelineConfig::from_optional_file(self.config.as_deref())?.train;
        if let Some(n) = self.iterations {
            config.iterations = n;
        }
        let resolution = match self.resolution {
            Some(factor) => factor,
            None => automatic_resolution(&self.scene)?,
        };
        Ok(TrainRun {
            scene: self.scene,
            gaussians: self.gaussians,
            init: InitOptions::default(),
            out: self.out,
            config,
            resolution,
            label_maps: self.label_maps,
            options,
        })
    }
}

impl TrainArgs {
    /// Refuses an --out that would overwrite an input: OUT equal to SCENE, the PLY, the config or
    /// the label maps, an input inside what train writes into OUT (`gaussians.ply`,
    /// `quality.json`, `object_features.npy`, `renders/`, `masks/`, `overlays/`, `readback/`,
    /// `point_cloud/`), or OUT inside the label-map folder; before anything is read.
    pub fn refuse_overwrite(&self) -> splatseg_scene::SceneResult<()> {
        use splatseg_scene::paths::{refuse_overwrite, Role};
        let mut inputs = vec![Role::folder("SCENE", &self.scene)];
        inputs.extend(self.gaussians.as_ref().map(|p| Role::file("--gaussians", p)));
        inputs.extend(self.config.as_ref().map(|p| Role::file("--config", p)));
        let beside = self.gaussians.as_ref().and_then(|p| p.parent()).map(|dir| dir.join("masks"));
        match (&self.label_maps, beside) {
            (Some(dir), _) => inputs.push(Role::tree("--label-maps", dir)),
            (None, Some(dir)) => inputs.push(Role::tree("the label maps beside --gaussians", dir)),
            (None, None) => {}
        }
        let mut outputs = vec![Role::folder("--out", &self.out)];
        for dir in ["renders", "masks", "overlays", "readback", "point_cloud"] {
            outputs.push(Role::tree(format!("--out's {dir}/"), self.out.join(dir)));
        }
        for file in ["gaussians.ply", "quality.json", "object_features.npy", ".splatseg.lock"] {
            outputs.push(Role::file(format!("--out's {file}"), self.out.join(file)));
        }
        refuse_overwrite(&inputs, &outputs)
    }
}
