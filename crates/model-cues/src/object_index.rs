//! `OUT/objects/objects.json`, the index of a run's object embeddings (issue 30), and what ties it to
//! that run (issue 59): the run's key (`OUT/cache/run.json`), the digest of the `gaussians.ply` whose
//! ids it names, and the identity of the CLIP checkpoint that embedded the objects. An index is used
//! only when all three still hold ([`ObjectIndex::check_belongs`]): a rerun on the folder, the PLY of
//! another run beside it, or another checkpoint in place of the run's one is refused, naming what
//! differs, instead of ranking the ids of other objects.

use crate::cached_output::{fnv1a, FNV_OFFSET};
use crate::{Context, ModelCuesError};
use serde::{Deserialize, Serialize};
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// Version of the files' layout and of the crop rules, part of the cache key: 2 added the run key,
/// the PLY digest and the checkpoint's content to the index.
pub const FORMAT: u32 = 2;

/// `OUT/objects/objects.json`: which row of `clip.npy` is which object, and from what.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObjectIndex {
    /// Layout version ([`FORMAT`]).
    pub format: u32,
    /// The cache key (the run's key, the PLY digest, the checkpoint's identity, the crop settings).
    pub key: String,
    /// The key of the run whose label maps were cropped (`OUT/cache/run.json`).
    pub run_key: String,
    /// The digest of `OUT/gaussians.ply` when the objects were embedded (`None`: a run without
    /// Gaussians).
    pub ply_digest: Option<String>,
    /// The checkpoint as given to `run --clip` (made absolute): queries load its text tower.
    pub checkpoint: PathBuf,
    /// The weights file's identity ([`checkpoint_identity`]): its size and a digest of its content.
    pub checkpoint_id: String,
    /// Embedding width `E`.
    pub dim: usize,
    /// Side of the crops the image tower saw.
    pub image_size: usize,
    /// Every object of the final label maps, by id.
    pub objects: Vec<IndexedObject>,
}

/// One object of the index.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IndexedObject {
    /// Its id (as in the label maps and `gaussians.ply`).
    pub id: u32,
    /// Its row in `clip.npy`; `None` when it is smaller than [`crate::clip_objects::MIN_PIXELS`] in
    /// every view.
    pub row: Option<usize>,
    /// Its palette colour.
    pub colour: [u8; 3],
    /// The views its crops came from, best first.
    pub views: Vec<UsedView>,
}

/// A view an object's crop came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UsedView {
    /// The view's image stem.
    pub stem: String,
    /// The object's pixels in it.
    pub pixels: u64,
    /// `pixels · (1 − share of the box's perimeter on the image border)`.
    pub score: f64,
}

/// What an index must match to be used: the run, its PLY and the checkpoint, as they are now.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RunIdentity {
    /// `OUT/cache/run.json` and its key.
    pub run: (PathBuf, String),
    /// The PLY the ids are looked up in and its digest (`None` when there is no such file).
    pub ply: (PathBuf, Option<String>),
    /// The checkpoint's weights file and its [`checkpoint_identity`].
    pub checkpoint: (PathBuf, String),
}

/// Bytes read from each of the start, the middle and the end of a checkpoint for its identity.
const IDENTITY_SAMPLE: u64 = 1 << 20;

/// A checkpoint's identity: its size and a digest of its first, middle and last MiB (hashing gigabytes
/// per query would cost more than it saves; another checkpoint of the same shapes differs there). Its
/// path and modification time are not part of it: a copy or a `touch` is the same checkpoint.
pub fn checkpoint_identity(path: &Path) -> crate::Result<String> {
    let unreadable = || format!("cannot read the CLIP checkpoint {}", path.display());
    let mut file = std::fs::File::open(path).with_context(unreadable)?;
    let size = file.metadata().with_context(unreadable)?.len();
    let mut hash = FNV_OFFSET;
    for start in [0, size.saturating_sub(IDENTITY_SAMPLE) / 2, size.saturating_sub(IDENTITY_SAMPLE)] {
        let mut sample = Vec::new();
        file.seek(SeekFrom::Start(start)).with_context(unreadable)?;
        (&mut file).take(IDENTITY_SAMPLE).read_to_end(&mut sample).with_context(unreadable)?;
        hash = fnv1a(&sample, hash);
    }
    Ok(format!("{size} bytes, sampled digest {hash:016x}"))
}

