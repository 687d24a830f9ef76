//! `splatseg merge`: Multi-Cue-Guided Mask Merging of every view's SAM masks.

use anyhow::{bail, Context};
use clap::{Args as ClapArgs, ValueEnum};
use rayon::prelude::*;
use serde::Serialize;
use splatseg_cues::{
    ColourTextureDescriptors, DenseFeatureDescriptors, DepthKind, DepthMap, DepthSource, DescriptorSource,
    FeatureGrids, Intrinsics, MaskInput, NpyDepthSource, RegionOptions, RegionSource,
};
use splatseg_merge::{build_view_inputs, merge_view, CueRequest, Decision, MergeConfig, RegionSummary};
use splatseg_render::{render, RenderCamera, RenderRequest};
use splatseg_scene::load::LoadOptions;
use splatseg_scene::{Gaussians, Plane, Scene, View};
use std::path::{Path, PathBuf};
use std::time::Instant;

use splatseg_pipeline::{merge_shard, read_view_mask_inputs, PipelineConfig, RunConfig, Shard};

/// What the `--depth` maps hold.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum DepthMeaning {
    /// Relative inverse depth (monocular models such as Depth Anything V2; larger = nearer).
    Inverse,
    /// Metric camera z (0 = no surface).
    Metric,
}

/// Merge each view's over-segmented SAM masks into objects (paper §4.2).
///
/// Inputs are matched to views by image file stem: `MASKS/<stem>.json` (SAM JSON) or
/// `MASKS/<stem>/metadata.csv`, `FEATURES/<stem>.npy` (`[h, w, C]`), `DEPTH/<stem>.npy` (`[H, W]`).
/// Writes per view `OUT/masks/<stem>.png` (16-bit label map, 0 = unlabelled),
/// `OUT/overlays/<stem>.png` and `OUT/merge/<stem>.json` (regions before/after and every merge
/// decision with its score terms and the rule that decided it).
///
/// With `--shard K/N` it runs `run`'s per-view merge stage instead, on the views `v` with
/// `v mod N = K`: the per-view results go to `OUT/cache/merge/` (what `splatseg run` reads), and
/// `--config` is then `run`'s pipeline TOML. Start the N shards anywhere they see the same folders
/// (a Slurm job array, a Kubernetes indexed Job, Ray tasks), then `splatseg run` with the same
/// arguments and `--out` does only the global steps (matching, lifting); it names any missing shard.
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
    /// Metric z maps (`<stem>.npy`) for the relative depth gate (default: rendered from the
    /// Gaussians when a PLY is available).
    #[arg(long)]
    pub metric_depth: Option<PathBuf>,
    /// 3DGS PLY for rendered depth (default: SCENE/gaussians.ply when present).
    #[arg(long)]
    pub gaussians: Option<PathBuf>,
    /// Merge settings (TOML `MergeConfig`; `profile = "paper" | "literal"`). With
    /// --shard: `run`'s pipeline TOML (`splatseg config`), the same file the later `run` gets.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Image down-scaling factor (1, 2, 4, 8) as 3DGS's `--resolution`.
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

/// `OUT/merge/<stem>.json`.
#[derive(Serialize)]
struct ViewLog<'a> {
    stem: &'a str,
    config: &'a MergeConfig,
    regions_before: usize,
    regions_after: usize,
    merges: usize,
    /// Input regions (SAM masks after overlaps were resolved), index = input label − 1.
    input_regions: &'a [RegionSource],
    /// Final id of each input region.
    final_id_of_input: &'a [u32],
    /// Final regions (descriptor omitted).
    regions: Vec<RegionBrief<'a>>,
    decisions: &'a [Decision],
}

#[derive(Serialize)]
struct RegionBrief<'a> {
    id: u32,
    area: u64,
    mean_depth: f32,
    bbox_px: [u32; 4],
    merged_from: &'a [u32],
}

fn brief(r: &RegionSummary) -> RegionBrief<'_> {
    RegionBrief {
        id: r.id,
        area: r.area,
        mean_depth: r.mean_depth,
        bbox_px: r.bbox_px,
        merged_from: &r.merged_from,
    }
}

