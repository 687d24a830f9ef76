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
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    std::fs::create_dir_all(&dir).map_err(|e| SceneError::io("cannot create folder", &dir, e))?;
    let mut tmp = tempfile::NamedTempFile::new_in(&dir)
        .map_err(|e| SceneError::io("cannot create temporary file in", &dir, e))?;
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
