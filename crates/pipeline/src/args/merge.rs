//! `splatseg merge`'s arguments.

use crate::{MergeRequest, PipelineConfig, PipelineError, RunConfig, RunOptions, Shard};
use splatseg_cues::DepthKind;
use splatseg_scene::load::LoadOptions;
use std::path::PathBuf;

/// What the `--depth` maps hold.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
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
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct MergeArgs {
    /// Scene folder (COLMAP or transforms.json).
    pub scene: PathBuf,
    /// SAM masks folder.
    #[cfg_attr(feature = "cli", arg(long))]
    pub masks: PathBuf,
    /// Dense feature maps (e.g. DINOv2 patch tokens); without it, the model-free colour + texture
    /// descriptors are used.
    #[cfg_attr(feature = "cli", arg(long))]
    pub features: Option<PathBuf>,
    /// Depth maps folder; without it, depth is rendered from the Gaussians.
    #[cfg_attr(feature = "cli", arg(long))]
    pub depth: Option<PathBuf>,
    /// What the `--depth` maps hold.
    #[cfg_attr(feature = "cli", arg(long, value_enum, default_value = "inverse"))]
    pub depth_kind: DepthMeaning,
    /// Gaussians for rendered depth: a 3DGS or compressed PLY, an SPZ, a .splat or a .ksplat
    /// (default: SCENE/gaussians.ply when present).
    #[cfg_attr(feature = "cli", arg(long))]
    pub gaussians: Option<PathBuf>,
    /// `run`'s pipeline TOML (`splatseg config`; the merge settings are its [merge] table), the
    /// same file the later `run` gets.
    #[cfg_attr(feature = "cli", arg(long))]
    pub config: Option<PathBuf>,
    /// Image down-scaling factor (1, 2, 4, 8) as 3DGS's `--resolution` (`run` and --shard: 1).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 1))]
    pub resolution: u32,
    /// Output folder.
    #[cfg_attr(feature = "cli", arg(long))]
    pub out: PathBuf,
    /// Shard `K/N` (0 ≤ K < N) of `run`'s merge stage: only the views `v` with `v mod N = K`, into
    /// OUT/cache/merge for a later `splatseg run --out OUT` (e.g. `--shard $SLURM_ARRAY_TASK_ID/8`).
    #[cfg_attr(feature = "cli", arg(long, allow_hyphen_values = true))]
    pub shard: Option<Shard>,
}

impl MergeArgs {
    /// `run`'s inputs and the merge request (all views, or one shard at `--resolution 1`).
    pub fn into_request(self, options: RunOptions) -> crate::Result<(RunConfig, MergeRequest)> {
        if self.shard.is_some() && self.resolution != 1 {
            return Err(PipelineError::Invalid(
                "--shard runs `run`'s merge stage, which reads the images at --resolution 1".into(),
            ));
        }
        let config = RunConfig {
            pipeline: PipelineConfig::from_optional_file(self.config.as_deref())?,
            scene: self.scene,
            masks: self.masks,
            features: self.features,
            depth: self.depth,
            depth_kind: match self.depth_kind {
                DepthMeaning::Inverse => DepthKind::InverseRelative,
                DepthMeaning::Metric => DepthKind::MetricZ,
            },
            // `run --resize-depth` only (the option budget): a map of another size is an error here.
            resize_depth: false,
            gaussians: self.gaussians,
            gt: None,
            out: self.out,
            options,
        };
        let load = LoadOptions { resolution: self.resolution, ..LoadOptions::default() };
        Ok((config, MergeRequest { shard: self.shard, load }))
    }
}

impl MergeArgs {
    /// Refuses an --out that would overwrite an input (see `super::run_outputs`, plus OUT/merge/),
    /// before anything is read.
    pub fn refuse_overwrite(&self) -> splatseg_scene::SceneResult<()> {
        let inputs = super::pipeline_inputs(
            &self.scene,
            Some(&self.masks),
            self.features.as_deref(),
            self.depth.as_deref(),
            self.gaussians.as_deref(),
            self.config.as_deref(),
        );
        let mut outputs = super::run_outputs(&self.out);
        outputs.push(splatseg_scene::paths::Role::tree("--out's merge/", self.out.join("merge")));
        splatseg_scene::paths::refuse_overwrite(&inputs, &outputs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shard_refuses_another_resolution() {
        let args = MergeArgs {
            scene: PathBuf::from("scene"),
            masks: PathBuf::from("sam"),
            features: None,
            depth: None,
            depth_kind: DepthMeaning::Metric,
            gaussians: None,
            config: None,
            resolution: 2,
            out: PathBuf::from("out"),
            shard: Some("0/2".parse().expect("a shard")),
        };
        let err = args.into_request(RunOptions::default()).unwrap_err().to_string();
        assert!(err.contains("--resolution 1"), "{err}");
    }
}
