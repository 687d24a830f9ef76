//! Writing a [`SynthScene`] as a capture folder (layout in the crate docs). Every file is
//! written atomically (temp file + rename); views are encoded in parallel.

use crate::{SynthError, SynthScene, SynthView};
use rayon::prelude::*;
use serde::Serialize;
use splatseg_scene::atomic::write_bytes_atomic;
use splatseg_scene::colmap::write_colmap_text;
use splatseg_scene::image_io::{write_png_rgb8, RgbImage};
use splatseg_scene::labels::write_label_png;
use splatseg_scene::npy::write_npy_f32;
use splatseg_scene::ply::write_ply;
use splatseg_scene::sam::write_sam_json;
use std::path::{Path, PathBuf};

/// What [`write`] wrote.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SynthSummary {
    /// The output folder.
    pub root: PathBuf,
    /// Number of views.
    pub views: usize,
    /// Number of ground-truth instances (floor and walls included).
    pub instances: usize,
    /// Number of Gaussians in `gaussians.ply`.
    pub gaussians: usize,
    /// Simulated SAM masks over all views.
    pub sam_masks: usize,
    /// Files written.
    pub files: usize,
}

/// The `gt/objects.json` document.
#[derive(Serialize)]
struct ObjectsDoc<'a> {
    config: &'a crate::SynthConfig,
    id_rule: &'static str,
    views: Vec<&'a str>,
    objects: Vec<crate::ObjectInfo>,
    hard_cases: &'a crate::HardCases,
}

/// Writes `scene` into `dir` (created if needed; existing files of the same names are
/// replaced). Returns what was written.
pub fn write(dir: &Path, scene: &SynthScene) -> Result<SynthSummary, SynthError> {
    std::fs::create_dir_all(dir)
        .map_err(|e| splatseg_scene::SceneError::io("cannot create folder", dir, e))?;
    let per_view: Vec<Result<usize, SynthError>> =
        scene.views.par_iter().map(|v| write_view(dir, v)).collect();
    let mut files = 0;
    for r in per_view {
        files += r?;
    }
    remove_stale_views(dir, scene)?;
    let mut colmap_scene = scene.scene.clone();
    colmap_scene.root = dir.to_path_buf();
    for v in &mut colmap_scene.views {
        v.image_path = dir.join(&v.image_path);
    }
    write_colmap_text(&dir.join("sparse").join("0"), &colmap_scene)?;
    write_ply(&dir.join("gaussians.ply"), &scene.gaussians)?;
    let ids: Vec<f32> = scene.gaussian_ids.iter().map(|&i| i as f32).collect();
    write_npy_f32(&dir.join("gt").join("gaussian_ids.npy"), &[ids.len()], &ids)?;
    let doc = ObjectsDoc {
        config: &scene.config,
        id_rule: "0 = no surface, 1 = floor, 2 = left wall, 3 = back wall, 4.. = objects; \
                  equal in every view and for the Gaussians",
        views: scene.views.iter().map(|v| v.stem.as_str()).collect(),
        objects: scene.object_infos(),
        hard_cases: &scene.hard_cases,
    };
    let objects_path = dir.join("gt").join("objects.json");
    let json = serde_json::to_vec_pretty(&doc).map_err(|e| SynthError::Encode {
        what: "objects JSON",
        reason: e.to_string(),
        path: objects_path.clone(),
    })?;
    write_bytes_atomic(&objects_path, &json)?;
    files += 3 + 1 + 1 + 1;
    Ok(SynthSummary {
        root: dir.to_path_buf(),
        views: scene.views.len(),
        instances: scene.objects.len(),
        gaussians: scene.gaussians.len(),
        sam_masks: scene.views.iter().map(|v| v.sam_masks.len()).sum(),
        files,
    })
}

/// The folders holding one file per view, with the file extension.
const PER_VIEW_FOLDERS: [(&str, &str); 6] = [
    ("images", "png"),
    ("gt/instance", "png"),
    ("gt/depth", "npy"),
    ("sam", "json"),
    ("features", "npy"),
    ("depth", "npy"),
];

/// Removes per-view files of an earlier, larger synthetic scene written into the same folder
/// (`view_NNN.*` whose view this scene does not have), so the folder never lists masks or cues
/// for views the COLMAP model lacks. Other files are left alone.
fn remove_stale_views(dir: &Path, scene: &SynthScene) -> Result<(), SynthError> {
    let current: std::collections::BTreeSet<&str> = scene.views.iter().map(|v| v.stem.as_str()).collect();
    for (folder, ext) in PER_VIEW_FOLDERS {
        let folder = dir.join(folder);
        let entries = std::fs::read_dir(&folder)
            .map_err(|e| splatseg_scene::SceneError::io("cannot list folder", &folder, e))?;
        for entry in entries.flatten() {
            let path = entry.path();
            let (Some(stem), Some(e)) = (path.file_stem().and_then(|s| s.to_str()), path.extension()) else {
                continue;
            };
            let ours = stem
                .strip_prefix("view_")
                .is_some_and(|n| n.len() >= 3 && n.bytes().all(|b| b.is_ascii_digit()));
            if ours && e == ext && !current.contains(stem) {
                std::fs::remove_file(&path)
                    .map_err(|e| splatseg_scene::SceneError::io("cannot remove stale view file", &path, e))?;
            }
        }
    }
    Ok(())
}

/// Writes the per-view files of `v`; returns how many.
fn write_view(dir: &Path, v: &SynthView) -> Result<usize, SynthError> {
    let stem = &v.stem;
    let (w, h) = v.image.size();
    let rgb: Vec<u8> = v.image.data.iter().flat_map(|p| p.iter().copied()).collect();
    let image_path = dir.join("images").join(format!("{stem}.png"));
    let image = RgbImage::from_vec(w, h, rgb).ok_or_else(|| SynthError::Encode {
        what: "PNG image",
        reason: "image plane size disagrees with its data".into(),
        path: image_path.clone(),
    })?;
    write_png_rgb8(&image_path, &image)?;
    write_label_png(&dir.join("gt").join("instance").join(format!("{stem}.png")), &v.gt_instance)?;
    write_npy_f32(&dir.join("gt").join("depth").join(format!("{stem}.npy")), &[h, w], &v.gt_depth_z.data)?;
    write_sam_json(&dir.join("sam").join(format!("{stem}.json")), &v.sam_masks)?;
    let f = &v.features;
    write_npy_f32(
        &dir.join("features").join(format!("{stem}.npy")),
        &[f.grid_h, f.grid_w, f.dim],
        &f.values,
    )?;
    write_npy_f32(&dir.join("depth").join(format!("{stem}.npy")), &[h, w], &v.relative_depth.data)?;
    Ok(6)
}
