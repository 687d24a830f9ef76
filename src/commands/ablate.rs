//! `splatseg ablate`: the merge stage's ablation and sensitivity tables on a synthetic scene.

use clap::Args as ClapArgs;
use splatseg_bench::ablate::{ablate, AblateRequest};
use std::path::PathBuf;

/// Measure Multi-Cue-Guided Mask Merging on a generated synthetic scene with ground truth.
///
/// Prints (and with --markdown writes) Markdown tables of masks per view and per-view mIoU
/// (Hungarian matching per view): the score profiles, boundary statistics, the cue ablation
/// (raw / semantic only / + LoG / + depth, as the paper's Table 3), the paper's supplementary
/// sensitivity table (τ_merge, τ_depth, w_sem), the depth gates on the white-on-white pair, and
/// the rule for uncovered pixels. Cues: the scene's simulated DINOv2-like features and monocular
/// depth; metric depth for the relative gate rendered from its Gaussians.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Seed of the synthetic scene.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Number of views.
    #[arg(long, default_value_t = 12)]
    pub views: usize,
    /// Image size as WIDTHxHEIGHT.
    #[arg(long, value_parser = super::parse_size)]
    pub size: Option<(u32, u32)>,
    /// Base merge settings (TOML `MergeConfig`); default: the paper profile.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Also write the tables to this Markdown file.
    #[arg(long)]
    pub markdown: Option<PathBuf>,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let base = splatseg_bench::ablate::base_config(args.config.as_deref())?;
    let request = AblateRequest { seed: args.seed, views: args.views, size: args.size, base };
    let out = ablate(&request)?;
    print!("{out}");
    if let Some(path) = &args.markdown {
        splatseg_scene::atomic::write_bytes_atomic(path, out.as_bytes())?;
    }
    Ok(())
}
