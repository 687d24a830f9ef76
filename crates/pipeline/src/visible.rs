//! The visible Gaussians of one view, spilled to `OUT/cache/visible/<stem>.bin` by the per-view
//! pass and read back one view at a time by lifting (votes, then the touching-objects counts),
//! so no stage holds every view's list at once: memory does not grow with the number of views.
//!
//! Layout (little-endian): `b"SSVIS1\0\0"`, `n: u64`, then `gaussians: [n] u32` (strictly
//! increasing), `weights: [n] f32` (fusion weights), `labels: [n] u32` (merged, view-local label
//! at each centre pixel, 0 = none). Written to a temporary file and renamed; removed once the run
//! has lifted. Beside it, `<stem>.bins`: the view's tile lists from the same pass ([`write_bins`]),
//! which rendering the labels back reuses instead of sorting the splats again (≈ 8 MB per
//! 1280×960 view of 1M Gaussians).
//!
//! With the separate-wholes gate on, the pass that finds a view's visible Gaussians is made
//! before any view is merged ([`crate::sam_wholes`]): what the view's merge reads of it (surface
//! depth and normals, visible Gaussians with their pixels and weights) is spilled to
//! `<stem>.pass` ([`write_pass`]) and read back, then removed, by the merge ([`pass_or`]); its tile
//! lists go straight to `<stem>.bins`, where rendering the labels back reads them. Each is written
//! once and nothing is computed twice.
//!
//! Matching keeps, in memory, a deterministic sample of every view's list instead
//! ([`sample_stride`]): the Gaussians whose index is a multiple of a power-of-two stride chosen
//! from the number of Gaussians and views alone, so the sample is the same whatever order the
//! views finish in and whichever shard merged them.

use crate::error::{bail, Context};
use splatseg_lift::visibility::NORMAL_STEPS;
use splatseg_lift::{ViewVisibility, VisibilityPass, VisibleGaussians};
use splatseg_match::ViewObservations;
use splatseg_render::bin::TileBins;
use splatseg_scene::Plane;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 8] = b"SSVIS1\0\0";

/// Upper bound on the (Gaussian, view) observations matching keeps in memory: 2^24 (128 MiB).
pub const MAX_SAMPLED_OBSERVATIONS: u64 = 1 << 24;

/// The power-of-two stride of the Gaussians matching samples: the smallest with
/// `n_gaussians · n_views / stride ≤ MAX_SAMPLED_OBSERVATIONS` (1 = every Gaussian).
pub fn sample_stride(n_gaussians: usize, n_views: usize) -> u32 {
    let worst = n_gaussians as u64 * n_views as u64;
    let need = worst.div_ceil(MAX_SAMPLED_OBSERVATIONS).max(1);
    need.next_power_of_two().min(1 << 31) as u32
}

/// The observations of `vis` / `labels` (`[n_visible]` each) whose Gaussian index is a multiple
/// of `stride`.
pub fn sampled(vis: &ViewVisibility, labels: &[u32], stride: u32) -> ViewObservations {
    let keep = |g: u32| g.is_multiple_of(stride);
    let (gaussians, labels) =
        vis.gaussians.iter().zip(labels).filter(|(&g, _)| keep(g)).map(|(&g, &l)| (g, l)).unzip();
    ViewObservations { gaussians, labels }
}

/// Where view `stem`'s list goes under `out`.
pub fn spill_path(out: &Path, stem: &str) -> PathBuf {
    out.join("cache").join("visible").join(format!("{stem}.bin"))
}

/// Writes `vis` (gaussians and weights) and `labels` (`[n_visible]`) to `path`.
pub fn write(path: &Path, vis: &ViewVisibility, labels: &[u32]) -> crate::Result<()> {
    let n = vis.gaussians.len();
    let mut bytes = Vec::with_capacity(16 + 12 * n);
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&(n as u64).to_le_bytes());
    if vis.weights.len() != n || labels.len() != n {
        bail!("visible Gaussians of unequal lengths for {}", path.display());
    }
    put_words(&mut bytes, &vis.gaussians, u32::to_le_bytes);
    put_words(&mut bytes, &vis.weights, f32::to_le_bytes);
    put_words(&mut bytes, labels, u32::to_le_bytes);
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    splatseg_scene::atomic::write_bytes_atomic(path, &bytes)
        .with_context(|| format!("writing the visible Gaussians to {}", path.display()))?;
    Ok(())
}

