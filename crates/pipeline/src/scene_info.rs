//! What splatseg finds in a scene folder before running anything on it (`splatseg info`): format,
//! cameras, views, missing or mis-sized images, sparse points, the Gaussians of a 3DGS PLY and
//! which views have SAM masks or cue maps, as a typed [`Report`] (serialisable, or as text with
//! [`Report::to_text`]).

use crate::error::{bail, Context};
use serde::Serialize;
use splatseg_scene::load::{check_image_size, ImageFit, LoadOptions, SceneFormat};
use splatseg_scene::{load_scene, Camera, Scene};
use std::path::{Path, PathBuf};

/// What to inspect.
#[derive(Clone, Debug)]
pub struct InfoRequest {
    /// Scene folder (or transforms .json file).
    pub path: PathBuf,
    /// A 3DGS PLY to describe. Default: the `*.ply` files directly in `path`, else the latest
    /// `point_cloud/iteration_*/point_cloud.ply` (3DGS training output).
    pub gaussians: Option<PathBuf>,
    /// Folder of per-view SAM masks; default: `sam/` or `masks/` in `path`.
    pub masks: Option<PathBuf>,
    /// Image down-scaling factor as 3DGS's `--resolution`.
    pub resolution: u32,
    /// Blender split to read.
    pub split: String,
    /// Refuse a Gaussian file holding non-finite values (`--strict`) rather than counting them.
    pub strict: bool,
}

/// Everything `info` found, as printed with `--json`.
#[derive(Debug, Serialize)]
pub struct Report {
    /// The folder or file inspected.
    pub path: PathBuf,
    /// Scene format.
    pub format: SceneFormat,
    /// Cameras at the chosen resolution.
    pub cameras: Vec<Camera>,
    /// Number of views with an image file.
    pub views: usize,
    /// Views whose image is at full size and gets resized on load.
    pub views_resized_on_load: usize,
    /// Problems with image files (unreadable, size disagreeing with the camera).
    pub image_problems: Vec<String>,
    /// The down-scaled copies found (`images_2/`, `images_4/`, `images_8/` beside the images, as
    /// 3DGS's `--resolution` reads them), each checked against the cameras down-scaled as much.
    pub downscaled: Vec<DownscaledImages>,
    /// Number of COLMAP sparse points, when the format has them.
    pub sparse_points: Option<usize>,
    /// PLY files described.
    pub gaussians: Vec<GaussiansInfo>,
    /// Per-view folders (masks, features, depth) and how many views they cover.
    pub per_view: Vec<PerViewFolder>,
    /// Loader warnings (e.g. listed images that are missing).
    pub warnings: Vec<String>,
}

/// The images of one down-scaling factor, as `--resolution f` reads them.
#[derive(Debug, Serialize)]
pub struct DownscaledImages {
    /// The factor `f` (2, 4 or 8).
    pub factor: u32,
    /// Views whose image is in the `<images>_<f>/` folder (the others would be resized on load).
    pub views: usize,
    /// Problems with those images (unreadable, size disagreeing with the camera down-scaled by `f`).
    pub image_problems: Vec<String>,
}

/// One 3DGS PLY.
#[derive(Debug, Serialize)]
pub struct GaussiansInfo {
    /// The file.
    pub path: PathBuf,
    /// Number of Gaussians.
    pub count: usize,
    /// Spherical-harmonics degree (0–3).
    pub sh_degree: u8,
    /// Whether the file has per-Gaussian `object_id`s (a labelled PLY).
    pub object_ids: bool,
    /// Dimension of per-Gaussian `feat_*` vectors, if any.
    pub feature_dim: Option<usize>,
    /// Names of properties kept but not interpreted.
    pub extra_properties: Vec<String>,
}

/// A folder of per-view files named by image stem.
#[derive(Debug, Serialize)]
pub struct PerViewFolder {
    /// What the files are: `SAM masks` or `.npy cue maps`.
    pub kind: &'static str,
    /// The folder.
    pub dir: PathBuf,
    /// Views that have a file.
    pub views_covered: usize,
    /// Stems of views without a file (first few).
    pub views_missing: Vec<String>,
    /// Files that match no view (first few): usually a naming mismatch.
    pub unmatched_files: Vec<String>,
    /// Entries named like a view's file that are not regular files (a FIFO, a device, a link to
    /// one, a folder without `metadata.csv`): not counted, as `run` does not read them.
    pub not_regular_files: Vec<String>,
}

