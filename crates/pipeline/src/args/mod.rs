//! The arguments of the commands this crate runs — `demo`, `train`, `info`, `render`, `merge` —
//! as clap's `Args` (with the `cli` feature), the requests they make, and what `run`
//! prints.

mod demo;
mod info;
mod merge;
mod render;
mod train;

pub use demo::DemoArgs;
pub use info::{InfoArgs, INFO_LONG_ABOUT};
pub use merge::{DepthMeaning, MergeArgs};
pub use render::{parse_rgb, RenderArgs, What};
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
        text + &format!("report: {}\n", self.out.join("report.md").display())
    }
}
