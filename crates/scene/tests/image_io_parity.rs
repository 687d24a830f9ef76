//! `image_io` decodes, converts, resizes and encodes exactly as the `image` crate (0.25.10) did
//! before it replaced it: the digests below were recorded at commit 0120aea by the same inputs
//! through image's own calls (`ImageReader::open(p)?.with_guessed_format()?.decode()?` then
//! `into_rgb8` / `into_luma8` / the loader's compositing of `into_rgba8`, `imageops::resize` with
//! `FilterType::Triangle`, and `write_to(.., ImageFormat::Png)` of `RgbImage`, `GrayImage` and
//! 16-bit luma buffers). Inputs: PNGs of every colour type and bit depth made here with the png
//! crate (palettes, tRNS transparency, 16 bits, grey + alpha, text chunks), exhaustive PNGs (every
//! RGB colour, every 16-bit value), and the JPEG fixtures of `tests/fixtures/jpeg/`
//! (`tools/fixtures/make_jpeg_fixtures.py`).
//!
//! `SPLATSEG_PRINT_PARITY=1` prints the tables `image_io` gives instead of comparing: image is no
//! longer a dependency, so tables printed now are not a reference (record new inputs through
//! image 0.25.10 in a scratch crate with the same calls).

use splatseg_scene::plane::Plane;
use std::path::{Path, PathBuf};

// ------------------------------------------------------------------------- the calls compared
mod calls {
    use super::*;
    use splatseg_scene::image_io::{self, RgbImage};

    pub fn size(path: &Path) -> Option<(u32, u32)> {
        image_io::image_size(path).ok()
    }
    pub fn rgb8(path: &Path) -> Option<(usize, usize, Vec<u8>)> {
        let img = image_io::read_rgb8(path).ok()?;
        Some((img.width, img.height, img.data))
    }
    pub fn luma8(path: &Path) -> Option<(usize, usize, Vec<u8>)> {
        let grey = image_io::read_luma8(path).ok()?;
        Some((grey.width, grey.height, grey.data))
    }
    pub fn composited(path: &Path, background: [f32; 3]) -> Option<(usize, usize, Vec<u8>)> {
        let (rgb, alpha) = image_io::read_rgb8_alpha(path).ok()?;
        let img = splatseg_scene::images::composite_on(rgb, alpha.as_ref(), background);
        Some((img.width, img.height, img.data))
    }
    pub fn resize(w: usize, h: usize, rgb: Vec<u8>, nw: usize, nh: usize) -> Vec<u8> {
        image_io::resize_triangle(&RgbImage::from_vec(w, h, rgb).expect("sized"), nw, nh).data
    }
    fn png(write: impl FnOnce(&Path) -> splatseg_scene::SceneResult<()>) -> Vec<u8> {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("out.png");
        write(&path).expect("encodes");
        std::fs::read(&path).expect("written")
    }
    pub fn png_rgb8(w: usize, h: usize, rgb: Vec<u8>) -> Vec<u8> {
        png(|path| image_io::write_png_rgb8(path, &RgbImage::from_vec(w, h, rgb).expect("sized")))
    }
    pub fn png_luma8(plane: Plane<u8>) -> Vec<u8> {
        png(|path| image_io::write_png_luma8(path, &plane))
    }
    pub fn png_luma16(plane: Plane<u16>) -> Vec<u8> {
        png(|path| image_io::write_png_luma16(path, &plane))
    }
}
// ---------------------------------------------------------------------------------------------

/// FNV-1a (64 bit) of `bytes`, with the size in front: `WxH:digest`.
fn digest(w: usize, h: usize, bytes: &[u8]) -> String {
    let hash =
        bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ b as u64).wrapping_mul(0x0100_0000_01b3));
    format!("{w}x{h}:{hash:016x}")
}

fn digest_of(decoded: Option<(usize, usize, Vec<u8>)>) -> String {
    decoded.map(|(w, h, d)| digest(w, h, &d)).unwrap_or_else(|| "error".to_string())
}

/// A xorshift generator: the same bytes on every platform.
struct Bytes(u64);

impl Bytes {
    fn take(&mut self, n: usize) -> Vec<u8> {
        (0..n)
            .map(|_| {
                self.0 ^= self.0 << 13;
                self.0 ^= self.0 >> 7;
                self.0 ^= self.0 << 17;
                (self.0 >> 24) as u8
            })
            .collect()
    }
}

