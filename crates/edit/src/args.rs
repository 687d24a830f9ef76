//! The arguments of `splatseg objects`, `extract`, `remove` and `recolor` (clap's `Args` with the
//! `cli` feature).

use crate::ExtraFields;
use std::path::PathBuf;

/// List the objects of a labelled PLY: id, Gaussian count, bounding box of the centres, palette
/// colour, the number of views showing it and the name `splatseg apply` gave it.
///
/// The views are counted in the per-view label maps `masks/<stem>.png` beside the PLY, where
/// `splatseg run` (and `train`) write them with the PLY; without that folder the column is empty.
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct ObjectsArgs {
    /// Labelled 3DGS PLY (with `object_id`, as `splatseg run` writes it).
    pub ply: PathBuf,
    /// Print JSON instead of a table.
    #[cfg_attr(feature = "cli", arg(long))]
    pub json: bool,
}

/// Write the Gaussians of the chosen objects to a new PLY (e.g. to open one object alone).
///
/// The input is a labelled PLY (with `object_id`, as `splatseg run` writes it); the Gaussians
/// keep their order and every value bit for bit. The output has the standard INRIA 3DGS layout
/// that viewers open: splatseg's `object_id` and `feat_*` properties (and any other non-standard
/// property) are dropped unless --keep-extras is given. The objects are given by --ids
/// (`splatseg objects PLY` lists them) or, after `run --clip`, by --query (the best match).
/// `--out` ending in .spz, .splat, .ksplat or .compressed.ply writes that format (quantised, no extras; see CONVENTIONS.md).
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[cfg_attr(feature = "cli", command(group(clap::ArgGroup::new("objects").required(true).args(["ids", "query"]))))]
pub struct ExtractArgs {
    /// Labelled 3DGS PLY.
    pub ply: PathBuf,
    /// Object ids to keep, comma-separated (e.g. `3,7`; `-1` = the unlabelled Gaussians).
    #[cfg_attr(feature = "cli", arg(long, value_delimiter = ',', allow_hyphen_values = true))]
    pub ids: Vec<i32>,
    /// Instead of --ids: an object's name given by `splatseg apply` (`objects.json` beside the
    /// PLY), or a text query, e.g. "a red mug": the object it matches best (CLIP relevancy, as
    /// `splatseg find` ranks) among those `run --clip` embedded in PLY's folder
    /// (`objects/objects.json` beside `gaussians.ply`).
    #[cfg_attr(feature = "cli", arg(long, value_name = "TEXT"))]
    pub query: Option<String>,
    /// Output file: a 3DGS PLY, or an SPZ / .splat / .ksplat / compressed PLY when it ends in
    /// .spz / .splat / .ksplat / .compressed.ply.
    #[cfg_attr(feature = "cli", arg(long))]
    pub out: PathBuf,
    /// Keep `object_id`, `feat_*` and other non-standard properties (some viewers reject them).
    #[cfg_attr(feature = "cli", arg(long))]
    pub keep_extras: bool,
}

