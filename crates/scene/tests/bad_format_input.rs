//! Bad input to the format readers and writers: each case is a clear error naming the file
//! and the problem, never a panic, and failed writes leave no file behind.

use splatseg_scene::image_io::write_png_luma8;
use splatseg_scene::labels::read_label_png;
use splatseg_scene::ply::{parse_ply_bytes, read_ply, to_ply_bytes, write_ply};
use splatseg_scene::rle::Rle;
use splatseg_scene::sam::{read_sam_json, read_sam_png_folder, read_view_masks, write_sam_json, SamMask};
use splatseg_scene::{Gaussians, Plane};
use std::path::{Path, PathBuf};

/// `n` simple SH-degree-0 Gaussians: 14 floats (56 bytes) per row in the written file, in the
/// order x y z f_dc_0..2 opacity scale_0..2 rot_0..3.
fn gaussians(n: usize, sh_degree: u8) -> Gaussians {
    let k3 = 3 * ((sh_degree as usize + 1).pow(2) - 1);
    Gaussians {
        means: (0..n).map(|i| [i as f32, 1.0, 2.0]).collect(),
        normals: None,
        sh_dc: vec![[0.1, 0.2, 0.3]; n],
        sh_degree,
        sh_rest: vec![0.01; n * k3],
        raw_opacities: vec![0.5; n],
        log_scales: vec![[-3.0; 3]; n],
        rotations: vec![[1.0, 0.0, 0.0, 0.0]; n],
        ..Default::default()
    }
}

fn header_len(bytes: &[u8]) -> usize {
    bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11
}

/// Writes `bytes` to `dir/name` and returns the read error message.
fn read_error(dir: &Path, name: &str, bytes: &[u8]) -> String {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    let err = read_ply(&path).unwrap_err().to_string();
    assert!(err.contains(name), "error does not name the file: {err}");
    err
}

fn assert_has(err: &str, parts: &[&str]) {
    for p in parts {
        assert!(err.contains(p), "expected {p:?} in: {err}");
    }
}

#[test]
fn truncated_ply_reports_declared_and_actual_sizes() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = to_ply_bytes(&gaussians(1000, 3)).unwrap();
    let body = bytes.len() - header_len(&bytes);
    assert_eq!(body, 1000 * 236);
    let err = read_error(dir.path(), "cut.ply", &bytes[..bytes.len() - 100]);
    let only = format!("only {} bytes follow", body - 100);
    assert_has(&err, &["truncated", "1000 vertices × 236 bytes = 236000 bytes", &only]);
    // A header claiming more vertices than the data holds is the same problem.
    let text = String::from_utf8_lossy(&bytes).replacen("element vertex 1000", "element vertex 1001", 1);
    let lying: Vec<u8> =
        [text.as_bytes()[..header_len(&bytes)].to_vec(), bytes[header_len(&bytes)..].to_vec()].concat();
    assert_has(&read_error(dir.path(), "lying.ply", &lying), &["1001 vertices", "only 236000 bytes"]);
    // And fewer: bytes left over.
    let text = String::from_utf8_lossy(&bytes[..header_len(&bytes)]).replacen(
        "element vertex 1000",
        "element vertex 999 ",
        1,
    );
    let fewer: Vec<u8> = [text.as_bytes(), &bytes[header_len(&bytes)..]].concat();
    assert_has(&read_error(dir.path(), "fewer.ply", &fewer), &["236 unexpected bytes", "999 vertices"]);
}

