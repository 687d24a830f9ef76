//! The train stage as `splatseg train` and `demo` run it: load the scene's images, hold out every
//! `test_every`-th view, train, score PSNR / SSIM before and after, write the trained PLY.

use crate::error::{bail, Context};
use rayon::prelude::*;
use serde::Serialize;
use splatseg_lift::render_labels::ABSTAIN;
use splatseg_lift::{render_label_map, LiftConfig, PreparedGaussians, RenderVotes};
use splatseg_render::export::write_rgb_png;
use splatseg_render::{render, RenderCamera, RenderRequest};
use splatseg_scene::image_io::{write_png_rgb8, RgbImage};
use splatseg_scene::images::load_image_rgb;
use splatseg_scene::labels::{overlay, read_label_png, write_label_png};
use splatseg_scene::load::LoadOptions;
use splatseg_scene::npy::write_npy_f32;
use splatseg_scene::ply::write_ply;
use splatseg_scene::{load_scene, Gaussians};
use splatseg_scene::{Camera, Pose};
use splatseg_train::{
    evaluate_views, gaussians_from_points, random_gaussians_in_cube, train_with_checkpoints, ReadBack,
    TrainConfig, TrainView, ViewQuality,
};
use std::path::{Path, PathBuf};

use super::cache::write_json;
use super::progress;

/// What to train.
#[derive(Clone, Debug)]
pub struct TrainRun {
    /// Scene folder (COLMAP or transforms.json).
    pub scene: PathBuf,
    /// Starting Gaussians (a 3DGS PLY; with `object_id` for the joint stage); `None` = initialise as
    /// 3DGS does (see [`InitOptions`]).
    pub gaussians: Option<PathBuf>,
    /// How to initialise without a PLY.
    pub init: InitOptions,
    /// Output folder.
    pub out: PathBuf,
    /// Settings (`[train]`).
    pub config: TrainConfig,
    /// Image down-scaling factor (3DGS's `--resolution`).
    pub resolution: u32,
    /// Folder of per-view label maps (`<stem>.png`, global ids) for the identity maps' 2D supervision;
    /// `None` = `masks/` beside the `gaussians` PLY (where `splatseg run` writes them).
    pub label_maps: Option<PathBuf>,
    /// `--strict` and `--quiet`.
    pub options: crate::RunOptions,
}

/// 3DGS's initialisation when no PLY is given: one Gaussian per sparse point when the scene has them
/// (COLMAP), otherwise `random_points` uniform in a cube: by default centred on the cameras' centre
/// with the cameras' extent as half side ([`random_start_cube`]), so it reaches whatever the cameras
/// surround, whatever the scene's units (3DGS's fixed `[−1.3, 1.3]³` fits only NeRF-synthetic scenes).
#[derive(Clone, Debug)]
pub struct InitOptions {
    /// Points of the random cube.
    pub random_points: usize,
    /// Half side of the cube around the origin (world units), e.g. 1.3 for 3DGS's NeRF-synthetic
    /// start; `None` = sized from the cameras ([`random_start_cube`]).
    pub cube_half_side: Option<f32>,
    /// SH degree of the new Gaussians (3DGS: 3).
    pub sh_degree: u8,
}

impl Default for InitOptions {
    fn default() -> Self {
        Self { random_points: 100_000, cube_half_side: None, sh_degree: 3 }
    }
}

/// Mean image quality over a set of views.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct MeanQuality {
    /// Views averaged.
    pub views: usize,
    /// Mean PSNR, dB.
    pub psnr: f64,
    /// Mean SSIM.
    pub ssim: f64,
}

