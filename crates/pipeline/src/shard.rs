//! Sharding the per-view stages over separate processes (a Slurm job array, a Kubernetes indexed
//! Job, Ray tasks): shard `K/N` (`0 ≤ K < N`) takes the views `v` with `v mod N = K`, in the
//! scene's order. Each finished shard leaves a manifest `OUT/cache/shards/<stage>-K-of-N.json`;
//! `run` on the same folder then checks that every shard of `N` is there (naming the missing
//! ones) and does only the global steps.

use crate::cache::{read_json, write_json};
use crate::error::bail;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// One shard of `count`: the views `v` with `v % count == index`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// `K`, from 0.
    pub index: usize,
    /// `N`, at least 1.
    pub count: usize,
}

impl Shard {
    /// The whole job as one shard.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Whether view `v` (index in the scene's order) belongs to this shard.
    pub fn contains(&self, v: usize) -> bool {
        v % self.count == self.index
    }

    /// `OUT/cache/shards/<stage>-K-of-N.json`.
    pub fn manifest_path(&self, out: &Path, stage: &str) -> PathBuf {
        shards_dir(out).join(format!("{stage}-{}-of-{}.json", self.index, self.count))
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = String;

    /// `K/N` with `0 ≤ K < N` (e.g. `$SLURM_ARRAY_TASK_ID/8` with `--array=0-7`).
    fn from_str(text: &str) -> Result<Self, String> {
        let wrong = || format!("`{text}`: expected K/N with 0 ≤ K < N, e.g. 0/4 (shards count from 0)");
        let (k, n) = text.split_once('/').ok_or_else(wrong)?;
        let index: usize = k.trim().parse().map_err(|_| wrong())?;
        let count: usize = n.trim().parse().map_err(|_| wrong())?;
        if count == 0 || index >= count {
            return Err(wrong());
        }
        Ok(Shard { index, count })
    }
}

/// `OUT/cache/shards`.
pub fn shards_dir(out: &Path) -> PathBuf {
    out.join("cache").join("shards")
}

/// What a finished shard wrote (`OUT/cache/shards/<stage>-K-of-N.json`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ShardManifest {
    /// `merge`.
    pub stage: String,
    /// Which shard.
    pub shard: Shard,
    /// Stems of the views it processed (those of the shard that have masks).
    pub views: Vec<String>,
}

/// Records that `shard` of `stage` finished.
pub fn write_manifest(out: &Path, manifest: &ShardManifest) -> crate::Result<()> {
    write_json(&manifest.shard.manifest_path(out, &manifest.stage), manifest)
}

/// The shard count of the `stage` manifests in `out`, when any: `None` for an unsharded folder.
/// Every shard of that count must be there (the error names the missing ones), and manifests of
/// two different counts are refused.
pub fn expected_shards(out: &Path, stage: &str) -> crate::Result<Option<usize>> {
    let dir = shards_dir(out);
    let Ok(entries) = std::fs::read_dir(&dir) else { return Ok(None) };
    let mut counts = std::collections::BTreeSet::new();
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().to_string();
        let Some(rest) = name.strip_prefix(&format!("{stage}-")).and_then(|r| r.strip_suffix(".json")) else {
            continue;
        };
        if let Some((_, n)) = rest.split_once("-of-") {
            if let Ok(n) = n.parse::<usize>() {
                counts.insert(n);
            }
        }
    }
    let Some(&count) = counts.iter().next() else { return Ok(None) };
    if counts.len() > 1 {
        bail!(
            "`{stage}` shards of different counts ({}) in one output folder: remove the stale ones: {}",
            counts.iter().map(|n| format!("N = {n}")).collect::<Vec<_>>().join(", "),
            dir.display()
        );
    }
    let missing: Vec<String> = (0..count)
        .map(|index| Shard { index, count })
        .filter(|s| read_json::<ShardManifest>(&s.manifest_path(out, stage)).is_none())
        .map(|s| s.to_string())
        .collect();
    if !missing.is_empty() {
        bail!(
            "missing `{stage}` shard(s) {} of {count}: run `splatseg {stage} --shard K/{count}` for each \
             (no finished manifest {stage}-K-of-{count}.json): {}",
            missing.join(", "),
            dir.display()
        );
    }
    Ok(Some(count))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_parse_cover_every_view_once_and_refuse_nonsense() {
        let s: Shard = "2/4".parse().expect("valid");
        assert_eq!(s, Shard { index: 2, count: 4 });
        assert_eq!(s.to_string(), "2/4");
        for bad in ["4/4", "1/0", "a/2", "3", "-1/2", ""] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        for v in 0..13 {
            let owners = (0..4).filter(|&k| Shard { index: k, count: 4 }.contains(v)).count();
            assert_eq!(owners, 1, "view {v}");
        }
    }

    #[test]
    fn a_missing_shard_is_named_and_mixed_counts_are_refused() {
        let tmp = tempfile::tempdir().expect("temp dir");
        assert_eq!(expected_shards(tmp.path(), "merge").expect("no shards"), None);
        for index in [0, 2] {
            let shard = Shard { index, count: 3 };
            write_manifest(tmp.path(), &ShardManifest { stage: "merge".into(), shard, views: vec![] })
                .expect("manifest");
        }
        let err = expected_shards(tmp.path(), "merge").expect_err("shard 1 missing").report();
        assert!(err.contains("shard(s) 1/3 of 3"), "{err}");
        let shard = Shard { index: 1, count: 3 };
        write_manifest(tmp.path(), &ShardManifest { stage: "merge".into(), shard, views: vec![] })
            .expect("manifest");
        assert_eq!(expected_shards(tmp.path(), "merge").expect("complete"), Some(3));
        let shard = Shard { index: 0, count: 2 };
        write_manifest(tmp.path(), &ShardManifest { stage: "merge".into(), shard, views: vec![] })
            .expect("manifest");
        let err = expected_shards(tmp.path(), "merge").expect_err("mixed").report();
        assert!(err.contains("N = 2, N = 3"), "{err}");
    }
}
