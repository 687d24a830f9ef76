//! What `run` writes: `masks/`, `overlays/`, `gaussians.ply`, `report.md`, `metrics.json`.

use super::RunSummary;
use crate::error::Context;
use splatseg_lift::FusedFeatures;
use splatseg_scene::labels::{overlay, write_label_png, write_png_rgb};
use splatseg_scene::load::LoadOptions;
use splatseg_scene::ply::{FeatureRows, PlyRows};
use splatseg_scene::{Gaussians, Plane, Scene};
use std::fmt::Write as _;
use std::path::Path;

/// `[N]` object ids of every row of the input PLY: `finite_ids` (`[N - k]`, one per finite row,
/// in order) spread back, and -1 for the `k` non-finite rows the stages skipped.
pub fn ids_of_every_row(rows: &PlyRows, finite_ids: &[i32]) -> Vec<i32> {
    let mut ids = vec![-1; rows.gaussians.len()];
    for (&row, &id) in rows.finite_rows().iter().zip(finite_ids) {
        ids[row] = id;
    }
    ids
}

/// The input rows with `object_id` = `ids` (`[N]`). With `fused` features (lifting fused them),
/// the input's own `feat_*` are dropped (the fused ones are written instead, see
/// [`FusedRows`]); otherwise they stay.
pub fn labelled_rows(rows: PlyRows, ids: &[i32], fused: bool) -> Gaussians {
    let mut g = rows.gaussians;
    g.object_ids = Some(ids.to_vec());
    if fused {
        g.features = None;
    }
    g
}

/// The fused features of every input row, made row by row while `gaussians.ply` is written:
/// the finite rows' fused features (one per finite row, in order), zeros for the skipped rows.
pub struct FusedRows {
    fused: FusedFeatures,
    /// `[N]` index among the finite rows, `u32::MAX` for a skipped row (empty: every row finite).
    finite_index: Vec<u32>,
}

impl FusedRows {
    /// `fused` (`[N − k]` rows) spread over the `n_rows` input rows; `finite_rows`: the input rows
    /// that are finite, in order.
    pub fn new(fused: FusedFeatures, finite_rows: &[usize], n_rows: usize) -> Self {
        let finite_index = if finite_rows.len() == n_rows {
            Vec::new()
        } else {
            let mut index = vec![u32::MAX; n_rows];
            for (k, &row) in finite_rows.iter().enumerate() {
                index[row] = k as u32;
            }
            index
        };
        FusedRows { fused, finite_index }
    }
}

impl FeatureRows for FusedRows {
    fn dim(&self) -> usize {
        self.fused.dim
    }

    fn row(&self, i: usize, out: &mut [f32]) {
        match self.finite_index.get(i) {
            None => self.fused.row(i, out),
            Some(&u32::MAX) => out.iter_mut().for_each(|x| *x = 0.0),
            Some(&k) => self.fused.row(k as usize, out),
        }
    }
}

/// Writes `OUT/masks/<stem>.png` (16-bit global ids) and `OUT/overlays/<stem>.png` of view `v`
/// (`map`: `[H, W]` final ids).
pub fn write_view_maps(
    out: &Path,
    scene: &Scene,
    load: &LoadOptions,
    v: usize,
    map: &Plane<u32>,
) -> crate::Result<()> {
    let view = &scene.views[v];
    write_label_png(&out.join("masks").join(format!("{}.png", view.stem)), map)?;
    let image = splatseg_scene::images::load_image_rgb(scene, view, load)?;
    let path = out.join("overlays").join(format!("{}.png", view.stem));
    write_png_rgb(&path, &overlay(&image, map, 0.5))?;
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
