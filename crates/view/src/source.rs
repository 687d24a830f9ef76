//! What `splatseg view PATH` shows: the Gaussians PLY, the capture's cameras, the per-view label
//! overlays, and where exports go.
//!
//! PATH is `run`'s or `train`'s output folder (`gaussians.ply`, `masks/`, `overlays/`), an INRIA
//! 3DGS output folder (`point_cloud.ply`, or `point_cloud/iteration_<n>/point_cloud.ply`, the
//! highest n), or a file of Gaussians: a 3DGS or compressed PLY, an SPZ, a `.splat` or a `.ksplat` (chosen by content). The cameras come from `--scene`, else from the scene `run`
//! recorded in its `report.md` (`Scene: \`…\``), else from a `scene/` folder beside PATH (the
//! demo's layout); without cameras the viewer starts from a camera looking at the bounding box.

use crate::error::{ViewError, ViewResult};
use splatseg_scene::{load_scene, Gaussians, LoadOptions, Scene};
use std::path::{Path, PathBuf};

/// One view of the capture and the files the page may show for it.
#[derive(Clone, Debug)]
pub struct ViewFiles {
    /// Image stem (file name without extension).
    pub stem: String,
    /// `overlays/<stem>.png` (image with palette-coloured labels), when present.
    pub overlay: Option<PathBuf>,
    /// `masks/<stem>.png` (16-bit label map), when present.
    pub mask: Option<PathBuf>,
}

/// Everything the viewer serves, resolved and read once at start.
#[derive(Debug)]
pub struct ViewSource {
    /// The PLY shown.
    pub ply_path: PathBuf,
    /// Its Gaussians.
    pub gaussians: Gaussians,
    /// The capture's cameras, when found.
    pub scene: Option<Scene>,
    /// Per scene view (same order as `scene.views`); empty without a scene.
    pub views: Vec<ViewFiles>,
    /// Folder exports are written to (`--out`, else the folder of PATH).
    pub export_dir: PathBuf,
    /// Non-fatal problems to show the user once (e.g. a recorded scene that no longer loads).
    pub warnings: Vec<String>,
}

/// What to open.
#[derive(Clone, Debug, Default)]
pub struct SourceOptions {
    /// Scene folder with the cameras (COLMAP or transforms.json); found automatically if `None`.
    pub scene: Option<PathBuf>,
    /// Folder for exports; PATH's folder if `None`.
    pub out: Option<PathBuf>,
}

impl ViewSource {
    /// The checks of the paths alone, before anything is read or bound: PATH exists and `--out`,
    /// when it exists, is a folder.
    pub fn check_paths(path: &Path, options: &SourceOptions) -> ViewResult<()> {
        if !path.exists() {
            return Err(ViewError::Missing(path.to_path_buf()));
        }
        if let Some(out) = options.out.as_ref().filter(|o| o.exists() && !o.is_dir()) {
            return Err(ViewError::OutNotAFolder(out.clone()));
        }
        Ok(())
    }

    /// Resolves `path` (see the module doc), reads the PLY and loads the cameras.
    pub fn open(path: &Path, options: &SourceOptions) -> ViewResult<ViewSource> {
        Self::check_paths(path, options)?;
        let (folder, ply_path) = if path.is_dir() {
            (path.to_path_buf(), find_ply(path).ok_or_else(|| ViewError::NoPly(path.to_path_buf()))?)
        } else {
            let parent = path.parent().map(Path::to_path_buf).unwrap_or_default();
            (if parent.as_os_str().is_empty() { PathBuf::from(".") } else { parent }, path.to_path_buf())
        };
        let gaussians = read_gaussians(&ply_path)?;
        let mut warnings = Vec::new();
        let scene = match &options.scene {
            Some(dir) => Some(load_cameras(dir)?),
            None => discover_scene(&folder, &mut warnings),
        };
        let views = scene.as_ref().map(|s| view_files(&folder, s)).unwrap_or_default();
        let export_dir = options.out.clone().unwrap_or(folder);
        Ok(ViewSource { ply_path, gaussians, scene, views, export_dir, warnings })
    }
}

