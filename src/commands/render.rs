//! `splatseg render`: render every view of a scene from a 3DGS PLY with the CPU rasteriser.

use anyhow::Context;
use clap::Args as ClapArgs;
use indicatif::{ProgressBar, ProgressStyle};
use splatseg_render::export::{write_depth, write_ids_png, write_rgb_png, write_unit_png};
use splatseg_render::{render, RenderCamera, RenderRequest};
use splatseg_scene::{load_scene, LoadOptions};
use std::path::PathBuf;

/// One kind of output image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum What {
    /// Colour, `<stem>_rgb.png`.
    Rgb,
    /// Expected metric depth: `<stem>_depth.png` (16-bit, 0 = empty, near → far over the view's
    /// own range) and `<stem>_depth.npy` (float32 camera z).
    Depth,
    /// Per pixel the Gaussian with the largest blending weight, coloured with the label palette
    /// (Gaussian i has the colour of id i + 1): `<stem>_ids.png`.
    Ids,
    /// Accumulated opacity, `<stem>_alpha.png` (8-bit).
    Alpha,
}

/// Render every camera of a scene from its Gaussians (CPU rasteriser, gsplat's math).
///
/// Lens distortion is ignored (the views are rendered as pinholes with the same intrinsics).
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Scene folder (COLMAP, Blender or instant-ngp transforms).
    pub scene: PathBuf,
    /// The 3DGS PLY to render.
    #[arg(long)]
    pub gaussians: PathBuf,
    /// Output folder (created if needed).
    #[arg(long)]
    pub out: PathBuf,
    /// Which outputs to write, comma-separated.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "rgb,depth,ids,alpha")]
    pub what: Vec<What>,
    /// Image down-scaling factor, as 3DGS's `--resolution` (1, 2, 4 or 8).
    #[arg(long, default_value_t = 1)]
    pub resolution: u32,
    /// Background colour R,G,B in [0, 1] (e.g. `1,1,1` for white).
    #[arg(long, default_value = "0,0,0", value_parser = parse_rgb)]
    pub background: [f32; 3],
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let options = LoadOptions { resolution: args.resolution, ..LoadOptions::default() };
    let scene = load_scene(&args.scene, &options)
        .with_context(|| format!("cannot load scene {}", args.scene.display()))?;
    for warning in &scene.warnings {
        tracing::warn!("{warning}");
    }
    let gaussians = splatseg_pipeline::ply_input::read_finite(&args.gaussians, super::run_options().strict)?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let want = |w: What| args.what.contains(&w);
    let request = RenderRequest {
        rgb: want(What::Rgb),
        depth: want(What::Depth),
        alpha: want(What::Alpha),
        max_weight_ids: want(What::Ids),
        background: args.background,
        ..RenderRequest::default()
    };
    let bar = ProgressBar::new(scene.views.len() as u64);
    if super::logging::quiet() {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} views ({eta})")?.progress_chars("=> "),
    );
    bar.set_message("rendering");
    for view in &scene.views {
        let camera = RenderCamera::from_scene(scene.camera(view), &view.world_from_cam);
        let out = render(&gaussians, &camera, &request)
            .with_context(|| format!("cannot render view {}", view.name))?;
        let path = |suffix: &str| args.out.join(format!("{}_{suffix}", view.stem));
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
    tracing::info!("wrote {} views to {}", scene.views.len(), args.out.display());
    Ok(())
}

/// Parses `R,G,B` with each channel in [0, 1].
fn parse_rgb(text: &str) -> Result<[f32; 3], String> {
    let values: Vec<f32> = text
        .split(',')
        .map(|v| v.trim().parse::<f32>().map_err(|_| format!("`{v}` is not a number")))
        .collect::<Result<_, _>>()?;
    match values[..] {
        [r, g, b] if values.iter().all(|c| (0.0..=1.0).contains(c)) => Ok([r, g, b]),
        _ => Err(format!("expected R,G,B with each channel in [0, 1], got `{text}`")),
    }
}
