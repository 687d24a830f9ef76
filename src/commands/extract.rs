//! `splatseg extract`: write the Gaussians of some objects to a new PLY.

use anyhow::Context;
use clap::Args as ClapArgs;
use splatseg_edit::io::{require_labels, write_edited_ply};
use splatseg_edit::{extract, ExtraFields};
use std::path::PathBuf;

/// Write the Gaussians of the chosen objects to a new PLY (e.g. to open one object alone).
///
/// The input is a labelled PLY (with `object_id`, as `splatseg run` writes it); the Gaussians
/// keep their order and every value bit for bit. The output has the standard INRIA 3DGS layout
/// that viewers open: splatseg's `object_id` and `feat_*` properties (and any other non-standard
/// property) are dropped unless --keep-extras is given. `splatseg objects PLY` lists the ids.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Labelled 3DGS PLY.
    pub ply: PathBuf,
    /// Object ids to keep, comma-separated (e.g. `3,7`; `-1` = the unlabelled Gaussians).
    #[arg(long, required = true, value_delimiter = ',', allow_negative_numbers = true)]
    pub ids: Vec<i32>,
    /// Output PLY.
    #[arg(long)]
    pub out: PathBuf,
    /// Keep `object_id`, `feat_*` and other non-standard properties (some viewers reject them).
    #[arg(long)]
    pub keep_extras: bool,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let g = require_labels(
        splatseg_pipeline::ply_input::read_finite(&args.ply, super::run_options().strict)?,
        &args.ply,
    )?;
    let picked = extract(&g, &args.ids).map_err(|e| e.with_path(&args.ply))?;
    let count = picked.len();
    let extras = if args.keep_extras { ExtraFields::Keep } else { ExtraFields::Strip };
    write_edited_ply(&args.out, picked, extras)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    println!("wrote {count} of {} Gaussians to {}", g.len(), args.out.display());
    Ok(())
}