/// Loads the scene and everything beside it that `args` points to.
pub fn inspect(args: &InfoRequest) -> crate::Result<Report> {
    let options =
        LoadOptions { resolution: args.resolution, split: args.split.clone(), ..LoadOptions::default() };
    let scene = load_scene(&args.path, &options)
        .with_context(|| format!("cannot load a scene from {}", args.path.display()))?;
    let (views_resized_on_load, image_problems) = check_images(&scene, &options);
    let downscaled = if args.resolution == 1 { downscaled_images(args) } else { Vec::new() };
    let gaussians = ply_files(&args.path, args.gaussians.as_deref())
        .iter()
        .map(|p| describe_ply(p, args.strict))
        .collect::<crate::Result<Vec<_>>>()?;
    let mut per_view = Vec::new();
    let folder = |name: &str| Some(args.path.join(name)).filter(|d| d.is_dir());
    let masks_dir = args.masks.clone().or_else(|| folder("sam")).or_else(|| folder("masks"));
    if let Some(dir) = masks_dir {
        if !dir.is_dir() {
            bail!("mask folder {} does not exist", dir.display());
        }
        per_view.push(per_view_folder(&scene, "SAM masks", &dir, &["json"]));
    }
    for dir in ["features", "depth"].iter().filter_map(|n| folder(n)) {
        per_view.push(per_view_folder(&scene, ".npy cue maps", &dir, &["npy"]));
    }
    Ok(Report {
        path: args.path.clone(),
        format: scene.format,
        cameras: scene.cameras.clone(),
        views: scene.views.len(),
        views_resized_on_load,
        image_problems,
        downscaled,
        sparse_points: scene.points.as_ref().map(Vec::len),
        gaussians,
        per_view,
        warnings: scene.warnings.clone(),
    })
}

/// Reads every image header: how many get resized on load, and the problems found.
fn check_images(scene: &Scene, options: &LoadOptions) -> (usize, Vec<String>) {
    let mut resized = 0;
    let mut problems = Vec::new();
    for view in &scene.views {
        match check_image_size(scene, view, options) {
            Ok(ImageFit::Exact) => {}
            Ok(ImageFit::Resize) => resized += 1,
            Err(err) => problems.push(err.to_string()),
        }
    }
    (resized, problems)
}

/// Every factor 2, 4, 8 with images in a `<images>_<f>/` folder, those images checked against the
/// cameras at that factor (header only).
fn downscaled_images(args: &InfoRequest) -> Vec<DownscaledImages> {
    let mut found = Vec::new();
    for factor in [2, 4, 8] {
        let options = LoadOptions { resolution: factor, split: args.split.clone(), ..LoadOptions::default() };
        let Ok(scene) = load_scene(&args.path, &options) else { continue };
        let suffix = format!("_{factor}");
        let in_folder = |v: &&splatseg_scene::View| {
            v.image_path
                .parent()
                .and_then(Path::file_name)
                .is_some_and(|n| n.to_string_lossy().ends_with(&suffix))
        };
        let views: Vec<&splatseg_scene::View> = scene.views.iter().filter(in_folder).collect();
        if views.is_empty() {
            continue;
        }
        let image_problems = views
            .iter()
            .filter_map(|v| check_image_size(&scene, v, &options).err().map(|e| e.to_string()))
            .collect();
        found.push(DownscaledImages { factor, views: views.len(), image_problems });
    }
    found
}

/// The PLY files to describe: `explicit`, else `*.ply` in `root`, else the latest 3DGS
/// `point_cloud/iteration_*/point_cloud.ply`.
fn ply_files(root: &Path, explicit: Option<&Path>) -> Vec<PathBuf> {
    if let Some(path) = explicit {
        return vec![path.to_path_buf()];
    }
    let dir = if root.is_dir() { root } else { root.parent().unwrap_or(Path::new(".")) };
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|entries| {
            entries
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.is_file() && p.extension().is_some_and(|e| e.eq_ignore_ascii_case("ply")))
                .collect()
        })
        .unwrap_or_default();
    found.sort();
    if found.is_empty() {
        let latest = std::fs::read_dir(dir.join("point_cloud"))
            .map(|entries| {
                entries
                    .filter_map(|e| e.ok().map(|e| e.path()))
                    .filter_map(|p| {
                        let name = p.file_name()?.to_str()?.to_string();
                        let iteration: u64 = name.strip_prefix("iteration_")?.parse().ok()?;
                        let ply = p.join("point_cloud.ply");
                        ply.is_file().then_some((iteration, ply))
                    })
                    .max()
            })
            .ok()
            .flatten();
        found.extend(latest.map(|(_, p)| p));
    }
    found
}

