//! `splatseg apply OUT`: a run's edits (`OUT/edits.json`, [`splatseg_edit::edits`]) applied to
//! its outputs. The operations start from the run's own result ([`crate::apply_base`]), so the
//! same edits give the same bytes however often they are applied; everything is checked before
//! anything is written (malformed or later-version file, edits made on another PLY or run, an
//! operation selecting something absent), and the outputs are then written as `run` writes them:
//! staged in `OUT/.staging/` and moved in together (`commit.rs`).
//!
//! Rewritten: `gaussians.ply` (`object_id`; every other property as it was), `masks/` and
//! `overlays/` of every view ([`crate::apply_maps`]), `objects.json` (the objects with their
//! Gaussian counts, boxes, views and names), `report.md` (the run's, with the edits applied);
//! `metrics.json` stays the run's.

use crate::apply_base::{Base, EDITS_HEADING};
use crate::apply_maps::{moved_to, votes_of, EditedRender};
use crate::error::{bail, Context};
use crate::inputs::finite_gaussians;
use crate::{commit, lock, outputs, RunCache, RunOptions};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use splatseg_edit::edits::{centres_digest, check_inputs};
use splatseg_edit::{apply_operations, read_edits, EditBase, EditInputs, Edited, EDITS_FILE};
use splatseg_lift::{PosedCamera, PreparedGaussians};
use splatseg_scene::{load_scene, LoadOptions, Scene};
use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Where `run` records the scene folder it read (`OUT/cache/run_scene.json`), for `apply`.
const RUN_SCENE_FILE: &str = "run_scene.json";

/// The scene folder of the run whose key is `run_key`.
#[derive(Serialize, Deserialize)]
struct RunScene {
    run_key: String,
    scene: PathBuf,
}

/// Records the scene of the run `run_key` in `out`'s cache (called by `run` once its outputs are
/// committed or found up to date).
pub(crate) fn record_run_scene(out: &Path, run_key: &str, scene: &Path) -> crate::Result<()> {
    let scene = std::path::absolute(scene).unwrap_or_else(|_| scene.to_path_buf());
    crate::write_json(
        &out.join("cache").join(RUN_SCENE_FILE),
        &RunScene { run_key: run_key.to_string(), scene },
    )
}

/// What `apply` did.
#[derive(Clone, Debug, Serialize)]
pub struct ApplySummary {
    /// Operations applied.
    pub operations: usize,
    /// Gaussians whose object id changed.
    pub changed_gaussians: usize,
    /// Objects owning Gaussians after the edits.
    pub objects: usize,
    /// Names given.
    pub names: usize,
    /// Label maps rewritten.
    pub views: usize,
}

impl ApplySummary {
    /// What `splatseg apply` prints.
    pub fn to_text(&self, out: &Path) -> String {
        format!(
            "applied {} operations of {}: {} Gaussians changed object, {} objects ({} named); \
             rewrote gaussians.ply, objects.json and {} views' label maps and overlays in {}\n",
            self.operations,
            EDITS_FILE,
            self.changed_gaussians,
            self.objects,
            self.names,
            self.views,
            out.display()
        )
    }
}

/// The identity of the run in `out` that edits must have been made on (see
/// [`splatseg_edit::EditInputs`]): what the viewer writes into a new `edits.json`.
pub fn edit_inputs(out: &Path) -> crate::Result<EditInputs> {
    let run = read_manifest(out)?.1;
    let ply = out.join("gaussians.ply");
    let g = splatseg_scene::ply::read_ply_rows(&ply)?.gaussians;
    Ok(EditInputs { gaussians: g.len() as u64, ply_digest: centres_digest(&g.means), run: run.key })
}