/// What a training run did (also written as `quality.json`).
#[derive(Clone, Debug, Serialize)]
pub struct TrainSummary {
    /// Iterations run.
    pub iterations: usize,
    /// Gaussians before and after.
    pub gaussians: (usize, usize),
    /// Held-out views before and after training (empty when nothing is held out).
    pub test_before: MeanQuality,
    /// After.
    pub test_after: MeanQuality,
    /// Training views after training.
    pub train_after: MeanQuality,
    /// Per held-out view, after training.
    pub test_views: Vec<ViewQuality>,
    /// Share of Gaussians with an object id (≥ 0) before and after the joint stage, when it ran.
    pub labelled: Option<(f64, f64)>,
    /// Every read-back the joint stage computed (the chosen one is in `gaussians.ply`; each one's label
    /// maps are in `readback/<kind>/masks/` when there are several).
    pub readbacks: Vec<ReadBackSummary>,
    /// What went less well than the inputs promised, one sentence each: a labelled PLY that gets
    /// no joint stage, held-out PSNR that fell (logged; in `quality.json` only when there is one).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    /// `[N]` ids of each read-back, rows as `gaussians.ply`.
    #[serde(skip)]
    pub readback_ids: Vec<(ReadBack, Vec<i32>)>,
    /// Output folder.
    #[serde(skip)]
    pub out: PathBuf,
}

fn mean(q: &[ViewQuality]) -> MeanQuality {
    let n = q.len().max(1) as f64;
    MeanQuality {
        views: q.len(),
        psnr: q.iter().map(|v| v.psnr).sum::<f64>() / n,
        ssim: q.iter().map(|v| v.ssim).sum::<f64>() / n,
    }
}

fn labelled_share(g: &Gaussians) -> Option<f64> {
    g.object_ids
        .as_ref()
        .map(|ids| ids.iter().filter(|&&id| id >= 0).count() as f64 / ids.len().max(1) as f64)
}

/// One way of reading ids back after the joint stage.
#[derive(Clone, Debug, Serialize)]
pub struct ReadBackSummary {
    /// Which.
    pub kind: ReadBack,
    /// Share of Gaussians with an id.
    pub labelled: f64,
    /// The one written to `gaussians.ply`.
    pub chosen: bool,
}

/// Everything [`run_training`] reads.
struct Inputs {
    /// Every view, in scene order.
    views: Vec<TrainView>,
    /// What the label maps of every view need.
    maps: MapViews,
    /// The starting Gaussians.
    gaussians: Gaussians,
    /// What the inputs make count for less (logged already).
    warnings: Vec<String>,
}

/// Every view, in scene order, as [`write_object_maps`] needs it.
struct MapViews {
    /// `[n_views]` image stems.
    names: Vec<String>,
    /// `[n_views]` scene camera and pose.
    posed: Vec<(Camera, Pose)>,
    /// `[n_views]` the images as loaded (for overlays).
    images: Vec<RgbImage>,
}

/// Loads every view's image and camera, in scene order, and the starting Gaussians.
fn load_inputs(run: &TrainRun, options: &LoadOptions) -> crate::Result<Inputs> {
    let scene_dir = &run.scene;
    let scene = load_scene(scene_dir, options)
        .with_context(|| format!("cannot load scene {}", scene_dir.display()))?;
    for warning in &scene.warnings {
        tracing::warn!("{warning}");
    }
    let images = scene
        .views
        .iter()
        .map(|view| load_image_rgb(&scene, view, options))
        .collect::<Result<Vec<_>, _>>()?;
    let posed = scene.views.iter().map(|view| (scene.camera(view).clone(), view.world_from_cam)).collect();
    let views = scene
        .views
        .iter()
        .zip(&images)
        .map(|(view, image)| {
            let camera = RenderCamera::from_scene(scene.camera(view), &view.world_from_cam);
            if image.size() != (camera.width as usize, camera.height as usize) {
                bail!(
                    "image of view {} is {}×{} but its camera is {}×{}",
                    view.name,
                    image.width,
                    image.height,
                    camera.width,
                    camera.height
                );
            }
            let pixels = image.data.iter().map(|&c| f32::from(c) / 255.0).collect();
            Ok(TrainView { name: view.stem.clone(), camera, image: pixels, labels: None })
        })
        .collect::<crate::Result<Vec<_>>>()?;
    let init = &run.init;
    let gaussians = match (&run.gaussians, &scene.points) {
        (Some(path), _) => crate::ply_input::read_finite(path, run.options.strict)?,
        (None, Some(points)) if !points.is_empty() => {
            tracing::info!("initialising one Gaussian per sparse point ({})", points.len());
            let xyz: Vec<[f32; 3]> = points.iter().map(|p| p.xyz.to_array().map(|v| v as f32)).collect();
            let rgb: Vec<[u8; 3]> = points.iter().map(|p| p.rgb).collect();
            gaussians_from_points(&xyz, &rgb, init.sh_degree)
        }
        (None, _) => {
            let centres: Vec<[f64; 3]> =
                scene.views.iter().map(|v| v.world_from_cam.translation.to_array()).collect();
            let (centre, half_side) = match init.cube_half_side {
                Some(h) => ([0.0; 3], h),
                None => random_start_cube(&centres),
            };
            tracing::info!(
                "no PLY and no sparse points: {} random Gaussians in a cube of half side {half_side:.3} around \
                 ({:.3}, {:.3}, {:.3}), the cameras' centre and extent",
                init.random_points,
                centre[0],
                centre[1],
                centre[2]
            );
            random_gaussians_in_cube(init.random_points, centre, half_side, init.sh_degree, run.config.seed)
        }
    };
    let c = &run.config;
    let mut warnings = Vec::new();
    if c.joint.enabled && gaussians.object_ids.is_some() && c.iterations <= c.densify.until {
        let w = format!(
            "the PLY carries object ids, but the joint stage starts after densification (iteration {}) \
             and this run stops at {}: no joint optimisation runs and no label maps are written (raise \
             --iterations or lower [train.densify] until in --config)",
            c.densify.until, c.iterations
        );
        tracing::warn!("{w}");
        warnings.push(w);
    }
    let mut views = views;
    if let Some(dir) = label_map_folder(run, &gaussians) {
        for view in &mut views {
            view.labels = Some(load_label_map(&dir, &view.name, &view.camera)?);
        }
        tracing::info!("identity maps supervised by the label maps in {}", dir.display());
    }
    let names = scene.views.iter().map(|view| view.stem.clone()).collect();
    Ok(Inputs { views, maps: MapViews { names, posed, images }, gaussians, warnings })
}

