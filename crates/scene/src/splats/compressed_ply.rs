//! PlayCanvas / SuperSplat's compressed PLY (`*.compressed.ply`): a binary little-endian PLY with
//! three elements. `chunk` (one row per 256 Gaussians, `float`): `min_x min_y min_z max_x max_y
//! max_z`, `min_scale_* max_scale_*` (log-scales) and optionally `min_r min_g min_b max_r max_g
//! max_b` (colours `0.5 + SH_C0 · f_dc`). `vertex` (`uint` each): `packed_position` and
//! `packed_scale` as 11-10-11 bits of unorm between the chunk's bounds (x in the top bits),
//! `packed_rotation` as 2 bits for the largest of `rot_0..rot_3` (stored positive) and 3 × 10 bits
//! of the others in order, `(q·√2/2 + 0.5)` as unorm, `packed_color` as 8-8-8-8 bits (r g b
//! between the chunk's colour bounds, or absolute without them; then the opacity after the
//! sigmoid). `sh` (optional, `uchar`): `f_rest_0..` in the INRIA order, `trunc((v/8 + 0.5) · 256)`.
//!
//! The writer keeps the Gaussians in their order (splat-transform sorts them along a Morton curve;
//! the format does not need it) and always writes the chunk colours.

use super::quantise::{logit_of_byte, sigmoid};
use crate::gaussians::{Gaussians, SH_C0};
use crate::ply::header::{parse_header, BodyFormat, ElementDecl};
use crate::ply::scalar::ScalarType;

/// Format name used in error messages.
pub(crate) const FORMAT: &str = "compressed PLY";

/// Gaussians per chunk.
const CHUNK: usize = 256;

/// The chunk bounds every file has, in the order the writer writes them.
const CHUNK_BOUNDS: [&str; 12] = [
    "min_x",
    "min_y",
    "min_z",
    "max_x",
    "max_y",
    "max_z",
    "min_scale_x",
    "min_scale_y",
    "min_scale_z",
    "max_scale_x",
    "max_scale_y",
    "max_scale_z",
];

/// The optional colour bounds of a chunk.
const CHUNK_COLOURS: [&str; 6] = ["min_r", "min_g", "min_b", "max_r", "max_g", "max_b"];

/// The packed words of a Gaussian.
const VERTEX_WORDS: [&str; 4] = ["packed_position", "packed_rotation", "packed_scale", "packed_color"];

/// True when a PLY header (at the start of `head`) declares a `chunk` element: a compressed PLY.
pub(crate) fn is_compressed_ply(head: &[u8]) -> bool {
    let end = head.windows(10).position(|w| w == b"end_header").unwrap_or(head.len());
    head[..end].split(|&b| b == b'\n').any(|line| line.starts_with(b"element chunk "))
}

/// Byte offsets of named properties in an element's rows, each of type `ty`.
fn offsets<const K: usize>(e: &ElementDecl, names: &[&str; K], ty: ScalarType) -> Result<[usize; K], String> {
    let mut out = [0usize; K];
    for (slot, name) in out.iter_mut().zip(names) {
        let mut offset = 0;
        let mut found = None;
        for p in &e.properties {
            if p.name == *name {
                found = Some((offset, p));
            }
            offset += p.ty.size();
        }
        let (offset, p) = found.ok_or_else(|| format!("element '{}' has no property '{name}'", e.name))?;
        if p.ty != ty {
            return Err(format!(
                "property '{name}' of element '{}' is '{}', where the format has {}",
                e.name,
                p.type_name,
                if ty == ScalarType::F32 {
                    "float"
                } else if ty == ScalarType::U32 {
                    "uint"
                } else {
                    "uchar"
                }
            ));
        }
        *slot = offset;
    }
    Ok(out)
}

fn f32_at(row: &[u8], o: usize) -> f32 {
    f32::from_le_bytes([row[o], row[o + 1], row[o + 2], row[o + 3]])
}

