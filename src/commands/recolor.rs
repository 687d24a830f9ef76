//! `splatseg recolor`: paint every object in its palette colour.

use anyhow::Context;
use clap::Args as ClapArgs;
use splatseg_edit::io::{require_labels, write_edited_ply};
use splatseg_edit::{palette_colour, recolor, ExtraFields, UnlabelledStyle};
use std::path::PathBuf;

/// Paint each object in its palette colour (the colours of the label-map overlays), to see a
/// segmentation in any 3DGS viewer.
///
/// Sets each labelled Gaussian's base colour (`f_dc`) to its object's colour and zeroes its
/// view-dependent part (`f_rest`), and Gaussians without an object flat dark grey; positions,
/// shapes and opacities are unchanged. The output
/// has the standard INRIA 3DGS layout unless --keep-extras is given.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Labelled 3DGS PLY.
    pub ply: PathBuf,
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
    let style = UnlabelledStyle::Grey;
    let painted = recolor(&g, |id| palette_colour(id, style)).map_err(|e| e.with_path(&args.ply))?;
    let extras = if args.keep_extras { ExtraFields::Keep } else { ExtraFields::Strip };
    write_edited_ply(&args.out, painted, extras)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    println!("wrote {} recoloured Gaussians to {}", g.len(), args.out.display());
    Ok(())
}