/// The key of the finished run in `out` (`OUT/cache/run.json`), which changes whenever its outputs do.
pub fn run_key(out: &Path) -> crate::Result<String> {
    let path = out.join("cache").join("run.json");
    let text = std::fs::read_to_string(&path).with_context(|| {
        format!(
            "no finished run here (its manifest is missing; run `splatseg run` first): {}",
            path.display()
        )
    })?;
    let value: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| ModelCuesError::Invalid(format!("not a run's manifest ({e}): {}", path.display())))?;
    value["key"]
        .as_str()
        .map(str::to_string)
        .with_context(|| format!("the run's manifest has no key: {}", path.display()))
}

/// The digest of `ply`, or `None` when there is no such file (a run without Gaussians).
pub fn ply_digest(ply: &Path) -> crate::Result<Option<String>> {
    match ply.is_file() {
        true => Ok(Some(splatseg_pipeline::digest::file_digest(ply)?)),
        false => Ok(None),
    }
}

impl RunIdentity {
    /// The run in `out`, the PLY `ply` and the weights file `weights` as they are now.
    pub fn of(out: &Path, ply: &Path, weights: &Path) -> crate::Result<RunIdentity> {
        Ok(RunIdentity {
            run: (out.join("cache").join("run.json"), run_key(out)?),
            ply: (ply.to_path_buf(), ply_digest(ply)?),
            checkpoint: (weights.to_path_buf(), checkpoint_identity(weights)?),
        })
    }
}

impl ObjectIndex {
    /// Reads an index written by `run --clip`; one of another layout version is refused (rerun).
    pub fn read(path: &Path) -> crate::Result<ObjectIndex> {
        let text = std::fs::read_to_string(path).with_context(|| {
            format!(
                "no object embeddings (run `splatseg run --clip CKPT` on this output folder first): {}",
                path.display()
            )
        })?;
        let value: serde_json::Value = serde_json::from_str(&text).map_err(|e| {
            ModelCuesError::Invalid(format!(
                "not an object index written by `run --clip` ({e}): {}",
                path.display()
            ))
        })?;
        if let Some(format) = value["format"].as_u64().filter(|&f| f != u64::from(FORMAT)) {
            return Err(ModelCuesError::Invalid(format!(
                "the object index has layout {format}, this splatseg reads {FORMAT} (rerun `splatseg run --clip \
                 CKPT` on this folder to embed the objects again): {}",
                path.display()
            )));
        }
        serde_json::from_value(value).map_err(|e| {
            ModelCuesError::Invalid(format!(
                "not an object index written by `run --clip` ({e}): {}",
                path.display()
            ))
        })
    }

    /// Refuses the index (at `path`) unless it was made for `now`: the same run key, PLY digest and
    /// checkpoint identity. The error names each that differs, with both values, and what to do.
    pub fn check_belongs(&self, path: &Path, now: &RunIdentity) -> crate::Result<()> {
        let mut differ = Vec::new();
        if self.run_key != now.run.1 {
            differ.push(format!(
                "the run: the index was made for the run of key {}, {} is of key {} (a later `splatseg run` \
                 on this folder, or an index copied from another)",
                self.run_key,
                now.run.0.display(),
                now.run.1
            ));
        }
        if self.ply_digest != now.ply.1 {
            let show = |d: &Option<String>| d.clone().unwrap_or_else(|| "none (no such file)".into());
            differ.push(format!(
                "the PLY: the index was made for a gaussians.ply of digest {}, {} is of digest {} (the PLY of \
                 another run?)",
                show(&self.ply_digest),
                now.ply.0.display(),
                show(&now.ply.1)
            ));
        }
        if self.checkpoint_id != now.checkpoint.1 {
            differ.push(format!(
                "the CLIP checkpoint: the objects were embedded by {} when it was {}; it is now {} (another \
                 checkpoint in its place?)",
                now.checkpoint.0.display(),
                self.checkpoint_id,
                now.checkpoint.1
            ));
        }
        if differ.is_empty() {
            return Ok(());
        }
        Err(ModelCuesError::Invalid(format!(
            "the object embeddings do not belong to what is here: {}; rerun `splatseg run --clip CKPT` on this folder \
             to embed its objects again: {}",
            differ.join("; "),
            path.display()
        )))
    }
}