/// The run's manifest, as bytes and parsed (or the one an apply killed while committing left in
/// the staging folder: this apply rewrites every output of that run).
fn read_manifest(out: &Path) -> crate::Result<(Vec<u8>, RunCache)> {
    let path = out.join("cache").join("run.json");
    let bytes =
        commit::pending_manifest(out, &path).map_or_else(|| std::fs::read(&path), Ok).map_err(|_| {
            crate::PipelineError::Invalid(format!(
                "no finished run here (its manifest is missing): run `splatseg run` with --out {} first: {}",
                out.display(),
                path.display()
            ))
        })?;
    let run: RunCache = serde_json::from_slice(&bytes)
        .with_context(|| format!("not a run's manifest: {}", path.display()))?;
    Ok((bytes, run))
}

/// Applies `OUT/edits.json` to the run in `out` (module docs).
pub fn apply_edits(out: &Path, options: RunOptions) -> crate::Result<ApplySummary> {
    let edits_path = out.join(EDITS_FILE);
    let edits = read_edits(&edits_path)?;
    let _lock = lock::lock_output(out, "apply")?;
    let (manifest_bytes, run) = read_manifest(out)?;
    commit::remove_leftover_staging(out)?;
    let scene = run_scene(out, &run.key)?;
    let stems: Vec<&str> = scene.views.iter().map(|v| v.stem.as_str()).collect();
    let base = Base::open_or_take(out, &run.key, &stems)?;
    let ply = out.join("gaussians.ply");
    let mut rows = crate::ply_input::read_rows_quietly(&ply, options.strict)?;
    if rows.gaussians.len() != base.ids.len() {
        bail!(
            "gaussians.ply has {} rows, the run's had {}: {}",
            rows.gaussians.len(),
            base.ids.len(),
            ply.display()
        );
    }
    let current = EditInputs {
        gaussians: base.ids.len() as u64,
        ply_digest: centres_digest(&rows.gaussians.means),
        run: run.key.clone(),
    };
    check_inputs(&edits, &current, &edits_path)?;
    let map_only_ids = map_only_ids(&base, &stems)?;
    let cams: Vec<_> = scene.views.iter().map(|v| (scene.camera(v), &v.world_from_cam)).collect();
    let edit_base =
        EditBase { ids: &base.ids, means: &rows.gaussians.means, map_only_ids: &map_only_ids, views: &cams };
    let edited = apply_operations(&edit_base, &edits.operations, &edits_path)?;

    // Everything is checked: the outputs are written.
    let staging = commit::Staging::begin(out)?;
    let usable = rows.usable_rows();
    let prepared = PreparedGaussians::new(&finite_gaussians(&rows))?;
    let before = votes_of(usable.iter().map(|&r| base.ids[r]));
    let after = (edited.changed_rows > 0).then(|| votes_of(usable.iter().map(|&r| edited.ids[r])));
    let moved = moved_to(&usable, &base.ids, &edited);
    let render = EditedRender {
        gaussians: &prepared,
        before: &before,
        after: after.as_ref(),
        edited: &edited,
        moved: &moved,
    };
    let load = LoadOptions::default();
    let view_ids: Vec<Vec<u32>> = (0..scene.views.len())
        .into_par_iter()
        .map(|v| -> crate::Result<Vec<u32>> {
            let (camera, world_from_cam) = cams[v];
            let run_map = base.label_map(stems[v])?;
            let map = render.view_map(PosedCamera { camera, world_from_cam }, &run_map)?;
            outputs::write_view_maps(staging.dir(), &scene, &load, v, &map, None)?;
            Ok(splatseg_edit::ids_in_label_map(&map))
        })
        .collect::<crate::Result<_>>()?;
    rows.gaussians.object_ids = Some(edited.ids.clone());
    splatseg_scene::ply::write_ply(&staging.dir().join("gaussians.ply"), &rows.gaussians)
        .with_context(|| format!("writing the edited Gaussians of {}", ply.display()))?;
    let objects = write_objects(staging.dir(), &rows.gaussians, &edited, &view_ids)?;
    let metrics = out.join("metrics.json");
    std::fs::copy(&metrics, staging.dir().join("metrics.json"))
        .with_context(|| format!("copying {}", metrics.display()))?;
    let report = base.report()? + &edits_section(&edits.operations, &edited, objects);
    splatseg_scene::atomic::write_bytes_atomic(&staging.dir().join("report.md"), report.as_bytes())?;
    let manifest = out.join("cache").join("run.json");
    staging.commit_same_manifest(&manifest, &manifest_bytes)?;
    Ok(ApplySummary {
        operations: edits.operations.len(),
        changed_gaussians: edited.changed_rows,
        objects,
        names: edited.names.len(),
        views: scene.views.len(),
    })
}