struct Png<'a> {
    name: &'a str,
    size: (u32, u32),
    colour: png::ColorType,
    bits: png::BitDepth,
    data: Vec<u8>,
    palette: Option<Vec<u8>>,
    trns: Option<Vec<u8>>,
}

impl Png<'_> {
    fn write(self, dir: &Path) -> PathBuf {
        let path = dir.join(format!("{}.png", self.name));
        let file = std::io::BufWriter::new(std::fs::File::create(&path).expect("create"));
        let mut encoder = png::Encoder::new(file, self.size.0, self.size.1);
        encoder.set_color(self.colour);
        encoder.set_depth(self.bits);
        if let Some(palette) = self.palette {
            encoder.set_palette(palette);
        }
        if let Some(trns) = self.trns {
            encoder.set_trns(trns);
        }
        if self.name.ends_with("text") {
            encoder.add_text_chunk("Comment".into(), "a text chunk".into()).expect("text");
            encoder.set_source_gamma(png::ScaledFloat::new(0.5));
        }
        encoder.write_header().expect("header").write_image_data(&self.data).expect("data");
        path
    }
}

/// Small PNGs of every colour type and bit depth (37×23, random samples), written into `dir`.
fn small_pngs(dir: &Path) -> Vec<PathBuf> {
    use png::{BitDepth as B, ColorType as C};
    let (w, h) = (37u32, 23u32);
    let px = (w * h) as usize;
    let mut rng = Bytes(0x5eed);
    let mut out = Vec::new();
    let mut add =
        |name: &str, colour, bits, data: Vec<u8>, palette: Option<Vec<u8>>, trns: Option<Vec<u8>>| {
            out.push(Png { name, size: (w, h), colour, bits, data, palette, trns }.write(dir));
        };
    for (bits, depth) in [(1usize, B::One), (2, B::Two), (4, B::Four)] {
        let data = rng.take((w as usize * bits).div_ceil(8) * h as usize);
        let palette = rng.take(3 << bits);
        let trns = rng.take((1 << bits) / 2 + 1);
        let names = [format!("grey{bits}"), format!("palette{bits}"), format!("palette{bits}_trns")];
        add(&names[0], C::Grayscale, depth, data.clone(), None, None);
        add(&names[1], C::Indexed, depth, data.clone(), Some(palette.clone()), None);
        add(&names[2], C::Indexed, depth, data, Some(palette), Some(trns));
    }
    let data = rng.take(px);
    let (palette, trns) = (rng.take(768), rng.take(200));
    add("grey8", C::Grayscale, B::Eight, data.clone(), None, None);
    add("grey8_text", C::Grayscale, B::Eight, data.clone(), None, None);
    add("grey8_trns", C::Grayscale, B::Eight, data.clone(), None, Some(vec![0, data[5]]));
    add("palette8", C::Indexed, B::Eight, data.clone(), Some(palette.clone()), None);
    add("palette8_trns", C::Indexed, B::Eight, data, Some(palette), Some(trns));
    let data = rng.take(px * 2);
    add("grey16", C::Grayscale, B::Sixteen, data.clone(), None, None);
    add("grey16_trns", C::Grayscale, B::Sixteen, data.clone(), None, Some(data[10..12].to_vec()));
    add("grey_alpha8", C::GrayscaleAlpha, B::Eight, data, None, None);
    let data = rng.take(px * 4);
    add("grey_alpha16", C::GrayscaleAlpha, B::Sixteen, data.clone(), None, None);
    add("rgba8", C::Rgba, B::Eight, data, None, None);
    let data = rng.take(px * 3);
    add("rgb8", C::Rgb, B::Eight, data.clone(), None, None);
    add("rgb8_trns", C::Rgb, B::Eight, data.clone(), None, Some(vec![0, data[0], 0, data[1], 0, data[2]]));
    let data = rng.take(px * 6);
    add("rgb16", C::Rgb, B::Sixteen, data.clone(), None, None);
    add("rgb16_trns", C::Rgb, B::Sixteen, data.clone(), None, Some(data[..6].to_vec()));
    add("rgba16", C::Rgba, B::Sixteen, rng.take(px * 8), None, None);
    out
}

