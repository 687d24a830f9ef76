//! NumPy `.npy` and `.npz` arrays: the pre-computed cue maps people already have from Python
//! (dense features `[h, w, C]`, depth `[H, W]`, one file per view named `<image stem>.npy`).
//!
//! Reads format versions 1.0–3.0, C order only, any of bool / int8–64 / uint8–64 / float16 /
//! float32 / float64 in either byte order; every value is converted to `f32`. Writes float32.

mod header;

use crate::atomic::write_bytes_atomic;
use crate::error::{SceneError, SceneResult};
use crate::plane::Plane;
use half::f16;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

const NPY: &str = "NumPy .npy";
const NPZ: &str = "NumPy .npz";

/// The element type an array was stored with (its values are always returned as `f32`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum NpyDtype {
    /// `bool` (`|b1`): false → 0, true → 1.
    Bool,
    /// `int8`.
    Int8,
    /// `uint8`.
    UInt8,
    /// `int16`.
    Int16,
    /// `uint16`.
    UInt16,
    /// `int32`.
    Int32,
    /// `uint32` (values above 2²⁴ lose precision in `f32`).
    UInt32,
    /// `int64` (values above 2²⁴ in magnitude lose precision in `f32`).
    Int64,
    /// `uint64`.
    UInt64,
    /// `float16` (exact in `f32`).
    Float16,
    /// `float32`.
    Float32,
    /// `float64` (rounded to `f32`).
    Float64,
}

impl NpyDtype {
    /// Bytes per element.
    pub fn size(self) -> usize {
        match self {
            NpyDtype::Bool | NpyDtype::Int8 | NpyDtype::UInt8 => 1,
            NpyDtype::Int16 | NpyDtype::UInt16 | NpyDtype::Float16 => 2,
            NpyDtype::Int32 | NpyDtype::UInt32 | NpyDtype::Float32 => 4,
            NpyDtype::Int64 | NpyDtype::UInt64 | NpyDtype::Float64 => 8,
        }
    }
}

/// A dense array read from a `.npy` file, values converted to `f32`.
#[derive(Clone, Debug, PartialEq)]
pub struct NpyArray {
    /// Dimensions, outermost first (NumPy's `shape`); empty for a 0-d scalar.
    pub shape: Vec<usize>,
    /// The element type the file stored.
    pub dtype: NpyDtype,
    /// `[prod(shape)]` values in C (row-major) order.
    pub data: Vec<f32>,
}

impl NpyArray {
    /// Number of elements (`prod(shape)`, 1 for a scalar).
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// True when the array holds no elements.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// The single value of a 0-d (or one-element) array, e.g. `width` in an `.npz`.
    pub fn scalar(&self) -> Option<f32> {
        (self.data.len() == 1).then(|| self.data[0])
    }

    /// `(h, w, channels)` of a feature map `[h, w, C]`, or of a single-channel map `[h, w]`
    /// (`channels = 1`); `None` for other ranks.
    pub fn hwc(&self) -> Option<(usize, usize, usize)> {
        match self.shape[..] {
            [h, w] => Some((h, w, 1)),
            [h, w, c] => Some((h, w, c)),
            _ => None,
        }
    }

    /// A `[H, W]` array (or `[H, W, 1]`) as a [`Plane`] of width `W`, height `H`, e.g. a depth map.
    pub fn to_plane(&self) -> Option<Plane<f32>> {
        match self.shape[..] {
            [h, w] | [h, w, 1] => Plane::from_vec(w, h, self.data.clone()),
            _ => None,
        }
    }
}

/// Reads a `.npy` file.
pub fn read_npy(path: &Path) -> SceneResult<NpyArray> {
    let bytes = std::fs::read(path).map_err(|e| SceneError::io("cannot read", path, e))?;
    parse_npy(&bytes).map_err(|reason| SceneError::invalid(NPY, path, reason))
}

/// Parses the bytes of a `.npy` file; the error is a reason without the file name.
pub fn parse_npy(bytes: &[u8]) -> Result<NpyArray, String> {
    let header = header::parse_header(bytes)?;
    let count = header
        .shape
        .iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .ok_or_else(|| format!("shape {:?} is too large", header.shape))?;
    let item = header.dtype.size();
    let payload = &bytes[header.data_offset..];
    let expected = count.checked_mul(item).ok_or_else(|| format!("shape {:?} is too large", header.shape))?;
    if payload.len() != expected {
        let what = if payload.len() < expected { "truncated" } else { "longer than its header says" };
        return Err(format!(
            "data is {what}: shape {:?} of {:?} needs {expected} bytes, the file has {}",
            header.shape,
            header.dtype,
            payload.len()
        ));
    }
    let data = convert(payload, header.dtype, header.little_endian);
    Ok(NpyArray { shape: header.shape, dtype: header.dtype, data })
}

