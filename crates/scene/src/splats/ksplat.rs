//! mkkellogg's `.ksplat` (GaussianSplats3D): a 4096-byte header, `maxSections` section headers
//! of 1024 bytes, then each section's data. Header (little-endian): version major u8 (0) and minor
//! u8 (≥ 1) at 0–1, `maxSections` u32 at 4, `sections` u32 at 8, `maxSplats` u32 at 12, `splats`
//! u32 at 16, compression level u16 at 20 (0, 1 or 2), SH range f32 at 36 and 40 (level 2;
//! −1.5 and 1.5 when 0). Section header: `splats` u32 at 0, `maxSplats` u32 at 4, bucket capacity
//! u32 at 8, bucket count u32 at 12, bucket block size f32 at 16, bucket storage bytes u16 at 20
//! (12: a centre), quantisation range u32 at 24 (0: the level's default), full buckets u32 at 32,
//! partial buckets u32 at 36, SH degree u16 at 40. Section data: the partial buckets' sizes (u32
//! each), the bucket centres (f32 × 3 each), then `maxSplats` rows of: position (level 0: f32 × 3;
//! 1–2: u16 × 3, `(q − range) · block/2/range + centre`), linear scale and rotation `w x y z` (f32,
//! or f16 at levels 1–2), colour and opacity (u8 × 4, as `.splat`), and SH rest (f32, f16, or u8
//! within the SH range) ordered band by band, each band channel by channel.
//!
//! The writer makes level 0 (floats, one section, buckets of 256 whose centres are written but
//! not needed), which keeps every value of the `.splat` format plus the SH rest exactly.

use super::quantise::{logit_of_byte, sigmoid, to_u8};
use crate::gaussians::{sh_coeffs_for_degree, Gaussians, SH_C0};

/// Format name used in error messages.
pub(crate) const FORMAT: &str = ".ksplat";

const MAIN_HEADER: usize = 4096;
const SECTION_HEADER: usize = 1024;

/// Per compression level: bytes of position, scale, rotation, colour, one SH value; the default
/// quantisation range.
const LEVELS: [(usize, usize, usize, usize, usize, u32); 3] =
    [(12, 12, 16, 4, 4, 1), (6, 6, 8, 4, 2, 32767), (6, 6, 8, 4, 1, 32767)];

/// Buckets the writer makes.
const WRITE_BUCKET: usize = 256;

fn u16_at(b: &[u8], o: usize) -> u16 {
    u16::from_le_bytes([b[o], b[o + 1]])
}

fn u32_at(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}

fn f32_at(b: &[u8], o: usize) -> f32 {
    f32::from_bits(u32_at(b, o))
}

fn f16_at(b: &[u8], o: usize) -> f32 {
    half::f16::from_bits(u16_at(b, o)).to_f32()
}

/// True when `head` starts as a `.ksplat` header (version 0.x with x ≥ 1, a known compression
/// level) — checked only for files named `.ksplat`, as the header has no magic.
pub(crate) fn looks_like_ksplat(head: &[u8]) -> bool {
    head.len() >= 22 && head[0] == 0 && head[1] >= 1 && u16_at(head, 20) <= 2
}

/// Where SH value `i` of a row (band by band, channel by channel within a band) goes in the
/// INRIA `[3, K]` row of `k` coefficients per channel.
fn inria_index(i: usize, k: usize) -> usize {
    let (channel, coefficient) = if i < 9 {
        (i / 3, i % 3)
    } else if i < 24 {
        ((i - 9) / 5, (i - 9) % 5 + 3)
    } else {
        ((i - 24) / 7, (i - 24) % 7 + 8)
    };
    channel * k + coefficient
}

/// One section's header fields.
struct Section {
    splats: usize,
    max_splats: usize,
    bucket_capacity: usize,
    buckets: usize,
    block_size: f32,
    bucket_bytes: usize,
    range: u32,
    full_buckets: usize,
    partial_buckets: usize,
    sh_degree: u8,
}