/// Appends `values` (`[n]`) to `bytes` as `4 n` bytes, word by word into space reserved up
/// front (a byte-wise `flat_map` is several times slower).
fn put_words<T: Copy>(bytes: &mut Vec<u8>, values: &[T], le: impl Fn(T) -> [u8; 4]) {
    let start = bytes.len();
    bytes.resize(start + 4 * values.len(), 0);
    for (slot, &v) in bytes[start..].chunks_exact_mut(4).zip(values) {
        slot.copy_from_slice(&le(v));
    }
}

/// Where the tile lists of the view whose visible Gaussians spill to `spill` go (beside them,
/// removed with them).
pub fn bins_path(spill: &Path) -> PathBuf {
    spill.with_extension("bins")
}

const BINS_MAGIC: &[u8; 8] = b"SSBIN1\0\0";

/// Writes a view's tile lists to `path`. Layout (little-endian): `b"SSBIN1\0\0"`, `tiles_x`,
/// `tiles_y`, `n` (u64 each), `offsets: [tiles_x · tiles_y + 1] u64`, `ids: [n] u32`.
pub fn write_bins(path: &Path, bins: &TileBins) -> crate::Result<()> {
    let mut bytes = Vec::with_capacity(32 + 8 * bins.offsets.len() + 4 * bins.ids.len());
    bytes.extend_from_slice(BINS_MAGIC);
    for v in [bins.tiles_x, bins.tiles_y, bins.ids.len()] {
        bytes.extend_from_slice(&(v as u64).to_le_bytes());
    }
    let start = bytes.len();
    bytes.resize(start + 8 * bins.offsets.len(), 0);
    for (slot, &o) in bytes[start..].chunks_exact_mut(8).zip(&bins.offsets) {
        slot.copy_from_slice(&(o as u64).to_le_bytes());
    }
    put_words(&mut bytes, &bins.ids, u32::to_le_bytes);
    splatseg_scene::atomic::write_bytes_atomic(path, &bytes)
        .with_context(|| format!("writing the tile lists to {}", path.display()))?;
    Ok(())
}

/// Reads back what [`write_bins`] wrote; a file of another size than its header declares is an
/// error naming it (the lists' fit to a view is checked where they are used).
pub fn read_bins(path: &Path) -> crate::Result<TileBins> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    if bytes.len() < 32 || &bytes[..8] != BINS_MAGIC {
        bail!("not a view's tile lists (bad header): {}", path.display());
    }
    let u64_at = |k: usize| u64::from_le_bytes(bytes[k..k + 8].try_into().unwrap_or_default());
    let (tiles_x, tiles_y, n) = (u64_at(8), u64_at(16), u64_at(24));
    let expected = tiles_x
        .checked_mul(tiles_y)
        .and_then(|t| t.checked_add(1))
        .and_then(|o| o.checked_mul(8))
        .and_then(|o| n.checked_mul(4).and_then(|i| i.checked_add(o)))
        .and_then(|b| b.checked_add(32));
    if expected != Some(bytes.len() as u64) {
        bail!("tile lists truncated or malformed ({tiles_x}×{tiles_y} tiles, {n} entries declared, {} bytes): {}", bytes.len(), path.display());
    }
    let n_offsets = (tiles_x * tiles_y + 1) as usize;
    let ids_at = 32 + 8 * n_offsets;
    let offsets = bytes[32..ids_at]
        .chunks_exact(8)
        .map(|c| u64::from_le_bytes(c.try_into().unwrap_or_default()) as usize)
        .collect();
    let ids = bytes[ids_at..].chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    Ok(TileBins { tiles_x: tiles_x as usize, tiles_y: tiles_y as usize, offsets, ids })
}

/// Where the evidence pass of the separate-wholes gate spills view `stem`'s whole visibility
/// pass under `out` for the view's merge to read back ([`pass_or`]).
pub fn pass_path(out: &Path, stem: &str) -> PathBuf {
    out.join("cache").join("visible").join(format!("{stem}.pass"))
}