#[test]
fn malformed_headers_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let good = to_ply_bytes(&gaussians(3, 0)).unwrap();
    let head = String::from_utf8(good[..header_len(&good)].to_vec()).unwrap();
    let body = &good[header_len(&good)..];
    let with_head = |h: String| [h.as_bytes(), body].concat();

    let no_end = with_head(head.replace("end_header\n", ""));
    assert_has(&read_error(dir.path(), "no_end.ply", &no_end), &["no end_header"]);
    let err = read_error(dir.path(), "only_header.ply", head.replace("end_header\n", "").as_bytes());
    assert_has(&err, &["no end_header"]);
    let unknown = with_head(head.replace("property float opacity", "property float16 opacity"));
    assert_has(&read_error(dir.path(), "type.ply", &unknown), &["unknown type 'float16'", "'opacity'"]);
    let list = with_head(
        head.replace("property float opacity\n", "property float opacity\nproperty list uchar int idx\n"),
    );
    assert_has(&read_error(dir.path(), "list.ply", &list), &["'idx' is a list"]);
    let not_ply = with_head(head.replacen("ply\n", "plx\n", 1));
    assert_has(&read_error(dir.path(), "magic.ply", &not_ply), &["not a PLY file"]);
    assert_has(&read_error(dir.path(), "jpeg.ply", &[0xff, 0xd8, 0xff, 0xe0, 0, 0x10]), &["not a PLY file"]);
    assert_has(&read_error(dir.path(), "empty.ply", b""), &["the file is empty"]);
    let format = with_head(head.replace("binary_little_endian", "binary_middle_endian"));
    assert_has(&read_error(dir.path(), "format.ply", &format), &["unknown format 'binary_middle_endian'"]);
    let garbage = with_head(head.replace("element vertex 3\n", "element vertex 3\nbanana\n"));
    assert_has(&read_error(dir.path(), "garbage.ply", &garbage), &["unexpected line 'banana'"]);
    let count = with_head(head.replace("element vertex 3", "element vertex -3"));
    assert_has(&read_error(dir.path(), "count.ply", &count), &["invalid count '-3'"]);
    let dup = with_head(head.replace("property float x\n", "property float x\nproperty float x\n"));
    assert_has(&read_error(dir.path(), "dup.ply", &dup), &["'x' appears twice"]);
    // Same row size, another convention: opacity 0–255 as uchar (plus 3 bytes of padding).
    let uchar = with_head(head.replace(
        "property float opacity\n",
        "property uchar opacity\nproperty uchar pad_0\nproperty uchar pad_1\nproperty uchar pad_2\n",
    ));
    assert_has(&read_error(dir.path(), "uchar.ply", &uchar), &["'opacity' is uchar", "stores it as float"]);
    let no_vertex = with_head(head.replace("element vertex", "element point"));
    assert_has(&read_error(dir.path(), "novertex.ply", &no_vertex), &["no 'vertex' element"]);
    let face = with_head(
        head.replace("end_header", "element face 1\nproperty list uchar int vertex_indices\nend_header"),
    );
    assert_has(&read_error(dir.path(), "face.ply", &face), &["element 'face' has list property"]);
}

#[test]
fn missing_or_miscounted_gaussian_properties_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let good = to_ply_bytes(&gaussians(2, 0)).unwrap();
    let head = String::from_utf8(good[..header_len(&good)].to_vec()).unwrap();
    // Rename a property: the body size is unchanged, the meaning is not.
    let renamed =
        |from: &str, to: &str| [head.replace(from, to).as_bytes(), &good[header_len(&good)..]].concat();
    assert_has(
        &read_error(dir.path(), "op.ply", &renamed("float opacity", "float opacity2")),
        &["'opacity' is missing"],
    );
    assert_has(
        &read_error(dir.path(), "rot.ply", &renamed("float rot_3", "float rot3")),
        &["'rot_3' is missing"],
    );
    assert_has(
        &read_error(dir.path(), "nrm.ply", &renamed("float scale_0", "float nx")),
        &["some of nx, ny, nz"],
    );
    // A coloured point cloud (as COLMAP or Open3D write them) is not a 3DGS file.
    let cloud = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
        property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n\
        1 2 3 255 0 0\n";
    assert_has(&read_error(dir.path(), "cloud.ply", cloud), &["'f_dc_0' is missing", "plain point cloud"]);
    // 10 f_rest properties: not a valid SH degree.
    let g1 = to_ply_bytes(&gaussians(2, 1)).unwrap();
    let h1 = String::from_utf8(g1[..header_len(&g1)].to_vec()).unwrap();
    let ten = [
        h1.replace("property float opacity", "property float f_rest_9\nproperty float opacity").as_bytes(),
        &g1[header_len(&g1)..],
        &[0u8; 8],
    ]
    .concat();
    assert_has(&read_error(dir.path(), "ten.ply", &ten), &["10 f_rest_* properties", "0, 9, 24 or 45"]);
    let gap = [h1.replace("f_rest_4\n", "f_rest_40\n").as_bytes(), &g1[header_len(&g1)..]].concat();
    assert_has(&read_error(dir.path(), "gap.ply", &gap), &["f_rest_4 is missing"]);
}