impl Section {
    fn parse(h: &[u8], default_range: u32) -> Result<Section, String> {
        let sh_degree = u16_at(h, 40);
        if sh_degree > 3 {
            return Err(format!("a section has SH degree {sh_degree}; .ksplat has 0 to 3"));
        }
        let range = match u32_at(h, 24) {
            0 => default_range,
            r => r,
        };
        Ok(Section {
            splats: u32_at(h, 0) as usize,
            max_splats: u32_at(h, 4) as usize,
            bucket_capacity: u32_at(h, 8) as usize,
            buckets: u32_at(h, 12) as usize,
            block_size: f32_at(h, 16),
            bucket_bytes: u16_at(h, 20) as usize,
            range,
            full_buckets: u32_at(h, 32) as usize,
            partial_buckets: u32_at(h, 36) as usize,
            sh_degree: sh_degree as u8,
        })
    }
}

/// Decodes a whole `.ksplat`; every size a header declares is checked against the file before
/// anything of that size is allocated.
pub(crate) fn parse_ksplat(file: &[u8]) -> Result<Gaussians, String> {
    if file.len() < MAIN_HEADER {
        return Err(format!("{} bytes, fewer than the 4096-byte .ksplat header", file.len()));
    }
    let (major, minor) = (file[0], file[1]);
    if major != 0 || minor < 1 {
        return Err(format!("version {major}.{minor}; splatseg reads .ksplat versions 0.1 and later 0.x"));
    }
    let level = u16_at(file, 20) as usize;
    let Some(&(pos_bytes, scale_bytes, rot_bytes, colour_bytes, sh_bytes, default_range)) = LEVELS.get(level)
    else {
        return Err(format!("compression level {level}; .ksplat has 0, 1 and 2"));
    };
    let total = u32_at(file, 16) as u64;
    crate::limits::check_gaussians(total)?;
    let (sh_min, sh_max) = match (f32_at(file, 36), f32_at(file, 40)) {
        (lo, hi) if lo != 0.0 && hi != 0.0 => (lo, hi),
        _ => (-1.5, 1.5),
    };
    let sections = u32_at(file, 4) as usize;
    let headers_end = sections
        .checked_mul(SECTION_HEADER)
        .and_then(|b| b.checked_add(MAIN_HEADER))
        .filter(|&end| end <= file.len())
        .ok_or_else(|| format!("{sections} section headers do not fit in the file's {} bytes", file.len()))?;
    let parsed: Vec<Section> = (0..sections)
        .map(|s| Section::parse(&file[MAIN_HEADER + s * SECTION_HEADER..], default_range))
        .collect::<Result<_, _>>()?;
    let degree = parsed.iter().filter(|s| s.splats > 0).map(|s| s.sh_degree).max().unwrap_or(0);
    let k = sh_coeffs_for_degree(degree) - 1;
    let declared: usize = parsed.iter().map(|s| s.splats).fold(0usize, usize::saturating_add);
    if declared as u64 != total {
        return Err(format!("the sections hold {declared} Gaussians, the header says {total}"));
    }
    // Every section's place in the file, checked before anything per Gaussian is allocated.
    let mut layouts = Vec::with_capacity(sections);
    let mut offset = headers_end;
    for (index, s) in parsed.iter().enumerate() {
        let too_big = || format!("section {index} declares more data than the file holds");
        let components = 3 * (sh_coeffs_for_degree(s.sh_degree) - 1);
        let row = pos_bytes + scale_bytes + rot_bytes + colour_bytes + components * sh_bytes;
        let meta = s.partial_buckets.checked_mul(4).ok_or_else(too_big)?;
        let centres = s.buckets.checked_mul(s.bucket_bytes).ok_or_else(too_big)?;
        let data = row.checked_mul(s.max_splats).ok_or_else(too_big)?;
        let end =
            [meta, centres, data].iter().try_fold(offset, |o, &b| o.checked_add(b)).ok_or_else(too_big)?;
        if end > file.len() {
            return Err(format!(
                "truncated: section {index} needs bytes {offset}..{end} but the file has {}",
                file.len()
            ));
        }
        if s.splats > s.max_splats {
            return Err(format!("section {index} holds {} Gaussians in room for {}", s.splats, s.max_splats));
        }
        if level > 0 && s.splats > 0 && s.bucket_bytes < 12 {
            return Err(format!("section {index} has {}-byte buckets; a centre needs 12", s.bucket_bytes));
        }
        layouts.push((offset, meta, centres, end, row, components));
        offset = end;
    }
    let n = total as usize;
    let mut g = Gaussians {
        means: Vec::with_capacity(n),
        sh_dc: Vec::with_capacity(n),
        sh_degree: degree,
        sh_rest: Vec::with_capacity(n * 3 * k),
        raw_opacities: Vec::with_capacity(n),
        log_scales: Vec::with_capacity(n),
        rotations: Vec::with_capacity(n),
        ..Gaussians::default()
    };
    for (index, (s, &(offset, meta, centres, end, row, components))) in
        parsed.iter().zip(&layouts).enumerate()
    {
        let partial_sizes: Vec<usize> =
            (0..s.partial_buckets).map(|b| u32_at(file, offset + 4 * b) as usize).collect();
        let centre_bytes = &file[offset + meta..offset + meta + centres];
        let rows = &file[offset + meta + centres..end];
        let buckets_of = bucket_of_each(s, &partial_sizes).map_err(|e| format!("section {index}: {e}"))?;
        let unit = s.block_size / 2.0 / s.range as f32;
        for (i, r) in rows.chunks_exact(row.max(1)).take(s.splats).enumerate() {
            let mean = if level == 0 {
                [0, 1, 2].map(|a| f32_at(r, 4 * a))
            } else {
                let b = buckets_of[i];
                if b >= s.buckets {
                    return Err(format!("section {index}: Gaussian {i} in bucket {b} of {}", s.buckets));
                }
                let c = &centre_bytes[b * s.bucket_bytes..];
                [0, 1, 2].map(|a| (u16_at(r, 2 * a) as f32 - s.range as f32) * unit + f32_at(c, 4 * a))
            };
            let wide = |o: usize| if level == 0 { f32_at(r, o) } else { f16_at(r, o) };
            let step = if level == 0 { 4 } else { 2 };
            g.means.push(mean);
            g.log_scales.push([0, 1, 2].map(|a| wide(pos_bytes + step * a).ln()));
            g.rotations.push([0, 1, 2, 3].map(|a| wide(pos_bytes + scale_bytes + step * a)));
            let c = pos_bytes + scale_bytes + rot_bytes;
            g.sh_dc.push([0, 1, 2].map(|ch| (r[c + ch] as f32 / 255.0 - 0.5) / SH_C0));
            g.raw_opacities.push(logit_of_byte(r[c + 3]));
            let mut rest = vec![0.0; 3 * k];
            for j in 0..components {
                let o = c + colour_bytes + j * sh_bytes;
                rest[inria_index(j, k)] = match level {
                    0 => f32_at(r, o),
                    1 => f16_at(r, o),
                    _ => sh_min + r[o] as f32 / 255.0 * (sh_max - sh_min),
                };
            }
            g.sh_rest.extend_from_slice(&rest);
        }
    }
    Ok(g)
}

