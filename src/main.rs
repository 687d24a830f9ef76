//! The `splatseg` command line: a thin layer over the stage crates.
use clap::Parser;

mod commands;
mod pipeline;

fn main() -> std::process::ExitCode {
    let cli = commands::Cli::parse();
    commands::logging::init(cli.quiet, cli.verbose);
    commands::ply_input::set_strict(cli.strict);
    match commands::run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