/// Depth rendered from the Gaussians (expected metric z), one view at a time.
struct RenderedDepth<'a> {
    scene: &'a Scene,
    gaussians: &'a Gaussians,
}

impl RenderedDepth<'_> {
    fn metric(&self, view: &View, width: usize, height: usize) -> anyhow::Result<Plane<f32>> {
        let camera = RenderCamera::from_scene(self.scene.camera(view), &view.world_from_cam);
        let request = RenderRequest { rgb: false, depth: true, ..RenderRequest::default() };
        let out = render(self.gaussians, &camera, &request)
            .with_context(|| format!("rendering depth of view `{}`", view.stem))?;
        let depth = out.depth.context("the renderer returned no depth")?;
        if depth.size() != (width, height) {
            bail!("rendered depth of view `{}` is {:?}, the image {width}×{height}", view.stem, depth.size());
        }
        Ok(depth)
    }
}

/// Reads the SAM masks of `view` (`width × height`) as merge inputs; an error when it has none.
pub fn read_mask_inputs(
    dir: &Path,
    view: &View,
    width: usize,
    height: usize,
) -> anyhow::Result<Vec<MaskInput>> {
    read_view_mask_inputs(dir, &view.stem, width, height)?
        .with_context(|| format!("no SAM masks for view `{}` in {}", view.stem, dir.display()))
}

/// Reads a merge config file (or the paper's defaults).
pub fn read_config(path: Option<&Path>) -> anyhow::Result<MergeConfig> {
    match path {
        None => Ok(MergeConfig::default()),
        Some(p) => {
            let text = std::fs::read_to_string(p).with_context(|| format!("cannot read {}", p.display()))?;
            MergeConfig::from_toml_str(&text).with_context(|| format!("in {}", p.display()))
        }
    }
}

struct Sources<'a> {
    descriptors: &'a dyn DescriptorSource,
    depth: Option<NpyDepthSource>,
    metric: Option<NpyDepthSource>,
    rendered: Option<RenderedDepth<'a>>,
}

struct ViewOutcome {
    before: usize,
    after: usize,
}

fn merge_one(
    args: &Args,
    scene: &Scene,
    view: &View,
    sources: &Sources,
    config: &MergeConfig,
) -> anyhow::Result<ViewOutcome> {
    let load = LoadOptions { resolution: args.resolution, ..LoadOptions::default() };
    let image = splatseg_scene::images::load_image_rgb(scene, view, &load)?;
    let (w, h) = (image.width() as usize, image.height() as usize);
    let rgb =
        Plane { width: w, height: h, data: image.pixels().map(|p| p.0.map(|c| c as f32 / 255.0)).collect() };
    let masks = read_mask_inputs(&args.masks, view, w, h)?;
    let rendered = match &sources.rendered {
        Some(r) if sources.depth.is_none() || sources.metric.is_none() => Some(r.metric(view, w, h)?),
        _ => None,
    };
    let depth = match (&sources.depth, &rendered) {
        (Some(src), _) => src.depth(&view.stem, w, h)?,
        (None, Some(z)) => DepthMap { values: z.clone(), kind: DepthKind::MetricZ },
        (None, None) => bail!("no depth for view `{}`: give --depth or a PLY", view.stem),
    };
    let metric = match &sources.metric {
        Some(src) => Some(src.depth(&view.stem, w, h)?.values),
        None => rendered,
    };
    let inputs = build_view_inputs(&CueRequest {
        stem: &view.stem,
        rgb: &rgb,
        masks: &masks,
        depth: &depth,
        metric_depth: metric.as_ref(),
        descriptors: sources.descriptors,
        region_options: RegionOptions::default(),
        intrinsics: Some(Intrinsics::of_camera(scene.camera(view), w, h)),
    })
    .with_context(|| format!("cues of view `{}`", view.stem))?;
    let result = merge_view(&inputs, config).with_context(|| format!("merging view `{}`", view.stem))?;
    let stem = &view.stem;
    splatseg_scene::labels::write_label_png(
        &args.out.join("masks").join(format!("{stem}.png")),
        &result.labels,
    )?;
    let overlay = splatseg_scene::labels::overlay(&image, &result.labels, 0.5);
    splatseg_scene::labels::write_png_rgb(&args.out.join("overlays").join(format!("{stem}.png")), &overlay)?;
    let log = ViewLog {
        stem,
        config,
        regions_before: result.log.regions_before,
        regions_after: result.log.regions_after,
        merges: result.log.merges,
        input_regions: &inputs.regions.sources,
        final_id_of_input: &result.log.final_id_of_input,
        regions: result.regions.iter().map(brief).collect(),
        decisions: &result.log.decisions,
    };
    let json = serde_json::to_vec_pretty(&log)?;
    splatseg_scene::atomic::write_bytes_atomic(&args.out.join("merge").join(format!("{stem}.json")), &json)?;
    Ok(ViewOutcome { before: result.log.regions_before, after: result.log.regions_after })
}

