//! What `splatseg view` needs to edit a run (issue 60), which only the pipeline knows: the run's
//! identity (`apply::edit_inputs`: its PLY's rows and centres digest, the key of
//! `OUT/cache/run.json`), when the outputs were already edited by `apply`, the run's own ids kept
//! in `OUT/cache/edits/` (edits always apply to those), and the ids the run's label maps show that
//! no Gaussian carries (which `apply` lets edits name, and counts when it numbers a split's new
//! object). Nothing is written.

use crate::apply_base::{Base, EDITS_HEADING};
use crate::error::Context;
use splatseg_edit::EditInputs;
use std::collections::BTreeSet;
use std::path::Path;

/// The run in `out` as the viewer edits it.
pub struct RunToEdit {
    /// The run's identity, written into `edits.json`.
    pub inputs: EditInputs,
    /// `[N]` the run's own ids when `gaussians.ply` holds edited ones (`None`: its ids are the run's).
    pub base_ids: Option<Vec<i32>>,
    /// Ids the run's label maps show that none of its Gaussians carries.
    pub map_only_ids: BTreeSet<i32>,
    /// The run's identity again at save time.
    pub watch: RunIdentityWatch,
}

/// Whether `out` holds a finished run (its manifest `cache/run.json`).
pub fn is_run_folder(out: &Path) -> bool {
    out.join("cache").join("run.json").is_file() && out.join("gaussians.ply").is_file()
}

/// The run in `out` (see the module doc).
pub fn run_to_edit(out: &Path) -> crate::Result<RunToEdit> {
    // stamped before reading: a run replacing the files meanwhile is seen at save time
    let stamps = stamps(out);
    let inputs = crate::apply::edit_inputs(out)?;
    let watch = RunIdentityWatch { out: out.to_path_buf(), known: inputs.clone(), stamps };
    let report_path = out.join("report.md");
    let report = std::fs::read_to_string(&report_path)
        .with_context(|| format!("cannot read the run's report {}", report_path.display()))?;
    // Not edited: nothing is read (and `Base` would take a copy, a write).
    if !report.contains(EDITS_HEADING) {
        let ply = out.join("gaussians.ply");
        let ids = splatseg_scene::ply::read_ply_rows(&ply)?.gaussians.object_ids.unwrap_or_default();
        let map_only_ids = map_only_ids(&out.join("masks"), &ids)?;
        return Ok(RunToEdit { inputs, base_ids: None, map_only_ids, watch });
    }
    // Edited: the copy of this run's own outputs exists (`apply` made it), or this is an error.
    let base = Base::open_or_take(out, &inputs.run, &[])?;
    let map_only_ids = map_only_ids(&out.join("cache").join("edits").join("masks"), &base.ids)?;
    Ok(RunToEdit { inputs, base_ids: Some(base.ids), map_only_ids, watch })
}

/// The ids the label maps in `dir` (every `.png`) show that no entry of `ids` is.
fn map_only_ids(dir: &Path, ids: &[i32]) -> crate::Result<BTreeSet<i32>> {
    let carried: BTreeSet<i32> = ids.iter().copied().collect();
    let mut shown = BTreeSet::new();
    let entries =
        std::fs::read_dir(dir).with_context(|| format!("cannot list the label maps in {}", dir.display()))?;
    let mut maps: Vec<_> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "png"))
        .collect();
    maps.sort();
    for path in maps {
        let map = splatseg_scene::labels::read_label_png(&path)?;
        shown.extend(splatseg_edit::ids_in_label_map(&map).into_iter().map(|id| id as i32));
    }
    Ok(shown.difference(&carried).copied().collect())
}

/// The run's identity again at save time, cheaply: the identity known at start while
/// `gaussians.ply` and `cache/run.json` keep their size and modification time (a new run or an
/// apply replaces them), else read again ([`crate::apply::edit_inputs`], which reads the PLY).
pub struct RunIdentityWatch {
    out: std::path::PathBuf,
    known: EditInputs,
    stamps: Vec<Option<(u64, std::time::SystemTime)>>,
}

impl RunIdentityWatch {
    /// The run's identity now.
    pub fn identity(&self) -> crate::Result<EditInputs> {
        if stamps(&self.out) == self.stamps && self.stamps.iter().all(Option::is_some) {
            return Ok(self.known.clone());
        }
        crate::apply::edit_inputs(&self.out)
    }
}

fn stamps(out: &Path) -> Vec<Option<(u64, std::time::SystemTime)>> {
    [out.join("gaussians.ply"), out.join("cache").join("run.json")]
        .iter()
        .map(|p| std::fs::metadata(p).ok().and_then(|m| Some((m.len(), m.modified().ok()?))))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_identity_is_read_again_once_the_runs_files_change() {
        let dir = tempfile::tempdir().expect("temp dir");
        let out = dir.path();
        std::fs::create_dir_all(out.join("cache")).expect("mkdir");
        std::fs::write(out.join("gaussians.ply"), b"not a ply").expect("write");
        std::fs::write(out.join("cache").join("run.json"), b"{}").expect("write");
        let known = EditInputs { gaussians: 3, ply_digest: "d".into(), run: "k".into() };
        let watch = RunIdentityWatch { out: out.to_path_buf(), known: known.clone(), stamps: stamps(out) };
        assert_eq!(watch.identity().expect("unchanged: the known identity"), known);
        std::fs::write(out.join("gaussians.ply"), b"another, longer PLY").expect("rewrite");
        assert!(watch.identity().is_err(), "changed: read again (and these files are no run)");
        let missing = RunIdentityWatch { out: out.join("gone"), known, stamps: stamps(&out.join("gone")) };
        assert!(missing.identity().is_err(), "missing files are not 'unchanged'");
    }
}
