//! One writer per output folder. `OUT/.splatseg.lock` is held with an exclusive, non-blocking
//! `flock` for as long as a command writes into `OUT`: a second `run` / `cues` / `train` on the
//! same `--out` is refused with an error naming the holder's pid. The kernel drops the lock
//! when its process ends, however it ends (SIGKILL included), so a lock left by a killed run
//! never blocks the next one; the file itself stays (emptied on a clean exit).

use crate::error::{bail, Context};
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, Write};
use std::path::Path;

/// The lock file's name inside an output folder.
pub const LOCK_FILE: &str = ".splatseg.lock";

/// Holds the lock on an output folder until dropped.
#[derive(Debug)]
pub struct OutputLock {
    file: File,
    /// Held by one shard among others: the file is left as it is.
    shared: bool,
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        // Empty the file while still holding the lock; closing the file releases it.
        if !self.shared {
            let _ = self.file.set_len(0);
        }
    }
}

/// Takes the lock on `out` (created if needed) for `command`, or fails at once when another
/// process holds it.
pub fn lock_output(out: &Path, command: &str) -> crate::Result<OutputLock> {
    let (path, mut file) = open_lock_file(out)?;
    if !try_lock(&file, true).with_context(|| format!("cannot lock {}", path.display()))? {
        let holder = holder_of(&file);
        bail!(
            "the output folder is in use by {holder}: two runs must not write the same --out at once \
             (wait for it to finish or choose another --out): {}",
            out.display()
        );
    }
    file.set_len(0)
        .and_then(|_| file.rewind())
        .with_context(|| format!("cannot write {}", path.display()))?;
    write!(file, "splatseg {command} (pid {})", std::process::id())
        .and_then(|_| file.flush())
        .with_context(|| format!("cannot write {}", path.display()))?;
    remove_stale_temp_files(out);
    Ok(OutputLock { file, shared: false })
}

/// Takes a *shared* lock on `out` for one shard of a per-view stage (`merge --shard K/N`,
/// `cues --shard K/N`): any number of shards write their own per-view files into `out` at once
/// (each file written whole, then renamed), while a `run` (exclusive) is refused until they end,
/// and a shard is refused while a `run` writes. No temporary files are removed (other shards'
/// writes may be in flight).
pub fn lock_output_shared(out: &Path, command: &str) -> crate::Result<OutputLock> {
    let (path, file) = open_lock_file(out)?;
    if !try_lock(&file, false).with_context(|| format!("cannot lock {}", path.display()))? {
        let holder = holder_of(&file);
        bail!(
            "the output folder is in use by {holder}: `{command}` shards wait for it to finish: {}",
            out.display()
        );
    }
    Ok(OutputLock { file, shared: true })
}

/// Creates `out` and opens (creating) its lock file; returns the file's path with it.
fn open_lock_file(out: &Path) -> crate::Result<(std::path::PathBuf, std::fs::File)> {
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create the output folder {}", out.display()))?;
    let path = out.join(LOCK_FILE);
    let file = OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(&path)
        .with_context(|| format!("cannot open the lock file {}", path.display()))?;
    Ok((path, file))
}

/// Who holds the lock, as the holder wrote it into the file ("another process" if unreadable).
fn holder_of(file: &std::fs::File) -> String {
    let mut holder = String::new();
    let _ = (&*file).read_to_string(&mut holder);
    match holder.trim() {
        "" => "another process".to_string(),
        h => h.to_string(),
    }
}

/// Removes the temporary files (`.tmp*`, see `splatseg_scene::atomic`) a killed writer left in
/// `dir` and its sub-folders; safe because the caller holds the lock. Failures are ignored (the
/// files are only clutter: outputs are renamed into place whole).
fn remove_stale_temp_files(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let path = entry.path();
        let is_temp = entry.file_name().to_string_lossy().starts_with(".tmp");
        match entry.file_type() {
            Ok(t) if t.is_dir() => remove_stale_temp_files(&path),
            Ok(t) if t.is_file() && is_temp => {
                tracing::debug!("removing {}, left by an interrupted run", path.display());
                let _ = std::fs::remove_file(&path);
            }
            _ => {}
        }
    }
}

/// `flock(LOCK_EX | LOCK_NB)` (or `LOCK_SH` when not `exclusive`): `Ok(false)` when another open
/// file description holds a lock that conflicts.
#[cfg(unix)]
fn try_lock(file: &File, exclusive: bool) -> std::io::Result<bool> {
    use std::os::unix::io::AsRawFd;
    let mode = if exclusive { libc::LOCK_EX } else { libc::LOCK_SH };
    // SAFETY: `flock` only reads the descriptor, which `file` keeps open for the call.
    let result = unsafe { libc::flock(file.as_raw_fd(), mode | libc::LOCK_NB) };
    if result == 0 {
        return Ok(true);
    }
    let error = std::io::Error::last_os_error();
    if error.kind() == std::io::ErrorKind::WouldBlock {
        Ok(false)
    } else {
        Err(error)
    }
}

/// Elsewhere no lock is taken (the file still records the last writer).
#[cfg(not(unix))]
fn try_lock(_file: &File, _exclusive: bool) -> std::io::Result<bool> {
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_lock_on_the_same_folder_is_refused_until_the_first_is_dropped() {
        let tmp = tempfile::tempdir().expect("temp dir");
        let first = lock_output(tmp.path(), "run").expect("first lock");
        let err = lock_output(tmp.path(), "train").expect_err("second lock must fail").to_string();
        assert!(err.contains(&format!("splatseg run (pid {})", std::process::id())), "{err}");
        assert!(err.contains("same --out"), "{err}");
        drop(first);
        let again = lock_output(tmp.path(), "train").expect("lock after release");
        assert!(tmp.path().join(LOCK_FILE).is_file());
        lock_output_shared(tmp.path(), "merge").expect_err("a shard waits for the run");
        drop(again);
    }

    #[test]
    fn shards_share_the_folder_and_a_run_waits_for_them() {
        let tmp = tempfile::tempdir().expect("temp dir");
        let a = lock_output_shared(tmp.path(), "merge").expect("first shard");
        let b = lock_output_shared(tmp.path(), "merge").expect("second shard");
        lock_output(tmp.path(), "run").expect_err("run waits for the shards");
        drop((a, b));
        lock_output(tmp.path(), "run").expect("run after the shards");
    }
}