/// `--shard K/N`: `run`'s merge stage on one shard of the views.
fn run_shard(args: Args, shard: Shard) -> anyhow::Result<()> {
    if args.metric_depth.is_some() || args.resolution != 1 {
        bail!("--shard runs `run`'s merge stage, which takes neither --metric-depth nor --resolution");
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
    };
    let summary = merge_shard(&config, shard)?;
    println!(
        "shard {shard}: {} of {} views merged ({} from the cache) into {}",
        summary.merged,
        summary.views,
        summary.cached,
        config.out.join("cache").join("merge").display()
    );
    Ok(())
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(shard) = args.shard {
        return run_shard(args, shard);
    }
    let started = Instant::now();
    let config = read_config(args.config.as_deref())?;
    config.validate()?;
    let load = LoadOptions { resolution: args.resolution, ..LoadOptions::default() };
    let scene = splatseg_scene::load_scene(&args.scene, &load)?;
    if !args.masks.is_dir() {
        bail!("SAM masks folder not found: {}", args.masks.display());
    }
    let views: Vec<&View> = scene
        .views
        .iter()
        .filter(|v| {
            args.masks.join(format!("{}.json", v.stem)).is_file() || args.masks.join(&v.stem).is_dir()
        })
        .collect();
    if views.is_empty() {
        bail!("no view of the scene has masks (expected <stem>.json per image): {}", args.masks.display());
    }
    let ply =
        args.gaussians.clone().or_else(|| Some(args.scene.join("gaussians.ply")).filter(|p| p.is_file()));
    let gaussians = match &ply {
        Some(p) if args.depth.is_none() || args.metric_depth.is_none() => {
            Some(splatseg_pipeline::ply_input::read_finite(p)?)
        }
        _ => None,
    };
    if args.depth.is_none() && gaussians.is_none() {
        bail!("no depth: give --depth DIR or a PLY (--gaussians, or gaussians.ply in the scene folder)");
    }
    let dense;
    let colour = ColourTextureDescriptors;
    let descriptors: &dyn DescriptorSource = match &args.features {
        Some(dir) => {
            dense = DenseFeatureDescriptors { grids: FeatureGrids::Folder(dir.clone()) };
            &dense
        }
        None => &colour,
    };
    let kind = match args.depth_kind {
        DepthMeaning::Inverse => DepthKind::InverseRelative,
        DepthMeaning::Metric => DepthKind::MetricZ,
    };
    let sources = Sources {
        descriptors,
        depth: args.depth.clone().map(|dir| NpyDepthSource { dir, kind }),
        metric: args.metric_depth.clone().map(|dir| NpyDepthSource { dir, kind: DepthKind::MetricZ }),
        rendered: gaussians.as_ref().map(|g| RenderedDepth { scene: &scene, gaussians: g }),
    };
    let outcomes = views
        .par_iter()
        .map(|view| merge_one(&args, &scene, view, &sources, &config))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let before: usize = outcomes.iter().map(|o| o.before).sum();
    let after: usize = outcomes.iter().map(|o| o.after).sum();
    let n = outcomes.len() as f64;
    println!(
        "merged {} views ({:?} profile): {:.1} → {:.1} regions per view, in {:.2} s; wrote {}/{{masks,overlays,merge}}/",
        outcomes.len(),
        config.profile,
        before as f64 / n,
        after as f64 / n,
        started.elapsed().as_secs_f64(),
        args.out.display()
    );
    Ok(())
}