/// PNGs holding every value a conversion can meet: every 16-bit grey (256×256), every 16-bit
/// grey with the complementary alpha, every 8-bit (grey, alpha) pair, 65536 16-bit RGB triples.
fn exhaustive_pngs(dir: &Path) -> Vec<PathBuf> {
    use png::{BitDepth as B, ColorType as C};
    let every = |f: &dyn Fn(u16) -> Vec<u8>| (0..=u16::MAX).flat_map(f).collect::<Vec<u8>>();
    let at = |name, colour, bits, data| Png {
        name,
        size: (256, 256),
        colour,
        bits,
        data,
        palette: None,
        trns: None,
    };
    vec![
        at("every_grey16", C::Grayscale, B::Sixteen, every(&|v| v.to_be_bytes().to_vec())).write(dir),
        at(
            "every_grey_alpha16",
            C::GrayscaleAlpha,
            B::Sixteen,
            every(&|v| [v.to_be_bytes(), (!v).to_be_bytes()].concat()),
        )
        .write(dir),
        at("every_grey_alpha8", C::GrayscaleAlpha, B::Eight, every(&|v| v.to_be_bytes().to_vec())).write(dir),
        at(
            "every_rgb16",
            C::Rgb,
            B::Sixteen,
            every(&|v| [v.to_be_bytes(), (!v).to_be_bytes(), v.rotate_left(5).to_be_bytes()].concat()),
        )
        .write(dir),
    ]
}

fn jpeg_fixtures() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/jpeg");
    let mut files: Vec<PathBuf> =
        std::fs::read_dir(&dir).expect("fixtures").map(|e| e.expect("entry").path()).collect();
    files.sort();
    files
}

fn print_mode() -> bool {
    std::env::var_os("SPLATSEG_PRINT_PARITY").is_some()
}

/// Compares `rows` (`name`, digests…) with `expected`, or prints them in Rust syntax.
fn check(table: &str, rows: Vec<Vec<String>>, expected: &[&[&str]]) {
    if print_mode() {
        println!("const {table}: &[&[&str]] = &[");
        for row in &rows {
            println!("    &[{}],", row.iter().map(|c| format!("{c:?}")).collect::<Vec<_>>().join(", "));
        }
        println!("];");
        return;
    }
    let mut wrong = Vec::new();
    for (got, want) in rows.iter().zip(expected) {
        if got.iter().map(String::as_str).ne(want.iter().copied()) {
            wrong.push(format!("{}: got {:?}, image 0.25.10 gave {:?}", got[0], &got[1..], &want[1..]));
        }
    }
    assert_eq!(rows.len(), expected.len(), "{table}: number of rows");
    assert!(wrong.is_empty(), "{table}: {} rows differ:\n{}", wrong.len(), wrong.join("\n"));
}

fn decode_rows(files: &[PathBuf]) -> Vec<Vec<String>> {
    files
        .iter()
        .map(|f| {
            vec![
                f.file_name().expect("name").to_string_lossy().into_owned(),
                format!("{:?}", calls::size(f)),
                digest_of(calls::rgb8(f)),
                digest_of(calls::luma8(f)),
                digest_of(calls::composited(f, [0.3, 0.6, 0.9])),
            ]
        })
        .collect()
}

#[test]
fn decoding_gives_the_pixels_image_gave() {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut files = small_pngs(dir.path());
    files.extend(exhaustive_pngs(dir.path()));
    files.extend(jpeg_fixtures());
    std::fs::write(dir.path().join("not_an_image.png"), b"not a PNG at all").expect("write");
    let rgb8 = std::fs::read(dir.path().join("rgb8.png")).expect("png");
    std::fs::write(dir.path().join("truncated.png"), &rgb8[..200]).expect("write");
    files.push(dir.path().join("not_an_image.png"));
    files.push(dir.path().join("truncated.png"));
    check("DECODED", decode_rows(&files), DECODED);
}

