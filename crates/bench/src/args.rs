//! The arguments of `splatseg bench quality`, `bench scale`, `bench identity` and `ablate` (clap's `Args` and
//! `Subcommand` with the `cli` feature), and the requests they make.

use crate::ablate::{base_config, AblateRequest};
use crate::quality::QualityRequest;
use crate::scale::ScaleRequest;
use crate::suite::{DepthSource, SceneOverrides};
use splatseg_pipeline::PipelineConfig;
use splatseg_synth::Family;
use std::path::PathBuf;

/// Measure the pipeline over many scenes and print the distributions.
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct BenchArgs {
    /// What to measure.
    #[cfg_attr(feature = "cli", command(subcommand))]
    pub what: What,
}

/// The benchmarks.
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Subcommand))]
pub enum What {
    /// Segmentation quality over the stress suite's families and seeds.
    #[cfg_attr(feature = "cli", command(long_about = QUALITY_LONG_ABOUT))]
    Quality(QualityArgs),
    /// Time and peak memory of `run`, per stage, on a synthetic capture of a given size.
    #[cfg_attr(feature = "cli", command(long_about = SCALE_LONG_ABOUT))]
    Scale(ScaleArgs),
    /// The joint stage with the 3D terms only against 3D terms + identity maps, on the demo's scenes.
    #[cfg_attr(feature = "cli", command(long_about = IDENTITY_LONG_ABOUT))]
    Identity(IdentityArgs),
}

/// The long help of `bench identity`.
pub const IDENTITY_LONG_ABOUT: &str = "\
The identity study (paper §4.4): for each seed, the demo's synthetic scene (12 views of 320×240, \
`splatseg demo --seed S`) and its pipeline run, then the train stage twice on the lifted Gaussians \
(300 iterations, the joint optimisation from iteration 100): with the 3D terms only, and with the 3D \
terms plus the 2D identity maps, every read-back of the ids scored against the ground truth next to \
the lifted ids. One Markdown table per seed (mIoU, boundary mIoU, #masks, consistency, 3D label \
accuracy, held-out PSNR / SSIM); `BENCHMARKS.md` records the means over seeds 5–8. Writes into \
out/identity-study/seed-<S>/ (the scene, the run, both trainings).

Examples:
  splatseg bench identity 5 6 7 8
  splatseg bench identity 0";

/// Arguments of `bench identity`.
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct IdentityArgs {
    /// Seeds of the demo's scene, one study each.
    #[cfg_attr(feature = "cli", arg(required = true, num_args = 1..))]
    pub seeds: Vec<u64>,
}

impl IdentityArgs {
    /// One demo request per seed, with the identity study, into `out/identity-study/seed-<S>/`.
    pub fn requests(
        &self,
        options: splatseg_pipeline::RunOptions,
    ) -> Vec<splatseg_pipeline::demo::DemoRequest> {
        self.seeds
            .iter()
            .map(|&seed| {
                let out = PathBuf::from("out").join("identity-study").join(format!("seed-{seed}"));
                splatseg_pipeline::args::identity_study_request(seed, out, options)
            })
            .collect()
    }
}

/// The long help of `bench quality`.
pub const QUALITY_LONG_ABOUT: &str = "\
Segmentation quality over the stress suite: for every family and seed, generate the synthetic \
scene (`splatseg synth --family F --seed S`), run the pipeline on it as a user would (`splatseg \
run` with --features, the scene's Gaussians and ground truth) and score the final label maps and \
labelled Gaussians. Prints each metric's distribution over the scenes (min, p10, median, mean, \
max), the means per family, the IoU per failure class (multi_tone, thin, border_cut, stacked, \
touching, white_pair, same_depth_pair, occluded, room, plain; instances matched by the eval \
crate's Hungarian matching over all views) and the worst scenes. Two ceilings are scored beside \
the final maps: the SAM masks as regions and the merged regions, every region given its majority \
ground-truth id (an oracle in place of matching and lifting): the gap from the SAM ceiling to the \
merged one is what merging lost by wrong merges, from the merged ceiling to the final maps what \
matching and lifting lost.

Seed sets: tune settings on the tuning seeds 0..16 and report on the report seeds 100..132 \
(`--seeds report`), which no setting was chosen on.

