//! `splatseg bench scale`: time and peak memory of `run` at a given size (`splatseg_bench::scale`).

use anyhow::Context;
use clap::Args as ClapArgs;
use splatseg_bench::scale::{scale, ScaleRequest};
use std::path::PathBuf;

/// Measure `splatseg run` on a synthetic capture of N views × W×H pixels × G Gaussians.
pub const LONG_ABOUT: &str = "Measure `splatseg run` on a synthetic capture of N views × W×H pixels × G Gaussians.

Writes the capture once into DIR/scene-<N>v-<W>x<H>-<G>g-s<seed>/ (a `rooms` scene with SAM JSON masks, \
`.npy` features and depth, as a user brings them; reused when it is there), then runs `splatseg run` on it \
in a child process with a fresh output folder, and prints the wall time and peak resident memory of the whole \
run and of each stage (from its --profile: VmHWM reset at each stage; the run's peak is the largest), \
with the thread time of each stage's parts (surface depth and visibility, merge, votes, render back…; \
summed over threads, so parts may add up to more than the stage's wall time).

The scene has min(N, --distinct-views) distinct views; beyond that, views repeat the distinct ones (same \
image, masks, cues and pose under a new name), so a 1,000-view capture costs the disk of 100. The Gaussians \
are the synthetic ones subsampled evenly to G, or repeated with a small deterministic offset up to G.

Example: splatseg bench scale --views 100 --size 1280x960 --gaussians 1000000 --dir /tmp/scale";

/// Arguments of `bench scale`.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Views of the capture.
    #[arg(long, default_value_t = 100)]
    pub views: usize,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, value_parser = crate::commands::parse_size, default_value = "1280x960")]
    pub size: (u32, u32),
    /// Gaussians in the PLY.
    #[arg(long, default_value_t = 1_000_000)]
    pub gaussians: usize,
    /// Most distinct views rendered; further views repeat them.
    #[arg(long, default_value_t = 100)]
    pub distinct_views: usize,
    /// Working folder (captures and outputs; several GB for large captures).
    #[arg(long, default_value = "bench-scale")]
    pub dir: PathBuf,
}

/// Runs the benchmark.
pub fn run(args: Args) -> anyhow::Result<()> {
    let request = ScaleRequest {
        views: args.views,
        size: args.size,
        gaussians: args.gaussians,
        seed: 0, // one fixed scene, so runs compare
        distinct_views: args.distinct_views,
        dir: args.dir,
    };
    let exe = std::env::current_exe().context("cannot find the splatseg binary")?;
    print!("{}", scale(&request, &exe)?);
    Ok(())
}
