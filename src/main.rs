//! The `splatseg` command line: a thin layer over the stage crates.
mod commands;
mod memory;

fn main() -> std::process::ExitCode {
    let cli = commands::parse();
    commands::logging::init(cli.quiet, cli.verbose);
    // Before any thread starts: one arena, freed buffers reused (see the function's docs).
    memory::keep_freed_memory_for_reuse();
    commands::set_run_options(splatseg_pipeline::RunOptions { strict: cli.strict, quiet: cli.quiet });
    match commands::run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
