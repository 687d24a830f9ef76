//! `splatseg remove`: write a PLY without some objects.

use anyhow::Context;
use clap::Args as ClapArgs;
use splatseg_edit::io::{require_labels, write_edited_ply};
use splatseg_edit::{remove, ExtraFields};
use std::path::PathBuf;

/// Write the scene without the chosen objects (every other Gaussian unchanged, same order).
///
/// The input is a labelled PLY (with `object_id`, as `splatseg run` writes it). The output has
/// the standard INRIA 3DGS layout that viewers open: splatseg's `object_id` and `feat_*`
/// properties (and any other non-standard property) are dropped unless --keep-extras is given.
/// `splatseg objects PLY` lists the ids.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Labelled 3DGS PLY.
    pub ply: PathBuf,
    /// Object ids to remove, comma-separated (e.g. `3,7`; `-1` = the unlabelled Gaussians).
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
    let kept = remove(&g, &args.ids).map_err(|e| e.with_path(&args.ply))?;
    let count = kept.len();
    let extras = if args.keep_extras { ExtraFields::Keep } else { ExtraFields::Strip };
    write_edited_ply(&args.out, kept, extras)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    println!("removed {} Gaussians, wrote {count} to {}", g.len() - count, args.out.display());
    Ok(())
}