/// Write the scene without the chosen objects (every other Gaussian unchanged, same order).
///
/// The input is a labelled PLY (with `object_id`, as `splatseg run` writes it). The output has
/// the standard INRIA 3DGS layout that viewers open: splatseg's `object_id` and `feat_*`
/// properties (and any other non-standard property) are dropped unless --keep-extras is given.
/// The objects are given by --ids (`splatseg objects PLY` lists them) or, after `run --clip`, by
/// --query (the best match). `--out` ending in .spz, .splat, .ksplat or .compressed.ply writes that format (quantised, no
/// extras; see CONVENTIONS.md).
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[cfg_attr(feature = "cli", command(group(clap::ArgGroup::new("objects").required(true).args(["ids", "query"]))))]
pub struct RemoveArgs {
    /// Labelled 3DGS PLY.
    pub ply: PathBuf,
    /// Object ids to remove, comma-separated (e.g. `3,7`; `-1` = the unlabelled Gaussians).
    #[cfg_attr(feature = "cli", arg(long, value_delimiter = ',', allow_hyphen_values = true))]
    pub ids: Vec<i32>,
    /// Instead of --ids: an object's name given by `splatseg apply` (`objects.json` beside the
    /// PLY), or a text query, e.g. "a red mug": the object it matches best (CLIP relevancy, as
    /// `splatseg find` ranks) among those `run --clip` embedded in PLY's folder
    /// (`objects/objects.json` beside `gaussians.ply`).
    #[cfg_attr(feature = "cli", arg(long, value_name = "TEXT"))]
    pub query: Option<String>,
    /// Output file: a 3DGS PLY, or an SPZ / .splat / .ksplat / compressed PLY when it ends in
    /// .spz / .splat / .ksplat / .compressed.ply.
    #[cfg_attr(feature = "cli", arg(long))]
    pub out: PathBuf,
    /// Keep `object_id`, `feat_*` and other non-standard properties (some viewers reject them).
    #[cfg_attr(feature = "cli", arg(long))]
    pub keep_extras: bool,
}

/// Paint each object in its palette colour (the colours of the label-map overlays), to see a
/// segmentation in any 3DGS viewer.
///
/// Sets each labelled Gaussian's base colour (`f_dc`) to its object's colour and zeroes its
/// view-dependent part (`f_rest`), and Gaussians without an object flat dark grey; positions,
/// shapes and opacities are unchanged. The output
/// has the standard INRIA 3DGS layout unless --keep-extras is given, or is an SPZ, a .splat, a
/// .ksplat or a compressed PLY when `--out` ends so.
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct RecolorArgs {
    /// Labelled 3DGS PLY.
    pub ply: PathBuf,
    /// Output file: a 3DGS PLY, or an SPZ / .splat / .ksplat / compressed PLY when it ends in
    /// .spz / .splat / .ksplat / .compressed.ply.
    #[cfg_attr(feature = "cli", arg(long))]
    pub out: PathBuf,
    /// Keep `object_id`, `feat_*` and other non-standard properties (some viewers reject them).
    #[cfg_attr(feature = "cli", arg(long))]
    pub keep_extras: bool,
}

/// `--keep-extras` as the writer's choice.
pub fn extras(keep_extras: bool) -> ExtraFields {
    if keep_extras {
        ExtraFields::Keep
    } else {
        ExtraFields::Strip
    }
}

/// `extract`, `remove` and `recolor` read one PLY and write one: `--out` must not be the input PLY
/// (by any spelling: symlinks, `./`, `..`).
fn refuse_overwrite(ply: &std::path::Path, out: &std::path::Path) -> splatseg_scene::SceneResult<()> {
    use splatseg_scene::paths::{refuse_overwrite, Role};
    refuse_overwrite(&[Role::file("the input PLY", ply)], &[Role::file("--out", out)])
}

impl ObjectsArgs {
    /// The folder of label maps the views are counted in: `masks/` beside the PLY, when it is there.
    pub fn label_maps(&self) -> Option<PathBuf> {
        let dir = self.ply.parent().unwrap_or(std::path::Path::new(".")).join("masks");
        dir.is_dir().then_some(dir)
    }
}

impl ExtractArgs {
    /// Refuses an `--out` that is the input PLY (before anything is read).
    pub fn refuse_overwrite(&self) -> splatseg_scene::SceneResult<()> {
        refuse_overwrite(&self.ply, &self.out)
    }
}

impl RemoveArgs {
    /// Refuses an `--out` that is the input PLY (before anything is read).
    pub fn refuse_overwrite(&self) -> splatseg_scene::SceneResult<()> {
        refuse_overwrite(&self.ply, &self.out)
    }
}

impl RecolorArgs {
    /// Refuses an `--out` that is the input PLY (before anything is read).
    pub fn refuse_overwrite(&self) -> splatseg_scene::SceneResult<()> {
        refuse_overwrite(&self.ply, &self.out)
    }
}
