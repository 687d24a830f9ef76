//! PNG and JPEG files to and from pixel buffers: the one place splatseg decodes, resizes and
//! encodes images, with the `png` and `zune-jpeg` crates.
//!
//! It gives the pixels and writes the bytes the `image` crate (0.25.10, which splatseg used
//! before) gave and wrote, so outputs did not change when it went; `tests/image_io_parity.rs`
//! pins that with digests recorded through image itself. What that takes:
//! - PNG is decoded with `Transformations::EXPAND` (palette → RGB(A), tRNS → alpha, 1/2/4-bit
//!   grey → 8 bits; 16 bits kept), text chunks read, a 512 MiB allocation limit.
//! - JPEG is decoded by zune-jpeg in lenient mode to its own colour space when that is RGB(A) or
//!   grey (+ alpha), otherwise (YCbCr, CMYK, …) to RGB; the EXIF orientation is not applied.
//! - Conversions: 16 → 8 bits is `(v + 128) / 257`; dropping or adding channels within grey or
//!   within colour copies samples; grey → RGB and colour → grey go through `f32` (`v · (1/max)`,
//!   then `round(x · 255)`), colour → grey with the Rec. 709 weights image derives for sRGB
//!   (see [`LUMA_WEIGHTS`]). No colour management (ICC profiles are ignored).
//! - PNG is written with `Compression::Fast` and adaptive filtering, 16-bit samples big-endian,
//!   no metadata chunks.
//! - [`resize_triangle`] is image's `imageops::resize` with `FilterType::Triangle`: a vertical
//!   then a horizontal pass of normalised tent weights in `f32`, rounded at the end.

use crate::atomic::write_bytes_atomic;
use crate::error::{SceneError, SceneResult};
use crate::plane::Plane;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::Path;

/// Most bytes one decoded image may take before any conversion (image's default limit):
/// larger images are refused from their header, before the pixels are decoded.
pub const MAX_DECODED_BYTES: u64 = 512 * 1024 * 1024;

/// An 8-bit RGB image: `data` is `[height, width, 3]`, row-major.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RgbImage {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `[height, width, 3]` samples, row-major.
    pub data: Vec<u8>,
}

impl RgbImage {
    /// A `width × height` image of one colour.
    pub fn filled(width: usize, height: usize, rgb: [u8; 3]) -> Self {
        RgbImage { width, height, data: rgb.repeat(width * height) }
    }

    /// `data` (`[height, width, 3]`) as an image; `None` if its length is not `width · height · 3`.
    pub fn from_vec(width: usize, height: usize, data: Vec<u8>) -> Option<Self> {
        (width.checked_mul(height)?.checked_mul(3)? == data.len()).then_some(RgbImage { width, height, data })
    }

    /// `(width, height)`.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The colour at column `x`, row `y`.
    pub fn pixel(&self, x: usize, y: usize) -> [u8; 3] {
        let i = (y * self.width + x) * 3;
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }
}

/// Why an image could not be decoded or encoded ([`SceneError::Image`] names the file).
#[derive(Debug, thiserror::Error)]
pub enum CodecError {
    /// Neither the content nor the file name says PNG or JPEG.
    #[error("not a PNG or JPEG file (neither signature at its start)")]
    UnknownFormat,
    /// The PNG decoder refused the file.
    #[error("cannot decode PNG: {0}")]
    Png(String),
    /// The JPEG decoder refused the file.
    #[error("cannot decode JPEG: {0}")]
    Jpeg(String),
    /// The header declares an image larger than [`MAX_DECODED_BYTES`] once decoded.
    #[error(
        "the image is {width}x{height} with {channels} channel(s) of {bits} bits: {bytes} bytes once \
         decoded, more than the 512 MiB allowed"
    )]
    TooLarge {
        /// Declared width.
        width: u64,
        /// Declared height.
        height: u64,
        /// Channels of the decoded samples.
        channels: u64,
        /// Bits per sample.
        bits: u64,
        /// Bytes the decoded samples would take.
        bytes: u64,
    },
    /// The PNG encoder refused the image (size, or a buffer that disagrees with it).
    #[error("cannot encode PNG: {0}")]
    Encode(String),
}

