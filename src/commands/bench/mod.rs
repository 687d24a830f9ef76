//! `splatseg bench`: measurements that take minutes, printed as tables (quality over many
//! synthetic scenes; time and memory at scale).

use clap::{Args as ClapArgs, Subcommand};

pub mod quality;
pub mod scale;

/// Measure the pipeline over many scenes and print the distributions.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// What to measure.
    #[command(subcommand)]
    pub what: What,
}

/// The benchmarks.
#[derive(Debug, Subcommand)]
pub enum What {
    /// Segmentation quality over the stress suite's families and seeds.
    #[command(long_about = quality::LONG_ABOUT)]
    Quality(quality::Args),
    /// Time and peak memory of `run`, per stage, on a synthetic capture of a given size.
    #[command(long_about = scale::LONG_ABOUT)]
    Scale(scale::Args),
}

/// Runs the chosen benchmark.
pub fn run(args: Args) -> anyhow::Result<()> {
    match args.what {
        What::Quality(a) => quality::run(a),
        What::Scale(a) => scale::run(a),
    }
}
