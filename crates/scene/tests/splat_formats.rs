//! The compact Gaussian formats (`splatseg_scene::splats`) against the reference: files made by
//! `@playcanvas/splat-transform` (Niantic's SPZ library inside) from `splats_source.ply`, and our
//! writers' files as splat-transform read them (`tools/fixtures/make_splat_fixtures.py`). Each
//! comparison is property by property within the format's quantisation step.

use splatseg_scene::gaussians::SH_C0;
use splatseg_scene::splats::{
    read_gaussian_rows, read_gaussian_rows_with_format, read_gaussians, to_gaussian_bytes, write_gaussians,
    SplatFormat,
};
use splatseg_scene::Gaussians;
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures")).join(name)
}

/// Largest allowed difference per property; `None`: the format does not keep it (not compared).
#[derive(Clone, Copy, Debug)]
struct Tolerance {
    position: f32,
    log_scale: f32,
    /// On the opacity after the sigmoid.
    opacity: f32,
    sh_dc: f32,
    /// Per component of the normalised quaternions (sign chosen to agree).
    rotation: f32,
    /// SH band 1 and bands 2–3.
    sh_rest: Option<(f32, f32)>,
}

/// SPZ version 3 as written: half a step of each quantiser, plus float rounding.
const SPZ: Tolerance = Tolerance {
    position: 0.5 / 4096.0 + 1e-6,
    log_scale: 0.5 / 16.0 + 1e-5,
    opacity: 0.5 / 255.0 + 1e-6,
    sh_dc: 0.5 / (0.15 * 255.0) + 1e-5,
    rotation: 2e-3,
    sh_rest: Some((4.5 / 128.0 + 1e-6, 8.5 / 128.0 + 1e-6)),
};

/// `.splat`: positions and scales as f32, colours and opacity as bytes, quaternions at 1/128.
const SPLAT: Tolerance = Tolerance {
    position: 0.0,
    log_scale: 1e-5,
    opacity: 0.5 / 255.0 + 1e-6,
    sh_dc: 0.5 / 255.0 / SH_C0 + 1e-5,
    rotation: 0.01,
    sh_rest: None,
};

/// Two decodings of the same bytes: float rounding only (and the reference's own quaternion
/// decoding of `.splat`, `b/255·2 − 1`, against ours, `(b − 128)/128`).
const SAME_BYTES: Tolerance = Tolerance {
    position: 1e-6,
    log_scale: 1e-5,
    opacity: 1e-5,
    sh_dc: 1e-4,
    rotation: 0.01,
    sh_rest: Some((1e-5, 1e-5)),
};

fn unit(q: [f32; 4]) -> [f32; 4] {
    let n = q.iter().map(|v| v * v).sum::<f32>().sqrt();
    q.map(|v| v / n)
}

fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}

/// Asserts `got` agrees with `want` property by property; a failure names the property, the
/// Gaussian and both values.
fn assert_agree(got: &Gaussians, want: &Gaussians, tol: Tolerance, what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: count");
    let close = |a: f32, b: f32, t: f32| (a - b).abs() <= t;
    for i in 0..want.len() {
        for a in 0..3 {
            let (g, w) = (got.means[i][a], want.means[i][a]);
            assert!(close(g, w, tol.position), "{what}: position {i}[{a}] {g} vs {w}");
            let (g, w) = (got.log_scales[i][a], want.log_scales[i][a]);
            assert!(close(g, w, tol.log_scale), "{what}: log-scale {i}[{a}] {g} vs {w}");
            let (g, w) = (got.sh_dc[i][a], want.sh_dc[i][a]);
            assert!(close(g, w, tol.sh_dc), "{what}: f_dc {i}[{a}] {g} vs {w}");
        }
        let (g, w) = (sigmoid(got.raw_opacities[i]), sigmoid(want.raw_opacities[i]));
        assert!(close(g, w, tol.opacity), "{what}: opacity {i} {g} vs {w}");
        let (g, w) = (unit(got.rotations[i]), unit(want.rotations[i]));
        let sign = if g.iter().zip(&w).map(|(a, b)| a * b).sum::<f32>() < 0.0 { -1.0 } else { 1.0 };
        for c in 0..4 {
            assert!(close(sign * g[c], w[c], tol.rotation), "{what}: rotation {i} {g:?} vs {w:?}");
        }
        if let Some((band1, rest)) = tol.sh_rest {
            assert_eq!(got.sh_degree, want.sh_degree, "{what}: SH degree");
            let k = want.rest_per_channel();
            for c in 0..3 {
                for j in 0..k {
                    let (g, w) = (got.sh_rest[i * 3 * k + c * k + j], want.sh_rest[i * 3 * k + c * k + j]);
                    let t = if j < 3 { band1 } else { rest };
                    assert!(close(g, w, t), "{what}: f_rest {i} channel {c} coefficient {j} {g} vs {w}");
                }
            }
        }
    }
}