/// Overwrites float `column` of row `row` in a degree-0 file with `value`.
fn poke(bytes: &[u8], row: usize, column: usize, value: f32) -> Vec<u8> {
    let mut out = bytes.to_vec();
    let at = header_len(bytes) + row * 56 + column * 4;
    out[at..at + 4].copy_from_slice(&value.to_le_bytes());
    out
}

#[test]
fn non_finite_values_name_the_property_and_first_index() {
    let dir = tempfile::tempdir().unwrap();
    let good = to_ply_bytes(&gaussians(5, 0)).unwrap();
    for (column, name, value) in [
        (1, "'y'", f32::NAN),
        (6, "'opacity'", f32::INFINITY),
        (8, "'scale_1'", f32::NEG_INFINITY),
        (12, "'rot_2'", f32::NAN),
    ] {
        let bad = poke(&poke(&good, 4, column, value), 3, column, value);
        let err = read_error(dir.path(), "nan.ply", &bad);
        assert_has(&err, &["non-finite", name, "at Gaussian 3"]);
    }
    // The writer refuses the same data and leaves no file.
    let mut g = gaussians(5, 0);
    g.log_scales[2][0] = f32::NAN;
    let path = dir.path().join("nan_out.ply");
    let err = write_ply(&path, &g).unwrap_err().to_string();
    assert_has(&err, &["'scale_0'", "at Gaussian 2", "nan_out.ply"]);
    assert!(!path.exists());
}

#[test]
fn degenerate_gaussians_are_listed_counted_once_and_refused_strictly() {
    let dir = tempfile::tempdir().unwrap();
    let mut g = gaussians(6, 0);
    g.log_scales[1] = [80.0, -3.0, -3.0];
    g.rotations[2] = [0.0; 4];
    g.log_scales[4][2] = 1e30;
    g.means[5][0] = f32::NAN;
    g.rotations[5] = [0.0; 4]; // non-finite first: counted once, as non-finite
    let path = dir.path().join("degenerate.ply");
    splatseg_scene::ply::write_ply_rows(&path, &g).unwrap();
    let rows = splatseg_scene::ply::read_ply_rows(&path).unwrap();
    assert_eq!((rows.non_finite.clone(), rows.degenerate.clone()), (vec![5], vec![1, 2, 4]));
    assert_eq!(rows.usable_rows(), vec![0, 3]);
    let warnings = rows.skip_warnings(&path, "they are left out");
    assert_eq!(warnings.len(), 2, "{warnings:?}");
    assert_has(
        &warnings[1],
        &["skipping 3 of 6 Gaussians with a degenerate shape", "Gaussian 1", "degenerate.ply"],
    );
    let err = rows.refuse_skipped(&path).unwrap_err().to_string();
    assert_has(&err, &["non-finite", "degenerate.ply"]);
    g.means[5][0] = 5.0;
    g.rotations[5] = [1.0, 0.0, 0.0, 0.0];
    splatseg_scene::ply::write_ply_rows(&path, &g).unwrap();
    let rows = splatseg_scene::ply::read_ply_rows(&path).unwrap();
    let err = rows.refuse_skipped(&path).unwrap_err().to_string();
    assert_has(&err, &["Gaussian 1 has a log-scale above 20", "degenerate.ply"]);
    assert_eq!(rows.into_usable().len(), 3);
    // A small but non-zero quaternion and a log-scale of 20 are usable.
    assert!(splatseg_scene::ply::degenerate_shape([20.0; 3], [1e-6, 0.0, 0.0, 0.0]).is_none());
}

#[test]
fn inconsistent_gaussians_are_not_written() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.ply");
    let mut short = gaussians(4, 1);
    short.rotations.pop();
    assert_has(
        &write_ply(&path, &short).unwrap_err().to_string(),
        &["rotations has 3 entries but there are 4"],
    );
    let mut rest = gaussians(4, 1);
    rest.sh_rest.push(0.0);
    assert_has(&write_ply(&path, &rest).unwrap_err().to_string(), &["sh_rest has 37 values"]);
    let mut extra = gaussians(2, 0);
    extra.extra.push(splatseg_scene::gaussians::ExtraProperty {
        name: "label".into(),
        ply_type: "uchar".into(),
        values: vec![1.0, 300.0],
    });
    assert_has(
        &write_ply(&path, &extra).unwrap_err().to_string(),
        &["'label' (uchar) cannot store value 300 at Gaussian 1"],
    );
    extra.extra[0] = splatseg_scene::gaussians::ExtraProperty {
        name: "opacity".into(),
        ply_type: "float".into(),
        values: vec![1.0, 3.0],
    };
    assert_has(&write_ply(&path, &extra).unwrap_err().to_string(), &["'opacity' has the name"]);
    extra.extra[0].name = "has space".into();
    assert_has(&write_ply(&path, &extra).unwrap_err().to_string(), &["without spaces"]);
    extra.extra[0] = splatseg_scene::gaussians::ExtraProperty {
        name: "w".into(),
        ply_type: "half".into(),
        values: vec![1.0, 3.0],
    };
    assert_has(&write_ply(&path, &extra).unwrap_err().to_string(), &["unknown PLY type 'half'"]);
    assert!(!path.exists());
}

