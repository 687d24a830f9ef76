//! `splatseg render`: render every view of a scene from a 3DGS PLY with the CPU rasteriser.

use clap::Args as ClapArgs;
use splatseg_pipeline::render_views::{render_views, RenderViews};
use splatseg_render::RenderRequest;
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
    let want = |w: What| args.what.contains(&w);
    let request = RenderRequest {
        rgb: want(What::Rgb),
        depth: want(What::Depth),
        alpha: want(What::Alpha),
        max_weight_ids: want(What::Ids),
        background: args.background,
        ..RenderRequest::default()
    };
    let job = RenderViews {
        scene: args.scene,
        gaussians: args.gaussians,
        out: args.out.clone(),
        request,
        resolution: args.resolution,
        options: super::run_options(),
    };
    let views = render_views(&job)?;
    tracing::info!("wrote {views} views to {}", args.out.display());
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
