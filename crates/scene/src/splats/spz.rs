//! Niantic's SPZ (versions 2 and 3): a gzip stream holding a 16-byte header
//! (`magic "NGSP" u32, version u32, numPoints u32, shDegree u8, fractionalBits u8, flags u8,
//! reserved u8`, little-endian) and then, attribute by attribute for all Gaussians: positions
//! (3 × 24-bit signed fixed point with `fractionalBits`), alphas (u8 of the sigmoid), colours
//! (u8 of `f_dc · 0.15 · 255 + 127.5`), log-scales (u8 of `(s + 10) · 16`), rotations (version 2:
//! x y z of the normalised quaternion with w ≥ 0 as `q · 127.5 + 127.5`; version 3: "smallest
//! three", 2 bits for the largest of x y z w and 3 × (sign + 9 bits) of the others scaled by √2),
//! then SH rest coefficients as u8 `q · 128 + 128`, colour channel fastest.
//!
//! SPZ is stored in a right-up-back (OpenGL) frame; the INRIA PLY's frame is right-down-front
//! (COLMAP), so reading and writing turn the scene 180° about x as the reference library does when
//! told the PLY frame: y and z of positions and quaternions negate, and the SH coefficients odd in
//! y·z change sign. Writing makes version 3 with 12 fractional bits (positions within ±2048) and
//! SH bands 1 at 5 bits and 2–3 at 4 bits, as the reference library does by default.

use super::quantise::{sh_rest_to_coefficient_major, sigmoid, to_u8};
use super::spz_decode::{BodyShape, Rows, RowsOf, Section, SpzDecoder, COLOUR_SCALE, SH_FLIP, SQRT1_2};
use crate::gaussians::{sh_coeffs_for_degree, Gaussians};
use flate2::bufread::GzDecoder;
use flate2::write::GzEncoder;
use std::cell::Cell;
use std::io::{BufRead, Read, Write};
use std::sync::mpsc::{self, TrySendError};

/// Format name used in error messages.
pub(crate) const FORMAT: &str = "SPZ";

/// "NGSP" read as a little-endian u32.
const MAGIC: u32 = 0x5053_474e;

/// The header's size in bytes.
const HEADER_BYTES: usize = 16;

/// Header flag: trained with antialiasing (kept by nothing in splatseg, accepted).
const FLAG_ANTIALIASED: u8 = 0x1;

/// Fractional bits of the positions the writer makes (≈ 0.24 mm).
const WRITE_FRACTIONAL_BITS: u8 = 12;

/// Bytes of the body the reader inflates at a time (whole elements of one section, so a little
/// less): small enough to stay in the caches between the inflating and the decoding thread, large
/// enough that handing one over costs nothing.
pub(super) const CHUNK_BYTES: usize = 1 << 20;

/// Chunks inflated ahead of the decoding thread; when that many wait, the inflating thread
/// decodes the next chunk itself.
const CHUNKS_IN_FLIGHT: usize = 2;

/// The most bytes deflate inflates from one compressed byte (a 258-byte match coded in 2 bits):
/// a file of `L` bytes cannot hold a body longer than `1032 · L`.
const DEFLATE_MAX_RATIO: u64 = 1032;

/// The 16-byte header.
#[derive(Clone, Copy, Debug)]
struct Header {
    version: u32,
    count: usize,
    sh_degree: u8,
    fractional_bits: u8,
}

impl Header {
    fn parse(bytes: &[u8]) -> Result<Header, String> {
        let u32_at = |o: usize| u32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
        if bytes.len() < HEADER_BYTES {
            return Err(format!(
                "the gzip stream holds {} bytes, fewer than SPZ's 16-byte header",
                bytes.len()
            ));
        }
        let magic = u32_at(0);
        if magic != MAGIC {
            return Err(format!("magic 0x{magic:08x} where SPZ has 0x{MAGIC:08x} (\"NGSP\")"));
        }
        let version = u32_at(4);
        if version != 2 && version != 3 {
            return Err(format!("SPZ version {version}; splatseg reads versions 2 and 3"));
        }
        let count = u32_at(8) as u64;
        crate::limits::check_gaussians(count)?;
        let (sh_degree, fractional_bits, flags) = (bytes[12], bytes[13], bytes[14]);
        if sh_degree > 3 {
            return Err(format!("SH degree {sh_degree}; splatseg reads SH degrees 0 to 3"));
        }
        if fractional_bits > 23 {
            return Err(format!("{fractional_bits} fractional bits in a 24-bit position"));
        }
        if flags & !FLAG_ANTIALIASED != 0 {
            return Err(format!(
                "header flags 0x{flags:02x}: extensions (0x2) and unknown flags are not supported"
            ));
        }
        Ok(Header { version, count: count as usize, sh_degree, fractional_bits })
    }

