//! Stage caching: every stage's output in `OUT/cache/` carries the key of the inputs and
//! settings it was computed from (a 64-bit FNV-style hash over file contents and the stage's
//! config as JSON); a rerun reuses an output whose key matches and recomputes it otherwise.

use crate::error::Context;
use std::path::Path;

/// An incremental 64-bit hash in the manner of FNV-1a, taking 8 bytes per step (xor, multiply
/// by the FNV prime, rotate; a 100-view capture's inputs are gigabytes, which FNV-1a's byte
/// per step took seconds over): stable across Rust versions and platforms (unlike std's
/// `DefaultHasher`), which a cache on disk needs.
#[derive(Clone, Copy, Debug)]
pub struct KeyHasher(u64);

impl Default for KeyHasher {
    fn default() -> Self {
        KeyHasher(0xcbf2_9ce4_8422_2325)
    }
}

impl KeyHasher {
    /// Adds raw bytes, prefixed by their length (so concatenations stay distinct).
    pub fn bytes(&mut self, bytes: &[u8]) -> &mut Self {
        self.word(bytes.len() as u64);
        let mut words = bytes.chunks_exact(8);
        for w in &mut words {
            self.word(u64::from_le_bytes([w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7]]));
        }
        for &b in words.remainder() {
            self.word(b as u64);
        }
        self
    }

    /// One step: xor, multiply, rotate (so high bits feed the low ones too).
    #[inline]
    fn word(&mut self, w: u64) {
        self.0 = (self.0 ^ w).wrapping_mul(0x0100_0000_01b3).rotate_left(27);
    }

    /// Adds a string.
    pub fn text(&mut self, text: &str) -> &mut Self {
        self.bytes(text.as_bytes())
    }

    /// Adds a value's JSON form (configs).
    pub fn json(&mut self, value: &impl serde::Serialize) -> &mut Self {
        let text = serde_json::to_string(value).unwrap_or_default();
        self.text(&text)
    }

    /// Adds a file's contents, or a marker when it does not exist.
    pub fn file(&mut self, path: &Path) -> crate::Result<&mut Self> {
        if path.is_file() {
            let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
            Ok(self.bytes(&bytes))
        } else {
            Ok(self.text("<absent>"))
        }
    }

    /// Adds every file of a folder (sorted by name, recursively), or a marker when absent.
    pub fn folder_entry(&mut self, dir: &Path, stem: &str) -> crate::Result<&mut Self> {
        for ext in ["json", "npy", "npz"] {
            self.file(&dir.join(format!("{stem}.{ext}")))?;
        }
        let sub = dir.join(stem);
        if sub.is_dir() {
            let mut names: Vec<_> = std::fs::read_dir(&sub)
                .with_context(|| format!("cannot list {}", sub.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .collect();
            names.sort();
            for p in names {
                self.text(&p.to_string_lossy());
                self.file(&p)?;
            }
        }
        Ok(self)
    }

    /// The key as 16 hex digits.
    pub fn finish(&self) -> String {
        format!("{:016x}", self.0)
    }
}

/// Reads `path` as JSON of type `T` if it exists and parses, else `None` (a damaged cache entry
/// is recomputed, not an error).
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Option<T> {
    let text = std::fs::read_to_string(path).ok()?;
    serde_json::from_str(&text).ok()
}

/// Writes `value` as pretty JSON, atomically.
pub fn write_json(path: &Path, value: &impl serde::Serialize) -> crate::Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    splatseg_scene::atomic::write_bytes_atomic(path, text.as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_depends_on_content_and_boundaries() {
        let key = |parts: &[&str]| {
            let mut h = KeyHasher::default();
            parts.iter().for_each(|p| {
                h.text(p);
            });
            h.finish()
        };
        assert_eq!(key(&["ab", "c"]), key(&["ab", "c"]));
        assert_ne!(key(&["ab", "c"]), key(&["a", "bc"]));
        assert_eq!(KeyHasher::default().finish(), "cbf29ce484222325");
        // Every byte counts, whole words and the tail alike.
        let bytes: Vec<u8> = (0..=40u8).collect();
        let base = KeyHasher::default().bytes(&bytes).finish();
        for i in 0..bytes.len() {
            for bit in [0, 7] {
                let mut changed = bytes.clone();
                changed[i] ^= 1 << bit;
                assert_ne!(KeyHasher::default().bytes(&changed).finish(), base, "byte {i}, bit {bit}");
            }
        }
    }
}