fn describe_ply(path: &Path, strict: bool) -> crate::Result<GaussiansInfo> {
    let g = crate::ply_input::read_rows(path, "commands skip them", strict)
        .with_context(|| format!("cannot read Gaussians from {}", path.display()))?
        .gaussians;
    Ok(GaussiansInfo {
        path: path.to_path_buf(),
        count: g.len(),
        sh_degree: g.sh_degree,
        object_ids: g.object_ids.is_some(),
        feature_dim: g.features.as_ref().map(|f| f.dim),
        extra_properties: g.extra.iter().map(|e| e.name.clone()).collect(),
    })
}

/// Matches the files of `dir` (with one of `extensions`, or SAM PNG sub-folders) to view stems.
/// Only regular files (through links) count, as in `run` ([`crate::inputs::mask_stems`]): an
/// entry with a matching name that is a FIFO or a device is listed as not a regular file.
fn per_view_folder(scene: &Scene, kind: &'static str, dir: &Path, extensions: &[&str]) -> PerViewFolder {
    let mut stems = std::collections::BTreeSet::new();
    let mut names = std::collections::BTreeMap::new();
    let mut not_regular_files = Vec::new();
    if let Ok(entries) = std::fs::read_dir(dir) {
        for path in entries.filter_map(|e| e.ok().map(|e| e.path())) {
            let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            let stem = if path.is_dir() && path.join("metadata.csv").is_file() {
                Some(name.clone())
            } else if path.extension().is_some_and(|e| extensions.iter().any(|x| e == *x)) {
                if !path.is_file() {
                    not_regular_files.push(name);
                    continue;
                }
                path.file_stem().map(|s| s.to_string_lossy().into_owned())
            } else {
                None
            };
            if let Some(stem) = stem {
                names.insert(stem.clone(), name);
                stems.insert(stem);
            }
        }
    }
    not_regular_files.sort();
    let view_stems: std::collections::BTreeSet<&str> = scene.views.iter().map(|v| v.stem.as_str()).collect();
    let views_missing: Vec<String> =
        view_stems.iter().filter(|s| !stems.contains(**s)).map(|s| s.to_string()).collect();
    let unmatched_files: Vec<String> = names
        .iter()
        .filter(|(stem, _)| !view_stems.contains(stem.as_str()))
        .map(|(_, n)| n.clone())
        .collect();
    PerViewFolder {
        kind,
        dir: dir.to_path_buf(),
        views_covered: view_stems.len() - views_missing.len(),
        views_missing,
        unmatched_files,
        not_regular_files,
    }
}

fn format_name(format: SceneFormat) -> &'static str {
    match format {
        SceneFormat::ColmapBinary => "COLMAP binary model",
        SceneFormat::ColmapText => "COLMAP text model",
        SceneFormat::Blender => "NeRF/Blender transforms",
        SceneFormat::InstantNgp => "instant-ngp/nerfstudio transforms.json",
    }
}

fn camera_line(c: &Camera) -> String {
    let d = c.distortion;
    let distortion = if d.is_zero() {
        "no distortion".to_string()
    } else {
        format!("k1 {} k2 {} p1 {} p2 {}", d.k1, d.k2, d.p1, d.p2)
    };
    format!(
        "  camera {}: {} {}x{}, fx {:.2} fy {:.2}, cx {:.2} cy {:.2}, {distortion} (horizontal FOV {:.1}°)",
        c.id,
        c.model.colmap_name(),
        c.width,
        c.height,
        c.fx,
        c.fy,
        c.cx,
        c.cy,
        c.fov_x().to_degrees()
    )
}

/// A list of at most 5 names, with "..." when longer.
fn short_list(names: &[String]) -> String {
    let shown: Vec<&str> = names.iter().take(5).map(String::as_str).collect();
    let more = if names.len() > shown.len() { ", ..." } else { "" };
    format!("{}{more}", shown.join(", "))
}

impl Report {
    /// The human-readable report.
    pub fn to_text(&self) -> String {
        format_report(self)
    }
}

