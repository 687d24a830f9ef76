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

use super::quantise::{logit_of_byte, sh_rest_to_coefficient_major, sigmoid, to_u8};
use crate::gaussians::{sh_coeffs_for_degree, Gaussians};
use flate2::read::GzDecoder;
use flate2::write::GzEncoder;
use rayon::prelude::*;
use std::io::{Read, Write};

/// Format name used in error messages.
pub(crate) const FORMAT: &str = "SPZ";

/// "NGSP" read as a little-endian u32.
const MAGIC: u32 = 0x5053_474e;

/// The header's size in bytes.
const HEADER_BYTES: usize = 16;

/// Header flag: trained with antialiasing (kept by nothing in splatseg, accepted).
const FLAG_ANTIALIASED: u8 = 0x1;

/// DC colours are stored as `f_dc · COLOUR_SCALE`, a smaller factor than SH_C0 so that colours a
/// little outside [0, 1] survive.
const COLOUR_SCALE: f32 = 0.15;

/// Fractional bits of the positions the writer makes (≈ 0.24 mm).
const WRITE_FRACTIONAL_BITS: u8 = 12;

/// 1/√2: the largest magnitude the three smallest components of a unit quaternion can have.
const SQRT1_2: f32 = std::f32::consts::FRAC_1_SQRT_2;

/// Sign of each SH rest coefficient `k` (INRIA order, bands 1–3) under the 180° turn about x
/// between SPZ's frame and the PLY's: −1 where the basis function is odd in y and z together.
const SH_FLIP: [f32; 15] = [-1., -1., 1., -1., 1., 1., -1., 1., -1., 1., -1., -1., 1., -1., 1.];

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

    /// Bytes per Gaussian after the header.
    fn row_bytes(&self) -> usize {
        9 + 1 + 3 + 3 + self.rotation_bytes() + 3 * self.rest_per_channel()
    }
}

/// True when `bytes` start as a gzip stream (what SPZ files are).
pub(crate) fn is_gzip(bytes: &[u8]) -> bool {
    bytes.starts_with(&[0x1f, 0x8b])
}

/// Decodes a whole `.spz` file. Each attribute is decoded (in parallel) while the stream goes on
/// inflating the next, and the SH rest chunk by chunk, so reading takes little more than inflating.
/// Sizes are checked before any per-Gaussian array is made: an attribute is read up to the size
/// the header declares and no further, and its array is made once its bytes have arrived (the SH
/// array once the 20 bytes of every Gaussian's other attributes have), so a small file declaring
/// many Gaussians is an error, not an allocation. The stream is then drained to check gzip's CRC.
pub(crate) fn parse_spz(file: &[u8]) -> Result<Gaussians, String> {
    if !is_gzip(file) {
        return Err("not a gzip stream (SPZ files start with bytes 1f 8b)".to_string());
    }
    let mut stream = GzDecoder::new(file);
    let mut head = Vec::with_capacity(HEADER_BYTES);
    (&mut stream).take(HEADER_BYTES as u64).read_to_end(&mut head).map_err(gzip_error)?;
    let header = Header::parse(&head)?;
    let n = header.count;
    let k = header.rest_per_channel();
    let mut g = Gaussians { sh_degree: header.sh_degree, ..Gaussians::default() };
    let Gaussians { means, sh_dc, sh_rest, raw_opacities, log_scales, rotations, .. } = &mut g;
    let mut read = Attributes { stream: &mut stream, header, done: 0 };
    rayon::scope(|scope| -> Result<(), String> {
        let bytes = read.next(9 * n, "positions")?;
        scope.spawn(move |_| *means = decode_positions(&bytes, header.fractional_bits));
        let bytes = read.next(n, "alphas")?;
        scope.spawn(move |_| *raw_opacities = bytes.par_iter().map(|&a| logit_of_byte(a)).collect());
        let bytes = read.next(3 * n, "colours")?;
        scope.spawn(move |_| {
            *sh_dc = bytes
                .par_chunks_exact(3)
                .map(|c| [0, 1, 2].map(|i| (c[i] as f32 / 255.0 - 0.5) / COLOUR_SCALE))
                .collect()
        });
        let bytes = read.next(3 * n, "scales")?;
        scope.spawn(move |_| {
            *log_scales =
                bytes.par_chunks_exact(3).map(|s| [0, 1, 2].map(|i| s[i] as f32 / 16.0 - 10.0)).collect()
        });
        let rotation_bytes = header.rotation_bytes();
        let bytes = read.next(rotation_bytes * n, "rotations")?;
        scope.spawn(move |_| *rotations = decode_rotations(&bytes, rotation_bytes));
        if k > 0 {
            *sh_rest = vec![0.0f32; 3 * k * n];
            for out in sh_rest.chunks_mut(3 * k * SH_ROWS_PER_TASK) {
                let bytes = read.next(out.len(), "SH coefficients")?;
                scope.spawn(move |_| decode_sh(&bytes, out, k));
            }
        }
        Ok(())
    })?;
    std::io::copy(&mut stream, &mut std::io::sink()).map_err(gzip_error)?;
    Ok(g)
}

