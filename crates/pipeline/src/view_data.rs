//! A view's decoded data, decoded once per run (issue 26): its image ([`ViewImage`], decoded on
//! first use by whichever step needs it first) and, for `run`, a spill of what the later stages
//! read again ([`write_spill`]: the image's colours and the raw and merged region maps), so the
//! lift stage (snapping, boundary refinement) and the outputs (overlays, matched maps, scores)
//! read plain bytes instead of decoding the image and the cache's PNGs again.
//!
//! Spill layout, `OUT/cache/views/<stem>.bin` (little-endian): `b"SSVIEW1\0"`, `width: u64`,
//! `height: u64`, `raw_runs: u64`, `merged_runs: u64`, then `rgb: [height · width · 3] u8`
//! (row-major), then the raw map's runs and the merged map's runs, each `[runs] (value: u32,
//! length: u32)` in row-major order. Written to a temporary file and renamed; removed with the
//! other spills once the run's outputs are written.

use crate::error::{bail, Context};
use splatseg_lift::{RunLengths, ViewRegions};
use splatseg_scene::image_io::RgbImage;
use splatseg_scene::images::load_image_rgb;
use splatseg_scene::load::LoadOptions;
use splatseg_scene::{Plane, Scene, View};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

const MAGIC: &[u8; 8] = b"SSVIEW1\0";
const HEADER_BYTES: usize = 40;

/// The image of one view, decoded at most once, when first asked for.
pub struct ViewImage<'a> {
    scene: &'a Scene,
    view: &'a View,
    load: &'a LoadOptions,
    decoded: OnceLock<RgbImage>,
}

impl<'a> ViewImage<'a> {
    /// The image of `view`, not decoded yet.
    pub fn new(scene: &'a Scene, view: &'a View, load: &'a LoadOptions) -> Self {
        ViewImage { scene, view, load, decoded: OnceLock::new() }
    }

    /// `[H, W, 3]` 8-bit colours at the camera's size, decoded on the first call.
    pub fn rgb(&self) -> crate::Result<&RgbImage> {
        if let Some(image) = self.decoded.get() {
            return Ok(image);
        }
        let image = load_image_rgb(self.scene, self.view, self.load)?;
        Ok(self.decoded.get_or_init(|| image))
    }
}

/// What the later stages read of one view with masks.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewData {
    /// `[H, W, 3]` 8-bit row-major colours.
    pub rgb: Vec<u8>,
    /// `[H, W]` SAM masks resolved into regions ("raw"), 0 = none.
    pub raw: Plane<u32>,
    /// `[H, W]` merged regions, 0 = none.
    pub merged: Plane<u32>,
}

impl ViewData {
    /// The regions to snap onto (the map `snap_kind` names: `raw` or `merged`) and the merged
    /// ones.
    pub fn into_regions(self, snap_kind: &str) -> crate::Result<ViewRegions> {
        let snap = match snap_kind {
            "raw" => self.raw,
            "merged" => self.merged.clone(),
            other => bail!("no `{other}` map in a view's spill (expected `raw` or `merged`)"),
        };
        Ok(ViewRegions { snap, merged: self.merged })
    }
}

/// Where view `stem`'s spill goes under `out`.
pub fn spill_path(out: &Path, stem: &str) -> PathBuf {
    out.join("cache").join("views").join(format!("{stem}.bin"))
}

