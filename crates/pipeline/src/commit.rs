//! `run`'s outputs committed as a whole. They are written into `OUT/.staging/` and moved in by
//! renames, in a fixed order, once all of them are complete; the manifest (`cache/run.json`: the
//! digest of the inputs and settings that made them) is removed before the first rename and
//! written after the last, and "up to date" needs it. So a run killed at any moment leaves
//! either the earlier outputs with their manifest, or outputs without a manifest that the next
//! run replaces; never a mixture called up to date. Outputs of an earlier run that this run
//! does not write (the label map of a view the scene no longer has, a `gaussians.ply` of a run
//! with Gaussians) are removed, and a killed run's staging folder with its temporary files is
//! removed by the next run.

use crate::error::Context;
use std::path::{Path, PathBuf};

/// Name of the staging folder inside `OUT`.
pub const STAGING: &str = ".staging";

/// Everything `run` and `apply` write besides their cache, in the order it is moved in
/// (`objects.json`, the edited objects' table, is `apply`'s alone: a new run removes it).
pub const OUTPUTS: [&str; 6] =
    ["masks", "overlays", "gaussians.ply", "objects.json", "metrics.json", "report.md"];

/// What later steps make from the outputs (`run --clip`'s object embeddings, `objects/`): they
/// describe the outputs they were made from, so a commit of new outputs removes them first (a
/// `run --clip` makes them again; a query on a folder without them says to).
pub const MADE_FROM_OUTPUTS: [&str; 1] = ["objects"];

/// An empty staging folder for one run's outputs.
#[derive(Debug)]
pub struct Staging {
    out: PathBuf,
    dir: PathBuf,
}

impl Staging {
    /// Empties `OUT/.staging/` (what a killed run left there included).
    pub fn begin(out: &Path) -> crate::Result<Self> {
        let dir = out.join(STAGING);
        remove_path(&dir)?;
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        Ok(Staging { out: out.to_path_buf(), dir })
    }

    /// Where the outputs are written before the commit.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Removes `manifest` and what was made from the earlier outputs ([`MADE_FROM_OUTPUTS`]), then
    /// replaces each of [`OUTPUTS`] in `OUT` by the staged one (or removes it when this run did not
    /// write it), then removes the staging folder. The caller writes the new manifest afterwards.
    pub fn commit(self, manifest: &Path) -> crate::Result<()> {
        self.move_in(manifest)?;
        remove_path(&self.dir)
    }

    /// [`Staging::commit`] for outputs whose manifest stays as it was (`apply`'s: the same run):
    /// `manifest_bytes` are written back before the staging folder, which holds them as
    /// [`PENDING_MANIFEST`] during the renames, is removed; so a process killed on the way leaves
    /// them there for the next `apply` ([`pending_manifest`]), and `run` (which removes the
    /// staging folder) recomputes.
    pub fn commit_same_manifest(self, manifest: &Path, manifest_bytes: &[u8]) -> crate::Result<()> {
        let pending = self.dir.join(PENDING_MANIFEST);
        splatseg_scene::atomic::write_bytes_atomic(&pending, manifest_bytes)?;
        self.move_in(manifest)?;
        splatseg_scene::atomic::write_bytes_atomic(manifest, manifest_bytes)?;
        remove_path(&self.dir)
    }

    /// Removes `manifest`, then moves each staged output in (or removes it when not staged).
    fn move_in(&self, manifest: &Path) -> crate::Result<()> {
        remove_path(manifest)?;
        for name in MADE_FROM_OUTPUTS {
            remove_path(&self.out.join(name))?;
        }
        for name in OUTPUTS {
            let (staged, target) = (self.dir.join(name), self.out.join(name));
            remove_path(&target)?;
            if staged.exists() {
                std::fs::rename(&staged, &target)
                    .with_context(|| format!("moving {} to {}", staged.display(), target.display()))?;
            }
        }
        Ok(())
    }
}

/// The manifest [`Staging::commit_same_manifest`] keeps in the staging folder while it commits.
pub const PENDING_MANIFEST: &str = "manifest.pending";

/// The manifest an `apply` killed while committing left in `OUT/.staging/`, when `OUT` has none.
pub fn pending_manifest(out: &Path, manifest: &Path) -> Option<Vec<u8>> {
    if manifest.exists() {
        return None;
    }
    std::fs::read(out.join(STAGING).join(PENDING_MANIFEST)).ok()
}

/// Removes the staging folder an interrupted run left (its temporary files included; the
/// output lock removes the others, `lock.rs`), also when the outputs turn out to be up to date.
pub fn remove_leftover_staging(out: &Path) -> crate::Result<()> {
    remove_path(&out.join(STAGING))
}