    fn rotation_bytes(&self) -> usize {
        if self.version >= 3 {
            4
        } else {
            3
        }
    }

    fn rest_per_channel(&self) -> usize {
        sh_coeffs_for_degree(self.sh_degree) - 1
    }

    fn body_shape(&self) -> BodyShape {
        BodyShape {
            fractional_bits: self.fractional_bits,
            rotation_bytes: self.rotation_bytes(),
            rest_per_channel: self.rest_per_channel(),
        }
    }

    /// Bytes per Gaussian after the header.
    fn row_bytes(&self) -> usize {
        9 + 1 + 3 + 3 + self.rotation_bytes() + 3 * self.rest_per_channel()
    }
}

/// True when `bytes` start as a gzip stream (what SPZ files are).
pub(crate) fn is_gzip(bytes: &[u8]) -> bool {
    bytes.starts_with(&[0x1f, 0x8b])
}

/// Decodes a whole `.spz` file held in memory; see [`read_spz`].
pub(crate) fn parse_spz(file: &[u8]) -> Result<Gaussians, String> {
    if !is_gzip(file) {
        return Err("not a gzip stream (SPZ files start with bytes 1f 8b)".to_string());
    }
    read_spz(file, file.len() as u64)
}

/// Decodes an SPZ file of `file_len` bytes read from `file` (a gzip stream); see
/// [`read_spz_in_chunks`].
pub(crate) fn read_spz<R: BufRead>(file: R, file_len: u64) -> Result<Gaussians, String> {
    read_spz_in_chunks(file, file_len, CHUNK_BYTES)
}

/// Decodes an SPZ file of `file_len` bytes read from `file` (a gzip stream). The Gaussians' arrays
/// are made first, for the count the header declares once the file is long enough to inflate to
/// that many (deflate expands at most 1032×; a file too short for its count is inflated to the end
/// to say where it stops, allocating nothing); they stay untouched (zeroed pages from the system)
/// until decoded. Then this thread inflates the body `chunk_bytes` at a time (whole elements of
/// one attribute section) and a second thread decodes the chunks straight into the arrays, handing
/// the buffers back to be filled again, so the inflater writes into memory that stays in the
/// caches; when the decoding thread falls behind, the inflating one decodes the next chunk itself.
/// The stream is then drained to check gzip's CRC.
pub(super) fn read_spz_in_chunks<R: BufRead>(
    file: R,
    file_len: u64,
    chunk_bytes: usize,
) -> Result<Gaussians, String> {
    let mut stream = GzDecoder::new(file);
    let mut head = Vec::with_capacity(HEADER_BYTES);
    (&mut stream).take(HEADER_BYTES as u64).read_to_end(&mut head).map_err(gzip_error)?;
    let header = Header::parse(&head)?;
    let body_len = header.count as u64 * header.row_bytes() as u64;
    if body_len > DEFLATE_MAX_RATIO.saturating_mul(file_len) {
        return Err(where_the_stream_ends(&mut stream, &header));
    }
    let (n, k) = (header.count, header.rest_per_channel());
    check_allocatable(n, k)?;
    let mut g = Gaussians {
        means: vec![[0.0; 3]; n],
        sh_dc: vec![[0.0; 3]; n],
        sh_degree: header.sh_degree,
        sh_rest: vec![0.0; 3 * k * n],
        raw_opacities: vec![0.0; n],
        log_scales: vec![[0.0; 3]; n],
        rotations: vec![[0.0; 4]; n],
        ..Gaussians::default()
    };
    let decoder = SpzDecoder::new(header.body_shape());
    let mut body = Body { stream: &mut stream, header, chunk_bytes, done: 0 };
    let mut rows = RowsOf::new(&mut g, k);
    if body_len <= chunk_bytes as u64 {
        body.inflate(
            &mut rows,
            || None,
            |rows, bytes| {
                decoder.decode(rows, &bytes);
                Ok(())
            },
        )?;
    } else {
        inflate_beside_decoding(&mut body, &mut rows, &decoder)?;
    }
    std::io::copy(&mut stream, &mut std::io::sink()).map_err(gzip_error)?;
    Ok(g)
}