/// Writes the spill of one view: `rgb` `[H, W, 3]`, `raw` and `merged` `[H, W]`.
pub fn write_spill(path: &Path, rgb: &[u8], raw: &Plane<u32>, merged: &Plane<u32>) -> crate::Result<()> {
    let (w, h) = (raw.width, raw.height);
    if merged.size() != (w, h) || rgb.len() != w * h * 3 {
        bail!("a view's maps and image disagree in size ({w}×{h}): {}", path.display());
    }
    let (raw_runs, merged_runs) = (RunLengths::encode(raw), RunLengths::encode(merged));
    let mut bytes =
        Vec::with_capacity(HEADER_BYTES + rgb.len() + 8 * (raw_runs.runs.len() + merged_runs.runs.len()));
    bytes.extend_from_slice(MAGIC);
    for n in [w, h, raw_runs.runs.len(), merged_runs.runs.len()] {
        bytes.extend_from_slice(&(n as u64).to_le_bytes());
    }
    bytes.extend_from_slice(rgb);
    for &(value, length) in raw_runs.runs.iter().chain(&merged_runs.runs) {
        bytes.extend_from_slice(&value.to_le_bytes());
        bytes.extend_from_slice(&length.to_le_bytes());
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    splatseg_scene::atomic::write_bytes_atomic(path, &bytes)
        .with_context(|| format!("writing a view's image and maps to {}", path.display()))?;
    Ok(())
}

/// Reads back what [`write_spill`] wrote; a file whose size or runs disagree with its header is
/// an error naming it.
pub fn read_spill(path: &Path) -> crate::Result<ViewData> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let malformed = || {
        crate::PipelineError::Invalid(format!(
            "not a view's image and maps, or truncated (its size disagrees with its header): {}",
            path.display()
        ))
    };
    if bytes.len() < HEADER_BYTES || &bytes[..8] != MAGIC {
        return Err(malformed());
    }
    let at = |k: usize| u64::from_le_bytes(bytes[8 + 8 * k..16 + 8 * k].try_into().unwrap_or_default());
    let (w, h, raw_runs, merged_runs) = (at(0), at(1), at(2), at(3));
    let expected = w
        .checked_mul(h)
        .and_then(|px| px.checked_mul(3))
        .and_then(|rgb| raw_runs.checked_add(merged_runs)?.checked_mul(8)?.checked_add(rgb))
        .and_then(|n| n.checked_add(HEADER_BYTES as u64));
    if expected != Some(bytes.len() as u64) {
        return Err(malformed());
    }
    let (w, h) = (w as usize, h as usize);
    let rgb_end = HEADER_BYTES + w * h * 3;
    let runs: Vec<(u32, u32)> = bytes[rgb_end..]
        .chunks_exact(8)
        .map(|c| (u32::from_le_bytes([c[0], c[1], c[2], c[3]]), u32::from_le_bytes([c[4], c[5], c[6], c[7]])))
        .collect();
    let (raw, merged) = runs.split_at(raw_runs as usize);
    let map = |runs: &[(u32, u32)]| -> crate::Result<Plane<u32>> {
        if runs.iter().map(|r| r.1 as u64).sum::<u64>() != (w * h) as u64 {
            return Err(malformed());
        }
        Ok(RunLengths { width: w, height: h, runs: runs.to_vec() }.decode(|v| v))
    };
    Ok(ViewData { rgb: bytes[HEADER_BYTES..rgb_end].to_vec(), raw: map(raw)?, merged: map(merged)? })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_spill_reads_back_as_written_and_a_damaged_one_is_refused() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = spill_path(dir.path(), "view_7");
        let raw = Plane { width: 3, height: 2, data: vec![1, 1, 2, 0, 0, 2] };
        let merged = Plane { width: 3, height: 2, data: vec![5, 5, 5, 5, 0, 9] };
        let rgb: Vec<u8> = (0..18).collect();
        write_spill(&path, &rgb, &raw, &merged).expect("writes");
        let back = read_spill(&path).expect("reads");
        assert_eq!(back, ViewData { rgb: rgb.clone(), raw: raw.clone(), merged: merged.clone() });
        let regions = back.clone().into_regions("raw").expect("raw");
        assert_eq!((regions.snap, regions.merged), (raw.clone(), merged.clone()));
        assert_eq!(back.clone().into_regions("merged").expect("merged").snap, merged);
        assert!(back.into_regions("final").is_err());
        let bytes = std::fs::read(&path).expect("bytes");
        for cut in [1, 8, bytes.len() - 10] {
            std::fs::write(&path, &bytes[..bytes.len() - cut]).expect("truncates");
            let err = read_spill(&path).expect_err("truncated").to_string();
            assert!(err.contains("view_7.bin"), "{err}");
        }
        let mut huge = bytes.clone();
        huge[8..16].copy_from_slice(&u64::MAX.to_le_bytes());
        std::fs::write(&path, &huge).expect("writes");
        assert!(read_spill(&path).is_err(), "a header declaring an absurd size is refused");
        let mut lying = bytes;
        let last = lying.len() - 4;
        lying[last..].copy_from_slice(&7u32.to_le_bytes());
        std::fs::write(&path, &lying).expect("writes");
        assert!(read_spill(&path).is_err(), "runs that do not cover the map are refused");
        assert!(write_spill(&path, &rgb[..17], &raw, &merged).is_err());
    }
}