/// Removes a file or a folder with its contents; nothing to do when it does not exist.
fn remove_path(path: &Path) -> crate::Result<()> {
    let removed = match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => Err(e),
        Ok(meta) if meta.is_dir() => std::fs::remove_dir_all(path),
        Ok(_) => std::fs::remove_file(path),
    };
    removed.with_context(|| format!("removing the earlier output {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commit_replaces_every_output_and_removes_the_ones_not_written() {
        let tmp = tempfile::tempdir().expect("temp dir");
        let out = tmp.path();
        for (path, text) in [
            ("masks/a.png", "old a"),
            ("masks/stale.png", "old stale"),
            ("gaussians.ply", "old ply"),
            ("report.md", "old report"),
            ("cache/run.json", "old manifest"),
            ("notes.txt", "the user's"),
            ("objects/objects.json", "the earlier run's object index"),
            (".staging/masks/.tmp123", "a killed run's temp file"),
        ] {
            let p = out.join(path);
            std::fs::create_dir_all(p.parent().expect("parent")).expect("mkdir");
            std::fs::write(p, text).expect("write");
        }
        let staging = Staging::begin(out).expect("begin");
        assert!(!staging.dir().join("masks").exists(), "begin empties the staging folder");
        for (path, text) in [("masks/a.png", "new a"), ("report.md", "new report"), ("metrics.json", "{}")] {
            let p = staging.dir().join(path);
            std::fs::create_dir_all(p.parent().expect("parent")).expect("mkdir");
            std::fs::write(p, text).expect("write");
        }
        let untouched = std::fs::read_to_string(out.join("masks/a.png")).expect("read");
        assert_eq!(untouched, "old a", "nothing in OUT changes before the commit");
        staging.commit(&out.join("cache/run.json")).expect("commit");
        let read = |p: &str| std::fs::read_to_string(out.join(p)).ok();
        assert_eq!(read("masks/a.png").as_deref(), Some("new a"));
        assert_eq!(read("masks/stale.png"), None, "a map this run did not write is gone");
        assert_eq!(read("gaussians.ply"), None, "a PLY this run did not write is gone");
        assert_eq!(read("report.md").as_deref(), Some("new report"));
        assert_eq!(read("metrics.json").as_deref(), Some("{}"));
        assert_eq!(read("cache/run.json"), None, "the caller writes the new manifest");
        assert_eq!(read("notes.txt").as_deref(), Some("the user's"), "other files are kept");
        assert!(!out.join("objects").exists(), "the earlier run's object index is gone");
        assert!(!out.join(STAGING).exists());
    }

    /// `apply`'s commit writes the same manifest back; killed between removing it and writing it
    /// back, the staging folder still holds it for the next apply.
    #[test]
    fn a_commit_keeping_the_manifest_leaves_it_pending_until_it_is_written_back() {
        let tmp = tempfile::tempdir().expect("temp dir");
        let (out, manifest) = (tmp.path(), tmp.path().join("cache/run.json"));
        std::fs::create_dir_all(out.join("cache")).expect("mkdir");
        std::fs::write(&manifest, "the run's manifest").expect("write");
        let staging = Staging::begin(out).expect("begin");
        std::fs::write(staging.dir().join("report.md"), "edited report").expect("write");
        assert_eq!(pending_manifest(out, &manifest), None, "the manifest is there");
        // As if killed after the manifest was removed: the pending copy is found.
        std::fs::write(staging.dir().join(PENDING_MANIFEST), "the run's manifest").expect("write");
        std::fs::remove_file(&manifest).expect("remove");
        assert_eq!(pending_manifest(out, &manifest).as_deref(), Some(&b"the run's manifest"[..]));
        staging.commit_same_manifest(&manifest, b"the run's manifest").expect("commit");
        assert_eq!(std::fs::read_to_string(&manifest).expect("manifest"), "the run's manifest");
        assert_eq!(std::fs::read_to_string(out.join("report.md")).expect("report"), "edited report");
        assert!(!out.join(STAGING).exists() && pending_manifest(out, &manifest).is_none());
    }

    #[test]
    fn a_leftover_staging_folder_is_removed() {
        let tmp = tempfile::tempdir().expect("temp dir");
        let staged = tmp.path().join(STAGING).join("masks/.tmpAbC");
        std::fs::create_dir_all(staged.parent().expect("parent")).expect("mkdir");
        std::fs::write(&staged, "x").expect("write");
        remove_leftover_staging(tmp.path()).expect("remove");
        assert!(!tmp.path().join(STAGING).exists());
        remove_leftover_staging(tmp.path()).expect("nothing to remove is fine");
    }
}