#[test]
fn bad_object_ids_and_ascii_bodies_are_rejected() {
    let mut g = gaussians(2, 0);
    g.extra.push(splatseg_scene::gaussians::ExtraProperty {
        name: "oid".into(),
        ply_type: "float".into(),
        values: vec![1.0, 1.5],
    });
    let bytes = to_ply_bytes(&g).unwrap();
    let head = String::from_utf8(bytes[..header_len(&bytes)].to_vec()).unwrap().replace(" oid", " object_id");
    let err = parse_ply_bytes(&[head.as_bytes(), &bytes[header_len(&bytes)..]].concat()).unwrap_err();
    assert_has(&err, &["object_id 1.5 of vertex 1"]);

    let ascii_head =
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n\
        property float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\nproperty float opacity\n\
        property float scale_0\nproperty float scale_1\nproperty float scale_2\nproperty float rot_0\n\
        property float rot_1\nproperty float rot_2\nproperty float rot_3\nend_header\n";
    let row = "0 0 0 0 0 0 0 0 0 0 1 0 0 0\n";
    let ok = parse_ply_bytes(format!("{ascii_head}{row}{row}").as_bytes()).unwrap();
    assert_eq!(ok.len(), 2);
    let err = parse_ply_bytes(format!("{ascii_head}{row}0 0 0").as_bytes()).unwrap_err();
    assert_has(&err, &["ends in vertex 1", "declares 2 vertices"]);
    let err =
        parse_ply_bytes(format!("{ascii_head}{row}0 0 zero 0 0 0 0 0 0 0 1 0 0 0\n").as_bytes()).unwrap_err();
    assert_has(&err, &["vertex 1", "'z' = 'zero' is not a valid float"]);
}

