//! One entry point per reader of user data, taking the raw bytes of a file: what the fuzz
//! targets (`fuzz/fuzz_targets/*.rs`, run with `cargo +nightly fuzz`) and the corpus replay test
//! (`tests/fuzz_corpus_replay.rs`, stable) both call, so a corpus file replays exactly what the
//! fuzzer ran. Each parses and drops the result: an `Err` is the right answer to bad bytes; a
//! panic, an abort or an allocation beyond the caps of [`crate::limits`] is a bug.
//!
//! The readers these call are the ones the path-based readers use after reading the file, so
//! no parser is duplicated for fuzzing.

use crate::plane::Plane;
use std::path::Path;

/// A fuzz target: the name of its corpus folder (`fuzz/corpus/<name>/`) and its entry point.
pub type Target = (&'static str, fn(&[u8]));

/// Every target.
pub const TARGETS: [Target; 14] = [
    ("ply", ply),
    ("spz", spz),
    ("splat", splat),
    ("compressed_ply", compressed_ply),
    ("ksplat", ksplat),
    ("colmap_bin", colmap_bin),
    ("colmap_txt", colmap_txt),
    ("transforms_json", transforms_json),
    ("sam_json", sam_json),
    ("sam_metadata_csv", sam_metadata_csv),
    ("npy", npy),
    ("npz", npz),
    ("label_png", label_png),
    ("rle_string", rle_string),
];

/// Masks at most this large are decoded as well as parsed (bigger ones are valid but slow
/// down the fuzzer without reaching new code).
const DECODE_PIXELS: u64 = 1 << 20;

/// A 3DGS PLY (binary little- or big-endian, or ASCII, as its header says): read keeping
/// non-finite rows, then the usable rows taken out and validated as `run` does.
pub fn ply(data: &[u8]) {
    if let Ok(rows) = crate::ply::parse_ply_bytes_rows(data) {
        let finite = rows.into_usable();
        if let Err(reason) = finite.validate() {
            panic!("the finite rows of a PLY that read must validate: {reason}");
        }
    }
}

/// An SPZ file (gzip stream): read keeping non-finite rows, the usable rows validated (so every
/// decoded value is finite, as the reader assumes), and written again as SPZ when they can be
/// (positions within SPZ's ±2048), which must read back as many. The file is also read in chunks of
/// [`SPZ_FUZZ_CHUNK_BYTES`], so that a small file runs the reader's two threads and its chunk
/// boundaries, and must give the same result: the same error or the same Gaussians bit for bit.
pub fn spz(data: &[u8]) {
    compact(crate::splats::SplatFormat::Spz, data);
    crate::splats::check_spz_chunked_read(data, SPZ_FUZZ_CHUNK_BYTES);
}

/// What the `spz` fuzz target runs once before the first input: makes the main thread's handle,
/// which waiting for [`spz`]'s decoding thread needs and which std makes on first use with a
/// thread-exit hook (32 bytes that glibc frees only when the thread ends). Made during an input
/// instead, LeakSanitizer reports them as a leak of the first input after which the main thread
/// had to wait (found after 63,652 executions, timing-dependent).
pub fn spz_init() {
    drop(std::thread::current());
}

/// Body bytes inflated at a time when [`spz`] reads a file in small chunks (a row of SH degree 3
/// is 45 bytes: a chunk holds whole elements, at least one).
const SPZ_FUZZ_CHUNK_BYTES: usize = 64;

/// A `.splat` file (32-byte rows), checked as [`spz`].
pub fn splat(data: &[u8]) {
    compact(crate::splats::SplatFormat::Splat, data);
}

/// A PlayCanvas compressed PLY, checked as [`spz`].
pub fn compressed_ply(data: &[u8]) {
    compact(crate::splats::SplatFormat::CompressedPly, data);
}

/// A `.ksplat` file, checked as [`spz`].
pub fn ksplat(data: &[u8]) {
    compact(crate::splats::SplatFormat::Ksplat, data);
}

fn compact(format: crate::splats::SplatFormat, data: &[u8]) {
    use crate::splats::{parse_gaussian_bytes_rows, to_gaussian_bytes};
    let Ok(rows) = parse_gaussian_bytes_rows(format, data) else { return };
    let usable = rows.into_usable();
    if let Err(reason) = usable.validate() {
        panic!("the usable rows of a {} that read must validate: {reason}", format.name());
    }
    if let Ok(bytes) = to_gaussian_bytes(format, &usable) {
        let again = parse_gaussian_bytes_rows(format, &bytes)
            .unwrap_or_else(|reason| panic!("what the {} writer wrote must read: {reason}", format.name()));
        assert_eq!(again.gaussians.len(), usable.len(), "a written {} keeps every Gaussian", format.name());
    }
}

/// A COLMAP binary model file; the first byte chooses which (0 `cameras.bin`, 1 `images.bin`,
/// 2 `points3D.bin`, modulo 3), the rest is the file.
pub fn colmap_bin(data: &[u8]) {
    let Some((&which, bytes)) = data.split_first() else { return };
    let path = Path::new("fuzz.bin");
    match which % 3 {
        0 => drop(crate::colmap::parse_cameras_bin(bytes, path)),
        1 => drop(crate::colmap::parse_images_bin(bytes, path)),
        _ => drop(crate::colmap::parse_points_bin(bytes, path)),
    }
}

/// A COLMAP text model file; the first byte chooses which as for [`colmap_bin`]. Bytes that
/// are not UTF-8 are refused before parsing, as reading the file does.
pub fn colmap_txt(data: &[u8]) {
    let Some((&which, bytes)) = data.split_first() else { return };
    let Ok(text) = std::str::from_utf8(bytes) else { return };
    let path = Path::new("fuzz.txt");
    match which % 3 {
        0 => drop(crate::colmap::parse_cameras_txt(text, path)),
        1 => drop(crate::colmap::parse_images_txt(text, path)),
        _ => drop(crate::colmap::parse_points_txt(text, path)),
    }
}

/// A NeRF/Blender or instant-ngp `transforms.json`.
pub fn transforms_json(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    drop(crate::transforms::parse_transforms_json(text, Path::new("transforms.json")));
}

/// SAM's mask JSON (COCO RLE strings, uncompressed counts or binary masks); small masks are
/// decoded too.
pub fn sam_json(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(file) = crate::sam::parse_sam_json(text, Path::new("masks.json"), None) {
        for mask in file.masks {
            let rle = &mask.segmentation;
            if rle.height as u64 * rle.width as u64 <= DECODE_PIXELS {
                if let Err(reason) = rle.decode() {
                    panic!("a mask that parsed must decode: {reason}");
                }
            }
        }
    }
}

/// SAM's `metadata.csv`; every row's mask is a fixed 4 × 3 mask.
pub fn sam_metadata_csv(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let mask = |_: &str| Ok(Plane::filled(4, 3, true));
    drop(crate::sam::parse_metadata_csv(text, Path::new("metadata.csv"), mask));
}

/// A NumPy `.npy` file.
pub fn npy(data: &[u8]) {
    drop(crate::npy::parse_npy(data));
}

/// A NumPy `.npz` archive.
pub fn npz(data: &[u8]) {
    drop(crate::npy::parse_npz(data));
}

/// A label-map PNG.
pub fn label_png(data: &[u8]) {
    drop(crate::labels::parse_label_png(data));
}

/// A COCO RLE `counts` string: the first 4 bytes are the declared height and width (2 bytes
/// each, little-endian), the rest is the string.
pub fn rle_string(data: &[u8]) {
    if data.len() < 4 {
        return;
    }
    let height = u16::from_le_bytes([data[0], data[1]]) as u32;
    let width = u16::from_le_bytes([data[2], data[3]]) as u32;
    let Ok(text) = std::str::from_utf8(&data[4..]) else { return };
    if let Ok(rle) = crate::rle::Rle::from_coco_string(height, width, text) {
        if height as u64 * width as u64 <= DECODE_PIXELS {
            let mask =
                rle.decode().unwrap_or_else(|reason| panic!("an RLE that parsed must decode: {reason}"));
            let again = crate::rle::Rle::encode(&mask).decode();
            assert_eq!(again.as_ref(), Ok(&mask), "encode then decode must give the mask back");
        }
    }
}