/// An error, not an abort, when the system cannot give the arrays of `n` Gaussians with `k` SH
/// coefficients per channel beyond DC (a file of highly compressible bytes may declare up to 1032×
/// its size): the whole size is reserved once and given back before the zeroed arrays are made.
fn check_allocatable(n: usize, k: usize) -> Result<(), String> {
    let floats = n.checked_mul(3 + 3 + 1 + 3 + 4 + 3 * k);
    let bytes = floats.and_then(|f| f.checked_mul(std::mem::size_of::<f32>()));
    let mut probe: Vec<u8> = Vec::new();
    match bytes {
        Some(b) if probe.try_reserve_exact(b).is_ok() => Ok(()),
        _ => Err(format!(
            "the header declares {n} Gaussians, whose arrays are more memory than this machine can give"
        )),
    }
}

/// `body` inflated on this thread into `rows` while a second thread decodes the chunks already
/// inflated and hands their buffers back; a chunk the second thread has no room for is decoded here.
fn inflate_beside_decoding<'a, R: Read>(
    body: &mut Body<'_, R>,
    rows: &mut RowsOf<'a>,
    decoder: &SpzDecoder,
) -> Result<(), String> {
    let (to_decoder, inflated) = mpsc::sync_channel::<(Rows<'a>, Vec<u8>)>(CHUNKS_IN_FLIGHT);
    let (to_inflater, decoded) = mpsc::channel::<Vec<u8>>();
    std::thread::scope(|scope| {
        let decoding = scope.spawn(move || {
            for (rows, bytes) in inflated {
                decoder.decode(rows, &bytes);
                // The inflater may have stopped (an error): then nobody needs the buffer back.
                let _ = to_inflater.send(bytes);
            }
        });
        // A buffer this thread decoded itself, to fill again.
        let own = Cell::new(None);
        let inflating = body.inflate(
            rows,
            || own.take().or_else(|| decoded.try_recv().ok()),
            |rows, bytes| match to_decoder.try_send((rows, bytes)) {
                Ok(()) => Ok(()),
                Err(TrySendError::Full((rows, bytes))) => {
                    decoder.decode(rows, &bytes);
                    own.set(Some(bytes));
                    Ok(())
                }
                Err(TrySendError::Disconnected(_)) => Err("the decoding thread stopped".to_string()),
            },
        );
        drop(to_decoder);
        // Joined here rather than by the scope, which waits only for the closure: joining waits
        // for the thread itself to end, its thread-local state freed, before the Gaussians are
        // handed back (LeakSanitizer counted that state against the fuzz target's input).
        if let Err(panic) = decoding.join() {
            std::panic::resume_unwind(panic);
        }
        inflating
    })
}

/// The body of a file, inflated section by section, chunk by chunk.
struct Body<'s, R: Read> {
    stream: &'s mut R,
    header: Header,
    chunk_bytes: usize,
    /// Body bytes inflated so far.
    done: u64,
}

