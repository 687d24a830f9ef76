//! Loading and checking what `run` reads: the scene, the SAM mask folder, the Gaussians and the
//! optional ground truth. Every inconsistency is an error naming the file or folder.

use crate::cache::KeyHasher;
use crate::error::{bail, Context};
use crate::RunConfig;
use splatseg_lift::PreparedGaussians;
use splatseg_scene::load::LoadOptions;
use splatseg_scene::ply::PlyRows;
use splatseg_scene::{Gaussians, Scene};
use std::borrow::Cow;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Stems that have masks in `dir` (`<stem>.json` files or `<stem>/metadata.csv` folders).
pub fn mask_stems(dir: &Path) -> crate::Result<BTreeSet<String>> {
    let entries =
        std::fs::read_dir(dir).with_context(|| format!("cannot list the mask folder {}", dir.display()))?;
    let mut stems = BTreeSet::new();
    for entry in entries {
        let path = entry.with_context(|| format!("cannot list the mask folder {}", dir.display()))?.path();
        let name = path.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default();
        let is_json = path.is_file() && path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json"));
        let is_png_folder = path.is_dir() && path.join("metadata.csv").is_file();
        if is_json || is_png_folder {
            stems.insert(if is_png_folder {
                path.file_name().unwrap_or_default().to_string_lossy().to_string()
            } else {
                name
            });
        }
    }
    Ok(stems)
}

/// Per scene view: whether it has masks. Masks for views the scene does not have are an error.
pub fn views_with_masks(scene: &Scene, dir: &Path) -> crate::Result<Vec<bool>> {
    let stems = mask_stems(dir)?;
    let known: BTreeSet<&str> = scene.views.iter().map(|v| v.stem.as_str()).collect();
    let unknown: Vec<&str> = stems.iter().map(String::as_str).filter(|s| !known.contains(s)).collect();
    if !unknown.is_empty() {
        bail!(
            "masks for {} view(s) the scene does not have: {} (the scene at {} has {} views, e.g. `{}`): {}",
            unknown.len(),
            unknown.iter().take(5).copied().collect::<Vec<_>>().join(", "),
            scene.root.display(),
            scene.views.len(),
            scene.views.first().map_or("", |v| v.stem.as_str()),
            dir.display()
        );
    }
    let flags: Vec<bool> = scene.views.iter().map(|v| stems.contains(&v.stem)).collect();
    if !flags.iter().any(|&f| f) {
        bail!("no masks for any view of the scene (expected <stem>.json per image): {}", dir.display());
    }
    Ok(flags)
}

/// The Gaussians to use: `explicit`, or `SCENE/gaussians.ply` when present.
pub fn gaussians_path(scene_dir: &Path, explicit: Option<&Path>) -> Option<PathBuf> {
    match explicit {
        Some(p) => Some(p.to_path_buf()),
        None => Some(scene_dir.join("gaussians.ply")).filter(|p| p.is_file()),
    }
}

/// What `run` does with a PLY's skipped rows (non-finite, degenerate).
const SKIPPED_CONSEQUENCE: &str = "they are labelled -1 in gaussians.ply";

/// One sentence naming the views of `scene` without a masks file in `dir` (`has_masks`:
/// `[n_views]`), or `None` when every view has one.
fn missing_masks_warning(scene: &Scene, has_masks: &[bool], dir: &Path) -> Option<String> {
    let missing: Vec<&str> =
        scene.views.iter().zip(has_masks).filter(|(_, &m)| !m).map(|(v, _)| v.stem.as_str()).collect();
    (!missing.is_empty()).then(|| {
        let more = if missing.len() > 5 { format!(" and {} more", missing.len() - 5) } else { String::new() };
        format!(
            "{} of {} views have no masks in {} (expected a regular file <stem>.json, or a folder <stem>/ with metadata.csv, per image): {}{more}; \
             they get no label of their own and count only through the other views",
            missing.len(),
            scene.views.len(),
            dir.display(),
            missing.iter().take(5).copied().collect::<Vec<_>>().join(", ")
        )
    })
}

/// Reads the PLY at `path`: every row, with the skipped ones listed (non-finite or degenerate; one
/// warning, which the caller reports, or refused with `--strict`).
pub fn read_gaussians(path: &Path, strict: bool) -> crate::Result<PlyRows> {
    let rows = crate::ply_input::read_rows_quietly(path, strict)?;
    crate::ply_input::refuse_empty(rows.gaussians.len() - rows.skipped(), path)?;
    Ok(rows)
}

/// The usable Gaussians of `rows` (finite, not degenerate), borrowed when no row is skipped.
pub fn finite_gaussians(rows: &PlyRows) -> Cow<'_, Gaussians> {
    if rows.skipped() == 0 {
        Cow::Borrowed(&rows.gaussians)
    } else {
        Cow::Owned(rows.gaussians.select(&rows.usable_rows()))
    }
}

/// Where the ground truth is.
#[derive(Clone, Debug)]
pub struct GroundTruth {
    /// Folder of `<stem>.png` instance label maps.
    pub maps_dir: PathBuf,
    /// `[N]` per-Gaussian instance ids, when `gaussian_ids.npy` exists.
    pub gaussian_ids: Option<Vec<i64>>,
}