/// Gaussians whose SH rest one task decodes while the stream inflates the next ones.
const SH_ROWS_PER_TASK: usize = 64 * 1024;

/// The attributes of the body, read one after the other from the inflating stream.
struct Attributes<'a, R: Read> {
    stream: &'a mut R,
    header: Header,
    /// Body bytes read so far.
    done: u64,
}

impl<R: Read> Attributes<'_, R> {
    /// The next `len` bytes of the body (`what` they hold), or an error saying the stream ends first.
    fn next(&mut self, len: usize, what: &str) -> Result<Vec<u8>, String> {
        let mut bytes = Vec::with_capacity(len);
        (&mut *self.stream).take(len as u64).read_to_end(&mut bytes).map_err(gzip_error)?;
        self.done += bytes.len() as u64;
        if bytes.len() < len {
            let h = &self.header;
            return Err(format!(
                "truncated: the header declares {} Gaussians × {} bytes = {} bytes but the stream \
                 ends after {} of them, in the {what}",
                h.count,
                h.row_bytes(),
                h.count as u64 * h.row_bytes() as u64,
                self.done
            ));
        }
        Ok(bytes)
    }
}

fn gzip_error(e: std::io::Error) -> String {
    format!("the gzip stream is truncated or corrupt ({e})")
}

/// `[N]` centres in the PLY's frame from `[N, 3]` 24-bit fixed-point coordinates.
fn decode_positions(bytes: &[u8], fractional_bits: u8) -> Vec<[f32; 3]> {
    let unit = 1.0 / (1u32 << fractional_bits) as f32;
    let flip = [1.0, -1.0, -1.0];
    bytes
        .par_chunks_exact(9)
        .map(|p| {
            [0, 1, 2].map(|a| {
                let b = &p[3 * a..3 * a + 3];
                let fixed = i32::from_le_bytes([b[0], b[1], b[2], 0]) << 8 >> 8;
                flip[a] * fixed as f32 * unit
            })
        })
        .collect()
}

/// `[N]` quaternions `w x y z` in the PLY's frame from version 2's (3 bytes) or 3's (4 bytes).
fn decode_rotations(bytes: &[u8], rotation_bytes: usize) -> Vec<[f32; 4]> {
    bytes
        .par_chunks_exact(rotation_bytes)
        .map(|r| {
            rdf_quaternion(if rotation_bytes == 4 { smallest_three_xyzw(r) } else { first_three_xyzw(r) })
        })
        .collect()
}

/// SH rest stored `[rows, K, 3]` (channel fastest) into `out`, `[rows, 3, K]`, in the PLY's frame.
fn decode_sh(bytes: &[u8], out: &mut [f32], k: usize) {
    out.par_chunks_mut(3 * k).zip(bytes.par_chunks_exact(3 * k)).for_each(|(row, q)| {
        for j in 0..k {
            for c in 0..3 {
                row[c * k + j] = SH_FLIP[j] * (q[3 * j + c] as f32 - 128.0) / 128.0;
            }
        }
    });
}

/// Version 2: x y z of a unit quaternion with w ≥ 0; w is what makes the norm 1.
fn first_three_xyzw(r: &[u8]) -> [f32; 4] {
    let [x, y, z] = [0, 1, 2].map(|i| r[i] as f32 / 127.5 - 1.0);
    [x, y, z, (1.0 - x * x - y * y - z * z).max(0.0).sqrt()]
}

/// Version 3: a little-endian u32 whose top 2 bits index the largest of x y z w (stored
/// positive, so not stored), then the other three from the first (highest bits) to the last,
/// each a sign bit and 9 bits of magnitude in units of (1/√2)/511.
fn smallest_three_xyzw(r: &[u8]) -> [f32; 4] {
    let mut packed = u32::from_le_bytes([r[0], r[1], r[2], r[3]]);
    let largest = (packed >> 30) as usize;
    let mut q = [0.0f32; 4];
    let mut sum_squares = 0.0;
    for i in (0..4).rev().filter(|&i| i != largest) {
        let magnitude = (packed & 0x1ff) as f32 / 511.0 * SQRT1_2;
        q[i] = if packed & 0x200 != 0 { -magnitude } else { magnitude };
        sum_squares += q[i] * q[i];
        packed >>= 10;
    }
    q[largest] = (1.0 - sum_squares).max(0.0).sqrt();
    q
}

/// An SPZ-frame quaternion `x y z w` as the PLY's `w x y z` in the PLY's frame.
fn rdf_quaternion([x, y, z, w]: [f32; 4]) -> [f32; 4] {
    [w, x, -y, -z]
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