/// Where the label maps of the identity maps' 2D supervision are, when that supervision will run
/// (identity maps on, joint stage on, lifted ids in the PLY): `--label-maps`, else `masks/` beside the
/// PLY if it exists (else none, with a warning).
fn label_map_folder(run: &TrainRun, gaussians: &Gaussians) -> Option<PathBuf> {
    let joint = &run.config.joint;
    if !(joint.enabled && joint.identity_maps && gaussians.object_ids.is_some()) {
        return None;
    }
    if let Some(dir) = &run.label_maps {
        return Some(dir.clone());
    }
    // by default `masks/` beside the PLY; without it (a labelled PLY from elsewhere) the 3D terms only
    let beside = run.gaussians.as_ref().and_then(|p| p.parent()).map(|dir| dir.join("masks"))?;
    if beside.is_dir() {
        Some(beside)
    } else {
        tracing::warn!(
            "no label maps at {} (pass --label-maps DIR): the joint stage runs without the identity maps",
            beside.display()
        );
        None
    }
}

/// `[H, W]` global ids of view `stem` from `dir/<stem>.png`, resampled (nearest) to the camera's size
/// when the map is at another resolution of the same frame.
fn load_label_map(dir: &Path, stem: &str, camera: &RenderCamera) -> crate::Result<Vec<u32>> {
    let path = dir.join(format!("{stem}.png"));
    if !path.is_file() {
        bail!(
            "no label map for view {stem} (the identity maps need every training view's final label map from              `splatseg run`; pass --label-maps DIR, or set [train.joint] identity_maps = false in --config): {}",
            path.display()
        );
    }
    let map = read_label_png(&path)?;
    let (w, h) = (camera.width as usize, camera.height as usize);
    if (map.width, map.height) == (w, h) {
        return Ok(map.data);
    }
    let (sx, sy) = (map.width as f64 / w as f64, map.height as f64 / h as f64);
    if map.width < w || (sx / sy - 1.0).abs() > 0.02 {
        bail!(
            "label map is {}×{} but the view is {w}×{h} (not the same frame at a coarser resolution): {}",
            map.width,
            map.height,
            path.display()
        );
    }
    let at = |v: usize, scale: f64, size: usize| (((v as f64 + 0.5) * scale) as usize).min(size - 1);
    Ok((0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| map.data[at(y, sy, map.height) * map.width + at(x, sx, map.width)])
        .collect())
}

