//! What `run` writes besides `gaussians.ply` (`splatseg_lift::write_labelled_ply`): `masks/`,
//! `overlays/`, `report.md`.

use super::RunSummary;
use crate::error::Context;
use splatseg_scene::image_io::{write_png_rgb8, RgbImage};
use splatseg_scene::labels::{overlay, write_label_png};
use splatseg_scene::load::LoadOptions;
use splatseg_scene::{Plane, Scene};
use std::fmt::Write as _;
use std::path::Path;

/// Writes `OUT/masks/<stem>.png` (16-bit global ids) and `OUT/overlays/<stem>.png` of view `v`
/// (`map`: `[H, W]` final ids; `rgb`: `[H, W, 3]` its image as the per-view pass decoded it, or
/// `None` to decode it here).
pub fn write_view_maps(
    out: &Path,
    scene: &Scene,
    load: &LoadOptions,
    v: usize,
    map: &Plane<u32>,
    rgb: Option<Vec<u8>>,
) -> crate::Result<()> {
    let view = &scene.views[v];
    write_label_png(&out.join("masks").join(format!("{}.png", view.stem)), map)?;
    let image = match rgb {
        Some(rgb) => RgbImage::from_vec(map.width, map.height, rgb)
            .with_context(|| format!("the spilled image of view `{}` has another size", view.stem))?,
        None => splatseg_scene::images::load_image_rgb(scene, view, load)?,
    };
    let path = out.join("overlays").join(format!("{}.png", view.stem));
    write_png_rgb8(&path, &overlay(&image, map, 0.5))?;
    Ok(())
}

/// Writes `report.md`.
pub fn write_report(out: &Path, scene: &Scene, summary: &RunSummary) -> crate::Result<()> {
    let mut md = String::from("# splatseg run\n\n");
    let _ = writeln!(md, "Scene: `{}` ({} views).\n", scene.root.display(), scene.views.len());
    let _ = writeln!(md, "| stage | result |\n| --- | --- |");
    let _ = writeln!(
        md,
        "| raw SAM regions | {} over {} views with masks ({:.1} per view) |",
        summary.raw_masks,
        summary.views_with_masks,
        summary.raw_masks as f64 / summary.views_with_masks.max(1) as f64
    );
    let _ = writeln!(
        md,
        "| merged (MCM) | {} ({:.1} per view) |",
        summary.merged_masks,
        summary.merged_masks as f64 / summary.views_with_masks.max(1) as f64
    );
    let _ = writeln!(
        md,
        "| matched | {} global objects ({} joins, {} 3D edges, {} cannot-links) |",
        summary.matched_objects,
        summary.match_stats.joins,
        summary.match_stats.edges_3d,
        summary.match_stats.cannot_links
    );
    if let Some(stats) = &summary.lift_stats {
        let _ = writeln!(
            md,
            "| lifted | {} objects in the label maps; Gaussians: {} labelled, {} unreliable (σ² > τ_var), {} in no object, {} unseen |",
            summary.final_objects, stats.labelled, stats.unreliable, stats.no_object, stats.unseen
        );
    }
    if !summary.warnings.is_empty() {
        let _ = writeln!(md, "\n## Warnings ({})\n", summary.warnings.len());
        for warning in &summary.warnings {
            let _ = writeln!(md, "- {warning}");
        }
    }
    if let Some(report) = &summary.report {
        md.push_str("\n## Metrics\n\n");
        md.push_str(&report.to_markdown());
    }
    md.push_str("\n## Views\n\n");
    for view in &scene.views {
        let _ = writeln!(md, "- `{0}`: [overlay](overlays/{0}.png), [label map](masks/{0}.png)", view.stem);
    }
    splatseg_scene::atomic::write_bytes_atomic(&out.join("report.md"), md.as_bytes())
        .with_context(|| format!("writing {}", out.join("report.md").display()))?;
    Ok(())
}