/// Reads the ground truth at `dir`: either a folder of label maps, or a synthetic scene's
/// `gt/` (`instance/<stem>.png` + `gaussian_ids.npy`). Checks the per-Gaussian ids against the
/// PLY (`n_gaussians`).
pub fn ground_truth(
    dir: &Path,
    n_gaussians: Option<usize>,
    ply: Option<&Path>,
) -> crate::Result<GroundTruth> {
    if !dir.is_dir() {
        bail!("ground-truth folder not found: {}", dir.display());
    }
    let instance = dir.join("instance");
    let maps_dir = if instance.is_dir() { instance } else { dir.to_path_buf() };
    let ids_path = dir.join("gaussian_ids.npy");
    let gaussian_ids = if ids_path.is_file() {
        let ids = splatseg_eval::read_gaussian_ids_npy(&ids_path)?;
        if let (Some(n), Some(ply)) = (n_gaussians, ply) {
            if n < ids.len() {
                bail!(
                    "the PLY has fewer Gaussians ({n}) than the ground truth has per-Gaussian ids ({}, {}): {}",
                    ids.len(),
                    ids_path.display(),
                    ply.display()
                );
            }
            if n > ids.len() {
                bail!(
                    "the PLY has more Gaussians ({n}) than the ground truth has per-Gaussian ids ({}, {}): {}",
                    ids.len(),
                    ids_path.display(),
                    ply.display()
                );
            }
        }
        Some(ids)
    } else {
        None
    };
    Ok(GroundTruth { maps_dir, gaussian_ids })
}

/// What `run` reads before any stage: the scene (every camera checked against its image), which
/// views have masks, the input PLY's rows and the ground truth.
pub struct RunInputs {
    /// The scene.
    pub scene: Scene,
    /// `[n_views]` whether the view has SAM masks.
    pub has_masks: Vec<bool>,
    /// The PLY, when there is one.
    pub ply_path: Option<PathBuf>,
    /// Every row of the PLY (`gaussians.ply` keeps them all; the stages work on the finite ones).
    pub ply_rows: Option<PlyRows>,
    /// The ground truth, when given.
    pub gt: Option<GroundTruth>,
    /// What makes a view or a Gaussian count for less than the user gave, one sentence each with
    /// its count (logged once when read, listed in `report.md`).
    pub warnings: Vec<String>,
}

impl RunInputs {
    /// Reads the inputs `config` names.
    pub fn load(config: &RunConfig, load: &LoadOptions) -> crate::Result<Self> {
        let scene = splatseg_scene::load_scene(&config.scene, load)?;
        let mut warnings = scene.warnings.clone();
        // Every camera against its image on disk, before anything of a camera's size is allocated.
        splatseg_scene::load::check_image_sizes(&scene, load)?;
        let has_masks = views_with_masks(&scene, &config.masks)?;
        warnings.extend(missing_masks_warning(&scene, &has_masks, &config.masks));
        let ply_path = gaussians_path(&config.scene, config.gaussians.as_deref());
        let ply_rows = match &ply_path {
            Some(p) => {
                tracing::info!("reading Gaussians from {}", p.display());
                let rows = read_gaussians(p, config.options.strict)?;
                let skipped = rows.skip_warnings(p, SKIPPED_CONSEQUENCE);
                warnings.extend(skipped.into_iter().map(|w| format!("{w} (--strict refuses such files)")));
                Some(rows)
            }
            None => None,
        };
        for w in &warnings {
            tracing::warn!("{w}");
        }
        if ply_rows.is_none() && config.depth.is_none() {
            bail!("no depth: give --depth DIR or a PLY (--gaussians, or gaussians.ply in the scene folder)");
        }
        let gt = match &config.gt {
            Some(dir) => {
                Some(ground_truth(dir, ply_rows.as_ref().map(|r| r.gaussians.len()), ply_path.as_deref())?)
            }
            None => None,
        };
        Ok(RunInputs { scene, has_masks, ply_path, ply_rows, gt, warnings })
    }

    /// The key of every input file and every setting of `config`.
    pub fn key(&self, config: &RunConfig) -> crate::Result<String> {
        let mut key = KeyHasher::default();
        key.text("run-v1").json(&config.pipeline).text(&format!("{:?}", config.depth_kind));
        if config.resize_depth {
            key.text("resize-depth");
        }
        for (view, &masked) in self.scene.views.iter().zip(&self.has_masks) {
            key.text(&view.stem).file(&view.image_path)?;
            if masked {
                key.folder_entry(&config.masks, &view.stem)?;
            }
            for dir in [&config.features, &config.depth].into_iter().flatten() {
                key.folder_entry(dir, &view.stem)?;
            }
        }
        if let Some(p) = &self.ply_path {
            key.file(p)?;
        }
        if let Some(dir) = &config.gt {
            key.file(&dir.join("gaussian_ids.npy"))?;
            for view in &self.scene.views {
                key.file(&dir.join("instance").join(format!("{}.png", view.stem)))?;
                key.file(&dir.join(format!("{}.png", view.stem)))?;
            }
        }
        let key = key.finish();
        tracing::debug!("inputs and settings key {key}");
        Ok(key)
    }

    /// The finite Gaussians prepared for every view, when there is a PLY.
    pub fn prepared_gaussians(&self) -> crate::Result<Option<PreparedGaussians>> {
        Ok(self.ply_rows.as_ref().map(|r| PreparedGaussians::new(&finite_gaussians(r))).transpose()?)
    }

    /// Whether the output files a cached run must still find are in `out`.
    pub fn outputs_present(&self, out: &Path) -> bool {
        ["report.md", "metrics.json"].iter().all(|f| out.join(f).is_file())
            && (self.ply_path.is_none() || out.join("gaussians.ply").is_file())
            && self.scene.views.iter().all(|v| out.join("masks").join(format!("{}.png", v.stem)).is_file())
    }
}