fn source() -> Gaussians {
    let g = read_gaussians(&fixture("splats_source.ply")).expect("the source PLY");
    assert_eq!((g.len(), g.sh_degree), (24, 3));
    g
}

#[test]
fn the_reference_spz_reads_as_its_source_ply() {
    let path = fixture("splats_reference.spz");
    let (format, rows) = read_gaussian_rows_with_format(&path).expect("splat-transform's SPZ");
    assert_eq!(format, SplatFormat::Spz);
    assert_eq!(rows.skipped(), 0);
    assert_agree(&rows.gaussians, &source(), SPZ, "splat-transform's SPZ");
}

#[test]
fn our_spz_reads_back_as_its_source_and_as_the_reference_reads_it() {
    let source = source();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.spz");
    write_gaussians(&path, &source).expect("writes an SPZ");
    let ours = read_gaussians(&path).expect("reads it back");
    assert_agree(&ours, &source, SPZ, "our SPZ read back");
    // The committed file is what the writer makes today, read by splat-transform as by us.
    let committed = read_gaussians(&fixture("splats_ours.spz")).unwrap();
    assert_eq!(committed, ours, "the writer changed since the fixture was made");
    let by_reference = read_gaussians(&fixture("splats_ours_spz_by_reference.ply")).unwrap();
    assert_agree(&by_reference, &ours, SAME_BYTES, "splat-transform's reading of our SPZ");
}

#[test]
fn our_splat_reads_back_as_its_source_and_as_the_reference_reads_it() {
    let source = source();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.splat");
    write_gaussians(&path, &source).expect("writes a .splat");
    let (format, rows) = read_gaussian_rows_with_format(&path).unwrap();
    assert_eq!(format, SplatFormat::Splat);
    let ours = rows.gaussians;
    assert_eq!(ours.sh_degree, 0, ".splat holds no SH rest");
    assert_agree(&ours, &source, SPLAT, "our .splat read back");
    assert_eq!(read_gaussians(&fixture("splats_ours.splat")).unwrap(), ours);
    let by_reference = read_gaussians(&fixture("splats_ours_splat_by_reference.ply")).unwrap();
    assert_agree(&by_reference, &ours, SAME_BYTES, "splat-transform's reading of our .splat");
}

#[test]
fn the_format_comes_from_the_content_not_the_name() {
    let dir = tempfile::tempdir().unwrap();
    // An SPZ named .ply and a PLY named .spz read as what they hold.
    let spz_named_ply = dir.path().join("looks.ply");
    std::fs::copy(fixture("splats_reference.spz"), &spz_named_ply).unwrap();
    assert_eq!(read_gaussian_rows_with_format(&spz_named_ply).unwrap().0, SplatFormat::Spz);
    let ply_named_spz = dir.path().join("looks.spz");
    std::fs::copy(fixture("splats_source.ply"), &ply_named_spz).unwrap();
    assert_eq!(read_gaussian_rows_with_format(&ply_named_spz).unwrap().0, SplatFormat::Ply);
    // Writing follows the extension, case-insensitively; an unknown one writes a PLY.
    let g = source();
    let by_name = [
        ("a.SPZ", SplatFormat::Spz),
        ("b.splat", SplatFormat::Splat),
        ("c.Compressed.PLY", SplatFormat::CompressedPly),
        ("d.ply", SplatFormat::Ply),
        ("e.out", SplatFormat::Ply),
    ];
    for (name, format) in by_name {
        let path = dir.path().join(name);
        write_gaussians(&path, &g).unwrap();
        assert_eq!(read_gaussian_rows_with_format(&path).unwrap().0, format, "{name}");
    }
}