fn u32_at(row: &[u8], o: usize) -> u32 {
    u32::from_le_bytes([row[o], row[o + 1], row[o + 2], row[o + 3]])
}

fn unorm(value: u32, bits: u32) -> f32 {
    let top = (1u32 << bits) - 1;
    (value & top) as f32 / top as f32
}

fn lerp(min: f32, max: f32, t: f32) -> f32 {
    min * (1.0 - t) + max * t
}

/// Three unorms packed 11-10-11 (the first in the top bits).
fn unpack_11_10_11(v: u32) -> [f32; 3] {
    [unorm(v >> 21, 11), unorm(v >> 11, 10), unorm(v, 11)]
}

/// A quaternion in the order of `rot_0..rot_3` from its 2-10-10-10 word.
fn unpack_rotation(v: u32) -> [f32; 4] {
    let scale = std::f32::consts::SQRT_2;
    let others = [v >> 20, v >> 10, v].map(|bits| (unorm(bits, 10) - 0.5) * scale);
    let largest = (v >> 30) as usize;
    let rest = others.iter().map(|x| x * x).sum::<f32>();
    let mut q = [0.0; 4];
    let mut next = others.iter();
    for (i, slot) in q.iter_mut().enumerate() {
        *slot = if i == largest { (1.0 - rest).max(0.0).sqrt() } else { *next.next().unwrap_or(&0.0) };
    }
    q
}