/// Renders every view's label map from the Gaussians' `object_id`s (ids ≥ 1 are objects, 0 and −1
/// vote for nothing) with lifting's label compositor, and writes `masks/<stem>.png` and
/// `overlays/<stem>.png` under `out`.
fn write_object_maps(
    out: &Path,
    gaussians: &Gaussians,
    views: &MapViews,
    overlays: bool,
) -> crate::Result<()> {
    let Some(ids) = gaussians.object_ids.as_deref() else { return Ok(()) };
    let prepared = PreparedGaussians::new(gaussians)?;
    let votes =
        RenderVotes::uniform(ids.iter().map(|&id| if id > 0 { id as u32 } else { ABSTAIN }).collect());
    let config = LiftConfig::default();
    let dirs: &[&str] = if overlays { &["masks", "overlays"] } else { &["masks"] };
    for dir in dirs {
        std::fs::create_dir_all(out.join(dir))
            .with_context(|| format!("cannot create {}", out.join(dir).display()))?;
    }
    views.names.par_iter().zip(&views.posed).zip(&views.images).try_for_each(
        |((name, (camera, pose)), image)| {
            let map = render_label_map(&prepared, &votes, camera, pose, &config, None)?;
            write_label_png(&out.join("masks").join(format!("{name}.png")), &map)?;
            if overlays {
                write_png_rgb8(
                    &out.join("overlays").join(format!("{name}.png")),
                    &overlay(image, &map, 0.5),
                )?;
            }
            Ok::<_, crate::PipelineError>(())
        },
    )
}

