//! The `splatseg` command line: a thin layer over the stage crates.
use clap::Parser;

mod commands;

fn main() -> std::process::ExitCode {
    let cli = commands::Cli::parse();
    commands::logging::init(cli.quiet, cli.verbose);
    splatseg_pipeline::ply_input::set_strict(cli.strict);
    match commands::run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
