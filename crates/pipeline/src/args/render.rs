//! `splatseg render`'s arguments.

use crate::render_views::RenderViews;
use crate::RunOptions;
use splatseg_render::RenderRequest;
use std::path::PathBuf;

/// One kind of output image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
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
/// Lens distortion is ignored (the views are rendered as pinholes with the same intrinsics). Colour
/// is rendered over black, as 3DGS's render.py does by default; `--what alpha` writes the accumulated
/// opacity to composite the RGB over any other background.
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct RenderArgs {
    /// Scene folder (COLMAP, Blender or instant-ngp transforms).
    pub scene: PathBuf,
    /// The 3DGS PLY to render.
    #[cfg_attr(feature = "cli", arg(long))]
    pub gaussians: PathBuf,
    /// Output folder (created if needed).
    #[cfg_attr(feature = "cli", arg(long))]
    pub out: PathBuf,
    /// Which outputs to write, comma-separated.
    #[cfg_attr(
        feature = "cli",
        arg(long, value_enum, value_delimiter = ',', default_value = "rgb,depth,ids,alpha")
    )]
    pub what: Vec<What>,
    /// Image down-scaling factor, as 3DGS's `--resolution` (1, 2, 4 or 8).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 1))]
    pub resolution: u32,
}

impl RenderArgs {
    /// The rendering job.
    pub fn job(self, options: RunOptions) -> RenderViews<'static> {
        let want = |w: What| self.what.contains(&w);
        let request = RenderRequest {
            rgb: want(What::Rgb),
            depth: want(What::Depth),
            alpha: want(What::Alpha),
            max_weight_ids: want(What::Ids),
            background: [0.0; 3],
            ..RenderRequest::default()
        };
        RenderViews {
            scene: self.scene,
            gaussians: self.gaussians,
            out: self.out,
            request,
            resolution: self.resolution,
            options,
        }
    }
}

impl RenderArgs {
    /// Refuses an --out (a folder of `<stem>_<what>.png` files) equal to SCENE or the PLY, or
    /// holding either, before anything is read.
    pub fn refuse_overwrite(&self) -> splatseg_scene::SceneResult<()> {
        use splatseg_scene::paths::{refuse_overwrite, Role};
        refuse_overwrite(
            &[Role::folder("SCENE", &self.scene), Role::file("--gaussians", &self.gaussians)],
            &[Role::tree("--out", &self.out)],
        )
    }
}
