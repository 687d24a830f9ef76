//! Export of a selection: the PLY is written by `splatseg-edit`'s `extract` / `remove` and
//! `write_edited_ply`, as `splatseg extract` / `remove` do, so the file is byte-identical to the
//! command's; or the Gaussians whose centres lie in a box (`crop`, edit's `crop`: every object's,
//! for the selection's box), or every Gaussian coloured by its object (`coloured`, the bytes of
//! `splatseg recolor`: `f_dc` set to the palette colour, `f_rest` zeroed, unlabelled dark grey). Files go into the export folder only, and never replace a file there: the export
//! is written into the hidden folder [`STAGING_DIR`] of the export folder, then given the first
//! free name of `extract_3.ply`, `extract_3-2.ply`, `extract_3-3.ply`, … (a hard link, which
//! fails rather than replace; where the file system has none, a rename to a name found free).
//! Every export starts by emptying [`STAGING_DIR`] and ends by removing it, so whatever a killed
//! export left there (its temporary file) goes with the next export.

use crate::error::{ViewError, ViewResult};
use serde::Deserialize;
use splatseg_edit::edits::Box3;
use splatseg_edit::io::write_edited_ply;
use splatseg_edit::{crop, extract, palette_colour, recolor, remove, ExtraFields, UnlabelledStyle};
use splatseg_scene::Gaussians;
use std::path::{Path, PathBuf};

/// What the page asks for (`POST /api/export`).
#[derive(Clone, Debug, Deserialize, PartialEq)]
pub struct ExportRequest {
    /// Selected object ids (`extract`, `remove`).
    #[serde(default)]
    pub ids: Vec<i32>,
    /// `extract`: the selection; `remove`: everything but the selection.
    pub mode: ExportMode,
    /// Keep `object_id` and the other non-INRIA properties (as `--keep-extras`).
    #[serde(default)]
    pub keep_extras: bool,
    /// The box of a `crop`, world units.
    #[serde(default, rename = "box")]
    pub region: Option<Box3>,
}

/// Which side of the selection to write.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ExportMode {
    /// The selected objects (`splatseg extract`).
    Extract,
    /// Everything but the selected objects (`splatseg remove`).
    Remove,
    /// Every Gaussian whose centre lies in `box`.
    Crop,
    /// Every Gaussian, coloured by its object (`splatseg recolor`).
    Coloured,
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
/// `extract_3_and_11_more.ply`; `crop.ply`, `coloured_by_object.ply`. Only digits, letters and `_`,
/// so never a path.
pub fn export_name(request: &ExportRequest) -> String {
    match request.mode {
        ExportMode::Crop => return "crop.ply".to_string(),
        ExportMode::Coloured => return "coloured_by_object.ply".to_string(),
        ExportMode::Extract | ExportMode::Remove => {}
    }
    let mut ids = request.ids.clone();
    ids.sort_unstable();
    ids.dedup();
    let id_name = |id: i32| if id < 0 { "unlabelled".to_string() } else { id.to_string() };
    let mode = if request.mode == ExportMode::Remove { "remove" } else { "extract" };
    let ids_part = if ids.len() > 8 {
        format!("{}_and_{}_more", id_name(ids[0]), ids.len() - 1)
    } else {
        ids.iter().map(|&id| id_name(id)).collect::<Vec<_>>().join("_")
    };
    format!("{mode}_{ids_part}.ply")
}

/// The hidden folder of the export folder where an export is written before it takes its name.
pub const STAGING_DIR: &str = ".splatseg-export-partial";

/// Names tried for one export (`extract_3.ply`, then `extract_3-2.ply` … `extract_3-1000.ply`)
/// before it is refused.
pub const MAX_NAMES: usize = 1000;

