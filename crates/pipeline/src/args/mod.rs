//! The arguments of the commands this crate runs — `apply`, `demo`, `train`, `info`, `render`, `merge` —
//! as clap's `Args` (with the `cli` feature), the requests they make, and what `run`
//! prints.

mod apply;
mod demo;
mod info;
mod merge;
mod render;
mod train;

pub use apply::ApplyArgs;
pub use demo::{identity_study_request, DemoArgs};
pub use info::{InfoArgs, INFO_LONG_ABOUT};
pub use merge::{DepthMeaning, MergeArgs};
pub use render::{RenderArgs, What};
pub use train::TrainArgs;

use crate::PipelineConfig;
use std::path::Path;

impl PipelineConfig {
    /// The settings of a `--config` file, or the defaults without one.
    pub fn from_optional_file(path: Option<&Path>) -> crate::Result<Self> {
        path.map_or_else(|| Ok(Self::default()), Self::from_file)
    }
}

impl crate::RunSummary {
    /// What `splatseg run` prints: what was cached, the counts per stage, the metrics table (with
    /// ground truth) and where the report is.
    pub fn to_text(&self) -> String {
        let mut text = String::new();
        if self.resumed {
            text += &format!("outputs in {} are up to date (nothing recomputed)\n", self.out.display());
        } else if self.cached_views > 0 {
            text += &format!(
                "{} of {} views' merges came from the cache\n",
                self.cached_views, self.views_with_masks
            );
        }
        text += &format!(
            "{} views: {} SAM regions → {} merged → {} global objects → {} objects in the final maps\n",
            self.views, self.raw_masks, self.merged_masks, self.matched_objects, self.final_objects
        );
        if let Some(table) = self.table() {
            text += &format!("\n{table}\n");
        }
        if !self.warnings.is_empty() {
            text += &format!("{} warning(s), listed in the report\n", self.warnings.len());
        }
        text + &format!("report: {}\n", self.out.join("report.md").display())
    }
}

/// The inputs `run` and `merge` share, as [`splatseg_scene::paths`] roles: SCENE (a folder of which
/// named parts are read), its default `gaussians.ply`, the cue folders (every file read), the PLY
/// and the config file.
pub fn pipeline_inputs(
    scene: &std::path::Path,
    masks: Option<&std::path::Path>,
    features: Option<&std::path::Path>,
    depth: Option<&std::path::Path>,
    gaussians: Option<&std::path::Path>,
    config: Option<&std::path::Path>,
) -> Vec<splatseg_scene::paths::Role> {
    use splatseg_scene::paths::Role;
    let mut inputs = vec![Role::folder("SCENE", scene)];
    inputs.push(match gaussians {
        Some(p) => Role::file("--gaussians", p),
        None => Role::file("SCENE's gaussians.ply", scene.join("gaussians.ply")),
    });
    inputs.extend(masks.map(|p| Role::tree("--masks", p)));
    inputs.extend(features.map(|p| Role::tree("--features", p)));
    inputs.extend(depth.map(|p| Role::tree("--depth", p)));
    inputs.extend(config.map(|p| Role::file("--config", p)));
    inputs
}

/// What `run` (and `merge`, a part of it) writes into OUT: the folder itself, `masks/`,
/// `overlays/`, `cache/` (every file), `objects/` (removed by a commit, written by `--clip`),
/// `gaussians.ply`, `report.md`, `metrics.json` and the lock.
pub fn run_outputs(out: &std::path::Path) -> Vec<splatseg_scene::paths::Role> {
    use splatseg_scene::paths::Role;
    let mut outputs = vec![Role::folder("--out", out)];
    for dir in ["masks", "overlays", "cache", "objects"] {
        outputs.push(Role::tree(format!("--out's {dir}/"), out.join(dir)));
    }
    for file in ["gaussians.ply", "report.md", "metrics.json", ".splatseg.lock"] {
        outputs.push(Role::file(format!("--out's {file}"), out.join(file)));
    }
    outputs
}
