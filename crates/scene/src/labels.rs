//! Label maps (8/16-bit grey PNGs, value = object id, 0 = unlabelled), the one id → colour
//! palette every output uses, and readable colour overlays.

use crate::error::{SceneError, SceneResult};
use crate::image_io::{write_png_luma16, RgbImage};
use crate::plane::Plane;
use std::path::Path;

const FORMAT: &str = "label map PNG";

/// Reads a label map: a greyscale PNG (8 or 16 bit; 1/2/4 bit too) or a palette-indexed PNG
/// (as DAVIS-style tools write them), whose value or palette index is the object id
/// (0 = unlabelled). Returns `[height, width]` ids.
pub fn read_label_png(path: &Path) -> SceneResult<Plane<u32>> {
    let bytes = std::fs::read(path).map_err(|e| SceneError::io("cannot read", path, e))?;
    parse_label_png(&bytes).map_err(|reason| SceneError::invalid(FORMAT, path, reason))
}

/// [`read_label_png`] on the bytes of a PNG file; the error is a reason without the file name.
/// The size in the header is checked against [`crate::limits::MAX_PIXELS`] before the pixels
/// are decoded.
pub fn parse_label_png(bytes: &[u8]) -> Result<Plane<u32>, String> {
    let invalid = |reason: String| reason;
    let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    // Keep palette indices and 16-bit values as stored.
    decoder.set_transformations(png::Transformations::IDENTITY);
    let mut reader = decoder.read_info().map_err(|e| invalid(format!("cannot decode PNG: {e}")))?;
    let (declared_w, declared_h) = (reader.info().width, reader.info().height);
    crate::limits::check_pixels("the label map", declared_w as u64, declared_h as u64)?;
    // Refused before the buffer is allocated: an RGBA 16-bit header at the pixel cap asks for
    // 2 GiB (found by the fuzz campaign).
    let declared = reader.info().color_type;
    if !matches!(declared, png::ColorType::Grayscale | png::ColorType::Indexed) {
        return Err(invalid(format!(
            "colour type {declared:?}; a label map must be greyscale (8 or 16 bit) or palette-indexed"
        )));
    }
    let size = reader.output_buffer_size().ok_or_else(|| invalid("image too large".to_string()))?;
    let mut buffer = vec![0u8; size];
    let frame = reader.next_frame(&mut buffer).map_err(|e| invalid(format!("cannot decode PNG: {e}")))?;
    if !matches!(frame.color_type, png::ColorType::Grayscale | png::ColorType::Indexed) {
        return Err(invalid(format!(
            "colour type {:?}; a label map must be greyscale (8 or 16 bit) or palette-indexed",
            frame.color_type
        )));
    }
    let (width, height) = (frame.width as usize, frame.height as usize);
    let bits = frame.bit_depth as usize;
    let mut data = Vec::with_capacity(width * height);
    for row in buffer.chunks_exact(frame.line_size).take(height) {
        match bits {
            16 => {
                data.extend(row.chunks_exact(2).take(width).map(|b| u16::from_be_bytes([b[0], b[1]]) as u32))
            }
            8 => data.extend(row.iter().take(width).map(|&v| v as u32)),
            _ => {
                // 1, 2 or 4 bits per pixel, most significant bits first.
                let per_byte = 8 / bits;
                let mask = (1u16 << bits) as u8 - 1;
                data.extend((0..width).map(|x| {
                    let shift = 8 - bits * (x % per_byte + 1);
                    ((row[x / per_byte] >> shift) & mask) as u32
                }));
            }
        }
    }
    Plane::from_vec(width, height, data).ok_or_else(|| invalid("PNG data shorter than its size".to_string()))
}

/// Writes a label map (`[height, width]` ids) as a 16-bit greyscale PNG, atomically. Fails if
/// an id exceeds 65535 (naming the first such pixel).
pub fn write_label_png(path: &Path, labels: &Plane<u32>) -> SceneResult<()> {
    if let Some(i) = labels.data.iter().position(|&id| id > u16::MAX as u32) {
        let (x, y) = (i % labels.width.max(1), i / labels.width.max(1));
        return Err(SceneError::invalid(
            FORMAT,
            path,
            format!("id {} at pixel ({x}, {y}) does not fit a 16-bit label map (max 65535)", labels.data[i]),
        ));
    }
    let data: Vec<u16> = labels.data.iter().map(|&id| id as u16).collect();
    let ids = Plane::from_vec(labels.width, labels.height, data)
        .ok_or_else(|| SceneError::invalid(FORMAT, path, "label plane size disagrees with its data"))?;
    write_png_luma16(path, &ids)
}

/// HSV (all in [0, 1]) to 8-bit RGB.
fn hsv_to_rgb(hue: f64, saturation: f64, value: f64) -> [u8; 3] {
    let h6 = (hue.fract() * 6.0).clamp(0.0, 5.999_999);
    let sector = h6.floor();
    let f = h6 - sector;
    let (p, q, t) =
        (value * (1.0 - saturation), value * (1.0 - saturation * f), value * (1.0 - saturation * (1.0 - f)));
    let (r, g, b) = match sector as u8 {
        0 => (value, t, p),
        1 => (q, value, p),
        2 => (p, value, t),
        3 => (p, q, value),
        4 => (t, p, value),
        _ => (value, p, q),
    };
    [r, g, b].map(|c| (c * 255.0).round() as u8)
}