/// Decodes a whole compressed PLY; sizes (chunk count, element sizes against the file) are
/// checked before anything per Gaussian is allocated.
pub(crate) fn parse_compressed_ply(file: &[u8]) -> Result<Gaussians, String> {
    let header = parse_header(file)?;
    if header.format != BodyFormat::BinaryLittleEndian {
        return Err("a compressed PLY is binary_little_endian".to_string());
    }
    let names: Vec<&str> = header.elements.iter().map(|e| e.name.as_str()).collect();
    let (chunk, vertex, sh) = match names.as_slice() {
        ["chunk", "vertex"] => (&header.elements[0], &header.elements[1], None),
        ["chunk", "vertex", "sh"] => (&header.elements[0], &header.elements[1], Some(&header.elements[2])),
        _ => {
            return Err(format!(
                "elements {names:?}, where a compressed PLY has chunk, vertex and optionally sh"
            ))
        }
    };
    let n = vertex.count;
    crate::limits::check_gaussians(n as u64)?;
    if chunk.count != n.div_ceil(CHUNK) {
        return Err(format!(
            "{} chunks for {n} Gaussians, where chunks of {CHUNK} make {}",
            chunk.count,
            n.div_ceil(CHUNK)
        ));
    }
    let bounds = offsets(chunk, &CHUNK_BOUNDS, ScalarType::F32)?;
    let colours = chunk.properties.iter().any(|p| p.name == "min_r");
    let colour_bounds = if colours { Some(offsets(chunk, &CHUNK_COLOURS, ScalarType::F32)?) } else { None };
    let words = offsets(vertex, &VERTEX_WORDS, ScalarType::U32)?;
    let rest = match sh {
        None => 0,
        Some(e) => {
            if !e.properties.iter().all(|p| p.ty == ScalarType::U8)
                || ![9, 24, 45].contains(&e.properties.len())
            {
                return Err("the sh element has 9, 24 or 45 uchar properties f_rest_*".to_string());
            }
            if e.count != n {
                return Err(format!("{} sh rows for {n} Gaussians", e.count));
            }
            e.properties.len()
        }
    };
    let rest_names: Vec<String> = (0..rest).map(|k| format!("f_rest_{k}")).collect();
    let rest_offsets = match sh {
        None => Vec::new(),
        Some(e) => rest_names
            .iter()
            .map(|name| {
                e.properties
                    .iter()
                    .position(|p| &p.name == name)
                    .ok_or_else(|| format!("the sh element has no property '{name}'"))
            })
            .collect::<Result<Vec<usize>, String>>()?,
    };
    let mut sizes = [chunk, vertex].into_iter().chain(sh).map(|e| e.count.checked_mul(e.row_bytes()));
    let total = sizes.try_fold(0usize, |acc, s| s.and_then(|s| acc.checked_add(s)));
    let body = &file[header.body_offset..];
    match total {
        Some(t) if t == body.len() => {}
        Some(t) => {
            return Err(format!(
                "the header declares {t} bytes of chunks, vertices and SH but {} follow it{}",
                body.len(),
                if body.len() < t { " (truncated)" } else { "" }
            ))
        }
        None => return Err("the header declares more data than any file can hold".to_string()),
    }
    let (chunk_rows, rest_bytes) = body.split_at(chunk.count * chunk.row_bytes());
    let (vertex_rows, sh_rows) = rest_bytes.split_at(n * vertex.row_bytes());
    let degree = match rest {
        0 => 0,
        9 => 1,
        24 => 2,
        _ => 3,
    };
    let mut g = Gaussians {
        means: Vec::with_capacity(n),
        sh_dc: Vec::with_capacity(n),
        sh_degree: degree,
        sh_rest: Vec::with_capacity(n * rest),
        raw_opacities: Vec::with_capacity(n),
        log_scales: Vec::with_capacity(n),
        rotations: Vec::with_capacity(n),
        ..Gaussians::default()
    };
    for (i, row) in vertex_rows.chunks_exact(vertex.row_bytes().max(1)).take(n).enumerate() {
        let c = &chunk_rows[(i / CHUNK) * chunk.row_bytes()..][..chunk.row_bytes()];
        let b = bounds.map(|o| f32_at(c, o));
        let [p, r, s, colour] = words.map(|o| u32_at(row, o));
        let p = unpack_11_10_11(p);
        g.means.push([0, 1, 2].map(|a| lerp(b[a], b[3 + a], p[a])));
        let s = unpack_11_10_11(s);
        g.log_scales.push([0, 1, 2].map(|a| lerp(b[6 + a], b[9 + a], s[a])));
        g.rotations.push(unpack_rotation(r));
        let rgb = [unorm(colour >> 24, 8), unorm(colour >> 16, 8), unorm(colour >> 8, 8)];
        let rgb = match colour_bounds {
            Some(cb) => [0, 1, 2].map(|k| lerp(f32_at(c, cb[k]), f32_at(c, cb[3 + k]), rgb[k])),
            None => rgb,
        };
        g.sh_dc.push(rgb.map(|v| (v - 0.5) / SH_C0));
        g.raw_opacities.push(logit_of_byte((colour & 0xff) as u8));
    }
    if let Some(e) = sh {
        for row in sh_rows.chunks_exact(e.row_bytes().max(1)).take(n) {
            g.sh_rest.extend(rest_offsets.iter().map(|&o| {
                let t = match row[o] {
                    0 => 0.0,
                    255 => 1.0,
                    v => (v as f32 + 0.5) / 256.0,
                };
                (t - 0.5) * 8.0
            }));
        }
    }
    Ok(g)
}

/// `(x − min) / (max − min)` clamped to [0, 1] (0 when the range is below 1e-5).
fn normalise(x: f32, min: f32, max: f32) -> f32 {
    if x <= min {
        0.0
    } else if x >= max {
        1.0
    } else if max - min < 1e-5 {
        0.0
    } else {
        (x - min) / (max - min)
    }
}

fn pack_unorm(t: f32, bits: u32) -> u32 {
    let top = ((1u32 << bits) - 1) as f32;
    (t * top + 0.5).floor().clamp(0.0, top) as u32
}

/// The 2-10-10-10 word of a quaternion (`rot_0..rot_3` order, any norm but zero).
fn pack_rotation(q: [f32; 4]) -> u32 {
    let norm = q.iter().map(|v| v * v).sum::<f32>().sqrt();
    let q = if norm > 0.0 { q.map(|v| v / norm) } else { [1.0, 0.0, 0.0, 0.0] };
    let largest = (1..4).fold(0, |best, i| if q[i].abs() > q[best].abs() { i } else { best });
    let q = if q[largest] < 0.0 { q.map(|v| -v) } else { q };
    let half_sqrt2 = std::f32::consts::FRAC_1_SQRT_2;
    (0..4)
        .filter(|&i| i != largest)
        .fold(largest as u32, |word, i| (word << 10) | pack_unorm(q[i] * half_sqrt2 + 0.5, 10))
}

