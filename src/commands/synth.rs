//! `splatseg synth`: write a synthetic scene with ground truth as a capture folder.

use anyhow::Context;
use clap::Args as ClapArgs;
use splatseg_synth::{generate, write, SynthConfig, SynthScene};
use std::path::PathBuf;
use std::time::Instant;

/// Generate a synthetic multi-object scene with ground truth, in the formats users bring.
///
/// Writes into OUT: `images/`, `sparse/0/*.txt` (COLMAP text model), `gaussians.ply`,
/// simulated SAM masks `sam/<stem>.json`, cue maps `features/<stem>.npy` (DINOv2-like patch
/// features) and `depth/<stem>.npy` (relative inverse depth), and the ground truth in `gt/`
/// (`instance/<stem>.png` 16-bit ids equal across views, `depth/<stem>.npy` metric z,
/// `gaussian_ids.npy`, `objects.json` with the objects and where the hard cases appear).
/// The same seed always gives the same files.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Output folder (created if needed).
    #[arg(long)]
    pub out: PathBuf,
    /// Seed of the scene (layout jitter, extra objects, simulated masks and cue noise).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Number of views on the camera arc.
    #[arg(long)]
    pub views: Option<usize>,
    /// Image size as WIDTHxHEIGHT.
    #[arg(long, value_parser = super::parse_size)]
    pub size: Option<(u32, u32)>,
    /// A TOML file with any `SynthConfig` fields (seed, views, width, height, fov_x_deg,
    /// arc_deg, gaussian_spacing_px, feature_dim, feature_patch_px, [sam]); flags override it.
    #[arg(long)]
    pub config: Option<PathBuf>,
}

fn config_from(args: &Args) -> anyhow::Result<SynthConfig> {
    let mut config = match &args.config {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read synth config {}", path.display()))?;
            toml::from_str(&text).with_context(|| format!("invalid synth config {}", path.display()))?
        }
        None => SynthConfig::default(),
    };
    if let Some(seed) = args.seed {
        config.seed = seed;
    }
    if let Some(views) = args.views {
        config.views = views;
    }
    if let Some((w, h)) = args.size {
        config.width = w;
        config.height = h;
    }
    Ok(config)
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let config = config_from(&args)?;
    let started = Instant::now();
    let scene = generate(&config).context("generating the synthetic scene")?;
    let generated = started.elapsed();
    let summary = write(&args.out, &scene)
        .with_context(|| format!("writing the synthetic scene to {}", args.out.display()))?;
    println!(
        "wrote {} files to {}: {} views of {}x{}, {} instances, {} Gaussians, {} simulated SAM masks \
         (generated in {:.2} s, written in {:.2} s)",
        summary.files,
        summary.root.display(),
        summary.views,
        config.width,
        config.height,
        summary.instances,
        summary.gaussians,
        summary.sam_masks,
        generated.as_secs_f64(),
        (started.elapsed() - generated).as_secs_f64()
    );
    print_hard_cases(&scene);
    Ok(())
}

fn print_hard_cases(scene: &SynthScene) {
    let stems = |views: Vec<usize>| {
        views.into_iter().map(|v| scene.views[v].stem.clone()).collect::<Vec<_>>().join(" ")
    };
    let name = |id: u32| scene.objects.get((id as usize).wrapping_sub(1)).map_or("?", |o| o.name.as_str());
    let hc = &scene.hard_cases;
    let pair = |p: &splatseg_synth::hard_cases::PairCase| {
        format!(
            "{} + {}, touching in: {}",
            name(p.ids[0]),
            name(p.ids[1]),
            stems(p.views.iter().filter(|v| v.touching).map(|v| v.view).collect())
        )
    };
    println!("  white-on-white pair: {}", pair(&hc.white_on_white));
    println!("  same-depth pair:     {}", pair(&hc.same_depth_pair));
    let mut occluded: Vec<u32> = hc.occlusions.iter().map(|o| o.id).collect();
    occluded.sort_unstable();
    occluded.dedup();
    println!("  occluded objects:    {}", occluded.iter().map(|&id| name(id)).collect::<Vec<_>>().join(", "));
    let mut cut: Vec<u32> = hc.frame_cuts.iter().map(|c| c.id).collect();
    cut.sort_unstable();
    cut.dedup();
    println!("  cut by the frame:    {}", cut.iter().map(|&id| name(id)).collect::<Vec<_>>().join(", "));
    println!("  details per view: gt/objects.json");
}
