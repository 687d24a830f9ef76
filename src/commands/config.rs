//! `splatseg config`: print the default settings as a TOML file to edit and pass with `--config`.

use anyhow::Context;
use clap::Args as ClapArgs;
use std::path::PathBuf;

/// Print every setting of `splatseg run` with its default value, as TOML.
///
/// One table per stage (`[merge]`, `[match]`, `[lift]`, `[objects]`, `[final_maps]`, `[eval]`,
/// `[train]`); each key comes after a comment with its meaning, unit and the source of its
/// default (the paper's, 3DGS's, or ours). Save it, change what you need (every key is
/// optional) and pass it with `splatseg run --config FILE`:
///
///     splatseg config --out splatseg.toml
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Write to this file instead of standard output.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let text = splatseg_pipeline::PipelineConfig::default()
        .to_file_text()
        .context("cannot serialise the default settings")?;
    match args.out {
        Some(path) => {
            splatseg_scene::atomic::write_bytes_atomic(&path, text.as_bytes())?;
            println!("wrote {}", path.display());
        }
        None => print!("{text}"),
    }
    Ok(())
}