const PASS_MAGIC: &[u8; 8] = b"SSPAS3\0\0";

/// A pixel without a rendered normal, in a spilled pass (no component of a unit normal rounds
/// to it: they lie in `[-NORMAL_STEPS, NORMAL_STEPS]`).
const NO_NORMAL: i16 = i16::MIN;

/// A rendered normal's components on the `i16` grid they were rounded to.
fn normal_words(n: [f32; 3]) -> [i16; 3] {
    if n[0].is_finite() {
        n.map(|c| (c * NORMAL_STEPS).round() as i16)
    } else {
        [NO_NORMAL; 3]
    }
}

/// The inverse of [`normal_words`] (exact on the grid).
fn normal_of_words(w: [i16; 3]) -> [f32; 3] {
    if w[0] == NO_NORMAL {
        [f32::NAN; 3]
    } else {
        w.map(|c| c as f32 / NORMAL_STEPS)
    }
}

/// Writes what a view's merge reads of its visibility pass to `path`, streamed (no second copy in
/// memory); the tile lists are not written (the evidence pass writes them to their own file,
/// [`write_bins`]). Layout (little-endian): `b"SSPAS3\0\0"`, `width`, `height` (both 0 without a
/// surface depth), `n` (u64 each), `surface_depth: [height · width] f32`,
/// `surface_normals: [height · width · 3] i16` (components × 32767, `i16::MIN` = none),
/// `gaussians: [n] u32`, `pixels: [n] u32`, `weights: [n] f32`.
pub fn write_pass(path: &Path, pass: &VisibilityPass) -> crate::Result<()> {
    let VisibilityPass { surface_depth, surface_normals, visible: vis, tile_lists: _ } = pass;
    let n = vis.gaussians.len();
    if vis.pixels.len() != n
        || vis.weights.len() != n
        || surface_depth.as_ref().map(Plane::size) != surface_normals.as_ref().map(Plane::size)
    {
        bail!("a visibility pass of unequal lengths for {}", path.display());
    }
    let (width, height, depth, normals) = match (surface_depth, surface_normals) {
        (Some(d), Some(n)) => (d.width, d.height, &d.data[..], &n.data[..]),
        _ => (0, 0, &[][..], &[][..]),
    };
    let normals: Vec<i16> = normals.iter().flat_map(|&n| normal_words(n)).collect();
    splatseg_scene::atomic::write_atomic(path, |w| {
        w.write_all(PASS_MAGIC)?;
        stream_words(w, &[width, height, n].map(|v| v as u64), u64::to_le_bytes)?;
        stream_words(w, depth, f32::to_le_bytes)?;
        stream_words(w, &normals, i16::to_le_bytes)?;
        stream_words(w, &vis.gaussians, u32::to_le_bytes)?;
        stream_words(w, &vis.pixels, u32::to_le_bytes)?;
        stream_words(w, &vis.weights, f32::to_le_bytes)
    })
    .with_context(|| format!("writing the visibility pass to {}", path.display()))?;
    Ok(())
}

/// What a view's merge and spills take of its visibility pass ([`pass_or`]).
#[derive(Clone, Debug)]
pub struct ViewPass {
    /// `[H, W]` surface depth, when rendered ([`VisibilityPass::surface_depth`]).
    pub surface_depth: Option<Plane<f32>>,
    /// `[H, W]` its normals ([`VisibilityPass::surface_normals`]).
    pub surface_normals: Option<Plane<[f32; 3]>>,
    /// The visible Gaussians with their pixels and weights.
    pub visible: ViewVisibility,
    /// The tile lists, to be written beside the visible Gaussians; `None` when the evidence pass
    /// wrote them there already.
    pub tile_lists: Option<TileBins>,
}