/// The `n`-th name tried for `name` (1: `name` itself, then `stem-n.ply`).
pub fn numbered_name(name: &str, n: usize) -> String {
    match (n, name.strip_suffix(".ply")) {
        (1, _) => name.to_string(),
        (_, Some(stem)) => format!("{stem}-{n}.ply"),
        (_, None) => format!("{name}-{n}"),
    }
}

/// Writes the export of `request` from `g` (read from `ply`) into `dir`, under a name no file has
/// there yet ([`numbered_name`]); exports into one folder must not run at once (the server runs
/// them one at a time).
pub fn export(g: &Gaussians, ply: &Path, dir: &Path, request: &ExportRequest) -> ViewResult<Exported> {
    let picked = match (request.mode, &request.region) {
        (ExportMode::Extract, _) => extract(g, &request.ids),
        (ExportMode::Remove, _) => remove(g, &request.ids),
        (ExportMode::Crop, Some(region)) => crop(g, region),
        (ExportMode::Crop, None) => {
            return Err(ViewError::Export(
                "a crop needs a box: {\"centre\": [x, y, z], \"half_size\": [x, y, z]}".into(),
            ))
        }
        (ExportMode::Coloured, _) => recolor(g, |id| palette_colour(id, UnlabelledStyle::Grey)),
    }
    .map_err(|e| ViewError::Export(e.with_path(ply).to_string()))?;
    let count = picked.len();
    let name = export_name(request);
    let staging = dir.join(STAGING_DIR);
    empty_staging(&staging)?;
    let staged = staging.join(&name);
    let extras = if request.keep_extras { ExtraFields::Keep } else { ExtraFields::Strip };
    let written = write_edited_ply(&staged, picked, extras)
        .map_err(|e| ViewError::Export(e.to_string()))
        .and_then(|()| take_free_name(&staged, dir, &name));
    let _ = std::fs::remove_dir_all(&staging);
    let (name, path) = written?;
    Ok(Exported { name, path, count })
}

