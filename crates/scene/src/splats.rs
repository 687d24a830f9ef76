//! Gaussians in the formats people hold them in, beside the INRIA 3DGS PLY ([`crate::ply`]):
//! Niantic's SPZ ([`spz`]), antimatter15's `.splat` ([`splat`]), mkkellogg's `.ksplat` ([`ksplat`])
//! and PlayCanvas's compressed PLY ([`compressed_ply`]). One entry reads any of them,
//! choosing by content ([`SplatFormat::detect`]), and one writes, choosing by the output's
//! extension ([`SplatFormat::from_extension`]).
//!
//! What each format keeps is in `CONVENTIONS.md` ("Gaussian file formats"): the compact formats
//! quantise, SPZ keeps SH degree ≤ 3 and `.splat` degree 0, and neither holds normals, `object_id`,
//! `feat_*` or other properties, so a labelled scene (`splatseg run`'s `gaussians.ply`) stays a PLY.

mod compressed_ply;
mod ksplat;
mod prefault;
mod quantise;
mod splat;
mod spz;
mod spz_decode;
#[cfg(test)]
mod spz_decode_tests;
#[cfg(test)]
mod spz_tests;

use crate::error::{SceneError, SceneResult};
use crate::gaussians::Gaussians;
use crate::ply::PlyRows;
use std::io::Read;
use std::path::Path;

/// A file format of Gaussians.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SplatFormat {
    /// The INRIA 3DGS PLY (`.ply`), full precision, any extra property.
    Ply,
    /// Niantic's SPZ (`.spz`): gzip, quantised, SH degree ≤ 3.
    Spz,
    /// antimatter15's `.splat`: 32 bytes per Gaussian, SH degree 0.
    Splat,
    /// PlayCanvas / SuperSplat's compressed PLY (`.compressed.ply`): chunks of 256 with bounds,
    /// 11-10-11 / 2-10-10-10 / 8-8-8-8 packed words, SH as bytes.
    CompressedPly,
    /// mkkellogg's `.ksplat` (GaussianSplats3D): sections of buckets, compression levels 0–2.
    Ksplat,
}

impl SplatFormat {
    /// The name errors and help use.
    pub fn name(self) -> &'static str {
        match self {
            SplatFormat::Ply => crate::ply::FORMAT,
            SplatFormat::Spz => spz::FORMAT,
            SplatFormat::Splat => splat::FORMAT,
            SplatFormat::CompressedPly => compressed_ply::FORMAT,
            SplatFormat::Ksplat => ksplat::FORMAT,
        }
    }

    /// The extension a file of this format is named with (what [`SplatFormat::from_extension`]
    /// reads back): `.ply`, `.spz`, `.splat`, `.compressed.ply`, `.ksplat`.
    pub fn extension(self) -> &'static str {
        match self {
            SplatFormat::Ply => ".ply",
            SplatFormat::Spz => ".spz",
            SplatFormat::Splat => ".splat",
            SplatFormat::CompressedPly => ".compressed.ply",
            SplatFormat::Ksplat => ".ksplat",
        }
    }

    /// The format an output path asks for by its extension (case-insensitive): `.spz`, `.splat`,
    /// `.ksplat`, `.compressed.ply`, `.ply`; `None` for any other.
    pub fn from_extension(path: &Path) -> Option<SplatFormat> {
        let name = path.file_name()?.to_str()?.to_ascii_lowercase();
        if name.ends_with(".compressed.ply") {
            return Some(SplatFormat::CompressedPly);
        }
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "ply" => Some(SplatFormat::Ply),
            "spz" => Some(SplatFormat::Spz),
            "splat" => Some(SplatFormat::Splat),
            "ksplat" => Some(SplatFormat::Ksplat),
            _ => None,
        }
    }

    /// The format of a file's bytes, `head` being its first bytes (up to [`DETECT_BYTES`]) and
    /// `path` its name: a gzip stream is SPZ, `ply` a PLY (compressed when its header declares a
    /// `chunk` element), a file named `.ksplat` with a `.ksplat` header (version 0.x, which is no
    /// magic) a `.ksplat`, and a file named `.splat` a `.splat` (which has no header at all).
    pub fn detect(head: &[u8], path: &Path) -> Result<SplatFormat, String> {
        if spz::is_gzip(head) {
            return Ok(SplatFormat::Spz);
        }
        if head.starts_with(b"ply") {
            if compressed_ply::is_compressed_ply(head) {
                return Ok(SplatFormat::CompressedPly);
            }
            return Ok(SplatFormat::Ply);
        }
        if head.starts_with(b"NGSP") {
            return Err("an SPZ file of version 4 or later (its header uncompressed); splatseg reads \
                        SPZ versions 2 and 3 (gzip): write version 3, e.g. `splat-transform \
                        --spz-version 3`"
                .to_string());
        }
        match SplatFormat::from_extension(path) {
            Some(SplatFormat::Splat) => return Ok(SplatFormat::Splat),
            Some(SplatFormat::Ksplat) if ksplat::looks_like_ksplat(head) => return Ok(SplatFormat::Ksplat),
            Some(SplatFormat::Ksplat) => {
                return Err("named .ksplat but its header is not one (version 0.x, compression level 0-2)"
                    .to_string())
            }
            _ => {}
        }
        Err("not a Gaussian splat file splatseg reads: expected a 3DGS or compressed PLY (starts with \
             \"ply\"), an SPZ (a gzip stream), a .ksplat (named *.ksplat) or a .splat (named *.splat)"
            .to_string())
    }
}