/// The error of reading `bytes` as a file named `name`, which must name the file and say each of `needles`.
fn read_error(name: &str, bytes: &[u8], needles: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    let err = read_gaussians(&path).expect_err("a bad file must not read").to_string();
    assert!(err.contains(name), "the error names the file: {err}");
    for needle in needles {
        assert!(err.contains(needle), "expected {needle:?} in: {err}");
    }
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

/// An SPZ header: version, count, SH degree, fractional bits, flags.
fn spz_header(version: u32, count: u32, sh_degree: u8, flags: u8) -> Vec<u8> {
    let mut h = b"NGSP".to_vec();
    h.extend_from_slice(&version.to_le_bytes());
    h.extend_from_slice(&count.to_le_bytes());
    h.extend_from_slice(&[sh_degree, 12, flags, 0]);
    h
}

#[test]
fn bad_spz_files_are_clear_errors_naming_the_file() {
    let good = std::fs::read(fixture("splats_reference.spz")).unwrap();
    read_error("cut.spz", &good[..good.len() / 2], &["SPZ", "truncated or corrupt"]);
    read_error("cut_trailer.spz", &good[..good.len() - 4], &["SPZ", "truncated or corrupt"]);
    read_error("magic.spz", &gzip(b"XGSP\x03\0\0\0\x01\0\0\0\0\x0c\0\0"), &["magic"]);
    read_error("version.spz", &gzip(&spz_header(7, 1, 0, 0)), &["SPZ version 7"]);
    read_error("short_header.spz", &gzip(b"NGSP"), &["16-byte header"]);
    read_error("degree.spz", &gzip(&spz_header(3, 1, 4, 0)), &["SH degree 4"]);
    read_error("extensions.spz", &gzip(&spz_header(3, 1, 0, 2)), &["extensions"]);
    // A count larger than the data: refused without allocating for it.
    read_error(
        "count.spz",
        &gzip(&spz_header(3, 1_000_000, 0, 0)),
        &["declares 1000000 Gaussians", "ends after 0 of them, in the positions"],
    );
    read_error("huge.spz", &gzip(&spz_header(3, u32::MAX, 0, 0)), &["2^27"]);
    // Version 4 keeps its header outside the compression.
    read_error("v4.spz", &spz_header(4, 1, 0, 0), &["version 4", "--spz-version 3"]);
    read_error("what.bin", b"hello, world", &["not a Gaussian splat file"]);
}

#[test]
fn strict_refusals_of_a_compact_file_name_its_format_not_the_ply() {
    // Two .splat rows: the first with a NaN x, the second with a zero rotation (bytes 128).
    let mut bytes = Vec::new();
    for (x, rotation) in [(f32::NAN, [255, 128, 128, 128]), (1.0, [128; 4])] {
        for v in [x, 0.0, 0.0, 0.1, 0.1, 0.1] {
            bytes.extend_from_slice(&f32::to_le_bytes(v));
        }
        bytes.extend_from_slice(&[128, 128, 128, 200]);
        bytes.extend_from_slice(&rotation);
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("odd.splat");
    std::fs::write(&path, &bytes).unwrap();
    let mut rows = read_gaussian_rows(&path).unwrap();
    let err = rows.refuse_skipped(&path).unwrap_err().to_string();
    assert!(err.contains(".splat") && err.contains("non-finite") && !err.contains("PLY"), "{err}");
    rows.gaussians.means[0][0] = 0.0;
    rows.non_finite.clear();
    let err = rows.refuse_skipped(&path).unwrap_err().to_string();
    assert!(err.contains(".splat") && err.contains("Gaussian 1 has") && !err.contains("PLY"), "{err}");
}

#[test]
fn bad_splat_files_are_clear_errors_naming_the_file() {
    let mut row = Vec::new();
    for v in [0.0f32, 1.0, 2.0, 0.1, 0.1, 0.1] {
        row.extend_from_slice(&v.to_le_bytes());
    }
    row.extend_from_slice(&[128, 128, 128, 200, 255, 128, 128, 128]);
    assert!(read_gaussians(&{
        let dir = tempfile::tempdir().unwrap().keep();
        let p = dir.join("one.splat");
        std::fs::write(&p, &row).unwrap();
        p
    })
    .is_ok());
    read_error("cut.splat", &row[..31], &[".splat", "not a multiple of the 32 bytes"]);
    let mut nan = row.clone();
    nan[4..8].copy_from_slice(&f32::NAN.to_le_bytes());
    read_error("nan.splat", &nan, &["non-finite"]);
    let mut zero_scale = row.clone();
    zero_scale[12..16].copy_from_slice(&0f32.to_le_bytes());
    read_error("zero_scale.splat", &zero_scale, &["non-finite"]);
}

#[test]
fn writers_refuse_what_the_format_cannot_hold_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let mut far = source();
    far.means[5] = [0.0, 3000.0, 0.0];
    let path = dir.path().join("far.spz");
    let err = write_gaussians(&path, &far).unwrap_err().to_string();
    assert!(err.contains("Gaussian 5") && err.contains("±2048") && err.contains("far.spz"), "{err}");
    assert!(!path.exists(), "nothing written");
    let mut nan = source();
    nan.sh_dc[2][1] = f32::NAN;
    for format in [SplatFormat::Spz, SplatFormat::Splat] {
        assert!(to_gaussian_bytes(format, &nan).unwrap_err().contains("non-finite"));
    }
    let path = dir.path().join("nan.splat");
    assert!(write_gaussians(&path, &nan).unwrap_err().to_string().contains("nan.splat"));
    assert!(!Path::new(&path).exists());
}

fn gunzip(path: &Path) -> Vec<u8> {
    use std::io::Read;
    let mut out = Vec::new();
    flate2::read::GzDecoder::new(std::fs::File::open(path).unwrap()).read_to_end(&mut out).unwrap();
    out
}

#[test]
fn our_spz_writer_makes_the_reference_libraries_bytes() {
    // Niantic's library (inside splat-transform) and ours, from the same PLY: the same header,
    // frame turn, quantisation and SH buckets, byte for byte once gunzipped (gzip's own header
    // differs: the OS byte).
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ours.spz");
    write_gaussians(&path, &source()).unwrap();
    assert_eq!(gunzip(&path), gunzip(&fixture("splats_reference.spz")));
}

/// A compressed PLY's steps on `g` when all of it is one chunk (as the fixtures are): half of
/// each quantiser's step across the chunk's range, plus float rounding.
fn compressed_tolerance(g: &Gaussians) -> Tolerance {
    let span = |v: &mut dyn Iterator<Item = f32>| {
        let (lo, hi) = v.fold((f32::MAX, f32::MIN), |(lo, hi), x| (lo.min(x), hi.max(x)));
        hi - lo
    };
    let widest = |f: &dyn Fn(usize, usize) -> f32| {
        (0..3).map(|a| span(&mut (0..g.len()).map(|i| f(i, a)))).fold(0.0, f32::max)
    };
    let position = widest(&|i, a| g.means[i][a]);
    let log_scale = widest(&|i, a| g.log_scales[i][a]);
    let colour = widest(&|i, a| 0.5 + SH_C0 * g.sh_dc[i][a]);
    Tolerance {
        position: 0.5 * position / 1023.0 + 1e-5,
        log_scale: 0.5 * log_scale / 1023.0 + 1e-5,
        opacity: 0.5 / 255.0 + 1e-6,
        sh_dc: 0.5 * colour / 255.0 / SH_C0 + 1e-5,
        rotation: 2e-3,
        sh_rest: Some((0.5 * 8.0 / 256.0 + 1e-5, 0.5 * 8.0 / 256.0 + 1e-5)),
    }
}

/// `g`'s Gaussians in the order of `like`'s, each the one nearest in position (the reference
/// writer sorts a compressed PLY along a Morton curve).
fn in_order_of(g: &Gaussians, like: &Gaussians) -> Gaussians {
    let d = |a: [f32; 3], b: [f32; 3]| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f32>();
    let order: Vec<usize> = like
        .means
        .iter()
        .map(|&p| (0..g.len()).min_by(|&i, &j| d(g.means[i], p).total_cmp(&d(g.means[j], p))).unwrap())
        .collect();
    let mut sorted = order.clone();
    sorted.sort_unstable();
    sorted.dedup();
    assert_eq!(sorted.len(), g.len(), "every Gaussian matched once");
    g.select(&order)
}

#[test]
fn the_reference_compressed_ply_reads_as_its_source_ply() {
    let path = fixture("splats_reference.compressed.ply");
    let (format, rows) = read_gaussian_rows_with_format(&path).expect("splat-transform's compressed PLY");
    assert_eq!(format, SplatFormat::CompressedPly);
    let source = source();
    let tol = compressed_tolerance(&source);
    assert_agree(&in_order_of(&rows.gaussians, &source), &source, tol, "splat-transform's compressed PLY");
}

#[test]
fn our_compressed_ply_reads_back_as_its_source_and_as_the_reference_reads_it() {
    let source = source();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.compressed.ply");
    write_gaussians(&path, &source).expect("writes a compressed PLY");
    let (format, rows) = read_gaussian_rows_with_format(&path).unwrap();
    assert_eq!(format, SplatFormat::CompressedPly);
    let ours = rows.gaussians;
    assert_agree(&ours, &source, compressed_tolerance(&source), "our compressed PLY read back");
    assert_eq!(read_gaussians(&fixture("splats_ours.compressed.ply")).unwrap(), ours);
    let by_reference = read_gaussians(&fixture("splats_ours_compressed_by_reference.ply")).unwrap();
    assert_agree(&by_reference, &ours, SAME_BYTES, "splat-transform's reading of our compressed PLY");
}

#[test]
fn many_chunks_and_sh_degree_1_round_trip() {
    // 600 Gaussians: three chunks, the last one partial.
    let mut g = source();
    let many: Vec<usize> = (0..600).map(|i| i % 24).collect();
    g = g.select(&many);
    g.means.iter_mut().enumerate().for_each(|(i, p)| p[0] += i as f32 * 0.01);
    g.sh_degree = 1;
    g.sh_rest = (0..600 * 9).map(|k| ((k % 17) as f32 - 8.0) * 0.05).collect();
    let bytes = to_gaussian_bytes(SplatFormat::CompressedPly, &g).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("many.compressed.ply");
    std::fs::write(&path, &bytes).unwrap();
    let back = read_gaussians(&path).unwrap();
    let mut tol = compressed_tolerance(&g);
    tol.position = 0.5 * 6.0 / 1023.0 + 0.5 * 2.56 / 1023.0 + 1e-5; // a chunk spans at most its own 2.56 in x
    assert_agree(&back, &g, tol, "three chunks, SH degree 1");
}

#[test]
fn gsplat_compressed_export_reads_near_its_values() {
    // gsplat's `ply_compressed` exporter (tools/fixtures/make_ply_fixtures.py), 4 Gaussians.
    let g = read_gaussians(&fixture("ply_gsplat_compressed.ply")).expect("gsplat's compressed PLY");
    let full = read_gaussians(&fixture("ply_gsplat_sh3.ply")).unwrap().select(&[0, 1, 2, 3]);
    assert_eq!((g.len(), g.sh_degree), (4, 3));
    let mut tol = compressed_tolerance(&full);
    tol.sh_rest = Some((0.5 * 8.0 / 256.0 + 1e-5, 0.5 * 8.0 / 256.0 + 1e-5));
    assert_agree(&in_order_of(&g, &full), &full, tol, "gsplat's compressed PLY");
}

#[test]
fn bad_compressed_plys_are_clear_errors_naming_the_file() {
    let good = std::fs::read(fixture("splats_reference.compressed.ply")).unwrap();
    read_error("cut.compressed.ply", &good[..good.len() - 10], &["compressed PLY", "truncated"]);
    let text = String::from_utf8_lossy(&good).into_owned();
    let header_end = text.find("end_header\n").unwrap() + "end_header\n".len();
    let header = &text[..header_end];
    let body = &good[header_end..];
    let swap = |from: &str, to: &str| {
        let mut bytes = header.replacen(from, to, 1).into_bytes();
        bytes.extend_from_slice(body);
        bytes
    };
    read_error("chunks.compressed.ply", &swap("element chunk 1", "element chunk 2"), &["2 chunks for 24"]);
    read_error(
        "rows.compressed.ply",
        &swap("element vertex 24", "element vertex 200"),
        &["24 sh rows for 200"],
    );
    let more = {
        let header = header.replacen("element vertex 24", "element vertex 200", 1);
        let mut bytes = header.replacen("element sh 24", "element sh 200", 1).into_bytes();
        bytes.extend_from_slice(body);
        bytes
    };
    read_error("count.compressed.ply", &more, &["follow it (truncated)"]);
    read_error(
        "type.compressed.ply",
        &swap("property uint packed_color", "property float packed_color"),
        &["'packed_color'", "uint"],
    );
    read_error("huge.compressed.ply", &swap("element vertex 24", "element vertex 4000000000"), &["2^27"]);
}

/// `.ksplat` level 0 as written: floats, colours and opacity as bytes.
const KSPLAT_0: Tolerance = Tolerance {
    position: 0.0,
    log_scale: 1e-5,
    opacity: 0.5 / 255.0 + 1e-6,
    sh_dc: 0.5 / 255.0 / SH_C0 + 1e-5,
    rotation: 1e-6,
    sh_rest: Some((0.0, 0.0)),
};

#[test]
fn our_ksplat_reads_back_as_its_source_and_as_the_reference_reads_it() {
    let source = source();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.ksplat");
    write_gaussians(&path, &source).expect("writes a .ksplat");
    let (format, rows) = read_gaussian_rows_with_format(&path).unwrap();
    assert_eq!(format, SplatFormat::Ksplat);
    let ours = rows.gaussians;
    assert_agree(&ours, &source, KSPLAT_0, "our .ksplat read back");
    assert_eq!(read_gaussians(&fixture("splats_ours.ksplat")).unwrap(), ours);
    let by_reference = read_gaussians(&fixture("splats_ours_ksplat_by_reference.ply")).unwrap();
    assert_agree(&by_reference, &ours, SAME_BYTES, "splat-transform's reading of our .ksplat");
}

/// A level-1 or level-2 `.ksplat` of two Gaussians with SH degree 1 in one section of one bucket
/// centred at (1, 2, 3), block size 5, the default quantisation range, made by hand from the
/// layout (no writer makes these levels).
fn quantised_ksplat(level: u16) -> Vec<u8> {
    let mut file = vec![0u8; 4096 + 1024];
    file[1] = 1;
    file[4..8].copy_from_slice(&1u32.to_le_bytes());
    file[16..20].copy_from_slice(&2u32.to_le_bytes());
    file[20..22].copy_from_slice(&level.to_le_bytes());
    let s = 4096;
    for (o, v) in [(0, 2u32), (4, 2), (8, 256), (12, 1), (36, 1)] {
        file[s + o..s + o + 4].copy_from_slice(&v.to_le_bytes());
    }
    file[s + 16..s + 20].copy_from_slice(&5.0f32.to_le_bytes());
    file[s + 20..s + 22].copy_from_slice(&12u16.to_le_bytes());
    file[s + 40..s + 42].copy_from_slice(&1u16.to_le_bytes());
    file.extend_from_slice(&2u32.to_le_bytes()); // the partial bucket holds both
    for c in [1.0f32, 2.0, 3.0] {
        file.extend_from_slice(&c.to_le_bytes());
    }
    let f16 = |v: f32| half::f16::from_f32(v).to_bits().to_le_bytes();
    for (q, scale, value) in [(32767u16 + 6553, 0.5f32, 0.25f32), (32767 - 13107, 0.125, -0.5)] {
        for _ in 0..3 {
            file.extend_from_slice(&q.to_le_bytes());
        }
        for _ in 0..3 {
            file.extend_from_slice(&f16(scale));
        }
        for r in [1.0, 0.0, 0.0, 0.0] {
            file.extend_from_slice(&f16(r));
        }
        file.extend_from_slice(&[255, 128, 0, 191]);
        for j in 0..9 {
            let v = if j == 4 { value } else { 0.0 };
            if level == 1 {
                file.extend_from_slice(&f16(v));
            } else {
                file.push(((v + 1.5) / 3.0 * 255.0).round() as u8);
            }
        }
    }
    file
}

#[test]
fn quantised_ksplat_levels_decode_from_their_buckets() {
    let dir = tempfile::tempdir().unwrap();
    for level in [1u16, 2] {
        let path = dir.path().join(format!("level{level}.ksplat"));
        std::fs::write(&path, quantised_ksplat(level)).unwrap();
        let g = read_gaussians(&path).unwrap();
        assert_eq!((g.len(), g.sh_degree), (2, 1));
        // (q − 32767) · 5 / 2 / 32767 + centre: +6553 → +0.5, −13107 → −1.0.
        let unit = 5.0 / 2.0 / 32767.0;
        for (i, offset) in [(0, 6553.0 * unit), (1, -13107.0 * unit)] {
            for (a, centre) in [1.0f32, 2.0, 3.0].into_iter().enumerate() {
                assert!(
                    (g.means[i][a] - (centre + offset)).abs() < 1e-5,
                    "level {level} mean {i}: {:?}",
                    g.means[i]
                );
            }
        }
        assert!(
            (g.log_scales[0][0] - 0.5f32.ln()).abs() < 1e-3
                && (g.log_scales[1][2] - 0.125f32.ln()).abs() < 1e-3
        );
        assert_eq!(g.rotations[1], [1.0, 0.0, 0.0, 0.0]);
        assert!((g.sh_dc[0][0] - 0.5 / SH_C0).abs() < 1e-4 && (g.sh_dc[0][2] + 0.5 / SH_C0).abs() < 1e-4);
        // Value 4 of band 1 is green's coefficient 1: f_rest index 1·3 + 1 = 4.
        let tol = if level == 1 { 1e-3 } else { 3.0 / 255.0 };
        assert!((g.sh_rest[4] - 0.25).abs() < tol && (g.sh_rest[9 + 4] + 0.5).abs() < tol, "{:?}", g.sh_rest);
        assert!(g.sh_rest.iter().enumerate().all(|(j, v)| j % 9 == 4 || v.abs() < tol));
    }
}

#[test]
fn bad_ksplats_are_clear_errors_naming_the_file() {
    let good = quantised_ksplat(1);
    read_error("cut.ksplat", &good[..good.len() - 3], &[".ksplat", "truncated: section 0"]);
    read_error("tiny.ksplat", &good[..100], &["fewer than the 4096-byte"]);
    let mut version = good.clone();
    version[1] = 0;
    read_error("version.ksplat", &version, &["header is not one"]);
    let mut sections = good.clone();
    sections[4..8].copy_from_slice(&100_000u32.to_le_bytes());
    read_error("sections.ksplat", &sections, &["100000 section headers do not fit"]);
    let mut total = good.clone();
    total[16..20].copy_from_slice(&3u32.to_le_bytes());
    read_error("total.ksplat", &total, &["the sections hold 2 Gaussians, the header says 3"]);
    let mut room = good.clone();
    room[4096..4100].copy_from_slice(&3u32.to_le_bytes());
    room[16..20].copy_from_slice(&3u32.to_le_bytes());
    read_error("room.ksplat", &room, &["holds 3 Gaussians in room for 2"]);
    let mut degree = good;
    degree[4096 + 40] = 7;
    read_error("degree.ksplat", &degree, &["SH degree 7"]);
}
