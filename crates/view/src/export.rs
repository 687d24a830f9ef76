//! Export of a selection: the PLY is written by `splatseg-edit`'s `extract` / `remove` and
//! `write_edited_ply`, as `splatseg extract` / `remove` do, so the file is byte-identical to the
//! command's. Files go into the export folder only, atomically (temp file then rename).

use crate::error::{ViewError, ViewResult};
use serde::Deserialize;
use splatseg_edit::io::write_edited_ply;
use splatseg_edit::{extract, remove, ExtraFields};
use splatseg_scene::paths::Role;
use splatseg_scene::Gaussians;
use std::path::{Path, PathBuf};

/// What the page asks for (`POST /api/export`).
#[derive(Clone, Debug, Deserialize, PartialEq)]
pub struct ExportRequest {
    /// Selected object ids.
    pub ids: Vec<i32>,
    /// `extract`: the selection; `remove`: everything but the selection.
    pub mode: ExportMode,
    /// Keep `object_id` and the other non-INRIA properties (as `--keep-extras`).
    #[serde(default)]
    pub keep_extras: bool,
}

/// Which side of the selection to write.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ExportMode {
    /// The selected objects (`splatseg extract`).
    Extract,
    /// Everything but the selected objects (`splatseg remove`).
    Remove,
}

/// A written export.
#[derive(Clone, Debug, PartialEq)]
pub struct Exported {
    /// File name inside the export folder.
    pub name: String,
    /// Full path.
    pub path: PathBuf,
    /// Gaussians written.
    pub count: usize,
}

/// File name for a request: `extract_3_7.ply`, `remove_unlabelled.ply`, or for more than eight ids
/// `extract_3_and_11_more.ply`. Only digits, letters and `_`, so never a path.
pub fn export_name(request: &ExportRequest) -> String {
    let mut ids = request.ids.clone();
    ids.sort_unstable();
    ids.dedup();
    let id_name = |id: i32| if id < 0 { "unlabelled".to_string() } else { id.to_string() };
    let mode = match request.mode {
        ExportMode::Extract => "extract",
        ExportMode::Remove => "remove",
    };
    let ids_part = if ids.len() > 8 {
        format!("{}_and_{}_more", id_name(ids[0]), ids.len() - 1)
    } else {
        ids.iter().map(|&id| id_name(id)).collect::<Vec<_>>().join("_")
    };
    format!("{mode}_{ids_part}.ply")
}

/// Writes the export of `request` from `g` (read from `ply`) into `dir`.
pub fn export(g: &Gaussians, ply: &Path, dir: &Path, request: &ExportRequest) -> ViewResult<Exported> {
    let picked = match request.mode {
        ExportMode::Extract => extract(g, &request.ids),
        ExportMode::Remove => remove(g, &request.ids),
    }
    .map_err(|e| ViewError::Export(e.with_path(ply).to_string()))?;
    let name = export_name(request);
    let path = dir.join(&name);
    splatseg_scene::paths::refuse_overwrite(
        &[Role::file("the served PLY", ply)],
        &[Role::file("the export", &path)],
    )
    .map_err(|e| ViewError::Export(e.to_string()))?;
    std::fs::create_dir_all(dir).map_err(|e| ViewError::Export(format!("{e}: {}", dir.display())))?;
    let count = picked.len();
    let extras = if request.keep_extras { ExtraFields::Keep } else { ExtraFields::Strip };
    write_edited_ply(&path, picked, extras).map_err(|e| ViewError::Export(e.to_string()))?;
    Ok(Exported { name, path, count })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_plain_file_names() {
        let r = |ids: Vec<i32>, mode| ExportRequest { ids, mode, keep_extras: false };
        assert_eq!(export_name(&r(vec![7, 3, 7], ExportMode::Extract)), "extract_3_7.ply");
        assert_eq!(export_name(&r(vec![-1], ExportMode::Remove)), "remove_unlabelled.ply");
        assert_eq!(export_name(&r((1..=10).collect(), ExportMode::Extract)), "extract_1_and_9_more.ply");
    }

    #[test]
    fn export_writes_what_extract_selects() {
        let dir = tempfile::tempdir().unwrap();
        let g = Gaussians {
            means: vec![[0.0; 3], [1.0; 3], [2.0; 3]],
            sh_dc: vec![[0.0; 3]; 3],
            raw_opacities: vec![0.0; 3],
            log_scales: vec![[0.0; 3]; 3],
            rotations: vec![[1.0, 0.0, 0.0, 0.0]; 3],
            object_ids: Some(vec![1, 2, 1]),
            ..Gaussians::default()
        };
        let request = ExportRequest { ids: vec![1], mode: ExportMode::Extract, keep_extras: true };
        let out = export(&g, Path::new("in.ply"), dir.path(), &request).unwrap();
        assert_eq!(out.count, 2);
        let back = splatseg_scene::ply::read_ply(&out.path).unwrap();
        assert_eq!(back.object_ids, Some(vec![1, 1]));
        let bad = ExportRequest { ids: vec![5], mode: ExportMode::Remove, keep_extras: false };
        let err = export(&g, Path::new("in.ply"), dir.path(), &bad).unwrap_err().to_string();
        assert!(err.contains("no Gaussian has object id 5"), "{err}");
    }

    #[test]
    fn an_export_named_as_the_served_ply_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let served = dir.path().join("extract_1.ply");
        std::fs::write(&served, b"the served PLY").unwrap();
        let g = Gaussians {
            means: vec![[0.0; 3]; 2],
            sh_dc: vec![[0.0; 3]; 2],
            raw_opacities: vec![0.0; 2],
            log_scales: vec![[0.0; 3]; 2],
            rotations: vec![[1.0, 0.0, 0.0, 0.0]; 2],
            object_ids: Some(vec![1, 2]),
            ..Gaussians::default()
        };
        let request = ExportRequest { ids: vec![1], mode: ExportMode::Extract, keep_extras: false };
        let err = export(&g, &served, &dir.path().join("."), &request).unwrap_err().to_string();
        assert!(err.contains("refusing to overwrite") && err.contains("extract_1.ply"), "{err}");
        assert_eq!(std::fs::read(&served).unwrap(), b"the served PLY");
        let remove = ExportRequest { ids: vec![1], mode: ExportMode::Remove, keep_extras: false };
        assert!(export(&g, &served, dir.path(), &remove).is_ok());
    }
}