/// Decoded samples as the file holds them: 8 or 16 bits, `channels` per pixel (1 grey, 2 grey +
/// alpha, 3 RGB, 4 RGBA), `[height, width, channels]` row-major.
struct Decoded {
    width: usize,
    height: usize,
    channels: usize,
    samples: Samples,
}

enum Samples {
    Eight(Vec<u8>),
    Sixteen(Vec<u16>),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Png,
    Jpeg,
}

const PNG_SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";
const JPEG_SIGNATURE: &[u8] = &[0xff, 0xd8, 0xff];

/// The format of a file starting with `start`; with no signature, the one its extension names
/// (as image did).
fn format_of(start: &[u8], path: Option<&Path>) -> Result<Format, CodecError> {
    if start.starts_with(PNG_SIGNATURE) {
        return Ok(Format::Png);
    }
    if start.starts_with(JPEG_SIGNATURE) {
        return Ok(Format::Jpeg);
    }
    let extension = path.and_then(|p| p.extension()).map(|e| e.to_string_lossy().to_ascii_lowercase());
    match extension.as_deref() {
        Some("png" | "apng") => Ok(Format::Png),
        Some("jpg" | "jpeg" | "jfif") => Ok(Format::Jpeg),
        _ => Err(CodecError::UnknownFormat),
    }
}

fn check_decoded_size(width: u64, height: u64, channels: u64, bits: u64) -> Result<usize, CodecError> {
    let bytes = width.saturating_mul(height).saturating_mul(channels).saturating_mul(bits / 8);
    if bytes > MAX_DECODED_BYTES {
        return Err(CodecError::TooLarge { width, height, channels, bits, bytes });
    }
    Ok(bytes as usize)
}

/// A PNG reader set up as image set it up: text chunks read, the allocation limit, `EXPAND`.
fn png_reader<R: BufRead + Seek>(input: R) -> Result<png::Reader<R>, CodecError> {
    let png_error = |e: png::DecodingError| CodecError::Png(e.to_string());
    let mut decoder = png::Decoder::new_with_limits(input, png::Limits { bytes: MAX_DECODED_BYTES as usize });
    decoder.set_ignore_text_chunk(false);
    decoder.read_header_info().map_err(png_error)?;
    decoder.set_transformations(png::Transformations::EXPAND);
    decoder.read_info().map_err(png_error)
}

fn decode_png<R: BufRead + Seek>(input: R) -> Result<Decoded, CodecError> {
    let mut reader = png_reader(input)?;
    let (colour, depth) = reader.output_color_type();
    let channels = match colour {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => return Err(CodecError::Png("palette output after expansion".into())),
    };
    let bits = match depth {
        png::BitDepth::Eight => 8,
        png::BitDepth::Sixteen => 16,
        other => return Err(CodecError::Png(format!("{other:?}-bit samples after expansion"))),
    };
    let (width, height) = reader.info().size();
    let bytes = check_decoded_size(width as u64, height as u64, channels as u64, bits)?;
    let mut buffer = vec![0u8; bytes];
    reader.next_frame(&mut buffer).map_err(|e| CodecError::Png(e.to_string()))?;
    let samples = if bits == 8 {
        Samples::Eight(buffer)
    } else {
        Samples::Sixteen(buffer.chunks_exact(2).map(|b| u16::from_be_bytes([b[0], b[1]])).collect())
    };
    Ok(Decoded { width: width as usize, height: height as usize, channels, samples })
}

/// zune-jpeg's options as image set them: lenient, no size cap of its own.
fn jpeg_options() -> zune_core::options::DecoderOptions {
    zune_core::options::DecoderOptions::default()
        .set_strict_mode(false)
        .set_max_width(usize::MAX)
        .set_max_height(usize::MAX)
}

