//! The `splatseg` command line: a thin layer over the stage crates.
use clap::Parser;

mod commands;

fn main() -> std::process::ExitCode {
    let cli = commands::Cli::parse();
    commands::logging::init(cli.quiet, cli.verbose);
    // Before any thread starts: one arena, freed buffers reused (see the function's docs).
    splatseg_scene::memory::keep_freed_memory_for_reuse();
    splatseg_pipeline::ply_input::set_strict(cli.strict);
    match commands::run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