/// Every RGB colour once (4096×4096): pins the RGB → luma weights and rounding, and every
/// (colour, alpha) pair's compositing.
#[test]
fn every_colour_converts_as_image_converted_it() {
    use png::{BitDepth as B, ColorType as C};
    let dir = tempfile::tempdir().expect("temp dir");
    let rgb: Vec<u8> = (0..1u32 << 24).flat_map(|c| [(c >> 16) as u8, (c >> 8) as u8, c as u8]).collect();
    let rgba: Vec<u8> =
        (0..1u32 << 24).flat_map(|c| [(c >> 16) as u8, (c >> 8) as u8, (c >> 4) as u8, c as u8]).collect();
    let files = [
        Png {
            name: "every_rgb8",
            size: (4096, 4096),
            colour: C::Rgb,
            bits: B::Eight,
            data: rgb,
            palette: None,
            trns: None,
        }
        .write(dir.path()),
        Png {
            name: "every_rgba8",
            size: (4096, 4096),
            colour: C::Rgba,
            bits: B::Eight,
            data: rgba,
            palette: None,
            trns: None,
        }
        .write(dir.path()),
    ];
    check("EVERY_COLOUR", decode_rows(&files), EVERY_COLOUR);
}

/// The triangle-filter resize of the loader (an image at full resolution while the scene is
/// loaded at `--resolution f`), down and up, to odd sizes, to 1×1 and to its own size.
#[test]
fn resizing_gives_the_pixels_image_gave() {
    let mut inputs = vec![("random_64x48".to_string(), 64, 48, Bytes(99).take(64 * 48 * 3))];
    for f in jpeg_fixtures() {
        let (w, h, rgb) = calls::rgb8(&f).expect("fixture decodes");
        inputs.push((f.file_name().expect("name").to_string_lossy().into_owned(), w, h, rgb));
    }
    let mut rows = Vec::new();
    for (name, w, h, rgb) in inputs {
        for (nw, nh) in
            [(w / 2, h / 2), (w / 4, h / 4), (33, 19), (w + 1, h - 1), (200, 7), (3, 90), (1, 1), (w, h)]
        {
            rows.push(vec![
                format!("{name} to {nw}x{nh}"),
                digest(nw, nh, &calls::resize(w, h, rgb.clone(), nw, nh)),
            ]);
        }
    }
    check("RESIZED", rows, RESIZED);
}

/// PNG bytes for 8-bit RGB, 8-bit grey and 16-bit grey: random, flat, smooth, 1×1, wide, tall.
#[test]
fn encoding_writes_the_bytes_image_wrote() {
    let mut rng = Bytes(7);
    let smooth = |w: usize, h: usize, c: usize| -> Vec<u8> {
        (0..w * h * c).map(|i| ((i / c % w) * 3 + (i / c / w) * 5 + (i % c) * 40) as u8).collect()
    };
    let mut rows = Vec::new();
    for (w, h) in [(37, 23), (1, 1), (300, 200), (640, 3), (2, 500)] {
        let random = rng.take(w * h * 3);
        let name = format!("{w}x{h}");
        rows.push(vec![format!("rgb8 random {name}"), digest(w, h, &calls::png_rgb8(w, h, random))]);
        rows.push(vec![format!("rgb8 smooth {name}"), digest(w, h, &calls::png_rgb8(w, h, smooth(w, h, 3)))]);
        rows.push(vec![
            format!("rgb8 flat {name}"),
            digest(w, h, &calls::png_rgb8(w, h, vec![77; w * h * 3])),
        ]);
        let grey = Plane { width: w, height: h, data: rng.take(w * h) };
        rows.push(vec![format!("luma8 random {name}"), digest(w, h, &calls::png_luma8(grey))]);
        let mask = Plane {
            width: w,
            height: h,
            data: smooth(w, h, 1).iter().map(|&v| if v > 128 { 255 } else { 0 }).collect(),
        };
        rows.push(vec![format!("luma8 mask {name}"), digest(w, h, &calls::png_luma8(mask))]);
        let wide: Vec<u16> =
            rng.take(w * h * 2).chunks_exact(2).map(|b| u16::from_le_bytes([b[0], b[1]])).collect();
        rows.push(vec![
            format!("luma16 random {name}"),
            digest(w, h, &calls::png_luma16(Plane { width: w, height: h, data: wide })),
        ]);
        let ids: Vec<u16> = (0..w * h).map(|i| (i / 50) as u16 * 257).collect();
        rows.push(vec![
            format!("luma16 ids {name}"),
            digest(w, h, &calls::png_luma16(Plane { width: w, height: h, data: ids })),
        ]);
    }
    check("ENCODED", rows, ENCODED);
}

