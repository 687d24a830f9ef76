//! Reading: header → layout → size checks → row decoding ([`super::rows`]) → validation.

use super::ascii::ascii_vertices_to_le;
use super::header::{parse_header, BodyFormat, ElementDecl, Header, MAX_HEADER_BYTES};
use super::layout::VertexLayout;
use super::rows::{decode_range, decode_with, ColumnsMut};
use super::validate::{degenerate_shape, MAX_LOG_SCALE};
use super::FORMAT;
use crate::error::{SceneError, SceneResult};
use crate::gaussians::Gaussians;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

/// Rows read from the file at a time (≈ 16 MB for 62-float rows), so a large file is never
/// held in memory twice.
const ROWS_PER_READ: usize = 64 * 1024;

/// Reads a 3DGS PLY file (binary little/big-endian or ASCII) and validates it
/// ([`Gaussians::validate`]). Errors name the file and what is wrong (truncation, malformed
/// header, missing properties, non-finite values with the property and first bad index).
/// Binary bodies are streamed in chunks straight into the output arrays. [`read_ply_rows`]
/// reads a file with some non-finite Gaussians instead of refusing it.
pub fn read_ply(path: &Path) -> SceneResult<Gaussians> {
    let g = read_ply_rows(path)?.gaussians;
    g.validate().map_err(|reason| SceneError::invalid(FORMAT, path, reason))?;
    Ok(g)
}

/// Every row of a 3DGS PLY, and which of them are skipped: those holding a non-finite value and
/// those with a degenerate shape ([`Gaussians::degenerate_rows`]).
#[derive(Clone, Debug)]
pub struct PlyRows {
    /// Every Gaussian of the file, in file order, non-finite values included.
    pub gaussians: Gaussians,
    /// `[k]` ascending indices of the Gaussians with a non-finite value
    /// ([`Gaussians::non_finite_rows`]).
    pub non_finite: Vec<usize>,
    /// `[j]` ascending indices of the finite Gaussians with a zero rotation quaternion or a scale
    /// too large to have a covariance ([`Gaussians::degenerate_rows`]).
    pub degenerate: Vec<usize>,
    /// The name of the file's format, as errors say it (a 3DGS PLY unless [`PlyRows::in_format`]).
    format: &'static str,
}

impl PlyRows {
    pub(crate) fn new(gaussians: Gaussians) -> Self {
        let non_finite = gaussians.non_finite_rows();
        let mut degenerate = gaussians.degenerate_rows();
        degenerate.retain(|i| non_finite.binary_search(i).is_err());
        PlyRows { gaussians, non_finite, degenerate, format: FORMAT }
    }

    /// The rows of a reader whose decoding cannot give a non-finite value or a degenerate shape
    /// (SPZ: every code of its fixed-point and byte encodings decodes finite, with a log-scale
    /// below 6 and a rotation whose norm is not 0; `splats::spz_decode_tests`), so none is looked for: the
    /// two scans cost as much as decoding. Debug builds (the tests, the fuzz targets) still scan.
    pub(crate) fn usable_by_construction(gaussians: Gaussians) -> Self {
        debug_assert!(gaussians.non_finite_rows().is_empty(), "a non-finite value decoded");
        debug_assert!(gaussians.degenerate_rows().is_empty(), "a degenerate shape decoded");
        PlyRows { gaussians, non_finite: Vec::new(), degenerate: Vec::new(), format: FORMAT }
    }

    /// The rows, read from a file in the format named `format` (what [`PlyRows::refuse_skipped`]
    /// names).
    pub(crate) fn in_format(self, format: &'static str) -> Self {
        PlyRows { format, ..self }
    }

    /// How many rows are skipped (non-finite or degenerate).
    pub fn skipped(&self) -> usize {
        self.non_finite.len() + self.degenerate.len()
    }

    /// `[N - k - j]` ascending indices of the usable Gaussians: finite, with a usable shape.
    pub fn usable_rows(&self) -> Vec<usize> {
        let skipped: std::collections::BTreeSet<usize> =
            self.non_finite.iter().chain(&self.degenerate).copied().collect();
        (0..self.gaussians.len()).filter(|i| !skipped.contains(i)).collect()
    }

    /// The usable Gaussians, in file order (the set itself when no row is skipped).
    pub fn into_usable(self) -> Gaussians {
        if self.skipped() == 0 {
            self.gaussians
        } else {
            self.gaussians.select(&self.usable_rows())
        }
    }