/// Reads back what [`write_pass`] wrote (without tile lists); a file of another size than its
/// header declares is an error naming it, found before anything is allocated.
pub fn read_pass(path: &Path) -> crate::Result<ViewPass> {
    let file = std::fs::File::open(path).with_context(|| format!("reading {}", path.display()))?;
    let len = file.metadata().with_context(|| format!("reading {}", path.display()))?.len();
    let mut r = std::io::BufReader::new(file);
    let mut magic = [0u8; 8];
    if len < 32 || r.read_exact(&mut magic).is_err() || &magic != PASS_MAGIC {
        bail!("not a view's visibility pass (bad header): {}", path.display());
    }
    let reading = || format!("reading {}", path.display());
    let words: [u64; 3] =
        read_words(&mut r, 3, u64::from_le_bytes).with_context(reading)?.try_into().unwrap_or_default();
    let [width, height, n] = words;
    // 4 + 6 bytes per pixel (depth, normal), 12 per visible Gaussian, 32 of header.
    let expected = width
        .checked_mul(height)
        .and_then(|pixels| pixels.checked_mul(10))
        .and_then(|b| b.checked_add(n.checked_mul(12)?))
        .and_then(|b| b.checked_add(32));
    if expected != Some(len) {
        bail!(
            "visibility pass truncated or malformed ({n} Gaussians, {width}×{height} px declared, \
             {len} bytes): {}",
            path.display()
        );
    }
    let [width, height, n] = words.map(|v| v as usize);
    read_pass_arrays(&mut r, width, height, n).with_context(reading)
}

/// The arrays of a pass after its header, in the order [`write_pass`] writes them.
fn read_pass_arrays(r: &mut impl Read, width: usize, height: usize, n: usize) -> std::io::Result<ViewPass> {
    let data = read_words(r, width * height, f32::from_le_bytes)?;
    let words = read_words(r, width * height * 3, i16::from_le_bytes)?;
    let normals = words.chunks_exact(3).map(|w| normal_of_words([w[0], w[1], w[2]])).collect();
    let surface_normals = (!data.is_empty()).then_some(Plane { width, height, data: normals });
    let surface_depth = (!data.is_empty()).then_some(Plane { width, height, data });
    let visible = ViewVisibility {
        gaussians: read_words(r, n, u32::from_le_bytes)?,
        pixels: read_words(r, n, u32::from_le_bytes)?,
        weights: read_words(r, n, f32::from_le_bytes)?,
    };
    Ok(ViewPass { surface_depth, surface_normals, visible, tile_lists: None })
}

/// View `stem`'s visibility pass: when `spilled`, the one the evidence pass spilled under `out`
/// ([`pass_path`]), read back and removed (its tile lists are in their file already); otherwise
/// `make()`'s.
pub fn pass_or(
    out: &Path,
    stem: &str,
    spilled: bool,
    make: impl FnOnce() -> VisibilityPass,
) -> crate::Result<ViewPass> {
    if !spilled {
        let VisibilityPass { surface_depth, surface_normals, visible, tile_lists } = make();
        return Ok(ViewPass { surface_depth, surface_normals, visible, tile_lists: Some(tile_lists) });
    }
    let path = pass_path(out, stem);
    let pass = read_pass(&path)?;
    std::fs::remove_file(&path).with_context(|| format!("removing {}", path.display()))?;
    Ok(pass)
}

/// Writes `values` (`[n]`) as `N n` little-endian bytes, a block of words at a time.
fn stream_words<T: Copy, const N: usize>(
    w: &mut dyn Write,
    values: &[T],
    le: impl Fn(T) -> [u8; N],
) -> std::io::Result<()> {
    let mut block = [0u8; 8192];
    for part in values.chunks(8192 / N) {
        for (slot, &v) in block.chunks_exact_mut(N).zip(part) {
            slot.copy_from_slice(&le(v));
        }
        w.write_all(&block[..N * part.len()])?;
    }
    Ok(())
}

/// Reads `n` words of `N` little-endian bytes, a block at a time.
fn read_words<T, const N: usize>(
    r: &mut impl Read,
    n: usize,
    from_le: impl Fn([u8; N]) -> T,
) -> std::io::Result<Vec<T>> {
    let mut values = Vec::with_capacity(n);
    let mut block = [0u8; 8192];
    let mut left = n;
    while left > 0 {
        let k = left.min(8192 / N);
        r.read_exact(&mut block[..N * k])?;
        values.extend(block[..N * k].chunks_exact(N).map(|c| from_le(c.try_into().unwrap_or([0; N]))));
        left -= k;
    }
    Ok(values)
}