/// How many leading bytes [`SplatFormat::detect`] looks at (a compressed PLY's header is ≈ 1 KB).
pub const DETECT_BYTES: usize = 64 * 1024;

/// Format name of errors that come before the format is known.
const ANY_FORMAT: &str = "Gaussian splat";

/// Reads the Gaussians of a PLY, compressed PLY, SPZ, `.splat` or `.ksplat` file, chosen by
/// content, and validates them ([`Gaussians::validate`]), as [`crate::ply::read_ply`] does for a
/// PLY. Errors name the file, its format and what is wrong.
pub fn read_gaussians(path: &Path) -> SceneResult<Gaussians> {
    let (format, rows) = read_gaussian_rows_with_format(path)?;
    let g = rows.gaussians;
    if !decodes_finite(format) {
        g.validate().map_err(|reason| SceneError::invalid(format.name(), path, reason))?;
    }
    Ok(g)
}

/// True for the formats whose reader checks the set's structure itself and cannot decode a
/// non-finite value or a degenerate shape, so that neither is looked for
/// ([`PlyRows::usable_by_construction`]): SPZ, all of whose values are fixed-point or byte codes.
fn decodes_finite(format: SplatFormat) -> bool {
    format == SplatFormat::Spz
}

/// Every Gaussian of a PLY, compressed PLY, SPZ, `.splat` or `.ksplat` file with the non-finite
/// and degenerate ones listed, as [`crate::ply::read_ply_rows`] reads a PLY; what every command
/// that reads Gaussians calls.
pub fn read_gaussian_rows(path: &Path) -> SceneResult<PlyRows> {
    Ok(read_gaussian_rows_with_format(path)?.1)
}

/// The format of the file at `path`, from its first bytes and its name ([`SplatFormat::detect`]);
/// an error names the file when it is none of them or cannot be read.
pub fn detect_file_format(path: &Path) -> SceneResult<SplatFormat> {
    let mut head = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(DETECT_BYTES as u64).read_to_end(&mut head))
        .map_err(|e| SceneError::io("cannot read", path, e))?;
    SplatFormat::detect(&head, path).map_err(|reason| SceneError::invalid(ANY_FORMAT, path, reason))
}

/// [`read_gaussian_rows`] and the format the file was in.
pub fn read_gaussian_rows_with_format(path: &Path) -> SceneResult<(SplatFormat, PlyRows)> {
    let io = |e| SceneError::io("cannot read", path, e);
    let format = detect_file_format(path)?;
    match format {
        SplatFormat::Ply => return Ok((format, crate::ply::read_ply_rows(path)?)),
        SplatFormat::Spz => return Ok((format, compact_rows(format, read_spz_file(path)?))),
        _ => {}
    }
    let bytes = std::fs::read(path).map_err(io)?;
    let g =
        parse_compact(format, &bytes).map_err(|reason| SceneError::invalid(format.name(), path, reason))?;
    Ok((format, compact_rows(format, g)))
}

/// The rows of `g`, decoded from a file in `format` (not a PLY), with the non-finite and
/// degenerate ones listed unless the format cannot hold any ([`decodes_finite`]).
fn compact_rows(format: SplatFormat, g: Gaussians) -> PlyRows {
    let rows = if decodes_finite(format) { PlyRows::usable_by_construction(g) } else { PlyRows::new(g) };
    rows.in_format(format.name())
}

/// An SPZ file's Gaussians, read through a buffer as it inflates (never held whole in memory).
fn read_spz_file(path: &Path) -> SceneResult<Gaussians> {
    let io = |e| SceneError::io("cannot read", path, e);
    let file = std::fs::File::open(path).map_err(io)?;
    let file_len = file.metadata().map_err(io)?.len();
    let g = spz::read_spz(std::io::BufReader::with_capacity(READ_BUFFER_BYTES, file), file_len)
        .and_then(|g| g.validate_structure().map(|()| g))
        .map_err(|reason| SceneError::invalid(spz::FORMAT, path, reason))?;
    Ok(g)
}

/// Bytes of a compressed file read at a time.
const READ_BUFFER_BYTES: usize = 256 * 1024;

/// Decodes the bytes of a file in `format` and checks their structure.
fn parse_compact(format: SplatFormat, bytes: &[u8]) -> Result<Gaussians, String> {
    let g = match format {
        SplatFormat::Spz => spz::parse_spz(bytes)?,
        SplatFormat::Splat => splat::parse_splat(bytes)?,
        SplatFormat::CompressedPly => compressed_ply::parse_compressed_ply(bytes)?,
        SplatFormat::Ksplat => ksplat::parse_ksplat(bytes)?,
        SplatFormat::Ply => return Ok(crate::ply::parse_ply_bytes_rows(bytes)?.gaussians),
    };
    g.validate_structure()?;
    Ok(g)
}