/// The colour of object `id`: black for 0, otherwise a bright colour from a fixed sequence
/// (hue stepped by the golden ratio, saturation/value cycled over four levels so that ids whose
/// hues nearly repeat, 13 or 21 apart, still differ) so nearby ids look different.
/// Deterministic: the same id has the same colour in every output.
pub fn colour_of_id(id: u32) -> [u8; 3] {
    /// (saturation, value) levels, cycled by id.
    const LEVELS: [(f64, f64); 4] = [(0.85, 0.95), (0.5, 1.0), (1.0, 0.7), (0.6, 0.8)];
    if id == 0 {
        return [0, 0, 0];
    }
    let hue = (id as f64 * 0.618_033_988_749_895).fract();
    let (s, v) = LEVELS[(id % 4) as usize];
    hsv_to_rgb(hue, s, v)
}

/// The label map in palette colours (`[height, width]` ids → RGB, 0 = black).
pub fn label_colour_image(labels: &Plane<u32>) -> RgbImage {
    let raw: Vec<u8> = labels.data.iter().flat_map(|&id| colour_of_id(id)).collect();
    RgbImage::from_vec(labels.width, labels.height, raw).unwrap_or_default()
}

/// `v.round()` without a libm call for `+0 ≤ v < 2²³` (`f32::round` is one without SSE4.1):
/// the fraction `v − trunc(v)` is exact there, so halves round up as `round` does.
#[inline]
fn round_non_negative(v: f32) -> f32 {
    // Below 2²³ and not negative (sign bit clear, -0.0 included): the bits are below 2²³'s.
    if v.to_bits() >= 8_388_608f32.to_bits() {
        return v.round();
    }
    let t = v as u32 as f32;
    if v - t >= 0.5 {
        t + 1.0
    } else {
        t
    }
}

/// Factor applied to label-boundary pixels so regions stay readable.
const BOUNDARY_DARKEN: f32 = 0.3;

/// The value a channel `v` takes in [`overlay`] under `tint` (`None`: unlabelled pixel), on a
/// boundary or not: the blend and darkening in `f32`, rounded half up, clamped to a byte.
fn overlay_channel(v: u8, tint: Option<u8>, alpha: f32, boundary: bool) -> u8 {
    let mut v = v as f32;
    if let Some(t) = tint {
        v = (1.0 - alpha) * v + alpha * t as f32;
    }
    if boundary {
        v *= BOUNDARY_DARKEN;
    }
    round_non_negative(v).clamp(0.0, 255.0) as u8
}

/// Every value of [`overlay_channel`] for one `alpha`: `[tint · 256 + v]` for labelled pixels
/// inside a region and on a boundary, `[v]` for unlabelled boundary pixels. A pixel then costs
/// three lookups instead of three blends with data-dependent rounding branches.
struct OverlayTables {
    /// `[256 · 256]` labelled, inside.
    inside: Vec<u8>,
    /// `[256 · 256]` labelled, on a boundary.
    edge: Vec<u8>,
    /// `[256]` unlabelled, on a boundary.
    dark: [u8; 256],
}

impl OverlayTables {
    fn new(alpha: f32) -> Self {
        let (mut inside, mut edge) = (Vec::with_capacity(65536), Vec::with_capacity(65536));
        for t in 0..=255u8 {
            for v in 0..=255u8 {
                inside.push(overlay_channel(v, Some(t), alpha, false));
                edge.push(overlay_channel(v, Some(t), alpha, true));
            }
        }
        let dark = std::array::from_fn(|v| overlay_channel(v as u8, None, alpha, true));
        OverlayTables { inside, edge, dark }
    }
}

