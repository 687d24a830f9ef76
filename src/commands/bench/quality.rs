//! `splatseg bench quality`: the stress suite's distributions (`splatseg_bench::quality`).

use crate::commands::synth::parse_family;
use clap::Args as ClapArgs;
use splatseg_bench::quality::{quality, QualityRequest};
use splatseg_bench::suite::SceneOverrides;
use splatseg_synth::Family;
use std::io::Write;
use std::path::PathBuf;

/// The long help.
pub const LONG_ABOUT: &str = "\
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
views).

Examples:
  splatseg bench quality --seeds 0..4 --family rooms
  splatseg bench quality --seeds report --out bench-report
  splatseg bench quality --seeds 100..108 --family hires --no-features
  splatseg bench quality --seeds 0..4 --config merge-off.toml --out tuning-merge-off";

/// Score the pipeline over many synthetic scenes of the stress suite.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Seeds: `A..B` (B excluded), `A..=B`, `1,5,9`, `tuning` (0..16) or `report` (100..132).
    #[arg(long, default_value = "tuning")]
    pub seeds: String,
    /// A family to run (repeat for several); default: rooms multi_tone thin border clutter
    /// sam_noise.
    #[arg(long = "family", value_parser = parse_family)]
    pub families: Vec<Family>,
    /// Also run every scene without --features (the model-free descriptors) and report it too.
    #[arg(long)]
    pub no_features: bool,
    /// Output folder: `quality.md` and `quality.json`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// A pipeline config (TOML, as for `splatseg run --config`) for every run instead of the
    /// defaults: to compare settings on the tuning seeds.
    #[arg(long)]
    pub config: Option<PathBuf>,
}

/// How many of the worst scenes the report lists.
const WORST_LISTED: usize = 8;

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let pipeline = match &args.config {
        Some(path) => splatseg_pipeline::PipelineConfig::from_file(path)?,
        None => splatseg_pipeline::PipelineConfig::default(),
    };
    let request = QualityRequest {
        seeds: args.seeds,
        families: args.families,
        overrides: SceneOverrides { size: None, views: None }, // each family's own size and views
        no_features: args.no_features,
        out: args.out,
        keep: false,
        pipeline,
        worst: WORST_LISTED,
    };
    let text = quality(&request, &mut |line| eprintln!("{line}"))?;
    let _ = std::io::stdout().write_all(text.as_bytes());
    Ok(())
}