const DECODED: &[&[&str]] = &[
    &[
        "grey1.png",
        "Some((37, 23))",
        "37x23:643044a899d9ab7a",
        "37x23:f84464856471a7c0",
        "37x23:643044a899d9ab7a",
    ],
    &[
        "palette1.png",
        "Some((37, 23))",
        "37x23:114272d977605ef0",
        "37x23:afce52ae06ec0145",
        "37x23:114272d977605ef0",
    ],
    &[
        "palette1_trns.png",
        "Some((37, 23))",
        "37x23:114272d977605ef0",
        "37x23:afce52ae06ec0145",
        "37x23:f2b10dd1b0c0b440",
    ],
    &[
        "grey2.png",
        "Some((37, 23))",
        "37x23:a351e0024dbd7ed4",
        "37x23:0b8ab424c758b0f2",
        "37x23:a351e0024dbd7ed4",
    ],
    &[
        "palette2.png",
        "Some((37, 23))",
        "37x23:45d29b5e8aacaec4",
        "37x23:cdb4cf00e46fc7ad",
        "37x23:45d29b5e8aacaec4",
    ],
    &[
        "palette2_trns.png",
        "Some((37, 23))",
        "37x23:45d29b5e8aacaec4",
        "37x23:cdb4cf00e46fc7ad",
        "37x23:34faac2569b3db18",
    ],
    &[
        "grey4.png",
        "Some((37, 23))",
        "37x23:7c20e8ce3b9e83be",
        "37x23:281f71b162f99384",
        "37x23:7c20e8ce3b9e83be",
    ],
    &[
        "palette4.png",
        "Some((37, 23))",
        "37x23:914a64f5c6e8163c",
        "37x23:fc2540720b75fb54",
        "37x23:914a64f5c6e8163c",
    ],
    &[
        "palette4_trns.png",
        "Some((37, 23))",
        "37x23:914a64f5c6e8163c",
        "37x23:fc2540720b75fb54",
        "37x23:0355ea4fb7ddabef",
    ],
    &[
        "grey8.png",
        "Some((37, 23))",
        "37x23:082d4605bdeb3b26",
        "37x23:b799d7eeaf3a5bcc",
        "37x23:082d4605bdeb3b26",
    ],
    &[
        "grey8_text.png",
        "Some((37, 23))",
        "37x23:082d4605bdeb3b26",
        "37x23:b799d7eeaf3a5bcc",
        "37x23:082d4605bdeb3b26",
    ],
    &[
        "grey8_trns.png",
        "Some((37, 23))",
        "37x23:082d4605bdeb3b26",
        "37x23:b799d7eeaf3a5bcc",
        "37x23:4474ebf950bf0738",
    ],
    &[
        "palette8.png",
        "Some((37, 23))",
        "37x23:d94c2a2246829226",
        "37x23:69b282736ff65b59",
        "37x23:d94c2a2246829226",
    ],
    &[
        "palette8_trns.png",
        "Some((37, 23))",
        "37x23:d94c2a2246829226",
        "37x23:69b282736ff65b59",
        "37x23:4d7dc70b9f4c76e7",
    ],
    &[
        "grey16.png",
        "Some((37, 23))",
        "37x23:009a6f81965f5387",
        "37x23:d39afaa737920823",
        "37x23:009a6f81965f5387",
    ],
    &[
        "grey16_trns.png",
        "Some((37, 23))",
        "37x23:009a6f81965f5387",
        "37x23:d39afaa737920823",
        "37x23:fac0261d68653ce9",
    ],
    &[
        "grey_alpha8.png",
        "Some((37, 23))",
        "37x23:ca5715a82f10b68b",
        "37x23:48629820fcaaed5b",
        "37x23:106a14f2338c7f50",
    ],
    &[
        "grey_alpha16.png",
        "Some((37, 23))",
        "37x23:c63eed6365bf62bd",
        "37x23:81d312a36f252531",
        "37x23:3b1d7ba7d03c5b98",
    ],
    &[
        "rgba8.png",
        "Some((37, 23))",
        "37x23:8b09af9bba028b47",
        "37x23:ae4ff326ede2b8ea",
        "37x23:9d557fcadd4c8d39",
    ],
    &[
        "rgb8.png",
        "Some((37, 23))",
        "37x23:c5f929e56953ba15",
        "37x23:e8b4bf8dddea9cd4",
        "37x23:c5f929e56953ba15",
    ],
    &[
        "rgb8_trns.png",
        "Some((37, 23))",
        "37x23:c5f929e56953ba15",
        "37x23:e8b4bf8dddea9cd4",
        "37x23:0a040d3294fb0509",
    ],
    &[
        "rgb16.png",
        "Some((37, 23))",
        "37x23:ce275adf91155503",
        "37x23:59cd4fe697c0731b",
        "37x23:ce275adf91155503",
    ],
    &[
        "rgb16_trns.png",
        "Some((37, 23))",
        "37x23:ce275adf91155503",
        "37x23:59cd4fe697c0731b",
        "37x23:6e6b85627aefe9e0",
    ],
    &[
        "rgba16.png",
        "Some((37, 23))",
        "37x23:4992becde4797083",
        "37x23:5594b9274edd623f",
        "37x23:a39ad20073910102",
    ],
    &[
        "every_grey16.png",
        "Some((256, 256))",
        "256x256:906d6281dd0c2fa5",
        "256x256:a944ce4b92dda6a5",
        "256x256:906d6281dd0c2fa5",
    ],
    &[
        "every_grey_alpha16.png",
        "Some((256, 256))",
        "256x256:906d6281dd0c2fa5",
        "256x256:a944ce4b92dda6a5",
        "256x256:6bc0063be85983a2",
    ],
    &[
        "every_grey_alpha8.png",
        "Some((256, 256))",
        "256x256:5f73a95b0831a325",
        "256x256:9e731e58b77ca325",
        "256x256:ccd221af6d3391bd",
    ],
    &[
        "every_rgb16.png",
        "Some((256, 256))",
        "256x256:00a815fc545c6465",
        "256x256:747b2f911580e26b",
        "256x256:00a815fc545c6465",
    ],
    &[
        "baseline_420.jpg",
        "Some((97, 65))",
        "97x65:5ad9a794caeaf027",
        "97x65:9c776bf230c4a7ca",
        "97x65:5ad9a794caeaf027",
    ],
    &[
        "black_40x30.jpg",
        "Some((40, 30))",
        "40x30:b98c0c5ef93b7c65",
        "40x30:74b4429a2fdd70e5",
        "40x30:b98c0c5ef93b7c65",
    ],
    &[
        "grey.jpg",
        "Some((97, 65))",
        "97x65:3d6a563171a2929c",
        "97x65:d6bd5fe05164f62e",
        "97x65:3d6a563171a2929c",
    ],
    &[
        "progressive.jpg",
        "Some((97, 65))",
        "97x65:7fd119d8ab19fe04",
        "97x65:25d2abe70aecd6a6",
        "97x65:7fd119d8ab19fe04",
    ],
    &[
        "rgb_colourspace.jpg",
        "Some((97, 65))",
        "97x65:4251f236f2976c0e",
        "97x65:2adb40cd8f0067cb",
        "97x65:4251f236f2976c0e",
    ],
    &[
        "sub422_restart.jpg",
        "Some((97, 65))",
        "97x65:17e523e443012bfb",
        "97x65:8058ffc7840c5edd",
        "97x65:17e523e443012bfb",
    ],
    &[
        "sub444.jpg",
        "Some((97, 65))",
        "97x65:82a03dc38db392f2",
        "97x65:8a22dc5647506295",
        "97x65:82a03dc38db392f2",
    ],
    &["not_an_image.png", "None", "error", "error", "error"],
    &["truncated.png", "Some((37, 23))", "error", "error", "error"],
];
const EVERY_COLOUR: &[&[&str]] = &[
    &[
        "every_rgb8.png",
        "Some((4096, 4096))",
        "4096x4096:a1726fd84093a325",
        "4096x4096:51e43c44177d0e9f",
        "4096x4096:a1726fd84093a325",
    ],
    &[
        "every_rgba8.png",
        "Some((4096, 4096))",
        "4096x4096:bb6e785ec7f5a325",
        "4096x4096:c4c5004d698bd2d5",
        "4096x4096:4877eada03ed0fd1",
    ],
];
const RESIZED: &[&[&str]] = &[
    &["random_64x48 to 32x24", "32x24:1ede6821b14bd67d"],
    &["random_64x48 to 16x12", "16x12:4dddc303bd320fd3"],
    &["random_64x48 to 33x19", "33x19:d4d9237396b69eca"],
    &["random_64x48 to 65x47", "65x47:5310d8239c8f0f1f"],
    &["random_64x48 to 200x7", "200x7:47ad08495264347f"],
    &["random_64x48 to 3x90", "3x90:36f3a0bcc669d810"],
    &["random_64x48 to 1x1", "1x1:2fba391ae17d4ca5"],
    &["random_64x48 to 64x48", "64x48:dc6a203752085ea4"],
    &["baseline_420.jpg to 48x32", "48x32:415efcf66df34aaf"],
    &["baseline_420.jpg to 24x16", "24x16:c1e97d0672cf2e52"],
    &["baseline_420.jpg to 33x19", "33x19:59c206cb117f1bc2"],
    &["baseline_420.jpg to 98x64", "98x64:a4ec1688818f5f5a"],
    &["baseline_420.jpg to 200x7", "200x7:168443284dce9cc9"],
    &["baseline_420.jpg to 3x90", "3x90:529d3e69f624d92a"],
    &["baseline_420.jpg to 1x1", "1x1:25eff71adba00872"],
    &["baseline_420.jpg to 97x65", "97x65:5ad9a794caeaf027"],
    &["black_40x30.jpg to 20x15", "20x15:07337c7d7090f9f5"],
    &["black_40x30.jpg to 10x7", "10x7:51d8f4040b006a2d"],
    &["black_40x30.jpg to 33x19", "33x19:de972c6aa9d3247f"],
    &["black_40x30.jpg to 41x29", "41x29:420aad4a7b68ca07"],
    &["black_40x30.jpg to 200x7", "200x7:880bb47fa003a145"],
    &["black_40x30.jpg to 3x90", "3x90:ac64ce6026f7920d"],
    &["black_40x30.jpg to 1x1", "1x1:d94d12186c0f2fb7"],
    &["black_40x30.jpg to 40x30", "40x30:b98c0c5ef93b7c65"],
    &["grey.jpg to 48x32", "48x32:38033a732c58490b"],
    &["grey.jpg to 24x16", "24x16:c4c55b39f880c8bf"],
    &["grey.jpg to 33x19", "33x19:f865cfef06c0dbcd"],
    &["grey.jpg to 98x64", "98x64:c481da30fe3e6ed6"],
    &["grey.jpg to 200x7", "200x7:7199cd0c8bccaf75"],
    &["grey.jpg to 3x90", "3x90:e7ff650fd1a278cd"],
    &["grey.jpg to 1x1", "1x1:b5318c19797598ca"],
    &["grey.jpg to 97x65", "97x65:3d6a563171a2929c"],
    &["progressive.jpg to 48x32", "48x32:9cb7cc581b2c05a5"],
    &["progressive.jpg to 24x16", "24x16:dab380f663ce87c8"],
    &["progressive.jpg to 33x19", "33x19:14a9b09b70c80faf"],
    &["progressive.jpg to 98x64", "98x64:906479b5076d0707"],
    &["progressive.jpg to 200x7", "200x7:93174f114e1af28f"],
    &["progressive.jpg to 3x90", "3x90:26d6823338c2a4cb"],
    &["progressive.jpg to 1x1", "1x1:2d45521adf66d0c1"],
    &["progressive.jpg to 97x65", "97x65:7fd119d8ab19fe04"],
    &["rgb_colourspace.jpg to 48x32", "48x32:a168dd1e94578b77"],
    &["rgb_colourspace.jpg to 24x16", "24x16:8330cc9cb93312a0"],
    &["rgb_colourspace.jpg to 33x19", "33x19:fbd0318e9486ff41"],
    &["rgb_colourspace.jpg to 98x64", "98x64:e182abbe964fd3d0"],
    &["rgb_colourspace.jpg to 200x7", "200x7:959d62ec79e4eb05"],
    &["rgb_colourspace.jpg to 3x90", "3x90:35299c57c508f449"],
    &["rgb_colourspace.jpg to 1x1", "1x1:2d45531adf66d274"],
    &["rgb_colourspace.jpg to 97x65", "97x65:4251f236f2976c0e"],
    &["sub422_restart.jpg to 48x32", "48x32:fadb462abd13032d"],
    &["sub422_restart.jpg to 24x16", "24x16:b54c46942aaf60fe"],
    &["sub422_restart.jpg to 33x19", "33x19:fdfd1f77286b91f5"],
    &["sub422_restart.jpg to 98x64", "98x64:c9de989816b793da"],
    &["sub422_restart.jpg to 200x7", "200x7:ae64519095ed60e0"],
    &["sub422_restart.jpg to 3x90", "3x90:a8423ff07ea3e3ee"],
    &["sub422_restart.jpg to 1x1", "1x1:2d45531adf66d274"],
    &["sub422_restart.jpg to 97x65", "97x65:17e523e443012bfb"],
    &["sub444.jpg to 48x32", "48x32:575af5dc4a34eb47"],
    &["sub444.jpg to 24x16", "24x16:c11d3387168c7edb"],
    &["sub444.jpg to 33x19", "33x19:bd4e6c6222420d56"],
    &["sub444.jpg to 98x64", "98x64:a86520cf35cd71af"],
    &["sub444.jpg to 200x7", "200x7:0c8080a26b49b625"],
    &["sub444.jpg to 3x90", "3x90:5121a9e6e22d1a4b"],
    &["sub444.jpg to 1x1", "1x1:2d45531adf66d274"],
    &["sub444.jpg to 97x65", "97x65:82a03dc38db392f2"],
];
const ENCODED: &[&[&str]] = &[
    &["rgb8 random 37x23", "37x23:5a80cb2909918486"],
    &["rgb8 smooth 37x23", "37x23:61de27192c75736c"],
    &["rgb8 flat 37x23", "37x23:4d1cb4f1b96835f0"],
    &["luma8 random 37x23", "37x23:fae263a001c06117"],
    &["luma8 mask 37x23", "37x23:954dcdb7330170cc"],
    &["luma16 random 37x23", "37x23:cdb9cffa3d675a27"],
    &["luma16 ids 37x23", "37x23:aec90b7f76fda776"],
    &["rgb8 random 1x1", "1x1:d3f8552d7ed26d42"],
    &["rgb8 smooth 1x1", "1x1:153812cac07f4e91"],
    &["rgb8 flat 1x1", "1x1:29014c77147bd5ea"],
    &["luma8 random 1x1", "1x1:2ec58db0f858a574"],
    &["luma8 mask 1x1", "1x1:0f059c6b3bee65c4"],
    &["luma16 random 1x1", "1x1:f766b713d8f94704"],
    &["luma16 ids 1x1", "1x1:da9122f438ad51e7"],
    &["rgb8 random 300x200", "300x200:00c05411618f8dea"],
    &["rgb8 smooth 300x200", "300x200:c80a42e7e3324d57"],
    &["rgb8 flat 300x200", "300x200:828794cb22898928"],
    &["luma8 random 300x200", "300x200:4f3b922b4acf69a8"],
    &["luma8 mask 300x200", "300x200:ce350af8914d0c63"],
    &["luma16 random 300x200", "300x200:5ff1fdbdf556de6e"],
    &["luma16 ids 300x200", "300x200:efe756b12187c468"],
    &["rgb8 random 640x3", "640x3:5ccd7a32602f68b0"],
    &["rgb8 smooth 640x3", "640x3:6b66cad8fdd17c80"],
    &["rgb8 flat 640x3", "640x3:7c49c044b4f68190"],
    &["luma8 random 640x3", "640x3:ecfae2d1c82e6155"],
    &["luma8 mask 640x3", "640x3:980a2e9c1b92c724"],
    &["luma16 random 640x3", "640x3:d1f9c908264bb48f"],
    &["luma16 ids 640x3", "640x3:94d829aed9d7d100"],
    &["rgb8 random 2x500", "2x500:e5ac8cb4d36fb946"],
    &["rgb8 smooth 2x500", "2x500:94b0e6f563d1b887"],
    &["rgb8 flat 2x500", "2x500:6d4c8695cbd8e334"],
    &["luma8 random 2x500", "2x500:7f2cce21b9958628"],
    &["luma8 mask 2x500", "2x500:e7b714a810b12f86"],
    &["luma16 random 2x500", "2x500:041e43a359632d46"],
    &["luma16 ids 2x500", "2x500:1f0e8cf8cb893800"],
];
