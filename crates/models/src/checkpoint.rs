//! Finding checkpoint files: an explicit file, a folder holding `model.safetensors`, or a model in the
//! standard Hugging Face cache (offline; nothing is downloaded).

use std::path::{Path, PathBuf};

use crate::error::{ModelKind, ModelsError, ModelsResult};

/// A checkpoint's weights file and, for Hugging Face layouts, its `config.json`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CheckpointFiles {
    /// `.safetensors`, `.pth`, `.pt` or `.bin`.
    pub weights: PathBuf,
    /// `config.json` beside the weights, when there is one.
    pub config: Option<PathBuf>,
}

const WEIGHT_NAMES: [&str; 3] = ["model.safetensors", "pytorch_model.bin", "model.pth"];

/// Resolves `path`: a weights file, a folder with `model.safetensors` (a snapshot), a cache folder
/// `models--org--name`, or a model id `org/name` looked up in the Hugging Face cache.
pub fn resolve(path: &Path, kind: ModelKind) -> ModelsResult<CheckpointFiles> {
    resolve_named(path, kind, &WEIGHT_NAMES)
}

/// [`resolve`] with the weight file names a folder or snapshot may hold, in order of preference.
pub fn resolve_named(path: &Path, kind: ModelKind, names: &[&str]) -> ModelsResult<CheckpointFiles> {
    refuse_special_file(path, kind)?;
    if path.is_file() {
        let config = path.parent().map(|d| d.join("config.json")).filter(|c| c.is_file());
        return Ok(CheckpointFiles { weights: path.to_path_buf(), config });
    }
    if path.is_dir() {
        if let Some(found) = in_snapshot(path, names) {
            return Ok(found);
        }
        for name in names {
            refuse_special_file(&path.join(name), kind)?;
        }
        if let Some(found) = in_cache_repo(path, names) {
            return Ok(found);
        }
        return Err(ModelsError::NotFound {
            kind,
            reason: format!("the folder holds none of {names:?} and no `snapshots/*/` with one"),
            path: path.to_path_buf(),
        });
    }
    let text = path.to_string_lossy();
    if !path.exists() && text.matches('/').count() == 1 && !text.starts_with('.') {
        return from_hf_cache_named(&text, kind, names);
    }
    Err(ModelsError::NotFound { kind, reason: "no such file or folder".into(), path: path.to_path_buf() })
}

/// Refuses a path that exists but is neither a regular file nor a folder (a FIFO, a socket, a device
/// or a link to one such as `/dev/zero`), which reading would block on or never finish.
pub fn refuse_special_file(path: &Path, kind: ModelKind) -> ModelsResult<()> {
    match std::fs::metadata(path) {
        Ok(meta) if !meta.is_file() && !meta.is_dir() => Err(ModelsError::Unreadable {
            kind,
            reason: "not a regular file (a FIFO, a socket or a device, or a link to one)".into(),
            path: path.to_path_buf(),
        }),
        _ => Ok(()),
    }
}

/// Looks a model id (`facebook/dinov2-small`) up in the Hugging Face cache (`$HF_HUB_CACHE`,
/// `$HF_HOME/hub`, or `~/.cache/huggingface/hub`).
pub fn from_hf_cache(model_id: &str, kind: ModelKind) -> ModelsResult<CheckpointFiles> {
    from_hf_cache_named(model_id, kind, &WEIGHT_NAMES)
}

fn from_hf_cache_named(model_id: &str, kind: ModelKind, names: &[&str]) -> ModelsResult<CheckpointFiles> {
    let cache = hf_cache_dir();
    let repo = cache.join(format!("models--{}", model_id.replace('/', "--")));
    in_cache_repo(&repo, names).ok_or_else(|| ModelsError::NotFound {
        kind,
        reason: format!(
            "no such file or folder, and no model `{model_id}` in the Hugging Face cache (looked in {})",
            repo.display()
        ),
        path: PathBuf::from(model_id),
    })
}

/// The Hugging Face hub cache folder.
pub fn hf_cache_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("HF_HUB_CACHE") {
        return PathBuf::from(dir);
    }
    if let Some(home) = std::env::var_os("HF_HOME") {
        return PathBuf::from(home).join("hub");
    }
    let home = std::env::var_os("HOME").map(PathBuf::from).unwrap_or_default();
    home.join(".cache").join("huggingface").join("hub")
}

fn in_snapshot(dir: &Path, names: &[&str]) -> Option<CheckpointFiles> {
    let weights = names.iter().map(|n| dir.join(n)).find(|p| p.is_file())?;
    let config = Some(dir.join("config.json")).filter(|c| c.is_file());
    Some(CheckpointFiles { weights, config })
}

/// `models--org--name/`: the snapshot named by `refs/main`, else the only/newest snapshot.
fn in_cache_repo(repo: &Path, names: &[&str]) -> Option<CheckpointFiles> {
    let snapshots = repo.join("snapshots");
    if let Ok(hash) = std::fs::read_to_string(repo.join("refs").join("main")) {
        if let Some(found) = in_snapshot(&snapshots.join(hash.trim()), names) {
            return Some(found);
        }
    }
    let mut dirs: Vec<(std::time::SystemTime, PathBuf)> = std::fs::read_dir(&snapshots)
        .ok()?
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.is_dir())
        .map(|p| (p.metadata().and_then(|m| m.modified()).unwrap_or(std::time::UNIX_EPOCH), p))
        .collect();
    dirs.sort();
    dirs.iter().rev().find_map(|(_, d)| in_snapshot(d, names))
}

/// Reads `config.json` when there is one.
pub fn read_config(files: &CheckpointFiles) -> ModelsResult<Option<serde_json::Value>> {
    let Some(path) = &files.config else { return Ok(None) };
    let text = std::fs::read_to_string(path)
        .map_err(|e| ModelsError::Config { reason: e.to_string(), path: path.clone() })?;
    let value = serde_json::from_str(&text)
        .map_err(|e| ModelsError::Config { reason: e.to_string(), path: path.clone() })?;
    Ok(Some(value))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_snapshot_named_by_refs_main() {
        let dir = std::env::temp_dir().join(format!("splatseg-models-cache-{}", std::process::id()));
        let repo = dir.join("models--facebook--dinov2-small");
        let snap = repo.join("snapshots").join("abc123");
        std::fs::create_dir_all(&snap).unwrap();
        std::fs::create_dir_all(repo.join("refs")).unwrap();
        std::fs::write(repo.join("refs").join("main"), "abc123\n").unwrap();
        std::fs::write(snap.join("model.safetensors"), b"x").unwrap();
        std::fs::write(snap.join("config.json"), b"{}").unwrap();
        let found = resolve(&repo, ModelKind::Dinov2).unwrap();
        assert_eq!(found.weights, snap.join("model.safetensors"));
        assert_eq!(found.config, Some(snap.join("config.json")));
        let missing = resolve(&dir.join("nothing-here"), ModelKind::Dinov2).unwrap_err().to_string();
        assert!(missing.contains("no such file"), "{missing}");
        assert!(missing.contains("facebook/dinov2-small"), "message should say where to get it: {missing}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