/// Reads back what [`write`] wrote.
pub fn read(path: &Path) -> crate::Result<VisibleGaussians> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    if bytes.len() < 16 || &bytes[..8] != MAGIC {
        bail!("not a list of visible Gaussians (bad header): {}", path.display());
    }
    let n = u64::from_le_bytes(bytes[8..16].try_into().unwrap_or_default()) as usize;
    if n.checked_mul(12).and_then(|b| b.checked_add(16)) != Some(bytes.len()) {
        bail!(
            "list of visible Gaussians truncated ({n} entries declared, {} bytes): {}",
            bytes.len(),
            path.display()
        );
    }
    let words = |k: usize| bytes[16 + 4 * n * k..16 + 4 * n * (k + 1)].chunks_exact(4);
    let word = |c: &[u8]| [c[0], c[1], c[2], c[3]];
    let gaussians = words(0).map(|c| u32::from_le_bytes(word(c))).collect();
    let weights = words(1).map(|c| f32::from_le_bytes(word(c))).collect();
    let labels = words(2).map(|c| u32::from_le_bytes(word(c))).collect();
    Ok(VisibleGaussians { gaussians, weights, labels })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_spilled_list_reads_back_and_a_truncated_one_is_an_error() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = spill_path(dir.path(), "view_7");
        let vis =
            ViewVisibility { gaussians: vec![2, 5, 9], pixels: vec![0, 1, 2], weights: vec![0.5, 1.25, 3.0] };
        write(&path, &vis, &[1, 0, 4]).expect("writes");
        let back = read(&path).expect("reads");
        assert_eq!(
            (back.gaussians, back.weights, back.labels),
            (vec![2, 5, 9], vec![0.5, 1.25, 3.0], vec![1, 0, 4])
        );
        let bytes = std::fs::read(&path).expect("bytes");
        // The layout, byte for byte: magic, count, then the three arrays' little-endian words.
        let mut layout = MAGIC.to_vec();
        layout.extend(3u64.to_le_bytes());
        layout.extend([2u32, 5, 9].iter().flat_map(|g| g.to_le_bytes()));
        layout.extend([0.5f32, 1.25, 3.0].iter().flat_map(|w| w.to_le_bytes()));
        layout.extend([1u32, 0, 4].iter().flat_map(|l| l.to_le_bytes()));
        assert_eq!(bytes, layout);
        let err = write(&path, &vis, &[1, 0]).expect_err("labels of another length").to_string();
        assert!(err.contains("unequal lengths") && err.contains("view_7.bin"), "{err}");
        std::fs::write(&path, &bytes[..bytes.len() - 4]).expect("truncates");
        let err = read(&path).expect_err("truncated").to_string();
        assert!(err.contains("truncated") && err.contains("view_7.bin"), "{err}");
    }

    #[test]
    fn tile_lists_read_back_and_a_truncated_file_is_an_error() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = bins_path(&spill_path(dir.path(), "view_3"));
        assert!(path.to_string_lossy().ends_with("view_3.bins"));
        std::fs::create_dir_all(path.parent().expect("a folder")).expect("folder");
        let bins = TileBins { tiles_x: 2, tiles_y: 1, offsets: vec![0, 3, 4], ids: vec![7, 1, 9, 2] };
        write_bins(&path, &bins).expect("writes");
        let back = read_bins(&path).expect("reads");
        assert_eq!((back.tiles_x, back.tiles_y, &back.offsets, &back.ids), (2, 1, &bins.offsets, &bins.ids));
        let bytes = std::fs::read(&path).expect("bytes");
        for cut in [4, 1, bytes.len() - 33] {
            std::fs::write(&path, &bytes[..bytes.len() - cut]).expect("truncates");
            let err = read_bins(&path).expect_err("truncated").to_string();
            assert!(err.contains("view_3.bins"), "{err}");
        }
        // A header declaring an absurd size is refused before anything is allocated.
        let mut huge = bytes.clone();
        huge[8..16].copy_from_slice(&u64::MAX.to_le_bytes());
        std::fs::write(&path, &huge).expect("writes");
        assert!(read_bins(&path).expect_err("huge").to_string().contains("malformed"));
    }

    #[test]
    fn a_spilled_pass_reads_back_once_and_a_truncated_one_is_an_error() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = pass_path(dir.path(), "view_2");
        let depth = Plane { width: 3, height: 2, data: vec![1.5, f32::INFINITY, 0.0, 2.0, 3.0, 4.0] };
        let normals = vec![
            [0.0, 0.0, -1.0],
            [f32::NAN; 3],
            [0.6, -0.8, 0.0],
            [1.0, 0.0, 0.0],
            [0.0; 3],
            [-0.5, 0.5, -0.5],
        ];
        let normals =
            normals.into_iter().map(|n: [f32; 3]| n.map(|c| (c * NORMAL_STEPS).round() / NORMAL_STEPS));
        let pass = VisibilityPass {
            surface_depth: Some(depth),
            surface_normals: Some(Plane { width: 3, height: 2, data: normals.collect() }),
            visible: ViewVisibility { gaussians: vec![1, 4], pixels: vec![0, 5], weights: vec![0.5, 2.0] },
            tile_lists: TileBins { tiles_x: 2, tiles_y: 1, offsets: vec![0, 1, 3], ids: vec![4, 1, 4] },
        };
        write_pass(&path, &pass).expect("writes");
        let bytes = std::fs::read(&path).expect("bytes");
        let never = || -> VisibilityPass { unreachable!("the spilled pass is read back") };
        let back = pass_or(dir.path(), "view_2", true, never).expect("reads");
        assert_eq!(back.surface_depth, pass.surface_depth);
        let bits = |p: &Option<Plane<[f32; 3]>>| -> Vec<[u32; 3]> {
            p.as_ref().map(|p| p.data.iter().map(|n| n.map(f32::to_bits)).collect()).unwrap_or_default()
        };
        assert_eq!(bits(&back.surface_normals), bits(&pass.surface_normals), "normals read back bit for bit");
        assert_eq!(back.visible, pass.visible);
        assert!(back.tile_lists.is_none(), "the tile lists are not in the pass (they have their own file)");
        assert_eq!(bytes.len(), 32 + 6 * 10 + 2 * 12, "header, depth and normals, visible Gaussians");
        assert!(!path.exists(), "read once, then removed");
        let made = pass_or(dir.path(), "view_2", false, || pass.clone()).expect("made");
        assert_eq!(made.visible, pass.visible);
        let bins = |b: &TileBins| (b.tiles_x, b.tiles_y, b.offsets.clone(), b.ids.clone());
        assert_eq!(
            made.tile_lists.as_ref().map(bins),
            Some(bins(&pass.tile_lists)),
            "a pass made here keeps them"
        );
        // Without a surface depth (a given depth map) the pass reads back without one.
        let without = VisibilityPass { surface_depth: None, surface_normals: None, ..pass.clone() };
        write_pass(&path, &without).expect("writes");
        let back = read_pass(&path).expect("reads");
        assert_eq!((back.surface_depth, back.surface_normals), (None, None));
        for cut in [4, bytes.len() - 60] {
            std::fs::write(&path, &bytes[..bytes.len() - cut]).expect("truncates");
            let err = read_pass(&path).expect_err("truncated").report();
            assert!(err.contains("view_2.pass"), "{err}");
        }
    }

    #[test]
    fn the_sample_stride_bounds_the_observations_and_is_one_when_they_fit() {
        assert_eq!(sample_stride(100_000, 100), 1);
        for (n, views) in [(1_000_000, 100), (3_000_000, 1_000), (1, 1)] {
            let s = sample_stride(n, views) as u64;
            assert!(s.is_power_of_two());
            assert!((n as u64 * views as u64).div_ceil(s) <= MAX_SAMPLED_OBSERVATIONS, "{n} × {views}: {s}");
            assert!(s == 1 || (n as u64 * views as u64).div_ceil(s / 2) > MAX_SAMPLED_OBSERVATIONS);
        }
        let vis =
            ViewVisibility { gaussians: vec![0, 3, 4, 8, 9], pixels: vec![0; 5], weights: vec![1.0; 5] };
        let obs = sampled(&vis, &[1, 2, 3, 4, 5], 4);
        assert_eq!((obs.gaussians, obs.labels), (vec![0, 4, 8], vec![1, 3, 4]));
    }
}
