//! `splatseg render`: every view of a scene rendered from a 3DGS PLY with the CPU rasteriser
//! (lens distortion ignored: pinholes with the same intrinsics), written per view as
//! `<stem>_rgb.png`, `<stem>_depth.png` + `<stem>_depth.npy`, `<stem>_ids.png`, `<stem>_alpha.png`.

use crate::error::Context;
use indicatif::{ProgressBar, ProgressStyle};
use splatseg_render::export::{write_depth, write_ids_png, write_rgb_png, write_unit_png};
use splatseg_render::{render, RenderCamera, RenderRequest};
use splatseg_scene::{load_scene, LoadOptions};
use std::path::PathBuf;

/// What to render and where.
#[derive(Clone, Debug)]
pub struct RenderViews<'a> {
    /// Scene folder (COLMAP, Blender or instant-ngp transforms).
    pub scene: PathBuf,
    /// The 3DGS PLY.
    pub gaussians: PathBuf,
    /// Output folder (created if needed).
    pub out: PathBuf,
    /// Which images: colour, depth, alpha, and the id of the Gaussian with the largest blending
    /// weight (`max_weight_ids`); the background colour.
    pub request: RenderRequest<'a>,
    /// Image down-scaling factor, as 3DGS's `--resolution`.
    pub resolution: u32,
    /// `--strict` (non-finite Gaussians refused) and `--quiet` (no progress bar).
    pub options: crate::RunOptions,
}

/// Renders every view of `job.scene`; the number of views written.
pub fn render_views(job: &RenderViews<'_>) -> crate::Result<usize> {
    let options = LoadOptions { resolution: job.resolution, ..LoadOptions::default() };
    let scene = load_scene(&job.scene, &options)
        .with_context(|| format!("cannot load scene {}", job.scene.display()))?;
    for warning in &scene.warnings {
        tracing::warn!("{warning}");
    }
    let gaussians = crate::ply_input::read_finite(&job.gaussians, job.options.strict)?;
    std::fs::create_dir_all(&job.out).with_context(|| format!("cannot create {}", job.out.display()))?;
    let bar = ProgressBar::new(scene.views.len() as u64);
    if job.options.quiet {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    } else {
        crate::progress_log::log_when_piped(&bar);
    }
    if let Ok(style) = ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} views ({eta})") {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message("rendering");
    for view in &scene.views {
        let camera = RenderCamera::from_scene(scene.camera(view), &view.world_from_cam);
        let out = render(&gaussians, &camera, &job.request)
            .with_context(|| format!("cannot render view {}", view.name))?;
        let path = |suffix: &str| job.out.join(format!("{}_{suffix}", view.stem));
        if let Some(rgb) = &out.rgb {
            write_rgb_png(&path("rgb.png"), rgb, out.width, out.height)?;
        }
        if let Some(depth) = &out.depth {
            write_depth(&path("depth.png"), &path("depth.npy"), depth)?;
        }
        if let Some(ids) = &out.max_weight_ids {
            write_ids_png(&path("ids.png"), ids)?;
        }
        if let Some(alpha) = &out.alpha {
            write_unit_png(&path("alpha.png"), alpha)?;
        }
        bar.inc(1);
    }
    bar.finish_with_message("rendered");
    Ok(scene.views.len())
}
