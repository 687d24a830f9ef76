//! `splatseg objects`: list the objects of a labelled PLY.

use anyhow::Context;
use clap::Args as ClapArgs;
use rayon::prelude::*;
use splatseg_edit::io::require_labels;
use splatseg_edit::{ids_in_label_map, objects};
use std::path::PathBuf;

/// List the objects of a labelled PLY: id, Gaussian count, bounding box of the centres, palette
/// colour and (with --masks) the number of views showing it.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Labelled 3DGS PLY (with `object_id`, as `splatseg run` writes it).
    pub ply: PathBuf,
    /// Folder of per-view label maps (`<stem>.png`, e.g. `OUT/masks`) to count views per object.
    #[arg(long, value_name = "DIR")]
    pub masks: Option<PathBuf>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let g = require_labels(
        splatseg_pipeline::ply_input::read_finite(&args.ply, super::run_options().strict)?,
        &args.ply,
    )?;
    let mut table = objects(&g).map_err(|e| e.with_path(&args.ply))?;
    if let Some(dir) = &args.masks {
        let maps = splatseg_eval::list_label_maps(dir)?;
        anyhow::ensure!(!maps.is_empty(), "no label map (*.png) found in folder: {}", dir.display());
        let ids: Vec<Vec<u32>> = maps
            .par_iter()
            .map(|(_, path)| splatseg_scene::labels::read_label_png(path).map(|m| ids_in_label_map(&m)))
            .collect::<Result<_, _>>()?;
        table.set_views_seen(&ids);
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&table).context("cannot serialise the object table")?);
    } else {
        print!("{}", table.to_markdown());
    }
    Ok(())
}
