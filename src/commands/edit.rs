//! `splatseg objects`, `extract`, `remove` and `recolor`: inspect and edit a labelled PLY.

use anyhow::Context;
use rayon::prelude::*;
use splatseg_edit::args::extras;
use splatseg_edit::io::{require_labels, write_edited_ply};
use splatseg_edit::{ExtractArgs, ObjectsArgs, RecolorArgs, RemoveArgs};
use splatseg_scene::gaussians::Gaussians;
use std::path::Path;

/// The labelled PLY (`--strict` refuses non-finite values).
fn read_labelled(ply: &Path) -> anyhow::Result<Gaussians> {
    Ok(require_labels(splatseg_pipeline::ply_input::read_finite(ply, super::run_options().strict)?, ply)?)
}

/// Writes an edited PLY.
fn write(out: &Path, g: Gaussians, keep_extras: bool) -> anyhow::Result<()> {
    write_edited_ply(out, g, extras(keep_extras)).with_context(|| format!("cannot write {}", out.display()))
}

/// Runs `splatseg objects`.
pub fn objects(args: ObjectsArgs) -> anyhow::Result<()> {
    let mut table = splatseg_edit::objects(&read_labelled(&args.ply)?).map_err(|e| e.with_path(&args.ply))?;
    if let Some(dir) = args.label_maps() {
        let maps = splatseg_eval::list_label_maps(&dir)?;
        anyhow::ensure!(!maps.is_empty(), "no label map (*.png) found in folder: {}", dir.display());
        let ids: Vec<Vec<u32>> = maps
            .par_iter()
            .map(|(_, p)| {
                splatseg_scene::labels::read_label_png(p).map(|m| splatseg_edit::ids_in_label_map(&m))
            })
            .collect::<Result<_, _>>()?;
        table.set_views_seen(&ids);
    }
    table.set_names(&splatseg_edit::names_beside(&args.ply)?);
    if args.json {
        println!("{}", serde_json::to_string_pretty(&table).context("cannot serialise the object table")?);
    } else {
        print!("{}", table.to_markdown());
    }
    Ok(())
}

/// `--ids`, or the object `apply` named so, or the object a query matches best (the embeddings
/// of `run --clip` beside the PLY).
fn chosen_ids(ply: &Path, ids: &[i32], query: Option<&str>) -> anyhow::Result<Vec<i32>> {
    let Some(query) = query else { return Ok(ids.to_vec()) };
    let named: Vec<i32> =
        splatseg_edit::names_beside(ply)?.into_iter().filter(|(_, n)| n == query).map(|(id, _)| id).collect();
    if !named.is_empty() {
        println!("{query:?}: object {}", named.iter().map(i32::to_string).collect::<Vec<_>>().join(", "));
        return Ok(named);
    }
    let found = splatseg_model_cues::clip_objects::best_match_beside(ply, query)?;
    println!("{query:?}: object {} (relevancy {:.4})", found.id, found.relevancy);
    Ok(vec![i32::try_from(found.id)?])
}

/// Runs `splatseg extract`.
pub fn extract(args: ExtractArgs) -> anyhow::Result<()> {
    args.refuse_overwrite()?;
    let g = read_labelled(&args.ply)?;
    let ids = chosen_ids(&args.ply, &args.ids, args.query.as_deref())?;
    let picked = splatseg_edit::extract(&g, &ids).map_err(|e| e.with_path(&args.ply))?;
    let count = picked.len();
    write(&args.out, picked, args.keep_extras)?;
    println!("wrote {count} of {} Gaussians to {}", g.len(), args.out.display());
    Ok(())
}

/// Runs `splatseg remove`.
pub fn remove(args: RemoveArgs) -> anyhow::Result<()> {
    args.refuse_overwrite()?;
    let g = read_labelled(&args.ply)?;
    let ids = chosen_ids(&args.ply, &args.ids, args.query.as_deref())?;
    let kept = splatseg_edit::remove(&g, &ids).map_err(|e| e.with_path(&args.ply))?;
    let count = kept.len();
    write(&args.out, kept, args.keep_extras)?;
    println!("removed {} Gaussians, wrote {count} to {}", g.len() - count, args.out.display());
    Ok(())
}

/// Runs `splatseg recolor`.
pub fn recolor(args: RecolorArgs) -> anyhow::Result<()> {
    args.refuse_overwrite()?;
    let g = read_labelled(&args.ply)?;
    let style = splatseg_edit::UnlabelledStyle::Grey;
    let painted = splatseg_edit::recolor(&g, |id| splatseg_edit::palette_colour(id, style))
        .map_err(|e| e.with_path(&args.ply))?;
    write(&args.out, painted, args.keep_extras)?;
    println!("wrote {} recoloured Gaussians to {}", g.len(), args.out.display());
    Ok(())
}
