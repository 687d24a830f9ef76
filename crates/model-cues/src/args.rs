//! The arguments of `splatseg cues` and `splatseg run` (clap's `Args` with the `cli` feature):
//! `run` lives here because its `--sam`, `--dinov2` and `--depth-model` run the models first.

use crate::clip_objects::ObjectEmbeddingRequest;
use crate::{compute_cues, models_for_run, CuesRequest, CuesSummary, ModelCuesError};
use splatseg_cues::DepthKind;
use splatseg_pipeline::{PipelineConfig, RunConfig, RunOptions};
use splatseg_scene::paths::Role;
use std::path::PathBuf;

/// What `splatseg cues --help` says after its one-line summary: how the views stream, how progress is
/// shown, and how a rerun resumes.
pub const CUES_LONG_ABOUT: &str = "Compute per-view cues with in-process models: SAM automatic masks \
(OUT/sam/<stem>.json), DINOv2 patch features (OUT/features/<stem>.npy), Depth Anything V2 relative inverse \
depth (OUT/depth/<stem>.npy) and the LoG edge map (OUT/log/<stem>.npy).

The next image is decoded while the models run on the current one. Progress and an ETA: a bar on a \
terminal; when stderr is piped, an INFO line at least every 30 s (SPLATSEG_LOG_EVERY_SECS sets the \
interval). Each output is written whole (a temporary file renamed) and then recorded in \
OUT/cache/<cue>/<stem>.key with the model (checkpoint path, size, modification time), the settings, and \
the image's size and content hash: a rerun, also after a kill, skips exactly the outputs whose key \
matches and computes the rest.

Models are given as a checkpoint file, a Hugging Face snapshot folder, or a model id found in the local \
Hugging Face cache (facebook/dinov2-small); nothing is downloaded. Feed the outputs to `splatseg run \
--masks OUT/sam --features OUT/features --depth OUT/depth`.";

/// The arguments of `splatseg cues` (what it does: [`CUES_LONG_ABOUT`], its `--help`). Feed its outputs
/// to `splatseg run --masks OUT/sam --features OUT/features --depth OUT/depth`. Models are given as a
/// checkpoint file, a Hugging Face snapshot folder, or a model id found in the local Hugging Face cache
/// (`facebook/dinov2-small`); nothing is downloaded.
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct CuesArgs {
    /// Scene folder (COLMAP `sparse/0` + `images/`, or transforms.json).
    pub scene: PathBuf,
    /// Output folder.
    #[cfg_attr(feature = "cli", arg(long))]
    pub out: PathBuf,
    /// DINOv2 checkpoint (`.safetensors`/`.pth`, HF folder or model id).
    #[cfg_attr(feature = "cli", arg(long))]
    pub dinov2: Option<PathBuf>,
    /// Depth Anything V2 checkpoint.
    #[cfg_attr(feature = "cli", arg(long = "depth-model"))]
    pub depth_model: Option<PathBuf>,
    /// Segment Anything checkpoint (`sam_vit_{b,l,h}_*.pth`).
    #[cfg_attr(feature = "cli", arg(long))]
    pub sam: Option<PathBuf>,
    /// Image down-scaling factor (as 3DGS `--resolution`).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 1))]
    pub resolution: u32,
    /// Shard `K/N` (0 ≤ K < N): only the views `v` with `v mod N = K`. Shards
    /// may run at once on the same --out (a Slurm job array, a Kubernetes indexed Job); together
    /// they write exactly what one unsharded run writes.
    #[cfg_attr(feature = "cli", arg(long))]
    pub shard: Option<splatseg_pipeline::Shard>,
}