/// `(width, height, colour space decoded to)` from a JPEG's headers.
fn jpeg_header(bytes: &[u8]) -> Result<(usize, usize, zune_core::colorspace::ColorSpace), CodecError> {
    use zune_core::colorspace::ColorSpace;
    let mut decoder =
        zune_jpeg::JpegDecoder::new_with_options(zune_core::bytestream::ZCursor::new(bytes), jpeg_options());
    decoder.decode_headers().map_err(|e| CodecError::Jpeg(format!("{e:?}")))?;
    let missing = || CodecError::Jpeg("no frame header".into());
    let (width, height) = decoder.dimensions().ok_or_else(missing)?;
    let output = match decoder.input_colorspace().ok_or_else(missing)? {
        own @ (ColorSpace::RGB | ColorSpace::RGBA | ColorSpace::Luma | ColorSpace::LumaA) => own,
        _ => ColorSpace::RGB,
    };
    Ok((width, height, output))
}

fn decode_jpeg(bytes: &[u8]) -> Result<Decoded, CodecError> {
    let (width, height, colour) = jpeg_header(bytes)?;
    let channels = colour.num_components();
    let size = check_decoded_size(width as u64, height as u64, channels as u64, 8)?;
    let options = jpeg_options().jpeg_set_out_colorspace(colour);
    let mut decoder =
        zune_jpeg::JpegDecoder::new_with_options(zune_core::bytestream::ZCursor::new(bytes), options);
    let mut buffer = vec![0u8; size];
    decoder.decode_into(&mut buffer).map_err(|e| CodecError::Jpeg(format!("{e:?}")))?;
    Ok(Decoded { width, height, channels, samples: Samples::Eight(buffer) })
}

/// Decodes PNG or JPEG `bytes`; `path` (only for its extension) when the content has no signature.
fn decode_bytes(bytes: &[u8], path: Option<&Path>) -> Result<Decoded, CodecError> {
    match format_of(&bytes[..bytes.len().min(16)], path)? {
        Format::Png => decode_png(std::io::Cursor::new(bytes)),
        Format::Jpeg => decode_jpeg(bytes),
    }
}

fn image_error(path: &Path) -> impl Fn(CodecError) -> SceneError + '_ {
    |source| SceneError::Image { path: path.to_path_buf(), source }
}

fn decode_file(path: &Path) -> SceneResult<Decoded> {
    let mut file = std::fs::File::open(path).map_err(|e| SceneError::io("cannot open image", path, e))?;
    let mut bytes = Vec::new();
    file.read_to_end(&mut bytes).map_err(|e| SceneError::io("cannot read image", path, e))?;
    decode_bytes(&bytes, Some(path)).map_err(image_error(path))
}

/// `(width, height)` of a PNG or JPEG file, from its header (a PNG's chunks up to its pixels;
/// a JPEG's markers up to its first scan).
pub fn image_size(path: &Path) -> SceneResult<(u32, u32)> {
    let file = std::fs::File::open(path).map_err(|e| SceneError::io("cannot open image", path, e))?;
    let mut reader = BufReader::new(file);
    let mut start = Vec::with_capacity(16);
    (&mut reader)
        .take(16)
        .read_to_end(&mut start)
        .map_err(|e| SceneError::io("cannot read image", path, e))?;
    reader.seek(SeekFrom::Start(0)).map_err(|e| SceneError::io("cannot read image", path, e))?;
    match format_of(&start, Some(path)).map_err(image_error(path))? {
        Format::Png => Ok(png_reader(reader).map_err(image_error(path))?.info().size()),
        Format::Jpeg => {
            let mut bytes = Vec::new();
            reader.read_to_end(&mut bytes).map_err(|e| SceneError::io("cannot read image", path, e))?;
            let (width, height, _) = jpeg_header(&bytes).map_err(image_error(path))?;
            Ok((width as u32, height as u32))
        }
    }
}

