//! `splatseg bench quality`: the stress suite's distributions (see [`super::suite`]).

use super::suite::{
    markdown, parse_seeds, score_scene, Descriptors, SceneOverrides, SceneScore, DEFAULT_FAMILIES,
    REPORT_SEEDS, TUNING_SEEDS,
};
use crate::commands::synth::parse_family;
use anyhow::Context;
use clap::Args as ClapArgs;
use splatseg_synth::Family;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

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

/// How many of the worst scenes the report lists.
const WORST_LISTED: usize = 8;

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

fn seeds_of(text: &str) -> anyhow::Result<Vec<u64>> {
    match text.trim() {
        "tuning" => Ok(TUNING_SEEDS.collect()),
        "report" => Ok(REPORT_SEEDS.collect()),
        t => parse_seeds(t).map_err(anyhow::Error::msg).context("--seeds"),
    }
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let seeds = seeds_of(&args.seeds)?;
    let families = if args.families.is_empty() { DEFAULT_FAMILIES.to_vec() } else { args.families.clone() };
    let descriptors: Vec<Descriptors> = if args.no_features {
        vec![Descriptors::Features, Descriptors::ModelFree]
    } else {
        vec![Descriptors::Features]
    };
    let overrides = SceneOverrides { size: None, views: None }; // each family's own size and views
    let pipeline = match &args.config {
        Some(path) => splatseg_pipeline::PipelineConfig::from_file(path)?,
        None => splatseg_pipeline::PipelineConfig::default(),
    };
    let work_root = match &args.out {
        Some(out) => out.join("scenes"),
        None => std::env::temp_dir().join(format!("splatseg-bench-{}", std::process::id())),
    };
    let started = Instant::now();
    let total = families.len() * seeds.len();
    let mut scores: Vec<SceneScore> = Vec::new();
    for (k, &family) in families.iter().enumerate() {
        for (j, &seed) in seeds.iter().enumerate() {
            let work = work_root.join(format!("{family}_{seed}"));
            let scene = score_scene(family, seed, overrides, &descriptors, &pipeline, &work)?;
            std::fs::remove_dir_all(&work)
                .with_context(|| format!("cannot remove the scene folder {}", work.display()))?;
            for s in &scene {
                eprintln!(
                    "[{}/{total}] {family} seed {seed} ({}): mIoU {:.3}, boundary {:.3}, consistency {:.3}, \
                     ids/GT {:.2}, 3D acc. {:.3}, unlabelled {:.3} ({:.1} s)",
                    k * seeds.len() + j + 1,
                    if s.descriptors == Descriptors::Features { "features" } else { "model-free" },
                    s.miou,
                    s.boundary_miou,
                    s.consistency,
                    s.ids_per_gt,
                    s.accuracy_3d,
                    s.unlabelled_share,
                    s.seconds
                );
            }
            scores.extend(scene);
        }
    }
    let _ = std::fs::remove_dir(&work_root);
    let names: Vec<&str> = families.iter().map(|f| f.name()).collect();
    let mut text = format!(
        "# splatseg bench quality\n\nseeds {} ({} scenes per family), families {}{}{}; {:.0} s in all\n",
        args.seeds,
        seeds.len(),
        names.join(" "),
        overrides.size.map_or(String::new(), |(w, h)| format!(", size {w}x{h}")),
        overrides.views.map_or(String::new(), |v| format!(", {v} views")),
        started.elapsed().as_secs_f64()
    );
    for d in &descriptors {
        let of: Vec<SceneScore> = scores.iter().filter(|s| s.descriptors == *d).cloned().collect();
        text.push_str(&format!("\n## {}\n\n{}", d.name(), markdown(&of, WORST_LISTED)));
    }
    if let Some(out) = &args.out {
        std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
        splatseg_scene::atomic::write_bytes_atomic(&out.join("quality.md"), text.as_bytes())?;
        let json = serde_json::to_vec_pretty(&scores).context("encoding the scores")?;
        splatseg_scene::atomic::write_bytes_atomic(&out.join("quality.json"), &json)?;
    }
    let _ = std::io::stdout().write_all(text.as_bytes());
    Ok(())
}
