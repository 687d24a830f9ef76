//! Subcommands. Their arguments are the libraries' structs (clap's `Args` with each crate's `cli`
//! feature); each file here calls the library and prints.

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use splatseg_pipeline::args as pipeline;

pub mod apply;
pub mod bench;
pub mod config;
pub mod cues;
pub mod demo;
pub mod edit;
pub mod eval;
pub mod find;
pub mod info;
pub mod logging;
pub mod merge;
pub mod render;
pub mod run;
pub mod synth;
pub mod train;
pub mod view;

/// `--strict` and `--quiet`, set once by `main` (the binary's own state: the libraries take them
/// in their settings).
static RUN_OPTIONS: std::sync::OnceLock<splatseg_pipeline::RunOptions> = std::sync::OnceLock::new();

/// Records the global flags' options for the commands (first call wins).
pub fn set_run_options(options: splatseg_pipeline::RunOptions) {
    let _ = RUN_OPTIONS.set(options);
}

/// The global flags' options (the defaults before `main` set them, as in tests).
pub fn run_options() -> splatseg_pipeline::RunOptions {
    RUN_OPTIONS.get().copied().unwrap_or_default()
}

/// splatseg: view-consistent object instances for 3D Gaussian Splatting scenes.
///
/// Turns a multi-view capture (COLMAP or transforms.json) and its 3DGS PLY into refined per-view
/// masks with global object ids and Gaussians labelled by object. Start with `splatseg demo`.
///
/// Logs go to stderr, coloured only on a terminal (never with NO_COLOR set). Without -q/-v the
/// level comes from RUST_LOG (e.g. RUST_LOG=debug or RUST_LOG=splatseg_lift=debug), else info.
/// Parses the command line. A negative number is read as the value of the option before it
/// (`--iterations -5` gets the option's own message, not clap's "unexpected argument '-5'").
pub fn parse() -> Cli {
    let matches = negative_numbers_as_values(Cli::command()).get_matches();
    Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit())
}

fn negative_numbers_as_values(command: clap::Command) -> clap::Command {
    command
        .mut_args(|arg| if arg.get_action().takes_values() { arg.allow_negative_numbers(true) } else { arg })
        .mut_subcommands(negative_numbers_as_values)
}

#[derive(Debug, Parser)]
#[command(name = "splatseg", version, about, long_about = None)]
pub struct Cli {
    /// Only warnings and errors; no progress bars.
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    pub quiet: bool,
    /// More detail in the logs: -v debug, -vv trace.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    /// Refuse a Gaussian file (PLY, compressed PLY, SPZ, .splat, .ksplat) holding any non-finite
    /// value (NaN, ±Inf) or degenerate Gaussian (zero quaternion, log-scale above 20). Without it such Gaussians are skipped with a warning: `run` keeps their rows in its gaussians.ply with
    /// object_id -1, other commands leave them out of what they write.
    #[arg(long, global = true)]
    pub strict: bool,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Apply a run's edits (OUT/edits.json: merge, split, reassign, name objects) to its outputs.
    Apply(pipeline::ApplyArgs),
    /// Print the merge stage's ablation and sensitivity tables on a synthetic scene.
    Ablate(splatseg_bench::AblateArgs),
    /// Measure quality over many synthetic scenes of the stress suite (`bench quality`).
    Bench(splatseg_bench::BenchArgs),
    /// Print the default settings, each with its meaning and source, as a TOML file for `run --config`.
    Config(config::Args),
    /// Compute per-view cues with in-process models (SAM masks, DINOv2 features, depth, LoG).
    #[command(long_about = splatseg_model_cues::args::CUES_LONG_ABOUT)]
    Cues(splatseg_model_cues::CuesArgs),
    /// Run the whole pipeline on a generated synthetic scene and print the metrics.
    Demo(pipeline::DemoArgs),
    /// Score predicted label maps against ground truth (mIoU, boundary mIoU, #masks, consistency).
    Eval(splatseg_eval::EvalArgs),
    /// Write the Gaussians of chosen objects of a labelled PLY to a new PLY.
    Extract(splatseg_edit::ExtractArgs),
    /// Rank a run's objects against a text query ("a red mug") with the CLIP embeddings of `run --clip`.
    Find(splatseg_model_cues::FindArgs),
    /// Show what a scene folder holds: cameras, views, missing images, Gaussians, masks.
    #[command(long_about = pipeline::INFO_LONG_ABOUT)]
    Info(pipeline::InfoArgs),
    /// Merge each view's over-segmented SAM masks with semantic, depth and edge cues (paper §4.2).
    Merge(pipeline::MergeArgs),
    /// List the objects of a labelled PLY (id, Gaussians, bounding box, colour, views).
    Objects(splatseg_edit::ObjectsArgs),
    /// Paint each object of a labelled PLY in its palette colour.
    Recolor(splatseg_edit::RecolorArgs),
    /// Write a labelled PLY without chosen objects.
    Remove(splatseg_edit::RemoveArgs),
    /// Render every view of a scene from a 3DGS PLY (rgb, depth, ids, alpha) on the CPU.
    Render(pipeline::RenderArgs),
    /// Run the pipeline (cues → merge → match → lift → eval) on a scene with SAM masks.
    Run(splatseg_model_cues::RunArgs),
    /// Write a synthetic multi-object scene with ground truth, simulated SAM masks and cues.
    Synth(splatseg_synth::SynthArgs),
    /// Train the Gaussians on the images (3DGS on the CPU) and, with lifted ids, the joint optimisation.
    Train(pipeline::TrainArgs),
    /// Open a labelled scene in the browser: see, pick, hide and export objects (WebGL2 viewer).
    View(splatseg_view::ViewArgs),
}

/// Runs the chosen subcommand.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Ablate(args) => bench::ablate(args),
        Command::Apply(args) => apply::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Config(args) => config::run(args),
        Command::Cues(args) => cues::run(args),
        Command::Demo(args) => demo::run(args),
        Command::Eval(args) => eval::run(args),
        Command::Extract(args) => edit::extract(args),
        Command::Find(args) => find::run(args),
        Command::Info(args) => info::run(args),
        Command::Merge(args) => merge::run(args),
        Command::Objects(args) => edit::objects(args),
        Command::Recolor(args) => edit::recolor(args),
        Command::Remove(args) => edit::remove(args),
        Command::Render(args) => render::run(args),
        Command::Run(args) => run::run(args),
        Command::Synth(args) => synth::run(args),
        Command::Train(args) => train::run(args),
        Command::View(args) => view::run(args),
    }
}