/// Reads a PNG or JPEG file as 8-bit RGB (an alpha channel is dropped; grey is repeated).
pub fn read_rgb8(path: &Path) -> SceneResult<RgbImage> {
    Ok(decode_file(path)?.to_rgb8())
}

/// Reads a PNG or JPEG file as 8-bit RGB and, when the file has an alpha channel (or PNG tRNS
/// transparency), its 8-bit alpha `[height, width]`.
pub fn read_rgb8_alpha(path: &Path) -> SceneResult<(RgbImage, Option<Plane<u8>>)> {
    let decoded = decode_file(path)?;
    Ok((decoded.to_rgb8(), decoded.alpha8()))
}

/// [`read_rgb8_alpha`] on the bytes of a file.
pub fn decode_rgb8_alpha(bytes: &[u8]) -> Result<(RgbImage, Option<Plane<u8>>), CodecError> {
    let decoded = decode_bytes(bytes, None)?;
    Ok((decoded.to_rgb8(), decoded.alpha8()))
}

/// Reads a PNG or JPEG file as 8-bit grey `[height, width]` (colour weighted as
/// [`LUMA_WEIGHTS`]; an alpha channel is dropped).
pub fn read_luma8(path: &Path) -> SceneResult<Plane<u8>> {
    Ok(decode_file(path)?.to_luma8())
}

/// The first pixel of a colour image whose channels differ: where a grey image was expected
/// (a mask), what was found instead.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ColourPixel {
    /// Column.
    pub x: usize,
    /// Row.
    pub y: usize,
    /// Its 8-bit red, green and blue.
    pub rgb: [u8; 3],
}

/// Reads a PNG or JPEG file as 8-bit grey `[height, width]` when it is grey: a one-channel file
/// (± alpha), or a colour file whose every pixel has R = G = B (a grey image saved as RGB, which
/// some tools do; read as [`read_luma8`] reads it). A colour file with a colour pixel gives the
/// first one instead, row-major (`Ok(Err(_))`), so the caller can name it.
pub fn read_grey8(path: &Path) -> SceneResult<Result<Plane<u8>, ColourPixel>> {
    let decoded = decode_file(path)?;
    if decoded.channels >= 3 {
        let rgb = decoded.to_rgb8();
        if let Some(i) = rgb.data.chunks_exact(3).position(|p| p[0] != p[1] || p[1] != p[2]) {
            let rgb = [rgb.data[3 * i], rgb.data[3 * i + 1], rgb.data[3 * i + 2]];
            return Ok(Err(ColourPixel { x: i % decoded.width.max(1), y: i / decoded.width.max(1), rgb }));
        }
    }
    Ok(Ok(decoded.to_luma8()))
}

/// Red, green and blue weights of grey (`f32` bits of Rec. 709's 0.2126, 0.7152, 0.0722 as
/// image derives them from the sRGB primaries and D65 white).
pub const LUMA_WEIGHTS: [f32; 3] =
    [f32::from_bits(0x3e59_c05b), f32::from_bits(0x3f37_15fc), f32::from_bits(0x3d93_cf75)];

/// A sample in `[0, 1]`: `v · (1 / max)`.
trait Sample: Copy {
    fn unit(self) -> f32;
    /// To 8 bits by integer rounding (`(v + 128) / 257` for 16 bits).
    fn to_u8(self) -> u8;
}

impl Sample for u8 {
    fn unit(self) -> f32 {
        const SCALE: f32 = 1.0 / u8::MAX as f32;
        self as f32 * SCALE
    }
    fn to_u8(self) -> u8 {
        self
    }
}

impl Sample for u16 {
    fn unit(self) -> f32 {
        const SCALE: f32 = 1.0 / u16::MAX as f32;
        self as f32 * SCALE
    }
    fn to_u8(self) -> u8 {
        ((self as u32 + 128) / 257) as u8
    }
}

