//! The `splatseg` command line: a thin layer over the stage crates.
use clap::Parser;

mod commands;
mod pipeline;

fn main() -> std::process::ExitCode {
    commands::init_logging();
    let cli = commands::Cli::parse();
    match commands::run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