/// Converts raw elements to `f32`. `payload.len()` is a multiple of the element size.
fn convert(payload: &[u8], dtype: NpyDtype, little_endian: bool) -> Vec<f32> {
    macro_rules! each {
        ($n:literal, |$b:ident| $e:expr) => {
            payload
                .chunks_exact($n)
                .map(|c| {
                    let mut $b = [0u8; $n];
                    $b.copy_from_slice(c);
                    if !little_endian {
                        $b.reverse();
                    }
                    $e
                })
                .collect()
        };
    }
    match dtype {
        NpyDtype::Bool => payload.iter().map(|&b| if b != 0 { 1.0 } else { 0.0 }).collect(),
        NpyDtype::Int8 => payload.iter().map(|&b| b as i8 as f32).collect(),
        NpyDtype::UInt8 => payload.iter().map(|&b| b as f32).collect(),
        NpyDtype::Int16 => each!(2, |b| i16::from_le_bytes(b) as f32),
        NpyDtype::UInt16 => each!(2, |b| u16::from_le_bytes(b) as f32),
        NpyDtype::Float16 => each!(2, |b| f16::from_le_bytes(b).to_f32()),
        NpyDtype::Int32 => each!(4, |b| i32::from_le_bytes(b) as f32),
        NpyDtype::UInt32 => each!(4, |b| u32::from_le_bytes(b) as f32),
        NpyDtype::Float32 => each!(4, |b| f32::from_le_bytes(b)),
        NpyDtype::Int64 => each!(8, |b| i64::from_le_bytes(b) as f32),
        NpyDtype::UInt64 => each!(8, |b| u64::from_le_bytes(b) as f32),
        NpyDtype::Float64 => each!(8, |b| f64::from_le_bytes(b) as f32),
    }
}

/// Encodes a little-endian float32 C-order `.npy` file (format 1.0, or 2.0 for huge headers).
/// `data`: `[prod(shape)]` row-major. Returns `None` if the lengths disagree.
pub fn encode_npy_f32(shape: &[usize], data: &[f32]) -> Option<Vec<u8>> {
    let count = shape.iter().try_fold(1usize, |acc, &d| acc.checked_mul(d))?;
    if count != data.len() {
        return None;
    }
    let mut out = header::format_f32_header(shape);
    out.reserve(data.len() * 4);
    for v in data {
        out.extend_from_slice(&v.to_le_bytes());
    }
    Some(out)
}

/// Writes `data` (`[prod(shape)]`, C order) as a float32 `.npy` file, atomically.
pub fn write_npy_f32(path: &Path, shape: &[usize], data: &[f32]) -> SceneResult<()> {
    let bytes = encode_npy_f32(shape, data).ok_or_else(|| {
        SceneError::invalid(NPY, path, format!("shape {shape:?} does not hold {} values", data.len()))
    })?;
    write_bytes_atomic(path, &bytes)
}

/// Reads every `*.npy` entry of a `.npz` archive (`numpy.savez`, stored or deflated), keyed by
/// the entry name without `.npy`. Entries that are not `.npy` files are ignored.
pub fn read_npz(path: &Path) -> SceneResult<BTreeMap<String, NpyArray>> {
    let file = std::fs::File::open(path).map_err(|e| SceneError::io("cannot open", path, e))?;
    npz_entries(std::io::BufReader::new(file)).map_err(|reason| SceneError::invalid(NPZ, path, reason))
}

/// [`read_npz`] on the bytes of a whole `.npz` file; the error is a reason without the file name.
pub fn parse_npz(bytes: &[u8]) -> Result<BTreeMap<String, NpyArray>, String> {
    npz_entries(std::io::Cursor::new(bytes))
}

/// Room reserved up front for one entry, whatever size its zip header claims; a larger entry
/// still reads (the buffer grows with the data actually inflated).
const NPZ_ENTRY_RESERVE: u64 = 64 << 20;

fn npz_entries(reader: impl Read + std::io::Seek) -> Result<BTreeMap<String, NpyArray>, String> {
    let mut archive =
        zip::ZipArchive::new(reader).map_err(|e| format!("not a readable zip archive ({e})"))?;
    let mut arrays = BTreeMap::new();
    for i in 0..archive.len() {
        let mut entry = archive.by_index(i).map_err(|e| format!("cannot read zip entry {i} ({e})"))?;
        let Some(key) = entry.name().strip_suffix(".npy").map(str::to_string) else {
            continue;
        };
        let mut bytes = Vec::with_capacity(entry.size().min(NPZ_ENTRY_RESERVE) as usize);
        entry.read_to_end(&mut bytes).map_err(|e| format!("cannot read entry {key}.npy ({e})"))?;
        let array = parse_npy(&bytes).map_err(|reason| format!("entry {key}.npy: {reason}"))?;
        arrays.insert(key, array);
    }
    Ok(arrays)
}

/// Reads `<dir>/<stem>.npy`, the per-view cue file of the image with that stem; `Ok(None)` when
/// there is no such file.
pub fn read_cue_folder_entry(dir: &Path, stem: &str) -> SceneResult<Option<NpyArray>> {
    let path = dir.join(format!("{stem}.npy"));
    if !path.is_file() {
        return Ok(None);
    }
    read_npy(&path).map(Some)
}