    /// One line for the user per kind of skipped row: how many, the first bad value or shape,
    /// what is done with them (`consequence`, e.g. "they are labelled -1") and the file; empty
    /// when every row is usable.
    pub fn skip_warnings(&self, path: &Path, consequence: &str) -> Vec<String> {
        let mut warnings = Vec::new();
        // The first bad value is looked for only when there is one (a scan of every value).
        let first_non_finite = || self.gaussians.first_non_finite();
        if let Some(first) = self.non_finite.first().and_then(|_| first_non_finite()) {
            warnings.push(format!(
                "skipping {} of {} Gaussians with non-finite values (first: {first}); {consequence}: {}",
                self.non_finite.len(),
                self.gaussians.len(),
                path.display()
            ));
        }
        if let Some(&first) = self.degenerate.first() {
            let g = &self.gaussians;
            let why =
                degenerate_shape(g.log_scales[first], g.rotations[first]).unwrap_or("a degenerate shape");
            warnings.push(format!(
                "skipping {} of {} Gaussians with a degenerate shape, a zero rotation quaternion or a \
                 log-scale above {MAX_LOG_SCALE} (first: Gaussian {first}, {why}); {consequence}: {}",
                self.degenerate.len(),
                g.len(),
                path.display()
            ));
        }
        warnings
    }

    /// The error [`read_ply`] gives for a file with non-finite rows, or a degenerate one, or
    /// `Ok` when every row is usable (what `--strict` asks for); it names the file's format.
    pub fn refuse_skipped(&self, path: &Path) -> SceneResult<()> {
        if let Some(reason) = self.non_finite.first().and_then(|_| self.gaussians.first_non_finite()) {
            return Err(SceneError::invalid(self.format, path, reason));
        }
        match self.degenerate.first() {
            Some(&i) => {
                let g = &self.gaussians;
                let why = degenerate_shape(g.log_scales[i], g.rotations[i]).unwrap_or("a degenerate shape");
                Err(SceneError::invalid(self.format, path, format!("Gaussian {i} has {why}")))
            }
            None => Ok(()),
        }
    }
}

/// Reads a 3DGS PLY like [`read_ply`], but keeps Gaussians with non-finite values and lists
/// them ([`PlyRows::non_finite`]); every other check is the same.
pub fn read_ply_rows(path: &Path) -> SceneResult<PlyRows> {
    let invalid = |reason: String| SceneError::invalid(FORMAT, path, reason);
    let io = |e| SceneError::io("cannot read", path, e);
    let mut file = File::open(path).map_err(io)?;
    let file_len = file.metadata().map_err(io)?.len();
    let mut prefix = Vec::new();
    (&mut file).take(MAX_HEADER_BYTES as u64 + 1024).read_to_end(&mut prefix).map_err(io)?;
    let header = parse_header(&prefix).map_err(invalid)?;
    if header.format == BodyFormat::Ascii {
        let bytes = std::fs::read(path).map_err(io)?;
        return parse_ply_bytes_rows(&bytes).map_err(invalid);
    }
    let (vertex_index, layout) = vertex_layout(&header).map_err(invalid)?;
    let body_len = usize::try_from(file_len).unwrap_or(usize::MAX) - header.body_offset;
    let span = binary_span(body_len, &header, vertex_index).map_err(invalid)?;
    file.seek(SeekFrom::Start((header.body_offset + span.before) as u64)).map_err(io)?;
    let n = header.elements[vertex_index].count;
    let g = if header.format == BodyFormat::BinaryBigEndian {
        decode_with(&layout, n, |out| stream_rows::<true>(&mut file, &layout, out))
    } else {
        decode_with(&layout, n, |out| stream_rows::<false>(&mut file, &layout, out))
    };
    let g = g.map_err(|e| match e {
        StreamError::Io(e) => io(e),
        StreamError::Invalid(reason) => invalid(reason),
    })?;
    g.validate_structure().map_err(invalid)?;
    Ok(PlyRows::new(g))
}

/// Parses the bytes of a whole 3DGS PLY file; see [`read_ply`]. The error says what is wrong.
pub fn parse_ply_bytes(bytes: &[u8]) -> Result<Gaussians, String> {
    let g = parse_ply_bytes_rows(bytes)?.gaussians;
    g.validate()?;
    Ok(g)
}

/// [`read_ply_rows`] on the bytes of a whole file (the fuzz targets' entry point).
pub fn parse_ply_bytes_rows(bytes: &[u8]) -> Result<PlyRows, String> {
    let header = parse_header(bytes)?;
    let (vertex_index, layout) = vertex_layout(&header)?;
    let body = &bytes[header.body_offset..];
    let n = header.elements[vertex_index].count;
    let g = match header.format {
        BodyFormat::BinaryLittleEndian | BodyFormat::BinaryBigEndian => {
            let span = binary_span(body.len(), &header, vertex_index)?;
            let rows = &body[span.before..span.before + span.vertex_bytes];
            if header.format == BodyFormat::BinaryBigEndian {
                decode_with(&layout, n, |out| decode_range::<true>(&layout, rows, out, 0))?
            } else {
                decode_with(&layout, n, |out| decode_range::<false>(&layout, rows, out, 0))?
            }
        }
        BodyFormat::Ascii => {
            let rows = ascii_vertices_to_le(body, &header.elements, vertex_index)?;
            decode_with(&layout, n, |out| decode_range::<false>(&layout, &rows, out, 0))?
        }
    };
    g.validate_structure()?;
    Ok(PlyRows::new(g))
}