/// Blends palette colours over `rgb` with weight `alpha` (0 = image only, 1 = colours only) on
/// labelled pixels and darkens pixels on a boundary between different labels. `labels`
/// (`[h, w]` ids) may have another size than the image: it is sampled nearest-neighbour.
pub fn overlay(rgb: &RgbImage, labels: &Plane<u32>, alpha: f32) -> RgbImage {
    let (w, h) = rgb.size();
    let mut out = rgb.clone();
    if labels.width == 0 || labels.height == 0 || w == 0 || h == 0 {
        return out;
    }
    let tables = OverlayTables::new(alpha.clamp(0.0, 1.0));
    // The ids at the image's pixels: the map itself, or its nearest-neighbour samples.
    let resampled;
    let ids: &[u32] = if labels.width == w && labels.height == h {
        &labels.data
    } else {
        let col: Vec<usize> = (0..w).map(|x| x * labels.width / w).collect();
        resampled = (0..h)
            .flat_map(|y| {
                let row = &labels.data[y * labels.height / h * labels.width..];
                col.iter().map(move |&c| row[c])
            })
            .collect::<Vec<u32>>();
        &resampled
    };
    let pixels: &mut [u8] = &mut out.data;
    // Neighbouring pixels mostly share their id: its colour is kept from the pixel before.
    let mut last = (0u32, colour_of_id(0));
    for y in 0..h {
        let row = &ids[y * w..(y + 1) * w];
        let above = (y > 0).then(|| &ids[(y - 1) * w..y * w]);
        let below = (y + 1 < h).then(|| &ids[(y + 1) * w..(y + 2) * w]);
        for (x, &id) in row.iter().enumerate() {
            let boundary = (x > 0 && row[x - 1] != id)
                || (x + 1 < w && row[x + 1] != id)
                || above.is_some_and(|r| r[x] != id)
                || below.is_some_and(|r| r[x] != id);
            if id == 0 && !boundary {
                continue;
            }
            let px = &mut pixels[(y * w + x) * 3..][..3];
            if id == 0 {
                for channel in px.iter_mut() {
                    *channel = tables.dark[*channel as usize];
                }
                continue;
            }
            if last.0 != id {
                last = (id, colour_of_id(id));
            }
            let table = if boundary { &tables.edge } else { &tables.inside };
            for (channel, &tint) in px.iter_mut().zip(&last.1) {
                *channel = table[(tint as usize) << 8 | *channel as usize];
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The former [`overlay`] (pixel by pixel, neighbours through the
    /// sampling closure): the reference the new one is compared with.
    fn overlay_reference(rgb: &RgbImage, labels: &Plane<u32>, alpha: f32) -> RgbImage {
        let (w, h) = rgb.size();
        let mut out = rgb.clone();
        if labels.width == 0 || labels.height == 0 {
            return out;
        }
        let alpha = alpha.clamp(0.0, 1.0);
        let col: Vec<usize> = (0..w).map(|x| x * labels.width / w).collect();
        let row: Vec<usize> = (0..h).map(|y| y * labels.height / h).collect();
        let label_at = |x: usize, y: usize| labels.data[row[y] * labels.width + col[x]];
        // Neighbouring pixels mostly share their id: its colour is kept from the pixel before.
        let mut last = (0u32, colour_of_id(0));
        for y in 0..h {
            for x in 0..w {
                let id = label_at(x, y);
                let differs = |nx: usize, ny: usize| label_at(nx, ny) != id;
                let boundary = (x > 0 && differs(x - 1, y))
                    || (x + 1 < w && differs(x + 1, y))
                    || (y > 0 && differs(x, y - 1))
                    || (y + 1 < h && differs(x, y + 1));
                if id == 0 && !boundary {
                    continue;
                }
                let px = &mut out.data[(y * w + x) * 3..][..3];
                if last.0 != id {
                    last = (id, colour_of_id(id));
                }
                let colour = last.1;
                for (channel, &tint) in px.iter_mut().zip(&colour) {
                    let mut v = *channel as f32;
                    if id != 0 {
                        v = (1.0 - alpha) * v + alpha * tint as f32;
                    }
                    if boundary {
                        v *= BOUNDARY_DARKEN;
                    }
                    *channel = round_non_negative(v).clamp(0.0, 255.0) as u8;
                }
            }
        }
        out
    }

    /// The overlay gives the former overlay's pixels: maps of the image's size and of other
    /// sizes (sampled), runs of ids, id 0 areas and boundaries, several blend weights.
    #[test]
    fn overlay_equals_the_former_overlay() {
        let mut seed = 17u32;
        let mut next = move |n: u32| {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) % n
        };
        for (w, h, lw, lh) in
            [(37, 23, 37, 23), (40, 30, 20, 15), (33, 17, 50, 40), (1, 1, 1, 1), (5, 1, 3, 2)]
        {
            let raw: Vec<u8> = (0..w * h * 3).map(|_| next(256) as u8).collect();
            let image = RgbImage::from_vec(w, h, raw).expect("sized");
            let mut data = Vec::with_capacity(lw * lh);
            while data.len() < lw * lh {
                let (id, run) = (if next(3) == 0 { 0 } else { next(300) }, 1 + next(9) as usize);
                data.extend(std::iter::repeat_n(id, run));
            }
            data.truncate(lw * lh);
            let labels = Plane { width: lw, height: lh, data };
            for alpha in [0.0, 0.5, 0.77, 1.0] {
                let (new, old) = (overlay(&image, &labels, alpha), overlay_reference(&image, &labels, alpha));
                assert_eq!(new.data, old.data, "{w}×{h} image, {lw}×{lh} map, alpha {alpha}");
            }
        }
    }

    /// The libm-free rounding equals `f32::round` on every value an overlay channel takes
    /// (halves included) and beyond.
    #[test]
    fn rounding_without_libm_equals_round() {
        let mut values: Vec<f32> = (0..=2_600_000).map(|i| i as f32 * 0.0001).collect();
        values.extend([0.49999997, 0.5, 1.5, 2.5, 254.5, 255.49998, 8_388_607.5, 1e9, -0.0, -3.5, f32::NAN]);
        for v in values {
            let (got, want) = (round_non_negative(v), v.round());
            assert!(
                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "{v}: {got} vs {want}"
            );
        }
    }
}