/// A value in `[0, 1]` to 8 bits: `round(x · 255)`, saturating.
fn unit_to_u8(x: f32) -> u8 {
    (x * u8::MAX as f32).round() as u8
}

/// RGB of `pixels` (`channels` samples each): colour samples to 8 bits, grey through `f32`.
fn rgb8_of<S: Sample>(pixels: &[S], channels: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(pixels.len() / channels * 3);
    for p in pixels.chunks_exact(channels) {
        if channels >= 3 {
            out.extend([p[0].to_u8(), p[1].to_u8(), p[2].to_u8()]);
        } else {
            let grey = unit_to_u8(p[0].unit());
            out.extend([grey; 3]);
        }
    }
    out
}

/// Grey of `pixels`: grey samples to 8 bits, colour weighted through `f32`.
fn luma8_of<S: Sample>(pixels: &[S], channels: usize) -> Vec<u8> {
    pixels
        .chunks_exact(channels)
        .map(|p| {
            if channels >= 3 {
                let mut luma = 0.0f32;
                for (&sample, weight) in p[..3].iter().zip(LUMA_WEIGHTS) {
                    luma += sample.unit() * weight;
                }
                unit_to_u8(luma)
            } else {
                p[0].to_u8()
            }
        })
        .collect()
}

/// Alpha of `pixels` (the last sample) to 8 bits: integer rounding beside colour, through `f32`
/// beside grey.
fn alpha8_of<S: Sample>(pixels: &[S], channels: usize) -> Vec<u8> {
    let alpha = |p: &[S]| if channels == 4 { p[3].to_u8() } else { unit_to_u8(p[1].unit()) };
    pixels.chunks_exact(channels).map(alpha).collect()
}

impl Decoded {
    fn to_rgb8(&self) -> RgbImage {
        let data = match &self.samples {
            Samples::Eight(v) if self.channels == 3 => v.clone(),
            Samples::Eight(v) => rgb8_of(v, self.channels),
            Samples::Sixteen(v) => rgb8_of(v, self.channels),
        };
        RgbImage { width: self.width, height: self.height, data }
    }

    fn to_luma8(&self) -> Plane<u8> {
        let data = match &self.samples {
            Samples::Eight(v) if self.channels == 1 => v.clone(),
            Samples::Eight(v) => luma8_of(v, self.channels),
            Samples::Sixteen(v) => luma8_of(v, self.channels),
        };
        Plane { width: self.width, height: self.height, data }
    }

    /// `None` without an alpha channel.
    fn alpha8(&self) -> Option<Plane<u8>> {
        if !self.channels.is_multiple_of(2) {
            return None;
        }
        let data = match &self.samples {
            Samples::Eight(v) => alpha8_of(v, self.channels),
            Samples::Sixteen(v) => alpha8_of(v, self.channels),
        };
        Some(Plane { width: self.width, height: self.height, data })
    }
}

/// For each output pixel along an axis of `input` pixels resized to `output`: the first input
/// pixel it reads and the normalised triangle weights of the pixels from there on.
fn triangle_taps(input: usize, output: usize) -> Vec<(usize, Vec<f32>)> {
    let ratio = input as f32 / output as f32;
    let scale = if ratio < 1.0 { 1.0 } else { ratio };
    let support = scale; // the triangle's support (1) in input pixels
    (0..output)
        .map(|o| {
            let centre = (o as f32 + 0.5) * ratio;
            let left = ((centre - support).floor() as i64).clamp(0, input as i64 - 1);
            let right = ((centre + support).ceil() as i64).clamp(left + 1, input as i64);
            let centre = centre - 0.5;
            let mut weights: Vec<f32> = (left..right)
                .map(|i| {
                    let x = ((i as f32 - centre) / scale).abs();
                    if x < 1.0 {
                        1.0 - x
                    } else {
                        0.0
                    }
                })
                .collect();
            let sum = weights.iter().fold(0.0f32, |s, &w| s + w);
            weights.iter_mut().for_each(|w| *w /= sum);
            (left as usize, weights)
        })
        .collect()
}

