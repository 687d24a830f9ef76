//! Converts Gaussians between the formats of `splatseg_scene::splats`: the input chosen by its
//! content, the output by its extension. `tools/fixtures/make_splat_fixtures.py` makes the
//! writers' fixtures with it.
//!
//!     cargo run --release -p splatseg-scene --example splat_convert -- IN OUT

use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let [input, output] = args.as_slice() else {
        eprintln!("usage: splat_convert IN OUT (IN: .ply/.spz/.splat by content; OUT by extension)");
        return ExitCode::FAILURE;
    };
    let result = splatseg_scene::splats::read_gaussians(input)
        .and_then(|g| splatseg_scene::splats::write_gaussians(output, &g));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