impl<R: Read> Body<'_, R> {
    /// Inflates every section the header declares, handing each chunk (whole elements of one
    /// section, in a buffer from `spare` when it has one) and its rows of `rows` to `take`;
    /// errors when the stream ends first, saying where.
    fn inflate<'a>(
        &mut self,
        rows: &mut RowsOf<'a>,
        mut spare: impl FnMut() -> Option<Vec<u8>>,
        mut take: impl FnMut(Rows<'a>, Vec<u8>) -> Result<(), String>,
    ) -> Result<(), String> {
        let shape = self.header.body_shape();
        for section in Section::ALL {
            let element = shape.element_bytes(section);
            if element == 0 {
                continue;
            }
            let chunk_rows = (self.chunk_bytes / element).max(1);
            let mut left = self.header.count;
            while left > 0 {
                let count = left.min(chunk_rows);
                let len = count * element;
                let mut bytes = spare().unwrap_or_default();
                // A recycled buffer is only zeroed where it grows (not once per read).
                bytes.resize(len, 0);
                let filled = fill(&mut *self.stream, &mut bytes).map_err(gzip_error)?;
                self.done += filled as u64;
                if filled < len {
                    return Err(truncated(&self.header, self.done, section));
                }
                take(rows.next(section, count), bytes)?;
                left -= count;
            }
        }
        Ok(())
    }
}