/// `image` resized to `width × height` with a triangle (tent) filter widened by the scale when
/// shrinking (area-like): rows first into `f32`, then columns, rounded and clamped to bytes.
/// The same size gives a copy; an empty image gives black.
pub fn resize_triangle(image: &RgbImage, width: usize, height: usize) -> RgbImage {
    let (w, h) = image.size();
    if w == 0 || h == 0 {
        return RgbImage::filled(width, height, [0; 3]);
    }
    if (width, height) == (w, h) {
        return image.clone();
    }
    // Vertical pass: `[height, w, 3]` f32.
    let mut rows = vec![0.0f32; height * w * 3];
    for (y, (top, weights)) in triangle_taps(h, height).into_iter().enumerate() {
        let out = &mut rows[y * w * 3..(y + 1) * w * 3];
        for (x, px) in out.chunks_exact_mut(3).enumerate() {
            let mut t = [0.0f32; 3];
            for (i, &weight) in weights.iter().enumerate() {
                let at = ((top + i) * w + x) * 3;
                for (c, acc) in t.iter_mut().enumerate() {
                    *acc += image.data[at + c] as f32 * weight;
                }
            }
            px.copy_from_slice(&t);
        }
    }
    // Horizontal pass, rounded to bytes.
    let mut data = vec![0u8; height * width * 3];
    for (x, (first, weights)) in triangle_taps(w, width).into_iter().enumerate() {
        for y in 0..height {
            let mut t = [0.0f32; 3];
            for (i, &weight) in weights.iter().enumerate() {
                let at = (y * w + first + i) * 3;
                for (c, acc) in t.iter_mut().enumerate() {
                    *acc += rows[at + c] * weight;
                }
            }
            let at = (y * width + x) * 3;
            for (c, v) in t.into_iter().enumerate() {
                data[at + c] = v.clamp(0.0, 255.0).round() as u8;
            }
        }
    }
    RgbImage { width, height, data }
}

/// PNG bytes of `samples` (`width × height` pixels of `colour`, 8 or 16 bits big-endian).
fn encode_png(
    width: usize,
    height: usize,
    colour: png::ColorType,
    depth: png::BitDepth,
    samples: &[u8],
) -> Result<Vec<u8>, CodecError> {
    let encode_error = |e: png::EncodingError| CodecError::Encode(e.to_string());
    let too_large = |_| CodecError::Encode(format!("{width}x{height} does not fit a PNG header"));
    let (w, h) = (u32::try_from(width).map_err(too_large)?, u32::try_from(height).map_err(too_large)?);
    let expected = width * height * colour.samples() * (depth as usize).div_ceil(8);
    if samples.len() != expected {
        return Err(CodecError::Encode(format!(
            "{width}x{height} {colour:?} needs {expected} bytes of samples, got {}",
            samples.len()
        )));
    }
    let mut bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut bytes, w, h);
    encoder.set_color(colour);
    encoder.set_depth(depth);
    encoder.set_compression(png::Compression::Fast);
    encoder.set_filter(png::Filter::Adaptive);
    let mut writer = encoder.write_header().map_err(encode_error)?;
    writer.write_image_data(samples).map_err(encode_error)?;
    writer.finish().map_err(encode_error)?;
    Ok(bytes)
}

/// Writes `image` as an 8-bit RGB PNG, atomically.
pub fn write_png_rgb8(path: &Path, image: &RgbImage) -> SceneResult<()> {
    let bytes = encode_png(image.width, image.height, png::ColorType::Rgb, png::BitDepth::Eight, &image.data)
        .map_err(image_error(path))?;
    write_bytes_atomic(path, &bytes)
}

