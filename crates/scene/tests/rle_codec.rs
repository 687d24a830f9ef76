//! COCO RLE: parity with pycocotools (committed fixture made by
//! `tools/fixtures/make_rle_fixtures.py`), round trips on random masks, malformed input.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Deserialize;
use splatseg_scene::rle::Rle;
use splatseg_scene::Plane;

#[derive(Deserialize)]
struct Fixture {
    name: String,
    height: u32,
    width: u32,
    /// `[height]` rows of '0'/'1'.
    rows: Vec<String>,
    counts_string: String,
    counts: Vec<u32>,
    area: u64,
    bbox_xywh: [u32; 4],
}

fn fixtures() -> Vec<Fixture> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/rle_pycocotools.json");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn mask_of(f: &Fixture) -> Plane<bool> {
    let data: Vec<bool> = f.rows.iter().flat_map(|r| r.bytes().map(|b| b == b'1')).collect();
    Plane::from_vec(f.width as usize, f.height as usize, data).unwrap()
}

#[test]
fn encoding_matches_pycocotools() {
    let fixtures = fixtures();
    assert!(fixtures.len() >= 10);
    for f in &fixtures {
        let rle = Rle::encode(&mask_of(f));
        assert_eq!((rle.height, rle.width), (f.height, f.width), "{}", f.name);
        assert_eq!(rle.counts, f.counts, "{}: uncompressed counts", f.name);
        assert_eq!(rle.to_coco_string(), f.counts_string, "{}: compressed string", f.name);
        assert_eq!(rle.area(), f.area, "{}: area", f.name);
        assert_eq!(rle.bbox_xywh(), f.bbox_xywh, "{}: bbox", f.name);
    }
}

#[test]
fn decoding_pycocotools_strings_gives_the_masks() {
    for f in &fixtures() {
        let rle = Rle::from_coco_string(f.height, f.width, &f.counts_string).unwrap();
        assert_eq!(rle.counts, f.counts, "{}", f.name);
        assert_eq!(rle.decode().unwrap(), mask_of(f), "{}", f.name);
    }
}

/// Exact area and bbox by scanning the pixels.
fn brute_area_bbox(m: &Plane<bool>) -> (u64, [u32; 4]) {
    let (mut x0, mut y0, mut x1, mut y1, mut area) = (usize::MAX, usize::MAX, 0, 0, 0u64);
    for y in 0..m.height {
        for x in 0..m.width {
            if *m.get(x, y) {
                area += 1;
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
            }
        }
    }
    if area == 0 {
        return (0, [0; 4]);
    }
    (area, [x0 as u32, y0 as u32, (x1 - x0 + 1) as u32, (y1 - y0 + 1) as u32])
}

#[test]
fn random_masks_round_trip_through_counts_and_strings() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for case in 0..300 {
        let (w, h) = (rng.gen_range(1..40), rng.gen_range(1..40));
        let density: f64 = rng.gen();
        // Blocky masks give long runs (multi-character string counts), noise gives short ones.
        let block = rng.gen_range(1..8);
        let cells: Vec<bool> = (0..w * h).map(|_| rng.gen_bool(density)).collect();
        let data: Vec<bool> =
            (0..h).flat_map(|y| (0..w).map(move |x| (y / block) * w + x / block)).map(|i| cells[i]).collect();
        let mask = Plane::from_vec(w, h, data).unwrap();
        let rle = Rle::encode(&mask);
        rle.check().unwrap();
        assert_eq!(rle.decode().unwrap(), mask, "case {case}");
        let s = rle.to_coco_string();
        assert!(s.bytes().all(|b| (48..112).contains(&b)), "case {case}: {s}");
        assert_eq!(Rle::from_coco_string(h as u32, w as u32, &s).unwrap(), rle, "case {case}");
        assert_eq!((rle.area(), rle.bbox_xywh()), brute_area_bbox(&mask), "case {case}");
    }
}

#[test]
fn large_counts_survive_the_string_form() {
    // Runs of millions of pixels and big differences between consecutive runs.
    let rle = Rle { height: 4000, width: 3000, counts: vec![0, 5_000_000, 3, 6_999_990, 7] };
    let back = Rle::from_coco_string(4000, 3000, &rle.to_coco_string()).unwrap();
    assert_eq!(back, rle);
    assert_eq!(rle.area(), 6_999_990 + 5_000_000);
}

#[test]
fn one_megapixel_round_trip() {
    let (w, h) = (1000, 1000);
    let data: Vec<bool> = (0..w * h).map(|i| ((i % w) / 7 + (i / w) / 11) % 3 == 0).collect();
    let mask = Plane::from_vec(w, h, data).unwrap();
    let rle = Rle::encode(&mask);
    assert_eq!(rle.decode().unwrap(), mask);
}

#[test]
fn malformed_rle_is_rejected_with_a_reason() {
    let short = Rle { height: 2, width: 3, counts: vec![1, 2] };
    let err = short.decode().unwrap_err();
    assert!(err.contains("sum to 3") && err.contains("6 pixels"), "{err}");
    let long = Rle { height: 2, width: 3, counts: vec![4, 4] };
    assert!(long.decode().unwrap_err().contains("sum to 8"));
    // Wrong total in string form.
    let s = Rle { height: 2, width: 3, counts: vec![1, 5] }.to_coco_string();
    assert!(Rle::from_coco_string(3, 3, &s).unwrap_err().contains("9 pixels"));
    // Characters outside the alphabet, and a count cut off mid-way ('P' = 0x20 set: more follow).
    assert!(Rle::from_coco_string(1, 1, "0 1").unwrap_err().contains("invalid character"));
    assert!(Rle::from_coco_string(1, 1, "0P").unwrap_err().contains("ends inside count 1"));
    // A negative first count ('O' = 0x1f: sign bit 0x10 set, no continuation → -1).
    assert!(Rle::from_coco_string(1, 1, "O").unwrap_err().contains("decodes to -1"));
    // Overlong counts.
    assert!(Rle::from_coco_string(1, 1, "ooooooooooooooooo1").unwrap_err().contains("too long"));
}