impl CuesArgs {
    /// Runs the chosen models on every view with the library's defaults: the references' input
    /// sizes (518 px) and SAM's automatic mask generator settings (32 points per side, no crops,
    /// no clean-up), the train split.
    /// `log_every`: the interval of progress lines when stderr is piped.
    pub fn compute(self, show_progress: bool, log_every: std::time::Duration) -> crate::Result<CuesSummary> {
        compute_cues(&CuesRequest {
            log_every,
            dinov2: self.dinov2,
            depth_model: self.depth_model,
            sam: self.sam,
            resolution: self.resolution,
            shard: self.shard,
            show_progress,
            ..CuesRequest::defaults_for(self.scene, self.out)
        })
    }
}

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
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct RunArgs {
    /// Scene folder (COLMAP `sparse/0` + `images/`, or transforms.json).
    pub scene: PathBuf,
    /// Folder of SAM automatic masks, `<image stem>.json` (COCO RLE) per view. Not needed with
    /// --sam (the masks are then computed into OUT/cues/sam).
    #[cfg_attr(feature = "cli", arg(long, required_unless_present = "sam"))]
    pub masks: Option<PathBuf>,
    /// Segment Anything checkpoint: compute the masks in-process with the automatic mask
    /// generator (as `splatseg cues --sam`) instead of reading --masks.
    #[cfg_attr(feature = "cli", arg(long, conflicts_with = "masks"))]
    pub sam: Option<PathBuf>,
    /// DINOv2 checkpoint: compute the dense features in-process instead of reading --features.
    #[cfg_attr(feature = "cli", arg(long, conflicts_with = "features"))]
    pub dinov2: Option<PathBuf>,
    /// Depth Anything V2 checkpoint: compute relative depth in-process instead of reading
    /// --depth or rendering it from the Gaussians.
    #[cfg_attr(feature = "cli", arg(long = "depth-model", conflicts_with = "depth"))]
    pub depth_model: Option<PathBuf>,
    /// Folder of dense feature maps `<image stem>.npy` (`[h, w, C]`, e.g. DINOv2 patches);
    /// without it, the model-free colour/texture descriptors are used.
    #[cfg_attr(feature = "cli", arg(long))]
    pub features: Option<PathBuf>,
    /// Folder of depth maps `<image stem>.npy`; without it depth is rendered from the Gaussians.
    #[cfg_attr(feature = "cli", arg(long))]
    pub depth: Option<PathBuf>,
    /// What --depth holds: `inverse` (relative inverse depth from monocular models such as Depth
    /// Anything V2; larger = nearer) or `metric` (camera z, 0 = no surface), as in `splatseg merge`.
    #[cfg_attr(feature = "cli", arg(long, default_value = "inverse", value_parser = splatseg_cues::parse_depth_kind))]
    pub depth_kind: DepthKind,
    /// Resample --depth maps whose size is not their image's (without it, such a map, e.g. a
    /// transposed one, is an error naming the file and both shapes).
    #[cfg_attr(feature = "cli", arg(long))]
    pub resize_depth: bool,
    /// Gaussians: a 3DGS PLY, a compressed PLY, an SPZ, a .splat or a .ksplat, chosen by content
    /// (default: SCENE/gaussians.ply when present). The labelled output is a PLY whatever the input.
    #[cfg_attr(feature = "cli", arg(long))]
    pub gaussians: Option<PathBuf>,
    /// Ground truth: a folder of `<image stem>.png` instance maps, or a synthetic scene's `gt/`
    /// (adds `gaussian_ids.npy` for the 3D label accuracy).
    #[cfg_attr(feature = "cli", arg(long))]
    pub gt: Option<PathBuf>,
    /// TOML settings (`splatseg config` prints them): tables [merge], [match], [lift], [objects],
    /// [final_maps], [eval], each optional.
    #[cfg_attr(feature = "cli", arg(long))]
    pub config: Option<PathBuf>,
    /// Output folder.
    #[cfg_attr(feature = "cli", arg(long))]
    pub out: PathBuf,
    /// CLIP checkpoint (with `bpe_simple_vocab_16e6.txt.gz` or `tokenizer.json` beside it), loaded
    /// and checked before the run: after it, embed each object's best views (at most 5 crops) into
    /// OUT/objects/ (`clip.npy`, `objects.json`) for `splatseg find` and `extract`/`remove --query`.
    /// Cached. A run without --clip removes the OUT/objects/ of an earlier run it replaces.
    #[cfg_attr(feature = "cli", arg(long))]
    pub clip: Option<PathBuf>,
}

impl RunArgs {
    /// What `--clip` asks for once the run is done: its objects embedded (`None` without `--clip`).
    pub fn clip_request(&self, show_progress: bool) -> Option<ObjectEmbeddingRequest> {
        self.clip.as_ref().map(|clip| ObjectEmbeddingRequest {
            scene: self.scene.clone(),
            out: self.out.clone(),
            clip: clip.clone(),
            show_progress,
        })
    }

    /// The pipeline's request: the `--config` settings, and the cues the models computed (into
    /// OUT/cues) in place of the folders given.
    pub fn into_config(self, options: RunOptions, show_progress: bool) -> crate::Result<RunConfig> {
        let pipeline = PipelineConfig::from_optional_file(self.config.as_deref())?;
        let computed = models_for_run(
            &self.scene,
            &self.out,
            self.sam.as_deref(),
            self.dinov2.as_deref(),
            self.depth_model.as_deref(),
            show_progress,
        )?;
        Ok(RunConfig {
            masks: computed
                .masks
                .or(self.masks)
                .ok_or_else(|| ModelCuesError::Invalid("either --masks or --sam is needed".into()))?,
            features: computed.features.or(self.features),
            depth_kind: if computed.depth.is_some() { DepthKind::InverseRelative } else { self.depth_kind },
            depth: computed.depth.or(self.depth),
            resize_depth: self.resize_depth,
            scene: self.scene,
            gaussians: self.gaussians,
            gt: self.gt,
            pipeline,
            out: self.out,
            options,
        })
    }
}

impl CuesArgs {
    /// Refuses an --out that would overwrite an input: OUT equal to SCENE or a checkpoint, or a
    /// checkpoint inside what cues writes (`sam/`, `features/`, `depth/`, `log/`, `cache/`);
    /// before anything is read.
    pub fn refuse_overwrite(&self) -> splatseg_scene::SceneResult<()> {
        let mut inputs = vec![Role::folder("SCENE", &self.scene)];
        inputs.extend(checkpoints(&self.sam, &self.dinov2, &self.depth_model));
        let mut outputs = vec![Role::folder("--out", &self.out)];
        for dir in ["sam", "features", "depth", "log", "cache"] {
            outputs.push(Role::tree(format!("--out's {dir}/"), self.out.join(dir)));
        }
        splatseg_scene::paths::refuse_overwrite(&inputs, &outputs)
    }
}