Families (default: rooms multi_tone thin border clutter sam_noise): default, rooms, multi_tone, \
thin, border, clutter, sam_noise, hires (the rooms at 1280×960), many_views (the rooms with 12–100 \
views), rough (the rooms with Gaussians tilted off their surfaces, thicker and off them, as a trained \
3DGS leaves them). Blind families, for judging and never for choosing a setting (their own rooms, cue \
statistics no tuning family uses; report them apart): blind_cues (noisier features, parts and \
objects closer in feature space, a worse monocular depth, more nested and wrong SAM merges), \
blind_lens (40°–75° lenses), blind_512 (512×384, both), blind_hires (1280×960, fine stripes and \
checkers on objects), blind_sam (SAM seldom nests whole-object masks and often covers two touching \
objects with one; 400×300, 16 views), blind_capture (100 views of 1280×960, cluttered rooms with \
touching and stacked objects, 50°–70° lenses), blind_rooms (every wall and floor patterned, \
touching and stacked objects, parts of an object further apart in feature space; 640×480, 32 views), \
blind_near (2–3 large textured objects near the cameras cut by the border, stacks, few whole-object \
masks; 480×360, 20 views), blind_rough (Gaussians tilted off their surfaces, thicker and moved off \
them as a trained 3DGS leaves them; cluttered rooms, 400×300, 24 views), blind_trained (Gaussians \
as a trained 3DGS leaves them in more ways: tilted, thick, off the surface, of spread sizes, 1–3 % \
floaters; patterned floors, multi-coloured objects, 512×384, 28 views), blind_parts (multi-coloured \
objects whose parts are far apart in feature space, large objects near the cameras, touching and \
stacked objects; 448×336, 22 views), blind_closeup (2–3 large multi-coloured objects near the \
cameras seen through a trained 3DGS's Gaussians, few whole-object masks; 384×288, 30 views), \
blind_alike (objects closer in feature space than anywhere else, 2–3 touching pairs, few \
whole-object masks, often one mask over two touching objects; 576×432, 26 views), blind_contact \
(objects in contact everywhere, mostly multi-coloured with finer patterns, through a trained 3DGS's \
Gaussians, one mask often over two touching objects; 416×312, 28 views), blind_fine (multi-coloured \
objects nearly everywhere with fine stripes, one large object near the cameras, mildly tilted \
Gaussians, few whole-object masks; 544×408, 32 views).

Examples:
  splatseg bench quality --seeds 0..4 --family rooms
  splatseg bench quality --seeds report --out bench-report
  splatseg bench quality --seeds 100..108 --family hires --no-features
  splatseg bench quality --seeds report --family blind_cues --family blind_lens --family blind_512
  splatseg bench quality --seeds 0..4 --config merge-off.toml --out tuning-merge-off";

/// Score the pipeline over many synthetic scenes of the stress suite.
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct QualityArgs {
    /// Seeds: `A..B` (B excluded), `A..=B`, `1,5,9`, `tuning` (0..16) or `report` (100..132).
    #[cfg_attr(feature = "cli", arg(long, default_value = "tuning"))]
    pub seeds: String,
    /// A family to run (repeat for several); default: rooms multi_tone thin border clutter
    /// sam_noise.
    #[cfg_attr(feature = "cli", arg(long = "family", value_parser = splatseg_synth::parse_family))]
    pub families: Vec<Family>,
    /// Also run every scene without --features (the model-free descriptors) and report it too.
    #[cfg_attr(feature = "cli", arg(long))]
    pub no_features: bool,
    /// Output folder: `quality.md` and `quality.json`.
    #[cfg_attr(feature = "cli", arg(long))]
    pub out: Option<PathBuf>,
    /// A pipeline config (TOML, as for `splatseg run --config`) for every run instead of the
    /// defaults: to compare settings on the tuning seeds.
    #[cfg_attr(feature = "cli", arg(long))]
    pub config: Option<PathBuf>,
}

/// How many of the worst scenes the report lists.
const WORST_LISTED: usize = 8;