/// The scene the run read, loaded as `run` loads it.
fn run_scene(out: &Path, run_key: &str) -> crate::Result<Scene> {
    let folder = recorded_scene(out, run_key)?;
    load_scene(&folder, &LoadOptions::default())
        .with_context(|| format!("cannot load the run's scene {}", folder.display()))
}

/// The scene folder the run with key `run_key` in `out` read (as `run` recorded it).
fn recorded_scene(out: &Path, run_key: &str) -> crate::Result<PathBuf> {
    let path = out.join("cache").join(RUN_SCENE_FILE);
    let recorded: Option<RunScene> = crate::read_json(&path);
    let Some(recorded) = recorded.filter(|r| r.run_key == run_key) else {
        bail!(
            "the run in {} did not record its scene folder (a run of an earlier splatseg): run `splatseg run` \
             on it again, which records it: {}",
            out.display(),
            path.display()
        );
    };
    Ok(recorded.scene)
}

/// The scene folder the finished run in `out` read (what `run --clip` crops the objects' views
/// from, to embed the edited objects again after `apply`).
pub fn run_scene_folder(out: &Path) -> crate::Result<PathBuf> {
    recorded_scene(out, &read_manifest(out)?.1.key)
}

/// The names `apply` gave the objects of the run in `out` (`OUT/objects.json`; id → name, empty
/// when nothing was named or applied).
pub fn object_names(out: &Path) -> crate::Result<std::collections::BTreeMap<i32, String>> {
    Ok(splatseg_edit::names_beside(&out.join("gaussians.ply"))?)
}

/// Ids the run's maps show that no Gaussian carries (one view's map read at a time).
fn map_only_ids(base: &Base, stems: &[&str]) -> crate::Result<BTreeSet<i32>> {
    let carried: BTreeSet<i32> = base.ids.iter().copied().collect();
    let mut shown = BTreeSet::new();
    for stem in stems {
        shown.extend(splatseg_edit::ids_in_label_map(&base.label_map(stem)?).into_iter().map(|id| id as i32));
    }
    Ok(shown.difference(&carried).copied().collect())
}

/// Writes `objects.json` (the object table with names and views); the number of objects.
fn write_objects(
    dir: &Path,
    g: &splatseg_scene::Gaussians,
    edited: &Edited,
    view_ids: &[Vec<u32>],
) -> crate::Result<usize> {
    let mut table = splatseg_edit::objects(g).context("listing the edited objects")?;
    table.set_views_seen(view_ids);
    for o in &mut table.objects {
        o.name = edited.names.get(&o.id).cloned();
    }
    crate::write_json(&dir.join("objects.json"), &table)?;
    Ok(table.objects.len())
}

/// The report's section on the edits.
fn edits_section(operations: &[splatseg_edit::Operation], edited: &Edited, objects: usize) -> String {
    let mut md = format!("\n{EDITS_HEADING}\n\n");
    let _ = writeln!(
        md,
        "{} operations of `{EDITS_FILE}` applied: {} Gaussians changed object; {objects} objects own Gaussians.\n",
        operations.len(),
        edited.changed_rows
    );
    for (i, op) in operations.iter().enumerate() {
        let _ = writeln!(md, "{i}. `{}`", op.kind());
    }
    if !edited.names.is_empty() {
        let _ = writeln!(md, "\n| id | name |\n| ---: | --- |");
        for (id, name) in &edited.names {
            let _ = writeln!(md, "| {id} | {name} |");
        }
    }
    md
}