#[test]
fn missing_files_are_reported_with_their_path() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.ply");
    assert_has(&read_ply(&missing).unwrap_err().to_string(), &["cannot read", "nope.ply"]);
    assert_has(&read_sam_json(&dir.path().join("nope.json")).unwrap_err().to_string(), &["nope.json"]);
    assert_has(&read_label_png(&dir.path().join("nope.png")).unwrap_err().to_string(), &["nope.png"]);
    let no_folder = dir.path().join("masks");
    assert_has(
        &read_view_masks(&no_folder, "a").unwrap_err().to_string(),
        &["missing SAM mask folder", "masks"],
    );
    assert_has(&read_sam_png_folder(dir.path()).unwrap_err().to_string(), &["metadata.csv"]);
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn malformed_sam_json_names_the_file_and_mask() {
    let dir = tempfile::tempdir().unwrap();
    let good = r#"{"segmentation": {"size": [2, 3], "counts": [1, 2, 3]}}"#;
    let short = r#"{"segmentation": {"size": [2, 3], "counts": [1, 2]}}"#;
    let path = write(dir.path(), "short.json", &format!("[{good}, {short}]"));
    assert_has(
        &read_sam_json(&path).unwrap_err().to_string(),
        &["mask 1", "sum to 3", "2×3 = 6 pixels", "short.json"],
    );
    let bad_string = r#"{"segmentation": {"size": [2, 3], "counts": "0 1"}}"#;
    let path = write(dir.path(), "chars.json", &format!("[{bad_string}]"));
    assert_has(
        &read_sam_json(&path).unwrap_err().to_string(),
        &["mask 0", "invalid character", "chars.json"],
    );
    let other_size = r#"{"segmentation": {"size": [3, 2], "counts": [6]}}"#;
    let path = write(dir.path(), "sizes.json", &format!("[{good}, {other_size}]"));
    assert_has(
        &read_sam_json(&path).unwrap_err().to_string(),
        &["mask 1 is 2×3 but mask 0 is 3×2", "sizes.json"],
    );
    let path = write(dir.path(), "poly.json", r#"[{"segmentation": [[1.5, 2.0, 3.0, 4.0]]}]"#);
    assert_has(&read_sam_json(&path).unwrap_err().to_string(), &["polygons are not supported"]);
    let path = write(dir.path(), "size.json", r#"[{"segmentation": {"size": [2], "counts": [2]}}]"#);
    assert_has(&read_sam_json(&path).unwrap_err().to_string(), &["size must be [height, width]"]);
    let path = write(dir.path(), "notlist.json", r#"{"segmentation": 1}"#);
    assert_has(
        &read_sam_json(&path).unwrap_err().to_string(),
        &["expected a JSON list of masks", "notlist.json"],
    );
}

#[test]
fn broken_png_folders_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let header = "id,area,bbox_x0,bbox_y0,bbox_w,bbox_h,point_input_x,point_input_y,predicted_iou,stability_score,crop_box_x0,crop_box_y0,crop_box_w,crop_box_h\n";
    write(dir.path(), "metadata.csv", &format!("{header}0,1,0,0,1,1,0.5,0.5,0.9,0.9,0,0,2,2\n"));
    assert_has(&read_sam_png_folder(dir.path()).unwrap_err().to_string(), &["SAM mask PNG", "0.png"]);
    write_png_luma8(&dir.path().join("0.png"), &Plane::filled(2, 2, 0)).unwrap();
    write_png_luma8(&dir.path().join("1.png"), &Plane::filled(3, 2, 0)).unwrap();
    write(
        dir.path(),
        "metadata.csv",
        &format!("{header}0,1,0,0,1,1,0.5,0.5,0.9,0.9,0,0,2,2\n1,1,0,0,1,1,0.5,0.5,0.9,0.9,0,0,2,2\n"),
    );
    assert_has(
        &read_sam_png_folder(dir.path()).unwrap_err().to_string(),
        &["mask 1 is 3×2 but mask 0 is 2×2", "metadata.csv"],
    );
    write(dir.path(), "metadata.csv", &format!("{header}0,1,0,0,1\n"));
    assert_has(
        &read_sam_png_folder(dir.path()).unwrap_err().to_string(),
        &["line 2 has 5 fields but the header has 14"],
    );
    write(dir.path(), "metadata.csv", &format!("{header}0,one,0,0,1,1,0.5,0.5,0.9,0.9,0,0,2,2\n"));
    assert_has(
        &read_sam_png_folder(dir.path()).unwrap_err().to_string(),
        &["line 2: area 'one' is not a number"],
    );
    write(dir.path(), "metadata.csv", "area,bbox_x0\n1,2\n");
    assert_has(&read_sam_png_folder(dir.path()).unwrap_err().to_string(), &["no 'id' column"]);
}

#[test]
fn not_a_png_label_map_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "labels.png", "this is not a png");
    assert_has(&read_label_png(&path).unwrap_err().to_string(), &["labels.png"]);
}

#[test]
fn sam_write_into_a_file_path_fails_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let blocker = write(dir.path(), "file", "x");
    let mask = SamMask::from_rle(Rle::encode(&Plane::filled(2, 2, true)));
    let err = write_sam_json(&blocker.join("out.json"), &[mask]).unwrap_err().to_string();
    assert!(err.contains("file"), "{err}");
}

