//! `splatseg info`'s arguments and long help.

use crate::scene_info::InfoRequest;
use std::path::PathBuf;

/// The long help of `splatseg info --help` (set on the subcommand by the binary).
pub const INFO_LONG_ABOUT: &str = "\
Show what a scene folder holds: format, cameras, views, missing or mis-sized images, sparse \
points, the Gaussians of a 3DGS PLY and which views have SAM masks or cue maps.

PATH is any scene splatseg reads: a COLMAP folder (sparse/0/ + images/, binary or text model), \
a COLMAP model folder itself, a NeRF/Blender folder (transforms_train.json) or an instant-ngp / \
nerfstudio folder or file (transforms.json).

Per-view inputs are matched by image stem: IMG_0001.jpg <-> sam/IMG_0001.json, \
features/IMG_0001.npy, depth/IMG_0001.npy. Folders named sam, masks, features and depth inside \
PATH are checked automatically.

Images are checked at full resolution against their cameras, and the down-scaled copies that \
3DGS's --resolution 2, 4 or 8 reads (images_2/, images_4/, images_8/ beside images/), when there \
are any, against the cameras down-scaled as much. Exits with an error when an image cannot be \
loaded at its camera's size.

Examples:
  splatseg info data/garden
  splatseg info data/garden --gaussians output/point_cloud.ply --masks sam_out
  splatseg info data/lego --json";

/// Show what a scene folder holds: format, cameras, views, missing or mis-sized images, sparse
/// points, the Gaussians of a 3DGS PLY and which views have SAM masks or cue maps.
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct InfoArgs {
    /// Scene folder (or transforms .json file).
    pub path: PathBuf,
    /// A 3DGS PLY to describe. Default: the `*.ply` files directly in PATH, else the latest
    /// `point_cloud/iteration_*/point_cloud.ply` (3DGS training output).
    #[cfg_attr(feature = "cli", arg(long))]
    pub gaussians: Option<PathBuf>,
    /// Folder of per-view SAM masks (`<stem>.json`, or `<stem>/metadata.csv` PNG folders).
    #[cfg_attr(feature = "cli", arg(long))]
    pub masks: Option<PathBuf>,
    /// Print the report as JSON on stdout (warnings included) instead of text.
    #[cfg_attr(feature = "cli", arg(long))]
    pub json: bool,
}

impl InfoArgs {
    /// What to inspect (at full resolution, with every down-scaled copy found; Blender scenes: the
    /// train split, as `run`).
    pub fn request(&self, strict: bool) -> InfoRequest {
        InfoRequest {
            path: self.path.clone(),
            gaussians: self.gaussians.clone(),
            masks: self.masks.clone(),
            resolution: 1,
            split: "train".into(),
            strict,
        }
    }
}
