//! Per-view outputs of `splatseg cues` that survive a kill: each output (`OUT/<cue>/<stem>.<ext>`) is
//! written atomically (a temporary file renamed over it) and recorded by a key file
//! (`OUT/cache/<cue>/<stem>.key`) written after it; a rerun skips a view's output only when its key
//! file holds exactly the key the rerun computes.
//!
//! The key is text: the cue's identity (model, checkpoint path, size and modification time, and
//! the settings that change the output), the image's size after `--resolution` and an FNV-1a hash of
//! its decoded RGB bytes. So a changed image, checkpoint or setting is computed again.
//!
//! The key file is removed before an output is written again, so a kill between the output's rename
//! and its new key leaves no key (the next run computes it), never an old key beside a new output.

use crate::error::Context;
use std::path::Path;

/// FNV-1a, 64 bit: a stable content hash for cache keys.
pub fn fnv1a(bytes: &[u8], mut hash: u64) -> u64 {
    for &b in bytes {
        hash ^= b as u64;
        hash = hash.wrapping_mul(0x100_0000_01b3);
    }
    hash
}

/// FNV-1a's offset basis.
pub const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// The image a view's cues are computed from, as the cache keys see it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageIdentity {
    /// (height, width) after `--resolution`.
    pub size: (usize, usize),
    /// FNV-1a of the decoded `[height, width, 3]` RGB bytes.
    pub content: u64,
}

impl ImageIdentity {
    /// The identity of `rgb` (`[height, width, 3]`).
    pub fn of(rgb: &[u8], size: (usize, usize)) -> Self {
        ImageIdentity { size, content: fnv1a(rgb, FNV_OFFSET) }
    }
}

/// The key of one cue's output for one image: `cue_identity` (model and settings) and the image.
pub fn cue_key(cue_identity: &str, image: ImageIdentity) -> String {
    let (h, w) = image.size;
    format!("{cue_identity}\nimage {w}x{h} rgb fnv1a {:016x}\n", image.content)
}

/// Whether `out` exists and `key_path` holds exactly `key`: the output was made from these inputs
/// and settings and written whole (the key is written only after the output's rename).
pub fn is_complete(out: &Path, key_path: &Path, key: &str) -> bool {
    out.is_file() && std::fs::read_to_string(key_path).is_ok_and(|k| k == key)
}

/// Writes one output by `write` (which must write `out` atomically) and then its key: the old key
/// is removed first, so an interrupted write never leaves a key that matches another output.
pub fn write_then_record(
    out: &Path,
    key_path: &Path,
    key: &str,
    write: impl FnOnce(&Path) -> crate::Result<()>,
) -> crate::Result<()> {
    match std::fs::remove_file(key_path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            return Err(e).with_context(|| format!("cannot remove the old key {}", key_path.display()));
        }
        _ => {}
    }
    write(out)?;
    splatseg_scene::atomic::write_bytes_atomic(key_path, key.as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ModelCuesError;

    #[test]
    fn the_key_changes_with_the_settings_the_image_and_its_size() {
        let rgb = [10u8, 20, 30, 40, 50, 60];
        let image = ImageIdentity::of(&rgb, (1, 2));
        let key = cue_key("sam ckpt {\"points_per_side\":32}", image);
        assert_eq!(key, cue_key("sam ckpt {\"points_per_side\":32}", ImageIdentity::of(&rgb, (1, 2))));
        assert_ne!(key, cue_key("sam ckpt {\"points_per_side\":16}", image));
        let mut other = rgb;
        other[5] = 61;
        assert_ne!(key, cue_key("sam ckpt {\"points_per_side\":32}", ImageIdentity::of(&other, (1, 2))));
        // the same bytes as another shape
        assert_ne!(key, cue_key("sam ckpt {\"points_per_side\":32}", ImageIdentity::of(&rgb, (2, 1))));
    }

    #[test]
    fn an_interrupted_write_leaves_no_key_that_matches() {
        let dir = tempfile::tempdir().expect("temp dir");
        let (out, key_path) = (dir.path().join("view.json"), dir.path().join("view.key"));
        let write = |text: &'static str| {
            move |path: &Path| -> crate::Result<()> {
                splatseg_scene::atomic::write_bytes_atomic(path, text.as_bytes())?;
                Ok(())
            }
        };
        write_then_record(&out, &key_path, "A", write("made with A")).expect("first write");
        assert!(is_complete(&out, &key_path, "A"));
        assert!(!is_complete(&out, &key_path, "B"), "another key is not complete");
        // B's output lands, then the process dies before B's key is written
        let dies_after_the_output = |path: &Path| -> crate::Result<()> {
            write("made with B")(path)?;
            Err(ModelCuesError::Invalid("killed".into()))
        };
        write_then_record(&out, &key_path, "B", dies_after_the_output).expect_err("the write fails");
        assert_eq!(std::fs::read_to_string(&out).expect("output"), "made with B");
        assert!(!is_complete(&out, &key_path, "A"), "A's key must not vouch for B's output");
        assert!(!is_complete(&out, &key_path, "B"), "B's key was never written");
        write_then_record(&out, &key_path, "A", write("made with A")).expect("rewrite");
        assert!(is_complete(&out, &key_path, "A"));
    }
}