/// Reads `stream` into `buffer` until it is full or the stream ends; the bytes read.
fn fill(stream: &mut impl Read, buffer: &mut [u8]) -> std::io::Result<usize> {
    let mut filled = 0;
    while filled < buffer.len() {
        match stream.read(&mut buffer[filled..]) {
            Ok(0) => break,
            Ok(read) => filled += read,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(filled)
}

/// The error for a file too short to inflate to the body its header declares: the stream
/// inflated to its end, nothing kept, to say where it stops.
fn where_the_stream_ends(stream: &mut impl Read, header: &Header) -> String {
    let body_len = header.count as u64 * header.row_bytes() as u64;
    let done = match std::io::copy(&mut stream.take(body_len), &mut std::io::sink()) {
        Ok(done) => done,
        Err(e) => return gzip_error(e),
    };
    let shape = header.body_shape();
    let mut end = 0;
    for section in Section::ALL {
        end += header.count as u64 * shape.element_bytes(section) as u64;
        if done < end {
            return truncated(header, done, section);
        }
    }
    format!("the header declares {body_len} bytes of Gaussians, more than deflate can hold in this file")
}

/// The error for a stream that ends `done` bytes into the body, in `section`.
fn truncated(header: &Header, done: u64, section: Section) -> String {
    format!(
        "truncated: the header declares {} Gaussians × {} bytes = {} bytes but the stream ends after {} \
         of them, in the {}",
        header.count,
        header.row_bytes(),
        header.count as u64 * header.row_bytes() as u64,
        done,
        section.name()
    )
}

fn gzip_error(e: std::io::Error) -> String {
    format!("the gzip stream is truncated or corrupt ({e})")
}

/// The bytes of an SPZ version 3 file holding `g` (which the caller validated: finite values).
/// Errors when a value is outside what SPZ can hold at all (a position beyond ±2048, an SH degree
/// above 3 cannot happen); values outside the byte ranges are clamped, as the format does.
pub(crate) fn to_spz_bytes(g: &Gaussians) -> Result<Vec<u8>, String> {
    let n = g.len();
    let count = u32::try_from(n).map_err(|_| format!("{n} Gaussians are more than SPZ's u32 count"))?;
    let scale = (1u32 << WRITE_FRACTIONAL_BITS) as f32;
    let limit = ((1i32 << 23) - 1) as f32;
    let outside = |p: &[f32; 3]| p.iter().any(|v| (v * scale).round().abs() > limit);
    if let Some((i, p)) = g.means.iter().enumerate().find(|(_, p)| outside(p)) {
        let range = 1u32 << (23 - WRITE_FRACTIONAL_BITS);
        return Err(format!(
            "Gaussian {i} lies at {p:?}, outside the ±{range} that SPZ's 24-bit positions hold at \
             {WRITE_FRACTIONAL_BITS} fractional bits"
        ));
    }
    let k = g.rest_per_channel();
    let mut raw = Vec::with_capacity(HEADER_BYTES + n * (20 + 3 * k));
    raw.extend_from_slice(&MAGIC.to_le_bytes());
    raw.extend_from_slice(&3u32.to_le_bytes());
    raw.extend_from_slice(&count.to_le_bytes());
    raw.extend_from_slice(&[g.sh_degree, WRITE_FRACTIONAL_BITS, 0, 0]);
    let flip = [1.0, -1.0, -1.0];
    for p in &g.means {
        for a in 0..3 {
            let fixed = (flip[a] * p[a] * scale).round() as i32;
            raw.extend_from_slice(&fixed.to_le_bytes()[..3]);
        }
    }
    raw.extend(g.raw_opacities.iter().map(|&o| to_u8(sigmoid(o) * 255.0)));
    for dc in &g.sh_dc {
        raw.extend(dc.iter().map(|&c| to_u8(c * COLOUR_SCALE * 255.0 + 127.5)));
    }
    for s in &g.log_scales {
        raw.extend(s.iter().map(|&v| to_u8((v + 10.0) * 16.0)));
    }
    for &[w, x, y, z] in &g.rotations {
        raw.extend_from_slice(&pack_smallest_three([x, -y, -z, w]).to_le_bytes());
    }
    let coefficient_major = sh_rest_to_coefficient_major(&g.sh_rest, k);
    for (i, rgb) in coefficient_major.chunks_exact(3).enumerate() {
        let j = i % k.max(1);
        let bucket = if j < 3 { 8 } else { 16 };
        raw.extend(rgb.iter().map(|&v| quantise_sh(SH_FLIP[j] * v, bucket)));
    }
    let mut encoder = GzEncoder::new(Vec::new(), flate2::Compression::default());
    encoder.write_all(&raw).and_then(|()| encoder.finish()).map_err(|e| format!("gzip failed: {e}"))
}

/// An SH coefficient as `round(v · 128 + 128)` snapped to the centre of its bucket of `bucket`
/// values (8 = 5 bits, 16 = 4 bits), as the reference writer does so that gzip finds repeats.
fn quantise_sh(v: f32, bucket: i32) -> u8 {
    let q = (v * 128.0).round() as i32 + 128;
    let snapped = (q + bucket / 2) / bucket * bucket;
    snapped.clamp(0, 255) as u8
}

/// A quaternion `x y z w` (any norm but zero) as version 3's "smallest three" word.
fn pack_smallest_three(q: [f32; 4]) -> u32 {
    let norm = q.iter().map(|v| v * v).sum::<f32>().sqrt();
    let q = if norm > 0.0 { q.map(|v| v / norm) } else { [0.0, 0.0, 0.0, 1.0] };
    let largest = (1..4).fold(0, |best, i| if q[i].abs() > q[best].abs() { i } else { best });
    let negate = q[largest] < 0.0;
    let mut packed = largest as u32;
    for (_, &v) in q.iter().enumerate().filter(|&(i, _)| i != largest) {
        let sign = ((v < 0.0) != negate) as u32;
        let magnitude = (511.0 * (v.abs() / SQRT1_2) + 0.5).min(511.0) as u32;
        packed = (packed << 10) | (sign << 9) | magnitude;
    }
    packed
}

#[cfg(test)]
mod tests {
    use super::super::spz_decode::smallest_three_xyzw;
    use super::*;

    #[test]
    fn smallest_three_round_trips_unit_quaternions_up_to_sign() {
        let cases =
            [[0.1, -0.7, 0.2, 0.5], [0.0, 0.0, 0.0, 1.0], [-0.9, 0.1, 0.3, -0.2], [0.5, 0.5, -0.5, 0.5]];
        for q in cases {
            let norm = q.iter().map(|v: &f32| v * v).sum::<f32>().sqrt();
            let unit = q.map(|v| v / norm);
            let back = smallest_three_xyzw(&pack_smallest_three(q).to_le_bytes());
            let dot: f32 = unit.iter().zip(&back).map(|(a, b)| a * b).sum();
            assert!(dot.abs() > 1.0 - 1e-5, "{q:?} came back as {back:?}");
        }
    }

    #[test]
    fn the_largest_component_index_sits_in_the_top_two_bits() {
        // z (index 2) largest: the reference library stores it as 2 << 30.
        assert_eq!(pack_smallest_three([0.0, 0.0, 1.0, 0.0]) >> 30, 2);
    }

    #[test]
    fn sh_buckets_keep_zero_exact() {
        assert_eq!(quantise_sh(0.0, 8), 128);
        assert_eq!(quantise_sh(0.0, 16), 128);
        assert_eq!(quantise_sh(1.0, 16), 255);
    }
}