#[test]
fn random_corruptions_never_panic() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let mut g = gaussians(6, 1);
    g.object_ids = Some(vec![1, 2, 3, -1, 5, 6]);
    let binary = to_ply_bytes(&g).unwrap();
    let head = header_len(&binary);
    let ascii = {
        let text =
            String::from_utf8(binary[..head].to_vec()).unwrap().replace("binary_little_endian", "ascii");
        let row = |i: usize| {
            let mut v = vec![i.to_string(), "1".into(), "2".into()];
            v.extend(std::iter::repeat_n("0.5".to_string(), 3 + 9 + 1 + 3 + 4));
            v.push("7".into());
            v.join(" ")
        };
        format!("{text}{}\n", (0..6).map(row).collect::<Vec<_>>().join("\n")).into_bytes()
    };
    assert_eq!(parse_ply_bytes(&ascii).unwrap().len(), 6);
    let mut outcomes = [0usize; 2];
    for case in 0..3000 {
        let mut bytes = if case % 2 == 0 { binary.clone() } else { ascii.clone() };
        match rng.gen_range(0..3) {
            // Flip bytes, mostly in the header where they change the meaning.
            0 => {
                for _ in 0..rng.gen_range(1..4) {
                    let at = if rng.gen_bool(0.7) {
                        rng.gen_range(0..head)
                    } else {
                        rng.gen_range(0..bytes.len())
                    };
                    bytes[at] = rng.gen();
                }
            }
            // Cut anywhere.
            1 => bytes.truncate(rng.gen_range(0..bytes.len())),
            // Replace a header digit (counts, indices) with another.
            _ => {
                let digits: Vec<usize> = (0..head).filter(|&i| bytes[i].is_ascii_digit()).collect();
                let at = digits[rng.gen_range(0..digits.len())];
                bytes[at] = b'0' + rng.gen_range(0..10);
            }
        }
        outcomes[parse_ply_bytes(&bytes).is_ok() as usize] += 1;
    }
    // Both outcomes happen: the corruptions are neither all harmless nor all fatal.
    assert!(outcomes[0] > 100 && outcomes[1] > 100, "{outcomes:?}");

    for _ in 0..3000 {
        let len = rng.gen_range(0..12);
        let s: String = (0..len).map(|_| char::from(rng.gen_range(40u8..120))).collect();
        let (h, w) = (rng.gen_range(0..5), rng.gen_range(0..5));
        if let Ok(rle) = Rle::from_coco_string(h, w, &s) {
            assert_eq!(rle.decode().unwrap().data.len(), (h * w) as usize);
        }
    }
}

#[test]
fn a_binary_camera_declaring_a_huge_size_is_refused_before_anything_is_allocated() {
    // One PINHOLE camera (model id 1), 3200000000 × 240000000, four parameters.
    let mut bytes = 1u64.to_le_bytes().to_vec();
    bytes.extend(1i32.to_le_bytes());
    bytes.extend(1i32.to_le_bytes());
    bytes.extend(3_200_000_000u64.to_le_bytes());
    bytes.extend(240_000_000u64.to_le_bytes());
    for p in [55.4f64, 55.4, 32.0, 24.0] {
        bytes.extend(p.to_le_bytes());
    }
    let err = splatseg_scene::colmap::parse_cameras_bin(&bytes, std::path::Path::new("sparse/0/cameras.bin"))
        .expect_err("refused")
        .to_string();
    assert!(err.contains("camera 1 is 3200000000x240000000"), "{err}");
    assert!(err.contains("2^28") && err.ends_with("sparse/0/cameras.bin"), "{err}");
}

#[test]
fn a_ply_declaring_more_gaussians_than_the_cap_is_refused_by_its_header() {
    let header = "ply\nformat ascii 1.0\nelement vertex 200000000\nproperty float x\nproperty float y\n\
                  property float z\nproperty float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\n\
                  property float opacity\nproperty float scale_0\nproperty float scale_1\nproperty float scale_2\n\
                  property float rot_0\nproperty float rot_1\nproperty float rot_2\nproperty float rot_3\nend_header\n";
    let err = splatseg_scene::ply::parse_ply_bytes(header.as_bytes()).expect_err("refused");
    assert!(err.contains("200000000 Gaussians declared") && err.contains("2^27"), "{err}");
}

#[test]
fn a_label_png_declaring_more_pixels_than_the_cap_is_refused_before_decoding() {
    // A valid 1×1 16-bit grey PNG, then its IHDR patched to 20000 × 20000 (CRC fixed up).
    let mut png = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut png, 1, 1);
        encoder.set_color(png::ColorType::Grayscale);
        encoder.set_depth(png::BitDepth::Sixteen);
        encoder.write_header().expect("header").write_image_data(&[0, 7]).expect("data");
    }
    png[16..20].copy_from_slice(&20_000u32.to_be_bytes());
    png[20..24].copy_from_slice(&20_000u32.to_be_bytes());
    let crc = crc32(&png[12..29]);
    png[29..33].copy_from_slice(&crc.to_be_bytes());
    let err = splatseg_scene::labels::parse_label_png(&png).expect_err("refused");
    assert!(err.contains("20000x20000") && err.contains("2^28"), "{err}");
}

/// CRC-32 (ISO-HDLC, as PNG chunks use).
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xffff_ffffu32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0xedb8_8320 } else { crc >> 1 };
        }
    }
    !crc
}
