//! What `splatseg apply` starts from: the run's own outputs before any edit, kept in
//! `OUT/cache/edits/` the first time edits are applied to a run, so that edits always apply to
//! the run's result and never to an edited one (applying twice gives the same bytes).
//!
//! ```text
//! OUT/cache/edits/base.json        the run's key (cache/run.json) these copies are of
//! OUT/cache/edits/object_ids.bin   [N] i32 little-endian: gaussians.ply's object_id, every row
//! OUT/cache/edits/masks/<stem>.png the run's final label maps
//! OUT/cache/edits/report.md        the run's report
//! ```
//!
//! The copy is written into `cache/edits.partial/` and renamed into place whole. A new run
//! (another key) makes the copy stale: the next apply takes a new one from the new run's outputs.

use crate::error::{bail, Context};
use serde::{Deserialize, Serialize};
use splatseg_scene::Plane;
use std::path::{Path, PathBuf};

/// The folder under `OUT/cache/`.
const BASE_DIR: &str = "edits";

/// The heading `apply` adds to `report.md`: outputs that have it were edited.
pub const EDITS_HEADING: &str = "## Edits (splatseg apply)";

#[derive(Serialize, Deserialize)]
struct BaseManifest {
    run_key: String,
    gaussians: usize,
}

/// The run's pre-edit outputs.
pub struct Base {
    dir: PathBuf,
    /// `[N]` the run's object id of every row of `gaussians.ply`.
    pub ids: Vec<i32>,
}

impl Base {
    /// The copy of the run `run_key` in `out`, taken now from `out`'s outputs when there is
    /// none (or one of another run). `stems`: the scene's views, whose maps are copied.
    pub fn open_or_take(out: &Path, run_key: &str, stems: &[&str]) -> crate::Result<Base> {
        let dir = out.join("cache").join(BASE_DIR);
        let manifest: Option<BaseManifest> = crate::read_json(&dir.join("base.json"));
        if let Some(m) = manifest.filter(|m| m.run_key == run_key) {
            let ids = read_ids(&dir.join("object_ids.bin"), m.gaussians)?;
            return Ok(Base { dir, ids });
        }
        let report = std::fs::read_to_string(out.join("report.md"))
            .with_context(|| format!("cannot read the run's report {}", out.join("report.md").display()))?;
        if report.contains(EDITS_HEADING) {
            bail!(
                "the outputs in {} were edited and their pre-edit copy ({}) is gone, so the edits cannot \
                 start from the run's own result: run `splatseg run` again (remove {} first to make it \
                 rewrite its outputs)",
                out.display(),
                dir.display(),
                out.join("cache").join("run.json").display()
            );
        }
        let partial = out.join("cache").join(format!("{BASE_DIR}.partial"));
        remove_dir(&partial)?;
        std::fs::create_dir_all(partial.join("masks"))
            .with_context(|| format!("creating {}", partial.display()))?;
        let ply = out.join("gaussians.ply");
        let ids = splatseg_scene::ply::read_ply_rows(&ply)?
            .gaussians
            .object_ids
            .with_context(|| format!("no object_id in the run's {}", ply.display()))?;
        let bytes: Vec<u8> = ids.iter().flat_map(|id| id.to_le_bytes()).collect();
        std::fs::write(partial.join("object_ids.bin"), bytes).context("writing the run's object ids")?;
        for stem in stems {
            let (from, to) = (
                out.join("masks").join(format!("{stem}.png")),
                partial.join("masks").join(format!("{stem}.png")),
            );
            std::fs::copy(&from, &to)
                .with_context(|| format!("copying the run's label map {}", from.display()))?;
        }
        std::fs::write(partial.join("report.md"), &report).context("copying the run's report")?;
        crate::write_json(
            &partial.join("base.json"),
            &BaseManifest { run_key: run_key.to_string(), gaussians: ids.len() },
        )?;
        remove_dir(&dir)?;
        std::fs::rename(&partial, &dir)
            .with_context(|| format!("moving {} to {}", partial.display(), dir.display()))?;
        Ok(Base { dir, ids })
    }

    /// `[H, W]` the run's final label map of view `stem`.
    pub fn label_map(&self, stem: &str) -> crate::Result<Plane<u32>> {
        Ok(splatseg_scene::labels::read_label_png(&self.dir.join("masks").join(format!("{stem}.png")))?)
    }

    /// The run's `report.md`.
    pub fn report(&self) -> crate::Result<String> {
        let path = self.dir.join("report.md");
        std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))
    }
}

/// `[n]` i32 little-endian ids from `path`.
fn read_ids(path: &Path, n: usize) -> crate::Result<Vec<i32>> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    if bytes.len() != 4 * n {
        bail!(
            "{} holds {} bytes, not the {n} ids of the run's Gaussians: {}",
            "the pre-edit copy",
            bytes.len(),
            path.display()
        );
    }
    Ok(bytes.chunks_exact(4).map(|b| i32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect())
}

fn remove_dir(dir: &Path) -> crate::Result<()> {
    if dir.exists() {
        std::fs::remove_dir_all(dir).with_context(|| format!("removing {}", dir.display()))?;
    }
    Ok(())
}