/// Runs the train stage and writes `gaussians.ply`, `quality.json`, `renders/` (held-out views) and,
/// after a joint stage, `object_features.npy` (`[N, D]`) and every view's label map rendered from the
/// relabelled Gaussians (`masks/`, `overlays/`); the Gaussians of each `save_iterations` entry before the
/// last go to `point_cloud/iteration_<N>/point_cloud.ply` (3DGS's layout).
pub fn run_training(run: &TrainRun) -> crate::Result<TrainSummary> {
    run.config.validate()?;
    let _lock = super::lock::lock_output(&run.out, "train")?;
    let options = LoadOptions {
        resolution: run.resolution,
        background: run.config.background,
        ..LoadOptions::default()
    };
    let Inputs { views, maps, gaussians, mut warnings } = load_inputs(run, &options)?;
    // 3DGS's `--eval` split: views 0, every, 2·every, … are held out (none when there is only one view)
    let every = run.config.test_every;
    let hold_out = every > 0 && views.len() > 1;
    let (mut test, mut train_views) = (Vec::new(), Vec::new());
    for (i, view) in views.into_iter().enumerate() {
        if hold_out && i % every == 0 {
            test.push(view);
        } else {
            train_views.push(view);
        }
    }
    tracing::info!(
        "training on {} views, {} held out, {} Gaussians, {} iterations",
        train_views.len(),
        test.len(),
        gaussians.len(),
        run.config.iterations
    );
    let background = run.config.background;
    let test_before = mean(&evaluate_views(&gaussians, &test, background)?);
    let labelled_before = labelled_share(&gaussians);
    let start_count = gaussians.len();

    let bar = progress(run.config.iterations, "training", run.options);
    let checkpoint_dir = run.out.join("point_cloud");
    let mut save = |iteration: usize, g: &Gaussians| -> splatseg_train::TrainResult<()> {
        let dir = checkpoint_dir.join(format!("iteration_{iteration}"));
        std::fs::create_dir_all(&dir).map_err(|e| {
            splatseg_train::TrainError::Input(format!("cannot create {}: {e}", dir.display()))
        })?;
        write_ply(&dir.join("point_cloud.ply"), g)
            .map_err(|e| splatseg_train::TrainError::Input(format!("cannot write a checkpoint: {e}")))?;
        tracing::info!("saved the Gaussians of iteration {iteration} to {}", dir.display());
        Ok(())
    };
    let trained = train_with_checkpoints(
        gaussians,
        &train_views,
        &run.config,
        &|p| {
            bar.inc(1);
            if p.iteration % 50 == 0 {
                bar.set_message(format!("loss {:.4}, {} Gaussians", p.render_loss, p.gaussians));
            }
        },
        &mut save,
    )?;
    bar.finish_and_clear();

    let test_views = evaluate_views(&trained.gaussians, &test, background)?;
    let train_after = mean(&evaluate_views(&trained.gaussians, &train_views, background)?);
    std::fs::create_dir_all(run.out.join("renders"))
        .with_context(|| format!("cannot create {}", run.out.display()))?;
    write_ply(&run.out.join("gaussians.ply"), &trained.gaussians)?;
    if trained.feature_dim > 0 {
        let n = trained.gaussians.len();
        write_npy_f32(
            &run.out.join("object_features.npy"),
            &[n, trained.feature_dim],
            &trained.object_features,
        )?;
    }
    for view in &test {
        let request = RenderRequest { background, ..RenderRequest::default() };
        let out = render(&trained.gaussians, &view.camera, &request)?;
        if let Some(rgb) = out.rgb {
            write_rgb_png(
                &run.out.join("renders").join(format!("{}.png", view.name)),
                &rgb,
                out.width,
                out.height,
            )?;
        }
    }
    if trained.feature_dim > 0 {
        write_object_maps(&run.out, &trained.gaussians, &maps, true)?;
    }
    if trained.readbacks.len() > 1 {
        // every read-back's label maps, to compare them
        let mut alternative = trained.gaussians.clone();
        for (kind, ids) in &trained.readbacks {
            alternative.object_ids = Some(ids.clone());
            write_object_maps(
                &run.out.join("readback").join(readback_name(*kind)),
                &alternative,
                &maps,
                false,
            )?;
        }
    }
    // the configured read-back, or the nearest-code one it falls back to without identity maps
    let wanted = run.config.joint.readback;
    let chosen =
        if trained.readbacks.iter().any(|(k, _)| *k == wanted) { wanted } else { ReadBack::NearestCode };
    let readbacks = trained
        .readbacks
        .iter()
        .map(|(kind, ids)| ReadBackSummary {
            kind: *kind,
            labelled: ids.iter().filter(|&&id| id >= 0).count() as f64 / ids.len().max(1) as f64,
            chosen: *kind == chosen,
        })
        .collect();
    let labelled = match (labelled_before, trained.feature_dim > 0) {
        (Some(before), true) => labelled_share(&trained.gaussians).map(|after| (before, after)),
        _ => None,
    };
    let test_after = mean(&test_views);
    if let Some(w) = psnr_fell_warning(&test_before, &test_after) {
        tracing::warn!("{w}");
        warnings.push(w);
    }
    let summary = TrainSummary {
        iterations: run.config.iterations,
        gaussians: (start_count, trained.gaussians.len()),
        test_before,
        test_after,
        train_after,
        test_views,
        labelled,
        readbacks,
        warnings,
        readback_ids: trained.readbacks,
        out: run.out.clone(),
    };
    write_json(&run.out.join("quality.json"), &summary)?;
    Ok(summary)
}