/// Finds the vertex element, rejects list properties, and maps the vertex properties.
fn vertex_layout(header: &Header) -> Result<(usize, VertexLayout), String> {
    let vertex_index = header
        .elements
        .iter()
        .position(|e| e.name == "vertex")
        .ok_or_else(|| "the header declares no 'vertex' element".to_string())?;
    for element in &header.elements {
        if let Some(list) = &element.first_list_property {
            return Err(if element.name == "vertex" {
                format!("vertex property '{list}' is a list; 3DGS vertices have scalar properties only")
            } else {
                format!(
                    "element '{}' has list property '{list}'; only elements with fixed-size rows \
                     can be skipped",
                    element.name
                )
            });
        }
    }
    crate::limits::check_gaussians(header.elements[vertex_index].count as u64)?;
    let properties = &header.elements[vertex_index].properties;
    if properties.iter().any(|p| p.name == "packed_position") {
        return Err("this is a compressed PLY (SuperSplat / gsplat 'ply_compressed': packed_position, \
                    ...), which the INRIA PLY reader does not read; splatseg_scene::splats::read_gaussians \
                    (what every command uses) does"
            .to_string());
    }
    let layout = VertexLayout::from_properties(properties)?;
    Ok((vertex_index, layout))
}

/// Where the vertex rows sit in a binary body.
struct VertexSpan {
    /// Bytes of the elements before the vertex element.
    before: usize,
    /// Bytes of the vertex rows.
    vertex_bytes: usize,
}

/// Checks a binary body of `body_len` bytes against the sizes the header declares.
fn binary_span(body_len: usize, header: &Header, vertex_index: usize) -> Result<VertexSpan, String> {
    let overflow = || "the header declares more data than any file can hold".to_string();
    let element_bytes = |e: &ElementDecl| e.count.checked_mul(e.row_bytes());
    let mut before = 0usize;
    let mut after = 0usize;
    for (i, e) in header.elements.iter().enumerate() {
        let n = element_bytes(e).ok_or_else(overflow)?;
        if i < vertex_index {
            before = before.checked_add(n).ok_or_else(overflow)?;
        } else if i > vertex_index {
            after = after.checked_add(n).ok_or_else(overflow)?;
        }
    }
    let vertex = &header.elements[vertex_index];
    let stride = vertex.row_bytes();
    let vertex_bytes = element_bytes(vertex).ok_or_else(overflow)?;
    let total = before.checked_add(vertex_bytes).and_then(|t| t.checked_add(after)).ok_or_else(overflow)?;
    let others = if before + after > 0 {
        format!(" plus {} bytes of other elements", before + after)
    } else {
        String::new()
    };
    if body_len < total {
        return Err(format!(
            "truncated: the header declares {} vertices × {stride} bytes = {vertex_bytes} bytes{others} \
             but only {body_len} bytes follow the header",
            vertex.count,
        ));
    }
    if body_len > total {
        return Err(format!(
            "{} unexpected bytes after the data the header declares ({} vertices × {stride} \
             bytes{others}); the vertex count in the header may be wrong",
            body_len - total,
            vertex.count
        ));
    }
    Ok(VertexSpan { before, vertex_bytes })
}

/// A failure while streaming rows from a file.
enum StreamError {
    Io(std::io::Error),
    Invalid(String),
}

/// Reads the vertex rows from `file` (positioned at the first row) chunk by chunk and decodes
/// each chunk into its part of `out`.
fn stream_rows<const BIG: bool>(
    file: &mut File,
    layout: &VertexLayout,
    out: ColumnsMut<'_>,
) -> Result<(), StreamError> {
    let n = out.rows();
    let mut buffer = vec![0u8; ROWS_PER_READ.min(n) * layout.stride];
    let mut remaining = out;
    let mut done = 0;
    while done < n {
        let rows = ROWS_PER_READ.min(n - done);
        let chunk = &mut buffer[..rows * layout.stride];
        file.read_exact(chunk).map_err(StreamError::Io)?;
        let (head, tail) = remaining.split_at(rows, layout.sh_rest.len(), layout.features.len());
        decode_range::<BIG>(layout, chunk, head, done).map_err(StreamError::Invalid)?;
        remaining = tail;
        done += rows;
    }
    Ok(())
}
