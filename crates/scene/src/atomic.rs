//! Atomic output: write into a temporary file in the destination folder, then rename over the
//! target, so a crash or an error never leaves a half-written file behind.

use crate::error::{SceneError, SceneResult};
use std::io::Write;
use std::path::Path;

/// Writes the bytes produced by `write` to `path` atomically (temp file + rename).
/// Creates the parent folder if needed.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> SceneResult<()> {
    let dir = parent_created(path)?;
    let tmp = tempfile::NamedTempFile::new_in(&dir)
        .map_err(|e| SceneError::io("cannot create temporary file in", &dir, e))?;
    write_and_persist(tmp, path, write)
}

/// Prefix of the temporary files of [`write_atomic_sweeping`], followed by the writer's process id
/// and a dash: `.splatseg-partial-<pid>-XXXXXX`.
pub const PARTIAL_PREFIX: &str = ".splatseg-partial-";

/// [`write_atomic`] for a file written into a folder of the user's, where no lock tells a killed
/// writer's leftovers from another's work (`extract`, `remove`, `recolor` and the viewer's exports):
/// the temporary file is `.splatseg-partial-<pid>-XXXXXX`, and first every such file in the folder
/// whose process is gone (a writer killed mid-write, which left hundreds of MB) is removed. Files of
/// writers still running are kept, and so is everything else (no other program's `.tmp*` is
/// touched). On platforms without process ids to test (not Unix) nothing is removed.
pub fn write_atomic_sweeping(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> SceneResult<()> {
    let dir = parent_created(path)?;
    remove_partial_files_of_dead_writers(&dir);
    let prefix = format!("{PARTIAL_PREFIX}{}-", std::process::id());
    let tmp = tempfile::Builder::new()
        .prefix(&prefix)
        .tempfile_in(&dir)
        .map_err(|e| SceneError::io("cannot create temporary file in", &dir, e))?;
    write_and_persist(tmp, path, write)
}

/// Removes the [`PARTIAL_PREFIX`] files in `dir` whose writer (the process id in the name) is not
/// running. Failures are ignored: the files are only clutter.
fn remove_partial_files_of_dead_writers(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(pid) = name.strip_prefix(PARTIAL_PREFIX).and_then(|rest| rest.split('-').next()) else {
            continue;
        };
        let is_file = entry.file_type().is_ok_and(|t| t.is_file());
        if is_file && pid.parse::<u32>().is_ok_and(|pid| !process_is_running(pid)) {
            tracing::debug!("removing {}, left by an interrupted writer", entry.path().display());
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// Whether a process `pid` exists (signal 0: nothing is sent; EPERM means it exists but is not ours).
#[cfg(unix)]
fn process_is_running(pid: u32) -> bool {
    let Ok(pid) = libc::pid_t::try_from(pid) else { return true };
    if pid <= 0 {
        return true;
    }
    // SAFETY: `kill` with signal 0 only checks that the process exists and may be signalled.
    let result = unsafe { libc::kill(pid, 0) };
    result == 0 || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
}

#[cfg(not(unix))]
fn process_is_running(_pid: u32) -> bool {
    true
}

/// `path`'s folder (`.` for a bare name), created if needed.
fn parent_created(path: &Path) -> SceneResult<std::path::PathBuf> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    std::fs::create_dir_all(&dir).map_err(|e| SceneError::io("cannot create folder", &dir, e))?;
    Ok(dir)
}

/// Writes into `tmp`, then renames it to `path`.
fn write_and_persist(
    mut tmp: tempfile::NamedTempFile,
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> SceneResult<()> {
    {
        let mut buf = std::io::BufWriter::new(tmp.as_file_mut());
        write(&mut buf).map_err(|e| SceneError::io("cannot write", path, e))?;
        buf.flush().map_err(|e| SceneError::io("cannot write", path, e))?;
    }
    tmp.persist(path).map_err(|e| SceneError::io("cannot move into place", path, e.error))?;
    Ok(())
}

/// Writes `bytes` to `path` atomically.
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> SceneResult<()> {
    write_atomic(path, |w| w.write_all(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(unix)]
    #[test]
    fn a_swept_write_removes_what_killed_writers_left_and_nothing_else() {
        let tmp = tempfile::tempdir().expect("temp dir");
        // 2^22 + 1 is past Linux's largest process id: that writer is gone
        let dead = tmp.path().join(format!("{PARTIAL_PREFIX}4194305-Ab12Cd"));
        let running = tmp.path().join(format!("{PARTIAL_PREFIX}{}-Ef34Gh", std::process::id()));
        let others = [".tmpXy12Zw", "notes.txt", ".splatseg-partial-notapid"];
        for p in [&dead, &running] {
            std::fs::write(p, b"half a PLY").expect("write");
        }
        for name in others {
            std::fs::write(tmp.path().join(name), b"the user's").expect("write");
        }
        let out = tmp.path().join("picked.ply");
        write_atomic_sweeping(&out, |w| w.write_all(b"ply")).expect("write");
        assert_eq!(std::fs::read(&out).expect("read"), b"ply");
        assert!(!dead.exists(), "a killed writer's partial file is removed");
        assert!(running.exists(), "a running writer's partial file is kept");
        for name in others {
            assert!(tmp.path().join(name).exists(), "{name} is not ours to remove");
        }
        let left: Vec<String> = std::fs::read_dir(tmp.path())
            .expect("list")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with(PARTIAL_PREFIX) && !n.ends_with("Ef34Gh") && !n.ends_with("notapid"))
            .collect();
        assert!(left.is_empty(), "the write leaves no partial file of its own: {left:?}");
    }
}