impl QualityArgs {
    /// The suite's request: each family's own size and views, the `--config` settings.
    pub fn into_request(self) -> crate::Result<QualityRequest> {
        Ok(QualityRequest {
            seeds: self.seeds,
            families: self.families,
            overrides: SceneOverrides { size: None, views: None },
            no_features: self.no_features,
            depth: DepthSource::Rendered,
            out: self.out,
            keep: false,
            pipeline: PipelineConfig::from_optional_file(self.config.as_deref())?,
            worst: WORST_LISTED,
        })
    }
}

/// The long help of `bench scale`.
pub const SCALE_LONG_ABOUT: &str = "Measure `splatseg run` on a synthetic capture of N views × W×H pixels × G Gaussians.

Writes the capture once into DIR/scene-<N>v-<W>x<H>-<G>g-s<seed>/ (a `rooms` scene with SAM JSON masks, \
`.npy` features and depth, as a user brings them; reused when it is there), then runs `splatseg run` on it \
in a child process with a fresh output folder, and prints the wall time and peak resident memory of the whole \
run and of each stage (from its OUT/cache/profile.json: VmHWM reset at each stage; the run's peak is the largest), \
with the thread time of each stage's parts (surface depth and visibility, merge, votes, render back…; \
summed over threads, so parts may add up to more than the stage's wall time).

The scene has min(N, 100) distinct views; beyond that, views repeat the distinct ones (same image, \
masks, cues and pose under a new name), so a 1,000-view capture costs the disk of 100. The Gaussians \
are the synthetic ones subsampled evenly to G, or repeated with a small deterministic offset up to G.

Example: splatseg bench scale --views 100 --size 1280x960 --gaussians 1000000 --dir /tmp/scale";

/// Arguments of `bench scale`.
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct ScaleArgs {
    /// Views of the capture.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 100))]
    pub views: usize,
    /// Image size, WIDTHxHEIGHT.
    #[cfg_attr(feature = "cli", arg(long, value_parser = splatseg_synth::parse_size, default_value = "1280x960"))]
    pub size: (u32, u32),
    /// Gaussians in the PLY.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 1_000_000))]
    pub gaussians: usize,
    /// Working folder (captures and outputs; several GB for large captures).
    #[cfg_attr(feature = "cli", arg(long, default_value = "bench-scale"))]
    pub dir: PathBuf,
}

impl ScaleArgs {
    /// The benchmark's request: one fixed scene (seed 0), so runs compare.
    pub fn request(self) -> ScaleRequest {
        ScaleRequest {
            views: self.views,
            size: self.size,
            gaussians: self.gaussians,
            seed: 0,
            distinct_views: crate::scale::DISTINCT_VIEWS,
            dir: self.dir,
        }
    }
}

/// Measure Multi-Cue-Guided Mask Merging on a generated synthetic scene with ground truth.
///
/// Prints Markdown tables of masks per view and per-view mIoU
/// (Hungarian matching per view): the score profiles, boundary statistics, the cue ablation
/// (raw / semantic only / + LoG / + depth, as the paper's Table 3), the paper's supplementary
/// sensitivity table (τ_merge, τ_depth, w_sem), the depth gates on the white-on-white pair, and
/// the rule for uncovered pixels. Cues: the scene's simulated DINOv2-like features and monocular
/// depth; metric depth for the crease gate rendered from its Gaussians.
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct AblateArgs {
    /// Base merge settings (TOML `MergeConfig`); default: the paper profile.
    #[cfg_attr(feature = "cli", arg(long))]
    pub config: Option<PathBuf>,
}

impl AblateArgs {
    /// The request of the documented tables: seed 0, 12 views, the `--config` merge settings.
    pub fn request(&self) -> crate::Result<AblateRequest> {
        Ok(AblateRequest { seed: 0, views: 12, size: None, base: base_config(self.config.as_deref())? })
    }
}

impl QualityArgs {
    /// Refuses a --config that is --out or its `quality.md` / `quality.json`, before anything is
    /// read.
    pub fn refuse_overwrite(&self) -> splatseg_scene::SceneResult<()> {
        use splatseg_scene::paths::{refuse_overwrite, Role};
        let (Some(config), Some(out)) = (&self.config, &self.out) else { return Ok(()) };
        let outputs = [
            Role::folder("--out", out),
            Role::file("--out's quality.md", out.join("quality.md")),
            Role::file("--out's quality.json", out.join("quality.json")),
        ];
        refuse_overwrite(&[Role::file("--config", config)], &outputs)
    }
}
