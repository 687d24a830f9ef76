//! Reading what a finished `run` wrote, for callers of the library (the viewer's server, a
//! binding): the summary, one view's label map, the per-Gaussian ids.

use crate::error::{bail, Context};
use crate::RunSummary;
use splatseg_scene::Plane;
use std::path::{Path, PathBuf};

/// A finished run's output folder.
#[derive(Clone, Debug)]
pub struct RunOutputs {
    /// The folder (`--out`).
    pub out: PathBuf,
    /// What the run produced (`metrics.json`).
    pub summary: RunSummary,
}

impl RunOutputs {
    /// Opens the outputs in `out`; an error naming `metrics.json` when the run did not finish.
    pub fn open(out: &Path) -> crate::Result<RunOutputs> {
        let path = out.join("metrics.json");
        if !path.is_file() {
            bail!("no finished run here (metrics.json is missing): {}", path.display());
        }
        let text =
            std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))?;
        let mut summary: RunSummary = serde_json::from_str(&text)
            .with_context(|| format!("not a run's metrics.json: {}", path.display()))?;
        summary.out = out.to_path_buf();
        Ok(RunOutputs { out: out.to_path_buf(), summary })
    }

    /// `[H, W]` final label map of view `stem` (global ids, 0 = none).
    pub fn label_map(&self, stem: &str) -> crate::Result<Plane<u32>> {
        Ok(splatseg_scene::labels::read_label_png(&self.out.join("masks").join(format!("{stem}.png")))?)
    }

    /// `[N]` object id of every row of the input PLY (−1 = none), from `gaussians.ply` (whose
    /// rows with non-finite values, kept in place with id −1, are read too).
    pub fn object_ids(&self) -> crate::Result<Vec<i32>> {
        let path = self.out.join("gaussians.ply");
        let g = splatseg_scene::ply::read_ply_rows(&path)?.gaussians;
        g.object_ids.with_context(|| format!("no object_id in {}", path.display()))
    }
}