/// `gaussians.ply`, `point_cloud.ply`, or the last `point_cloud/iteration_<n>/point_cloud.ply`.
fn find_ply(dir: &Path) -> Option<PathBuf> {
    for name in ["gaussians.ply", "point_cloud.ply"] {
        if dir.join(name).is_file() {
            return Some(dir.join(name));
        }
    }
    let iterations = std::fs::read_dir(dir.join("point_cloud")).ok()?;
    iterations
        .filter_map(Result::ok)
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().to_string();
            let n: u64 = name.strip_prefix("iteration_")?.parse().ok()?;
            let ply = e.path().join("point_cloud.ply");
            ply.is_file().then_some((n, ply))
        })
        .max_by_key(|(n, _)| *n)
        .map(|(_, ply)| ply)
}

/// Reads and checks the Gaussians (PLY, compressed PLY, SPZ, `.splat` or `.ksplat`, by content): there must be some.
fn read_gaussians(path: &Path) -> ViewResult<Gaussians> {
    let g = splatseg_scene::splats::read_gaussians(path).map_err(ViewError::BadPly)?;
    if g.is_empty() {
        return Err(ViewError::EmptyPly(path.to_path_buf()));
    }
    Ok(g)
}

/// Loads the cameras of `dir` (images are not decoded).
fn load_cameras(dir: &Path) -> ViewResult<Scene> {
    load_scene(dir, &LoadOptions::default())
        .map_err(|e| ViewError::Scene { reason: e.to_string(), path: dir.to_path_buf() })
}

/// The scene recorded in `report.md`, else `../scene`; problems become warnings.
fn discover_scene(folder: &Path, warnings: &mut Vec<String>) -> Option<Scene> {
    let mut candidates = Vec::new();
    if let Some(recorded) = recorded_scene(&folder.join("report.md")) {
        candidates.push(recorded);
    }
    if let Some(parent) = folder.parent() {
        candidates.push(parent.join("scene"));
    }
    for dir in candidates {
        if !dir.exists() {
            continue;
        }
        match load_cameras(&dir) {
            Ok(scene) => return Some(scene),
            Err(e) => warnings.push(e.to_string()),
        }
    }
    warnings.push(format!(
        "no cameras found for {} (give --scene SCENE); starting from a view of the bounding box",
        folder.display()
    ));
    None
}

/// The scene path `run` wrote into its report: the line `Scene: \`PATH\` (N views).`.
pub fn recorded_scene(report: &Path) -> Option<PathBuf> {
    let text = std::fs::read_to_string(report).ok()?;
    let line = text.lines().find(|l| l.starts_with("Scene: `"))?;
    let rest = line.strip_prefix("Scene: `")?;
    let end = rest.find('`')?;
    Some(PathBuf::from(&rest[..end]))
}

/// Overlay and mask files per view, when they exist in `folder`.
fn view_files(folder: &Path, scene: &Scene) -> Vec<ViewFiles> {
    let existing = |sub: &str, stem: &str| {
        let p = folder.join(sub).join(format!("{stem}.png"));
        p.is_file().then_some(p)
    };
    scene
        .views
        .iter()
        .map(|v| ViewFiles {
            stem: v.stem.clone(),
            overlay: existing("overlays", &v.stem),
            mask: existing("masks", &v.stem),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_recorded_scene_is_read_from_the_report() {
        let dir = tempfile::tempdir().unwrap();
        let report = dir.path().join("report.md");
        std::fs::write(&report, "# splatseg run\n\nScene: `out/demo/scene` (12 views).\n").unwrap();
        assert_eq!(recorded_scene(&report), Some(PathBuf::from("out/demo/scene")));
        std::fs::write(&report, "# nothing here\n").unwrap();
        assert_eq!(recorded_scene(&report), None);
    }

    #[test]
    fn a_folder_without_a_ply_is_a_clear_error() {
        let dir = tempfile::tempdir().unwrap();
        let err = ViewSource::open(dir.path(), &SourceOptions::default()).unwrap_err();
        assert!(matches!(err, ViewError::NoPly(_)), "{err}");
        assert!(err.to_string().contains("no 3DGS PLY"), "{err}");
    }

    #[test]
    fn the_last_inria_iteration_is_found() {
        let dir = tempfile::tempdir().unwrap();
        for n in [7000, 30000, 500] {
            let sub = dir.path().join("point_cloud").join(format!("iteration_{n}"));
            std::fs::create_dir_all(&sub).unwrap();
            std::fs::write(sub.join("point_cloud.ply"), b"x").unwrap();
        }
        let found = find_ply(dir.path()).unwrap();
        assert!(found.ends_with("iteration_30000/point_cloud.ply"), "{}", found.display());
    }
}
