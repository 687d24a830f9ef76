//! Label-map PNGs (8/16-bit), the id palette and overlays.

use splatseg_scene::image_io::{read_rgb8, write_png_luma8, write_png_rgb8, RgbImage};
use splatseg_scene::labels::{colour_of_id, label_colour_image, overlay, read_label_png, write_label_png};
use splatseg_scene::Plane;

fn ids(width: usize, height: usize, f: impl Fn(usize, usize) -> u32) -> Plane<u32> {
    let data = (0..height).flat_map(|y| (0..width).map(move |x| (x, y))).map(|(x, y)| f(x, y)).collect();
    Plane::from_vec(width, height, data).unwrap()
}

#[test]
fn sixteen_bit_label_maps_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let labels = ids(17, 9, |x, y| ((x * 3917 + y * 7) % 65536) as u32);
    let path = dir.path().join("labels/view.png");
    write_label_png(&path, &labels).unwrap();
    assert_eq!(read_label_png(&path).unwrap(), labels);
    // It really is a 16-bit grey PNG.
    let reader =
        png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap())).read_info().unwrap();
    assert_eq!(
        (reader.info().color_type, reader.info().bit_depth),
        (png::ColorType::Grayscale, png::BitDepth::Sixteen)
    );
}

#[test]
fn eight_bit_label_maps_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let labels = ids(5, 3, |x, y| (x + 5 * y) as u32 * 17 % 256);
    let pixels = labels.map(|&v| v as u8);
    let path = dir.path().join("eight.png");
    write_png_luma8(&path, &pixels).unwrap();
    assert_eq!(read_label_png(&path).unwrap(), labels);
}

/// Writes a PNG with the png crate: `bits` per pixel, greyscale or indexed (with a palette).
fn write_raw_png(
    path: &std::path::Path,
    width: u32,
    height: u32,
    colour: png::ColorType,
    bits: png::BitDepth,
    packed: &[u8],
) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut encoder = png::Encoder::new(file, width, height);
    encoder.set_color(colour);
    encoder.set_depth(bits);
    if colour == png::ColorType::Indexed {
        encoder.set_palette((0..=255u8).flat_map(|i| [i, 255 - i, i / 2]).collect::<Vec<u8>>());
    }
    encoder.write_header().unwrap().write_image_data(packed).unwrap();
}

#[test]
fn palette_and_low_bit_depth_label_maps_are_read_as_indices() {
    let dir = tempfile::tempdir().unwrap();
    // 8-bit palette: index = id.
    let labels = ids(6, 2, |x, y| (x * 40 + y) as u32);
    let packed: Vec<u8> = labels.data.iter().map(|&v| v as u8).collect();
    let path = dir.path().join("palette8.png");
    write_raw_png(&path, 6, 2, png::ColorType::Indexed, png::BitDepth::Eight, &packed);
    assert_eq!(read_label_png(&path).unwrap(), labels);
    // 4-bit palette, 5 pixels per row (rows padded to whole bytes): ids 0..=9.
    let labels = ids(5, 2, |x, y| (x + 5 * y) as u32);
    let packed = [0x01, 0x23, 0x40, 0x56, 0x78, 0x90];
    let path = dir.path().join("palette4.png");
    write_raw_png(&path, 5, 2, png::ColorType::Indexed, png::BitDepth::Four, &packed);
    assert_eq!(read_label_png(&path).unwrap(), labels);
    // 1-bit greyscale: a binary mask, 1 = id 1.
    let labels = ids(10, 1, |x, _| (x % 3 == 0) as u32);
    let path = dir.path().join("grey1.png");
    write_raw_png(&path, 10, 1, png::ColorType::Grayscale, png::BitDepth::One, &[0b1001_0010, 0b0100_0000]);
    assert_eq!(read_label_png(&path).unwrap(), labels);
}

#[test]
fn ids_above_65535_are_rejected_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let labels = ids(4, 4, |x, y| if (x, y) == (2, 3) { 70_000 } else { 1 });
    let path = dir.path().join("big.png");
    let err = write_label_png(&path, &labels).unwrap_err().to_string();
    assert!(err.contains("70000") && err.contains("(2, 3)") && err.contains("big.png"), "{err}");
    assert!(!path.exists());
}

#[test]
fn colour_labels_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rgb.png");
    write_png_rgb8(&path, &RgbImage::filled(2, 2, [0; 3])).unwrap();
    let err = read_label_png(&path).unwrap_err().to_string();
    assert!(err.contains("greyscale") && err.contains("rgb.png"), "{err}");
}

fn distance(a: [u8; 3], b: [u8; 3]) -> f64 {
    a.iter().zip(b).map(|(&p, q)| (p as f64 - q as f64).powi(2)).sum::<f64>().sqrt()
}

#[test]
fn palette_is_deterministic_distinct_and_black_only_for_zero() {
    assert_eq!(colour_of_id(0), [0, 0, 0]);
    assert_eq!(colour_of_id(17), colour_of_id(17));
    for id in 1..2000u32 {
        assert!(colour_of_id(id).iter().map(|&c| c as u32).sum::<u32>() > 150, "id {id} too dark");
    }
    // Consecutive ids are far apart, and the first 60 colours are pairwise distinguishable.
    for id in 1..500u32 {
        assert!(distance(colour_of_id(id), colour_of_id(id + 1)) > 80.0, "ids {id} and {}", id + 1);
    }
    for a in 1..=60u32 {
        for b in a + 1..=60 {
            assert!(distance(colour_of_id(a), colour_of_id(b)) > 25.0, "ids {a} and {b}");
        }
    }
}

#[test]
fn colour_image_and_overlay_use_the_palette_and_mark_boundaries() {
    let labels = ids(8, 6, |x, _| if x < 4 { 0 } else { 3 });
    let colours = label_colour_image(&labels);
    assert_eq!(colours.pixel(0, 0), [0, 0, 0]);
    assert_eq!(colours.pixel(7, 5), colour_of_id(3));
    let grey = RgbImage::filled(8, 6, [100, 100, 100]);
    let over = overlay(&grey, &labels, 0.5);
    // Unlabelled, away from the boundary: unchanged.
    assert_eq!(over.pixel(1, 2), [100, 100, 100]);
    // Labelled interior: halfway between grey and the palette colour.
    let c = colour_of_id(3);
    let expected = c.map(|v| ((100.0 + v as f32) / 2.0).round() as u8);
    assert_eq!(over.pixel(6, 2), expected);
    // Both sides of the boundary are darker than their interiors.
    assert!(over.pixel(3, 2)[0] < 100);
    assert!(over.pixel(4, 2).iter().sum::<u8>() < expected.iter().sum::<u8>());
    // A half-resolution label map is sampled nearest-neighbour.
    let half = ids(4, 3, |x, _| if x < 2 { 0 } else { 3 });
    assert_eq!(overlay(&grey, &half, 0.5).pixel(6, 2), expected);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("overlay.png");
    write_png_rgb8(&path, &over).unwrap();
    assert_eq!(read_rgb8(&path).unwrap(), over);
}