/// The rows of a file's bytes in `format` (the fuzz targets' entry point; a PLY goes to
/// [`crate::ply::parse_ply_bytes_rows`]).
pub fn parse_gaussian_bytes_rows(format: SplatFormat, bytes: &[u8]) -> Result<PlyRows, String> {
    match format {
        SplatFormat::Ply => crate::ply::parse_ply_bytes_rows(bytes),
        _ => Ok(compact_rows(format, parse_compact(format, bytes)?)),
    }
}

/// Panics unless the SPZ `bytes` read `chunk_bytes` of body at a time (on two threads once the
/// body is longer) give what reading them whole gives: the same error, or the same Gaussians bit
/// for bit (the fuzz target's check of the chunked reader, [`crate::fuzzing::spz`]).
pub(crate) fn check_spz_chunked_read(bytes: &[u8], chunk_bytes: usize) {
    let whole = spz::parse_spz(bytes);
    let chunked = if spz::is_gzip(bytes) {
        spz::read_spz_in_chunks(bytes, bytes.len() as u64, chunk_bytes)
    } else {
        spz::parse_spz(bytes)
    };
    match (whole, chunked) {
        (Ok(a), Ok(b)) => {
            assert!(float_bits(&a) == float_bits(&b), "SPZ read in chunks of {chunk_bytes} bytes differs")
        }
        (Err(a), Err(b)) => assert_eq!(a, b, "SPZ read in chunks of {chunk_bytes} bytes fails otherwise"),
        (a, b) => panic!("SPZ read whole: {:?}; in chunks of {chunk_bytes} bytes: {:?}", a.err(), b.err()),
    }
}

/// The SH degree and every float an SPZ holds, as bits (so −0.0 ≠ 0.0), attribute by attribute.
fn float_bits(g: &Gaussians) -> (u8, Vec<u32>) {
    let floats = (g.means.iter().flatten())
        .chain(&g.raw_opacities)
        .chain(g.sh_dc.iter().flatten())
        .chain(g.log_scales.iter().flatten())
        .chain(g.rotations.iter().flatten())
        .chain(&g.sh_rest);
    (g.sh_degree, floats.map(|v| v.to_bits()).collect())
}

/// Writes `g` atomically in the format `path`'s extension names ([`SplatFormat::from_extension`]),
/// or as a PLY when the extension names none. Refuses (naming the file, writing nothing) what
/// [`Gaussians::validate`] refuses; SPZ refuses positions beyond its ±2048 range. What a format
/// cannot hold (see the module docs) is left out.
pub fn write_gaussians(path: &Path, g: &Gaussians) -> SceneResult<()> {
    write_gaussians_as(SplatFormat::from_extension(path).unwrap_or(SplatFormat::Ply), path, g)
}

/// [`write_gaussians`] in a chosen format whatever the extension.
pub fn write_gaussians_as(format: SplatFormat, path: &Path, g: &Gaussians) -> SceneResult<()> {
    let invalid = |reason: String| SceneError::invalid(format.name(), path, reason);
    let bytes = match format {
        SplatFormat::Ply => return crate::ply::write_ply(path, g),
        _ => to_gaussian_bytes(format, g).map_err(invalid)?,
    };
    crate::atomic::write_bytes_atomic(path, &bytes)
}

/// [`write_gaussians_as`] for a file written into a folder of the user's (edits, exports): the
/// temporary file a killed write left there is removed by the next write into that folder
/// ([`crate::atomic::write_atomic_sweeping`]).
pub fn write_gaussians_swept_as(format: SplatFormat, path: &Path, g: &Gaussians) -> SceneResult<()> {
    if format == SplatFormat::Ply {
        return crate::ply::write_ply_swept(path, g);
    }
    let bytes =
        to_gaussian_bytes(format, g).map_err(|reason| SceneError::invalid(format.name(), path, reason))?;
    crate::atomic::write_atomic_sweeping(path, |w| w.write_all(&bytes))
}

/// The bytes of `g` as a file in `format`; the error says what is wrong with `g`.
pub fn to_gaussian_bytes(format: SplatFormat, g: &Gaussians) -> Result<Vec<u8>, String> {
    g.validate()?;
    match format {
        SplatFormat::Ply => crate::ply::to_ply_bytes(g),
        SplatFormat::Spz => spz::to_spz_bytes(g),
        SplatFormat::Splat => Ok(splat::to_splat_bytes(g)),
        SplatFormat::CompressedPly => Ok(compressed_ply::to_compressed_ply_bytes(g)),
        SplatFormat::Ksplat => {
            u32::try_from(g.len())
                .map_err(|_| format!("{} Gaussians are more than .ksplat's u32 count", g.len()))?;
            Ok(ksplat::to_ksplat_bytes(g))
        }
    }
}