/// Writes `grey` as an 8-bit greyscale PNG, atomically.
pub fn write_png_luma8(path: &Path, grey: &Plane<u8>) -> SceneResult<()> {
    let bytes =
        encode_png(grey.width, grey.height, png::ColorType::Grayscale, png::BitDepth::Eight, &grey.data)
            .map_err(image_error(path))?;
    write_bytes_atomic(path, &bytes)
}

/// Writes `grey` as a 16-bit greyscale PNG, atomically.
pub fn write_png_luma16(path: &Path, grey: &Plane<u16>) -> SceneResult<()> {
    let samples: Vec<u8> = grey.data.iter().flat_map(|v| v.to_be_bytes()).collect();
    let bytes =
        encode_png(grey.width, grey.height, png::ColorType::Grayscale, png::BitDepth::Sixteen, &samples)
            .map_err(image_error(path))?;
    write_bytes_atomic(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn written_pngs_read_back() {
        let dir = tempfile::tempdir().expect("temp dir");
        let rgb = RgbImage::from_vec(3, 2, (0..18).map(|v| v * 14).collect()).expect("sized");
        let path = dir.path().join("rgb.png");
        write_png_rgb8(&path, &rgb).expect("writes");
        assert_eq!(read_rgb8_alpha(&path).expect("reads"), (rgb.clone(), None));
        assert_eq!(image_size(&path).expect("size"), (3, 2));
        let grey = Plane { width: 2, height: 3, data: vec![0, 1, 127, 128, 254, 255] };
        let path = dir.path().join("grey.png");
        write_png_luma8(&path, &grey).expect("writes");
        assert_eq!(read_luma8(&path).expect("reads"), grey);
        let wide = Plane { width: 3, height: 1, data: vec![0u16, 32896, 65535] };
        let path = dir.path().join("wide.png");
        write_png_luma16(&path, &wide).expect("writes");
        assert_eq!(read_luma8(&path).expect("reads").data, vec![0, 128, 255]);
    }

    #[test]
    fn sizes_that_disagree_with_the_samples_are_refused_naming_the_file() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("bad.png");
        let image = RgbImage { width: 4, height: 4, data: vec![0; 5] };
        let err = write_png_rgb8(&path, &image).expect_err("too few samples").to_string();
        assert!(err.contains("bad.png") && err.contains("48 bytes"), "{err}");
        assert!(!path.exists());
        assert!(RgbImage::from_vec(4, 4, vec![0; 5]).is_none());
    }

    #[test]
    fn an_image_too_large_to_decode_is_refused_from_its_header() {
        // A 20000 × 20000 RGBA 16-bit header (3.2 GB decoded) with a token IDAT.
        let mut bytes = Vec::new();
        let mut encoder = png::Encoder::new(&mut bytes, 20_000, 20_000);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Sixteen);
        let mut writer = encoder.write_header().expect("header");
        writer.write_chunk(png::chunk::IDAT, &[0x78, 0x9c, 0x03, 0x00]).expect("chunk");
        drop(writer);
        let err = decode_rgb8_alpha(&bytes).expect_err("too large").to_string();
        assert!(err.contains("20000x20000") && err.contains("more than"), "{err}");
    }

    #[test]
    fn the_file_name_decides_when_the_content_has_no_signature() {
        assert_eq!(format_of(b"\x89PNG\r\n\x1a\nrest", None).ok(), Some(Format::Png));
        assert_eq!(format_of(&[0xff, 0xd8, 0xff, 0xe0], Some(Path::new("a.png"))).ok(), Some(Format::Jpeg));
        assert_eq!(format_of(b"garbage", Some(Path::new("a.JPG"))).ok(), Some(Format::Jpeg));
        assert!(matches!(format_of(b"garbage", Some(Path::new("a.txt"))), Err(CodecError::UnknownFormat)));
        assert!(matches!(format_of(b"", None), Err(CodecError::UnknownFormat)));
    }
}