/// Min and max of `values`.
fn range(values: impl Iterator<Item = f32>) -> (f32, f32) {
    values.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)))
}

/// The bytes of a compressed PLY holding `g` (which the caller validated: finite values).
pub(crate) fn to_compressed_ply_bytes(g: &Gaussians) -> Vec<u8> {
    let n = g.len();
    let chunks = n.div_ceil(CHUNK);
    let rest = 3 * g.rest_per_channel();
    let mut header = String::from("ply\nformat binary_little_endian 1.0\ncomment written by splatseg\n");
    header += &format!("element chunk {chunks}\n");
    for name in CHUNK_BOUNDS.iter().chain(&CHUNK_COLOURS) {
        header += &format!("property float {name}\n");
    }
    header += &format!("element vertex {n}\n");
    for name in VERTEX_WORDS {
        header += &format!("property uint {name}\n");
    }
    if rest > 0 {
        header += &format!("element sh {n}\n");
        for k in 0..rest {
            header += &format!("property uchar f_rest_{k}\n");
        }
    }
    header += "end_header\n";
    let mut chunk_bytes = Vec::with_capacity(chunks * 18 * 4);
    let mut vertex_bytes = Vec::with_capacity(n * 16);
    for first in (0..n).step_by(CHUNK) {
        let members = first..(first + CHUNK).min(n);
        let colour = |i: usize| g.sh_dc[i].map(|dc| dc * SH_C0 + 0.5);
        let position = [0, 1, 2].map(|a| range(members.clone().map(|i| g.means[i][a])));
        let scale = [0, 1, 2].map(|a| {
            let (lo, hi) = range(members.clone().map(|i| g.log_scales[i][a]));
            (lo.clamp(-20.0, 20.0), hi.clamp(-20.0, 20.0))
        });
        let rgb = [0, 1, 2].map(|k| range(members.clone().map(|i| colour(i)[k])));
        let floats = [position, scale, rgb].map(|b| (b.map(|(lo, _)| lo), b.map(|(_, hi)| hi)));
        for (lo, hi) in floats {
            for v in lo.into_iter().chain(hi) {
                chunk_bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
        for i in members {
            let t = |b: [(f32, f32); 3], v: [f32; 3], a: usize| normalise(v[a], b[a].0, b[a].1);
            let p = g.means[i];
            let s = g.log_scales[i];
            let c = colour(i);
            let packed_position = pack_unorm(t(position, p, 0), 11) << 21
                | pack_unorm(t(position, p, 1), 10) << 11
                | pack_unorm(t(position, p, 2), 11);
            let packed_scale = pack_unorm(t(scale, s, 0), 11) << 21
                | pack_unorm(t(scale, s, 1), 10) << 11
                | pack_unorm(t(scale, s, 2), 11);
            let packed_colour = pack_unorm(t(rgb, c, 0), 8) << 24
                | pack_unorm(t(rgb, c, 1), 8) << 16
                | pack_unorm(t(rgb, c, 2), 8) << 8
                | pack_unorm(sigmoid(g.raw_opacities[i]), 8);
            for word in [packed_position, pack_rotation(g.rotations[i]), packed_scale, packed_colour] {
                vertex_bytes.extend_from_slice(&word.to_le_bytes());
            }
        }
    }
    let mut out = header.into_bytes();
    out.extend_from_slice(&chunk_bytes);
    out.extend_from_slice(&vertex_bytes);
    out.extend(g.sh_rest.iter().map(|&v| ((v / 8.0 + 0.5) * 256.0).trunc().clamp(0.0, 255.0) as u8));
    out
}