fn format_report(r: &Report) -> String {
    let mut out = String::new();
    let mut line = |s: String| {
        out.push_str(&s);
        out.push('\n');
    };
    line(format!("scene: {} ({})", r.path.display(), format_name(r.format)));
    line(format!("cameras: {}", r.cameras.len()));
    for c in &r.cameras {
        line(camera_line(c));
    }
    let resized = if r.views_resized_on_load > 0 {
        format!(", {} resized on load from full resolution", r.views_resized_on_load)
    } else {
        String::new()
    };
    line(format!("views: {} with image files{resized}", r.views));
    if r.image_problems.is_empty() {
        line("images: every image size agrees with its camera".into());
    } else {
        line(format!("images: {} problem(s):", r.image_problems.len()));
        for p in r.image_problems.iter().take(10) {
            line(format!("  {p}"));
        }
    }
    for d in &r.downscaled {
        let state = match d.image_problems.len() {
            0 => "every size agrees with its camera at that factor".to_string(),
            n => format!("{n} problem(s):"),
        };
        line(format!("images_{} (--resolution {}): {} views, {state}", d.factor, d.factor, d.views));
        for p in d.image_problems.iter().take(10) {
            line(format!("  {p}"));
        }
    }
    match r.sparse_points {
        Some(n) => line(format!("sparse points: {n}")),
        None => line("sparse points: none (format has none)".into()),
    }
    if r.gaussians.is_empty() {
        line("gaussians: no PLY found (give one with --gaussians)".into());
    }
    for g in &r.gaussians {
        let features = g.feature_dim.map_or_else(String::new, |d| format!(", {d}-d features"));
        let ids = if g.object_ids { ", labelled (object_id)" } else { "" };
        line(format!(
            "gaussians: {}: {} Gaussians, SH degree {}{ids}{features}",
            g.path.display(),
            g.count,
            g.sh_degree
        ));
    }
    for f in &r.per_view {
        line(format!("{}: {}: {} of {} views", f.kind, f.dir.display(), f.views_covered, r.views));
        if !f.views_missing.is_empty() {
            line(format!("  views without a file: {}", short_list(&f.views_missing)));
        }
        if !f.unmatched_files.is_empty() {
            line(format!(
                "  {} file(s) match no view (names must be <image stem>.<ext>): {}",
                f.unmatched_files.len(),
                short_list(&f.unmatched_files)
            ));
        }
        if !f.not_regular_files.is_empty() {
            line(format!(
                "  {} entr(ies) not regular files (FIFO, device; not read): {}",
                f.not_regular_files.len(),
                short_list(&f.not_regular_files)
            ));
        }
    }
    for w in &r.warnings {
        line(format!("warning: {w}"));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use splatseg_scene::Gaussians;

    fn write_png(path: &Path, width: u32, height: u32) {
        let labels = splatseg_scene::Plane::filled(width as usize, height as usize, 1u32);
        splatseg_scene::labels::write_label_png(path, &labels).expect("png");
    }

    /// A COLMAP text scene with three 40×30 views (`v1` has the wrong size), a PLY of 5
    /// Gaussians, and `sam/` holding masks for v0, v2 and a misnamed file.
    fn scene_folder(root: &Path) {
        let model = root.join("sparse/0");
        std::fs::create_dir_all(&model).expect("mkdir");
        std::fs::write(model.join("cameras.txt"), "1 PINHOLE 40 30 50 50 20 15\n").expect("write");
        let images: String =
            (0..3).map(|i| format!("{} 1 0 0 0 0 0 {} 1 v{i}.png\n\n", i + 1, i + 2)).collect();
        std::fs::write(model.join("images.txt"), images).expect("write");
        std::fs::write(model.join("points3D.txt"), "7 0 0 0 1 2 3 0.5 1 0\n").expect("write");
        for (i, w) in [40, 41, 40].into_iter().enumerate() {
            write_png(&root.join(format!("images/v{i}.png")), w, 30);
        }
        // copies at half size for v0 and v2 (v2's of the wrong width); none at 4 or 8
        write_png(&root.join("images_2/v0.png"), 20, 15);
        write_png(&root.join("images_2/v2.png"), 22, 15);
        let g = Gaussians {
            means: vec![[0.0; 3]; 5],
            sh_dc: vec![[0.1; 3]; 5],
            sh_degree: 1,
            sh_rest: vec![0.0; 5 * 9],
            raw_opacities: vec![0.0; 5],
            log_scales: vec![[-2.0; 3]; 5],
            rotations: vec![[1.0, 0.0, 0.0, 0.0]; 5],
            ..Default::default()
        };
        splatseg_scene::ply::write_ply(&root.join("gaussians.ply"), &g).expect("ply");
        std::fs::create_dir_all(root.join("sam")).expect("mkdir");
        for name in ["v0.json", "v2.json", "IMG_v1.json", "notes.txt"] {
            std::fs::write(root.join("sam").join(name), "[]").expect("write");
        }
    }

    fn args(path: &Path) -> InfoRequest {
        InfoRequest {
            path: path.to_path_buf(),
            gaussians: None,
            masks: None,
            resolution: 1,
            split: "train".into(),
            strict: false,
        }
    }

    #[test]
    fn reports_cameras_images_gaussians_and_mask_coverage() {
        let dir = tempfile::tempdir().expect("tempdir");
        scene_folder(dir.path());
        let report = inspect(&args(dir.path())).expect("inspects");
        assert_eq!(report.format, SceneFormat::ColmapText);
        assert_eq!((report.views, report.cameras.len(), report.sparse_points), (3, 1, Some(1)));
        assert_eq!(report.image_problems.len(), 1);
        assert!(report.image_problems[0].contains("41x30") && report.image_problems[0].contains("v1.png"));
        assert_eq!(report.gaussians.len(), 1);
        assert_eq!((report.gaussians[0].count, report.gaussians[0].sh_degree), (5, 1));
        let masks = &report.per_view[0];
        assert_eq!((masks.kind, masks.views_covered), ("SAM masks", 2));
        assert_eq!(masks.views_missing, ["v1"]);
        assert_eq!(masks.unmatched_files, ["IMG_v1.json"]);

        assert_eq!(report.downscaled.len(), 1, "only images_2/ is there");
        let half = &report.downscaled[0];
        assert_eq!((half.factor, half.views), (2, 2));
        assert_eq!(half.image_problems.len(), 1, "{:?}", half.image_problems);
        assert!(half.image_problems[0].contains("22x15") && half.image_problems[0].contains("v2.png"));

        let text = report.to_text();
        assert!(text.contains("views: 3 with image files"), "{text}");
        assert!(text.contains("images_2 (--resolution 2): 2 views, 1 problem(s):"), "{text}");
        assert!(text.contains("5 Gaussians, SH degree 1"), "{text}");
        assert!(text.contains("SAM masks:") && text.contains("2 of 3 views"), "{text}");
        assert!(text.contains("1 file(s) match no view"), "{text}");
        let json = serde_json::to_value(&report).expect("json");
        assert_eq!(json["views"], 3);
    }

    #[test]
    fn warnings_are_reported_once_and_bad_paths_fail() {
        let dir = tempfile::tempdir().expect("tempdir");
        scene_folder(dir.path());
        std::fs::remove_file(dir.path().join("images/v2.png")).expect("remove");
        let report = inspect(&args(dir.path())).expect("inspects");
        assert_eq!(report.views, 2);
        assert_eq!(report.warnings.len(), 1);
        let text = report.to_text();
        assert_eq!(text.matches("warning:").count(), 1, "{text}");
        assert!(text.contains("1 of 3 images listed"), "{text}");

        let err = inspect(&args(&dir.path().join("absent"))).expect_err("no scene");
        assert!(err.report().contains("absent"), "{}", err.report());
        let mut with_masks = args(dir.path());
        with_masks.masks = Some(dir.path().join("no_masks_here"));
        assert!(inspect(&with_masks).is_err());
    }

    /// A FIFO (or a link to a device) named like a view's masks is not counted as its masks,
    /// as `run` does not read it: it is listed instead.
    #[cfg(unix)]
    #[test]
    fn a_fifo_or_a_device_is_not_counted_as_a_views_masks() {
        let dir = tempfile::tempdir().expect("tempdir");
        scene_folder(dir.path());
        let c =
            std::ffi::CString::new(dir.path().join("sam/v1.json").to_str().expect("utf-8")).expect("path");
        // SAFETY: `c` is a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0, "mkfifo");
        std::os::unix::fs::symlink("/dev/zero", dir.path().join("sam/v2.json.tmp")).expect("link");
        std::fs::remove_file(dir.path().join("sam/v2.json")).expect("remove");
        std::fs::rename(dir.path().join("sam/v2.json.tmp"), dir.path().join("sam/v2.json")).expect("rename");
        let report = inspect(&args(dir.path())).expect("inspects");
        let masks = &report.per_view[0];
        assert_eq!(masks.views_covered, 1);
        assert_eq!(masks.views_missing, ["v1", "v2"]);
        assert_eq!(masks.not_regular_files, ["v1.json", "v2.json"]);
        let text = report.to_text();
        assert!(text.contains("1 of 3 views") && text.contains("not regular files"), "{text}");
    }
}