/// The bucket of each of a section's Gaussians: full buckets of `bucket_capacity`, then the
/// partial buckets by their sizes.
fn bucket_of_each(s: &Section, partial_sizes: &[usize]) -> Result<Vec<usize>, String> {
    let full = s.full_buckets.checked_mul(s.bucket_capacity).filter(|&f| f <= s.splats);
    let full = full.ok_or_else(|| {
        format!(
            "{} full buckets of {} hold more than its {} Gaussians",
            s.full_buckets, s.bucket_capacity, s.splats
        )
    })?;
    let mut of = Vec::with_capacity(s.splats);
    of.extend((0..full).map(|i| i / s.bucket_capacity.max(1)));
    for (p, &size) in partial_sizes.iter().enumerate() {
        let room = s.splats - of.len();
        of.extend(std::iter::repeat_n(s.full_buckets + p, size.min(room)));
    }
    // Gaussians past the declared buckets stay in the last one, as the reference reader leaves them.
    let last = of.last().copied().unwrap_or(0);
    of.resize(s.splats, last);
    Ok(of)
}

/// The bytes of a level-0 `.ksplat` holding `g` (which the caller validated: finite values).
pub(crate) fn to_ksplat_bytes(g: &Gaussians) -> Vec<u8> {
    let n = g.len();
    let k = g.rest_per_channel();
    let components = 3 * k;
    let buckets = n.div_ceil(WRITE_BUCKET);
    let (full, partial) = (n / WRITE_BUCKET, usize::from(!n.is_multiple_of(WRITE_BUCKET)));
    let row = 12 + 12 + 16 + 4 + 4 * components;
    let section_bytes = 4 * partial + 12 * buckets + row * n;
    let mut out = vec![0u8; MAIN_HEADER + SECTION_HEADER];
    let put_u32 = |out: &mut Vec<u8>, o: usize, v: u32| out[o..o + 4].copy_from_slice(&v.to_le_bytes());
    out[1] = 1;
    put_u32(&mut out, 4, 1);
    put_u32(&mut out, 8, 1);
    put_u32(&mut out, 12, n as u32);
    put_u32(&mut out, 16, n as u32);
    out[36..40].copy_from_slice(&(-1.5f32).to_le_bytes());
    out[40..44].copy_from_slice(&1.5f32.to_le_bytes());
    let s = MAIN_HEADER;
    put_u32(&mut out, s, n as u32);
    put_u32(&mut out, s + 4, n as u32);
    put_u32(&mut out, s + 8, WRITE_BUCKET as u32);
    put_u32(&mut out, s + 12, buckets as u32);
    out[s + 16..s + 20].copy_from_slice(&5.0f32.to_le_bytes());
    out[s + 20..s + 22].copy_from_slice(&12u16.to_le_bytes());
    put_u32(&mut out, s + 24, 1);
    put_u32(&mut out, s + 28, section_bytes as u32);
    put_u32(&mut out, s + 32, full as u32);
    put_u32(&mut out, s + 36, partial as u32);
    out[s + 40..s + 42].copy_from_slice(&(g.sh_degree as u16).to_le_bytes());
    out.reserve(section_bytes);
    if partial == 1 {
        out.extend_from_slice(&((n % WRITE_BUCKET) as u32).to_le_bytes());
    }
    for first in (0..n).step_by(WRITE_BUCKET) {
        let members = first..(first + WRITE_BUCKET).min(n);
        let count = members.len() as f32;
        for a in 0..3 {
            let centre = members.clone().map(|i| g.means[i][a]).sum::<f32>() / count;
            out.extend_from_slice(&centre.to_le_bytes());
        }
    }
    for i in 0..n {
        let q = g.rotations[i];
        let norm = q.iter().map(|v| v * v).sum::<f32>().sqrt();
        let unit = if norm > 0.0 { q.map(|v| v / norm) } else { [1.0, 0.0, 0.0, 0.0] };
        let floats = g.means[i].into_iter().chain(g.scales(i)).chain(unit);
        for v in floats {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend(g.sh_dc[i].map(|dc| to_u8((0.5 + SH_C0 * dc) * 255.0)));
        out.push(to_u8(sigmoid(g.raw_opacities[i]) * 255.0));
        let rest = &g.sh_rest[i * components..(i + 1) * components];
        for j in 0..components {
            out.extend_from_slice(&rest[inria_index(j, k)].to_le_bytes());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::inria_index;

    #[test]
    fn sh_order_is_band_by_band_then_channel_by_channel() {
        // Degree 3 (K = 15): band 1 of green is values 3..6, coefficients 0..3 of channel 1.
        assert_eq!(inria_index(3, 15), 15);
        // Band 2 starts at value 9: red coefficient 3, then blue band 2 at 19.
        assert_eq!(inria_index(9, 15), 3);
        assert_eq!(inria_index(19, 15), 2 * 15 + 3);
        // Band 3's last value: blue coefficient 14.
        assert_eq!(inria_index(44, 15), 44);
        let mut seen: Vec<usize> = (0..45).map(|i| inria_index(i, 15)).collect();
        seen.sort_unstable();
        assert_eq!(seen, (0..45).collect::<Vec<_>>());
    }
}