/// The random start's cube without sparse points: centred on the mean of the camera centres
/// (`[n_views]` world positions), with half side 3DGS's cameras' extent — 1.1 × the largest
/// distance of a camera from that mean (at least 1e-3) — so a capture looking in at an object, or
/// out at a room, is covered in its own units.
pub fn random_start_cube(camera_centres: &[[f64; 3]]) -> ([f32; 3], f32) {
    let n = camera_centres.len().max(1) as f64;
    let mean = [0, 1, 2].map(|a| camera_centres.iter().map(|c| c[a]).sum::<f64>() / n);
    let radius = camera_centres
        .iter()
        .map(|c| (0..3).map(|a| (c[a] - mean[a]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    (mean.map(|v| v as f32), (1.1 * radius.max(1e-3)) as f32)
}

/// A warning when training made the held-out views worse (mean PSNR after below before), or
/// `None` (also without held-out views).
fn psnr_fell_warning(before: &MeanQuality, after: &MeanQuality) -> Option<String> {
    (after.views > 0 && before.views > 0 && after.psnr < before.psnr).then(|| {
        format!(
            "training made the {} held-out views worse: mean PSNR {:.2} dB before, {:.2} dB after; the \
             Gaussians fit the training views only (too few views, a start that does not cover the scene, \
             or too few iterations to recover from densification)",
            after.views, before.psnr, after.psnr
        )
    })
}

/// The folder name of a read-back (`[train.joint] readback`'s spelling).
pub fn readback_name(kind: ReadBack) -> &'static str {
    match kind {
        ReadBack::NearestCode => "nearest-code",
        ReadBack::Classifier => "classifier",
        ReadBack::Rendered => "rendered",
    }
}

impl TrainSummary {
    /// A short Markdown table: held-out PSNR / SSIM before and after, train PSNR, Gaussians, labelled share.
    pub fn table(&self) -> String {
        let mut s = String::from("| | PSNR (dB) | SSIM |\n| --- | ---: | ---: |\n");
        if self.test_after.views > 0 {
            s += &format!(
                "| held-out views, before ({}) | {:.2} | {:.3} |\n| held-out views, after | {:.2} | {:.3} |\n",
                self.test_before.views, self.test_before.psnr, self.test_before.ssim, self.test_after.psnr, self.test_after.ssim
            );
        }
        s += &format!(
            "| training views, after ({}) | {:.2} | {:.3} |\n",
            self.train_after.views, self.train_after.psnr, self.train_after.ssim
        );
        s += &format!(
            "\n{} iterations; Gaussians {} → {}",
            self.iterations, self.gaussians.0, self.gaussians.1
        );
        if let Some((before, after)) = self.labelled {
            s += &format!(
                "; Gaussians with an object id {:.1} % → {:.1} % (joint stage)",
                100.0 * before,
                100.0 * after
            );
        }
        s
    }
}

/// Widest image a view is trained at without `--resolution` (3DGS's rule).
const MAX_AUTO_WIDTH_PX: u32 = 1600;

/// The image down-scaling factor for training without `--resolution`: 1, or the smallest whole factor that brings the widest camera of `scene` to 1600 px or less.
pub fn automatic_resolution(scene: &std::path::Path) -> crate::Result<u32> {
    let loaded = splatseg_scene::load_scene(scene, &splatseg_scene::LoadOptions::default())
        .with_context(|| format!("cannot load scene {}", scene.display()))?;
    let widest = loaded.views.iter().map(|v| loaded.camera(v).width).max().unwrap_or(0);
    let factor = widest.div_ceil(MAX_AUTO_WIDTH_PX).max(1);
    if factor > 1 {
        tracing::warn!(
            "images are up to {widest} px wide: training at 1/{factor} resolution (as 3DGS rescales above \
             {MAX_AUTO_WIDTH_PX} px); pass --resolution 1 to keep the full size"
        );
    }
    Ok(factor)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quality(views: usize, psnr: f64) -> MeanQuality {
        MeanQuality { views, psnr, ssim: 0.5 }
    }

    #[test]
    fn the_random_start_covers_the_cameras_in_their_units() {
        let (centre, half) = random_start_cube(&[[10.0, 0.0, 0.0], [14.0, 0.0, 0.0], [12.0, 2.0, 0.0]]);
        let expected = [12.0, 2.0 / 3.0, 0.0];
        assert!(centre.iter().zip(expected).all(|(c, e)| (c - e).abs() < 1e-6), "{centre:?}");
        let farthest = (4.0f64 + (2.0f64 / 3.0).powi(2)).sqrt();
        assert!((f64::from(half) - 1.1 * farthest).abs() < 1e-5, "{half}");
        let (_, one) = random_start_cube(&[[1.0, 2.0, 3.0]]);
        assert!(one > 0.0, "a single camera still gives a cube");
    }

    #[test]
    fn a_fall_of_held_out_psnr_is_warned_with_both_values() {
        let w = psnr_fell_warning(&quality(2, 8.66), &quality(2, 6.65)).expect("a warning");
        assert!(w.contains("2 held-out views worse") && w.contains("8.66 dB before, 6.65 dB after"), "{w}");
        assert_eq!(psnr_fell_warning(&quality(2, 8.66), &quality(2, 8.66)), None);
        assert_eq!(psnr_fell_warning(&quality(2, 8.66), &quality(2, 20.0)), None);
        assert_eq!(psnr_fell_warning(&quality(0, 0.0), &quality(0, 0.0)), None, "nothing held out");
    }
}