/// Creates `staging` (and the export folder), empty: what a killed export left in it is removed.
fn empty_staging(staging: &Path) -> ViewResult<()> {
    let failed =
        |what: &str, e: std::io::Error| ViewError::Export(format!("{what} ({e}): {}", staging.display()));
    match std::fs::symlink_metadata(staging) {
        Ok(meta) if meta.is_dir() => {
            std::fs::remove_dir_all(staging).map_err(|e| failed("cannot empty the staging folder", e))?
        }
        Ok(_) => {
            return Err(ViewError::Export(format!(
            "the export folder holds a file named {STAGING_DIR}, where exports are staged; move it away: {}",
            staging.display()
        )))
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(failed("cannot read", e)),
    }
    std::fs::create_dir_all(staging).map_err(|e| failed("cannot create the staging folder", e))
}

/// Gives `staged` the first free name of `name`'s numbered names in `dir`: never replaces a file.
fn take_free_name(staged: &Path, dir: &Path, name: &str) -> ViewResult<(String, PathBuf)> {
    for n in 1..=MAX_NAMES {
        let candidate = numbered_name(name, n);
        let path = dir.join(&candidate);
        match std::fs::hard_link(staged, &path) {
            Ok(()) => return Ok((candidate, path)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            // no hard links on this file system: a rename, to a name nothing holds
            Err(_) if std::fs::symlink_metadata(&path).is_err() => {
                return match std::fs::rename(staged, &path) {
                    Ok(()) => Ok((candidate, path)),
                    Err(e) => Err(ViewError::Export(format!(
                        "cannot move the export into place ({e}): {}",
                        path.display()
                    ))),
                };
            }
            Err(_) => continue,
        }
    }
    Err(ViewError::Export(format!(
        "{} and {} more numbered names are taken; exports never replace a file: move them away or give another --out: {}",
        name,
        MAX_NAMES - 1,
        dir.join(name).display()
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_plain_file_names() {
        let r = |ids: Vec<i32>, mode| ExportRequest { ids, mode, keep_extras: false, region: None };
        assert_eq!(export_name(&r(vec![7, 3, 7], ExportMode::Extract)), "extract_3_7.ply");
        assert_eq!(export_name(&r(vec![-1], ExportMode::Remove)), "remove_unlabelled.ply");
        assert_eq!(export_name(&r((1..=10).collect(), ExportMode::Extract)), "extract_1_and_9_more.ply");
    }

    #[test]
    fn export_writes_what_extract_selects() {
        let dir = tempfile::tempdir().unwrap();
        let g = three_gaussians();
        let request =
            ExportRequest { ids: vec![1], mode: ExportMode::Extract, keep_extras: true, region: None };
        let out = export(&g, Path::new("in.ply"), dir.path(), &request).unwrap();
        assert_eq!(out.count, 2);
        let back = splatseg_scene::ply::read_ply(&out.path).unwrap();
        assert_eq!(back.object_ids, Some(vec![1, 1]));
        let bad = ExportRequest { ids: vec![5], mode: ExportMode::Remove, keep_extras: false, region: None };
        let err = export(&g, Path::new("in.ply"), dir.path(), &bad).unwrap_err().to_string();
        assert!(err.contains("no Gaussian has object id 5"), "{err}");
    }

    fn three_gaussians() -> Gaussians {
        Gaussians {
            means: vec![[0.0; 3], [1.0; 3], [2.0; 3]],
            sh_dc: vec![[0.0; 3]; 3],
            raw_opacities: vec![0.0; 3],
            log_scales: vec![[0.0; 3]; 3],
            rotations: vec![[1.0, 0.0, 0.0, 0.0]; 3],
            object_ids: Some(vec![1, 2, 1]),
            ..Gaussians::default()
        }
    }

    fn names_in(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn an_export_never_replaces_a_file_and_takes_the_next_free_name() {
        let dir = tempfile::tempdir().unwrap();
        // the user's own file, and the served PLY, named as the exports would be
        std::fs::write(dir.path().join("remove_1.ply"), b"the user's file").unwrap();
        let served = dir.path().join("extract_1.ply");
        std::fs::write(&served, b"the served PLY").unwrap();
        let g = three_gaussians();
        let remove1 =
            ExportRequest { ids: vec![1], mode: ExportMode::Remove, keep_extras: false, region: None };
        let first = export(&g, &served, dir.path(), &remove1).unwrap();
        assert_eq!(first.name, "remove_1-2.ply");
        assert_eq!(std::fs::read(dir.path().join("remove_1.ply")).unwrap(), b"the user's file");
        // again: its own earlier export is not replaced either
        let second = export(&g, &served, dir.path(), &remove1).unwrap();
        assert_eq!(second.name, "remove_1-3.ply");
        assert_eq!(std::fs::read(&first.path).unwrap(), std::fs::read(&second.path).unwrap());
        let extract1 =
            ExportRequest { ids: vec![1], mode: ExportMode::Extract, keep_extras: false, region: None };
        let third = export(&g, &served, &dir.path().join("."), &extract1).unwrap();
        assert_eq!((third.name.as_str(), third.count), ("extract_1-2.ply", 2));
        assert_eq!(std::fs::read(&served).unwrap(), b"the served PLY");
        assert_eq!(
            names_in(dir.path()),
            ["extract_1-2.ply", "extract_1.ply", "remove_1-2.ply", "remove_1-3.ply", "remove_1.ply"],
            "nothing else is left in the folder"
        );
    }

    #[test]
    fn what_a_killed_export_left_goes_with_the_next_export() {
        let dir = tempfile::tempdir().unwrap();
        let staging = dir.path().join(STAGING_DIR);
        std::fs::create_dir_all(&staging).unwrap();
        // as a kill in the middle of the write leaves it: write_atomic's temporary file
        std::fs::write(staging.join(".tmpAbC123"), vec![0u8; 4096]).unwrap();
        std::fs::write(staging.join("extract_2.ply"), b"half").unwrap();
        let request =
            ExportRequest { ids: vec![2], mode: ExportMode::Extract, keep_extras: false, region: None };
        let out = export(&three_gaussians(), Path::new("in.ply"), dir.path(), &request).unwrap();
        assert_eq!((out.name.as_str(), out.count), ("extract_2.ply", 1));
        assert_eq!(names_in(dir.path()), ["extract_2.ply"]);
        // a refused export leaves nothing either
        let bad = ExportRequest { ids: vec![9], mode: ExportMode::Extract, keep_extras: false, region: None };
        assert!(export(&three_gaussians(), Path::new("in.ply"), dir.path(), &bad).is_err());
        assert_eq!(names_in(dir.path()), ["extract_2.ply"]);
    }

    #[test]
    fn a_file_where_the_staging_folder_goes_is_not_removed() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join(STAGING_DIR), b"a user's file").unwrap();
        let request =
            ExportRequest { ids: vec![2], mode: ExportMode::Extract, keep_extras: false, region: None };
        let err =
            export(&three_gaussians(), Path::new("in.ply"), dir.path(), &request).unwrap_err().to_string();
        assert!(err.contains("move it away") && err.contains(STAGING_DIR), "{err}");
        assert_eq!(std::fs::read(dir.path().join(STAGING_DIR)).unwrap(), b"a user's file");
    }

    #[test]
    fn a_box_crop_and_a_ply_coloured_by_object() {
        let dir = tempfile::tempdir().unwrap();
        let g = three_gaussians();
        let region = Box3 { centre: [1.5; 3], half_size: [0.6; 3], rotation: None };
        let request = ExportRequest {
            ids: vec![],
            mode: ExportMode::Crop,
            keep_extras: true,
            region: Some(region.clone()),
        };
        let out = export(&g, Path::new("in.ply"), dir.path(), &request).unwrap();
        assert_eq!((out.name.as_str(), out.count), ("crop.ply", 2));
        let back = splatseg_scene::ply::read_ply(&out.path).unwrap();
        assert_eq!(back.means, vec![[1.0; 3], [2.0; 3]], "both objects' Gaussians in the box");
        assert_eq!(back.object_ids, Some(vec![2, 1]));
        let no_box = ExportRequest { region: None, ..request.clone() };
        let err = export(&g, Path::new("in.ply"), dir.path(), &no_box).unwrap_err().to_string();
        assert!(err.contains("needs a box"), "{err}");
        let empty = ExportRequest { region: Some(Box3 { centre: [9.0; 3], ..region }), ..request };
        let err = export(&g, Path::new("in.ply"), dir.path(), &empty).unwrap_err().to_string();
        assert!(err.contains("no Gaussian has its centre inside the box"), "{err}");

        let coloured =
            ExportRequest { ids: vec![], mode: ExportMode::Coloured, keep_extras: false, region: None };
        let out = export(&g, Path::new("in.ply"), dir.path(), &coloured).unwrap();
        assert_eq!((out.name.as_str(), out.count), ("coloured_by_object.ply", 3));
        let back = splatseg_scene::ply::read_ply(&out.path).unwrap();
        let expected =
            |id: i32| splatseg_edit::recolor::sh_dc_of_rgb(splatseg_scene::labels::colour_of_id(id as u32));
        assert_eq!(back.sh_dc, vec![expected(1), expected(2), expected(1)]);
        assert_eq!(back.means, g.means, "everything else kept");
        assert_eq!(back.object_ids, None, "extras stripped for other viewers");
    }

    #[test]
    fn numbered_names_keep_the_extension() {
        assert_eq!(numbered_name("extract_3.ply", 1), "extract_3.ply");
        assert_eq!(numbered_name("extract_3.ply", 2), "extract_3-2.ply");
        assert_eq!(numbered_name("remove_unlabelled.ply", 17), "remove_unlabelled-17.ply");
    }
}