/// The model checkpoints given, as inputs.
fn checkpoints(sam: &Option<PathBuf>, dinov2: &Option<PathBuf>, depth_model: &Option<PathBuf>) -> Vec<Role> {
    [("--sam", sam), ("--dinov2", dinov2), ("--depth-model", depth_model)]
        .into_iter()
        .filter_map(|(what, p)| p.as_ref().map(|p| Role::file(what, p)))
        .collect()
}

impl RunArgs {
    /// Refuses an --out that would overwrite an input, before anything is read: OUT equal to any
    /// input (SCENE, its `gaussians.ply`, --masks, --features, --depth, --gaussians, --gt,
    /// --config, a checkpoint), an input inside what run writes into OUT (`masks/`, `overlays/`,
    /// `cache/`, `cues/` with models, `objects/`, `gaussians.ply`, `report.md`,
    /// `metrics.json`), OUT inside
    /// an input folder of masks, features, depth or ground truth.
    pub fn refuse_overwrite(&self) -> splatseg_scene::SceneResult<()> {
        let mut inputs = splatseg_pipeline::args::pipeline_inputs(
            &self.scene,
            self.masks.as_deref(),
            self.features.as_deref(),
            self.depth.as_deref(),
            self.gaussians.as_deref(),
            self.config.as_deref(),
        );
        inputs.extend(self.gt.as_ref().map(|p| Role::tree("--gt", p)));
        let models = checkpoints(&self.sam, &self.dinov2, &self.depth_model);
        let mut outputs = splatseg_pipeline::args::run_outputs(&self.out);
        if !models.is_empty() {
            outputs.push(Role::tree("--out's cues/", self.out.join("cues")));
        }
        inputs.extend(models);
        if let Some(clip) = &self.clip {
            inputs.push(Role::file("--clip", clip));
        }
        splatseg_scene::paths::refuse_overwrite(&inputs, &outputs)
    }
}

/// Rank the objects of a finished run by how well they match a text query (CLIP, as LERF scores
/// relevancy: the cosine to the query against the phrases "object", "things", "stuff", "texture").
///
/// Needs `splatseg run --clip CKPT` to have embedded the objects (OUT/objects/); the query is
/// embedded with the text tower of the checkpoint OUT/objects/objects.json names, so objects and
/// query come from one model. Prints the embedded objects, best first: rank, id, relevancy (above
/// 0.5: closer to the query than to every generic phrase), cosine, colour and the views its
/// embedding came from. Equal relevancies keep the order of the margins under them, then ids.
///
/// Refused, saying why: an empty query, one longer than CLIP's context (75 tokens), and embeddings
/// that no longer belong to OUT (its run, its gaussians.ply or the checkpoint changed since).
///
/// Example: splatseg find OUT "a red mug" --top 3 --json
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct FindArgs {
    /// A finished run's output folder (`splatseg run --clip CKPT --out OUT`).
    pub out: PathBuf,
    /// What to look for, e.g. "a red mug".
    pub query: String,
    /// Only the K best objects (default: every embedded object).
    #[cfg_attr(feature = "cli", arg(long, value_name = "K", value_parser = parse_top))]
    pub top: Option<usize>,
    /// Print a JSON array for scripts instead of the table: per object, best first, `rank`, `id`,
    /// `relevancy`, `cosine`, `colour` ([r, g, b]) and `views` (image stems).
    #[cfg_attr(feature = "cli", arg(long))]
    pub json: bool,
}

impl FindArgs {
    /// The ranked objects, the `--top` best (best first).
    pub fn find(&self) -> crate::Result<Vec<crate::clip_objects::FoundObject>> {
        crate::clip_objects::ObjectSearch::open(&self.out)?.find(&self.query, self.top.unwrap_or(usize::MAX))
    }

    /// What `find` prints: the table, or with `--json` the JSON array.
    pub fn report(&self) -> crate::Result<String> {
        let found = self.find()?;
        Ok(match self.json {
            true => crate::clip_objects::found_json(&found)?,
            false => crate::clip_objects::found_table(&self.query, &found),
        })
    }
}

/// Parses `--top K`: a whole number of at least 1.
pub fn parse_top(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(k) if k >= 1 => Ok(k),
        _ => Err(format!("expected a number of objects of at least 1, got `{text}`")),
    }
}

#[cfg(test)]
mod tests {
    use super::parse_top;

    #[test]
    fn top_is_at_least_one() {
        assert_eq!(parse_top("3"), Ok(3));
        assert!(parse_top("0").unwrap_err().contains("at least 1"));
        assert!(parse_top("-2").is_err());
        assert!(parse_top("many").is_err());
    }
}
