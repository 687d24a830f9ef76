//! 3DGS PLY: write → read round trips are exact and re-writing gives identical bytes; files
//! with other property orders, types, byte orders and ASCII bodies read to the same values.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use splatseg_scene::gaussians::{ExtraProperty, FeatureBlock};
use splatseg_scene::ply::{parse_ply_bytes, read_ply, to_ply_bytes, write_ply};
use splatseg_scene::Gaussians;

/// What optional parts a random set has.
struct Shape {
    n: usize,
    sh_degree: u8,
    normals: bool,
    object_ids: bool,
    feature_dim: usize,
    extras: bool,
}

fn random_gaussians(shape: &Shape, seed: u64) -> Gaussians {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = shape.n;
    let k3 = 3 * ((shape.sh_degree as usize + 1).pow(2) - 1);
    let v3 = |rng: &mut ChaCha8Rng| -> Vec<[f32; 3]> {
        (0..n)
            .map(|_| [rng.gen_range(-5.0..5.0), rng.gen_range(-5.0..5.0), rng.gen_range(-5.0..5.0)])
            .collect()
    };
    let means = v3(&mut rng);
    let normals = shape.normals.then(|| v3(&mut rng));
    let sh_dc = v3(&mut rng);
    let log_scales = v3(&mut rng);
    let extra = if shape.extras {
        vec![
            ExtraProperty {
                name: "confidence".into(),
                ply_type: "double".into(),
                values: (0..n).map(|_| rng.gen::<f64>()).collect(),
            },
            ExtraProperty {
                name: "label".into(),
                ply_type: "uchar".into(),
                values: (0..n).map(|_| rng.gen_range(0..=255) as f64).collect(),
            },
            ExtraProperty {
                name: "delta".into(),
                ply_type: "int16".into(),
                values: (0..n).map(|_| rng.gen_range(-32768..=32767) as f64).collect(),
            },
            ExtraProperty {
                name: "weight".into(),
                ply_type: "float".into(),
                values: (0..n).map(|_| rng.gen::<f32>() as f64).collect(),
            },
            ExtraProperty {
                name: "tag".into(),
                ply_type: "uint".into(),
                values: (0..n).map(|_| rng.gen::<u32>() as f64).collect(),
            },
            ExtraProperty {
                name: "flag".into(),
                ply_type: "char".into(),
                values: (0..n).map(|_| rng.gen_range(-128..=127) as f64).collect(),
            },
        ]
    } else {
        Vec::new()
    };
    Gaussians {
        means,
        normals,
        sh_dc,
        sh_degree: shape.sh_degree,
        sh_rest: (0..n * k3).map(|_| rng.gen_range(-1.0..1.0)).collect(),
        raw_opacities: (0..n).map(|_| rng.gen_range(-8.0..8.0)).collect(),
        log_scales,
        rotations: (0..n).map(|_| [rng.gen(), rng.gen(), rng.gen(), rng.gen()]).collect(),
        object_ids: shape.object_ids.then(|| (0..n).map(|_| rng.gen_range(-1..1000)).collect()),
        features: (shape.feature_dim > 0).then(|| FeatureBlock {
            dim: shape.feature_dim,
            values: (0..n * shape.feature_dim).map(|_| rng.gen_range(-1.0..1.0)).collect(),
        }),
        extra,
    }
}

#[test]
fn round_trip_is_exact_for_every_sh_degree_and_optional_part() {
    let dir = tempfile::tempdir().unwrap();
    for sh_degree in 0..=3u8 {
        for variant in 0..2 {
            let rich = variant == 1;
            let shape = Shape {
                n: 257,
                sh_degree,
                normals: rich,
                object_ids: rich,
                feature_dim: if rich { 5 } else { 0 },
                extras: rich,
            };
            let g = random_gaussians(&shape, 10 * sh_degree as u64 + variant);
            let path = dir.path().join(format!("g{sh_degree}_{variant}.ply"));
            write_ply(&path, &g).unwrap();
            let back = read_ply(&path).unwrap();
            assert_eq!(back.sh_degree, sh_degree);
            assert_eq!(back, g, "degree {sh_degree}, variant {variant}");
            let bytes = std::fs::read(&path).unwrap();
            assert_eq!(to_ply_bytes(&back).unwrap(), bytes, "re-writing changed the bytes");
        }
    }
}

#[test]
fn large_set_round_trips_through_the_chunked_and_parallel_paths() {
    // More rows than one read/write chunk and one parallel task, so the splitting is exercised.
    let shape =
        Shape { n: 150_001, sh_degree: 1, normals: false, object_ids: true, feature_dim: 2, extras: true };
    let g = random_gaussians(&shape, 99);
    let bytes = to_ply_bytes(&g).unwrap();
    assert_eq!(parse_ply_bytes(&bytes).unwrap(), g);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("large.ply");
    write_ply(&path, &g).unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), bytes, "streamed write differs from to_ply_bytes");
    assert_eq!(read_ply(&path).unwrap(), g);
}

#[test]
fn empty_set_round_trips() {
    let g = Gaussians { sh_degree: 3, ..Default::default() };
    let back = parse_ply_bytes(&to_ply_bytes(&g).unwrap()).unwrap();
    assert_eq!(back, g);
}

#[test]
fn written_header_uses_the_inria_order() {
    let shape = Shape { n: 2, sh_degree: 1, normals: true, object_ids: true, feature_dim: 2, extras: true };
    let bytes = to_ply_bytes(&random_gaussians(&shape, 1)).unwrap();
    let text = String::from_utf8_lossy(&bytes[..bytes.windows(10).position(|w| w == b"end_header").unwrap()])
        .to_string();
    let names: Vec<&str> = text
        .lines()
        .filter_map(|l| l.strip_prefix("property "))
        .map(|l| l.split(' ').nth(1).unwrap())
        .collect();
    let mut expected: Vec<String> =
        ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"].map(String::from).to_vec();
    expected.extend((0..9).map(|k| format!("f_rest_{k}")));
    expected.extend(
        [
            "opacity",
            "scale_0",
            "scale_1",
            "scale_2",
            "rot_0",
            "rot_1",
            "rot_2",
            "rot_3",
            "object_id",
            "feat_0",
            "feat_1",
        ]
        .map(String::from),
    );
    expected.extend(["confidence", "label", "delta", "weight", "tag", "flag"].map(String::from));
    assert_eq!(names, expected);
    assert!(text.starts_with("ply\nformat binary_little_endian 1.0\nelement vertex 2\n"));
    assert!(text.contains("property int object_id\n"));
    assert!(text.contains("property uchar label\n") && text.contains("property int16 delta\n"));
}

/// A hand-made vertex element: properties `(type, name, values per vertex)`.
struct Column {
    ty: &'static str,
    name: String,
    values: Vec<f64>,
}

fn col(ty: &'static str, name: &str, values: Vec<f64>) -> Column {
    Column { ty, name: name.to_string(), values }
}

fn encode_value(ty: &str, v: f64, big: bool, out: &mut Vec<u8>) {
    macro_rules! put {
        ($x:expr) => {
            out.extend_from_slice(&if big { $x.to_be_bytes() } else { $x.to_le_bytes() })
        };
    }
    match ty {
        "char" | "int8" => put!(v as i8),
        "uchar" | "uint8" => put!(v as u8),
        "short" | "int16" => put!(v as i16),
        "ushort" | "uint16" => put!(v as u16),
        "int" | "int32" => put!(v as i32),
        "uint" | "uint32" => put!(v as u32),
        "float" | "float32" => put!(v as f32),
        "double" | "float64" => put!(v),
        _ => panic!("test bug: type {ty}"),
    }
}

/// Builds a PLY file with the given format (`binary_little_endian`, `binary_big_endian`,
/// `ascii`) and columns.
fn build_ply(format: &str, columns: &[Column]) -> Vec<u8> {
    let n = columns[0].values.len();
    let mut out =
        format!("ply\nformat {format} 1.0\ncomment made by a test\nelement vertex {n}\n").into_bytes();
    for c in columns {
        out.extend_from_slice(format!("property {} {}\n", c.ty, c.name).as_bytes());
    }
    out.extend_from_slice(b"end_header\n");
    for i in 0..n {
        if format == "ascii" {
            let row: Vec<String> = columns.iter().map(|c| format!("{}", c.values[i])).collect();
            out.extend_from_slice(format!("{}\n", row.join(" ")).as_bytes());
        } else {
            for c in columns {
                encode_value(c.ty, c.values[i], format == "binary_big_endian", &mut out);
            }
        }
    }
    out
}

/// Degree-1 Gaussians with shuffled property order and mixed types, plus the expected values.
fn shuffled_columns() -> Vec<Column> {
    let n = 3;
    let v = |base: f64| (0..n).map(|i| base + i as f64 * 0.25).collect::<Vec<f64>>();
    let mut columns = vec![
        col("float", "opacity", v(0.5)),
        col("uchar", "red", vec![1.0, 2.0, 255.0]),
        col("double", "z", v(3.0)),
        col("float32", "rot_3", v(0.4)),
        col("float", "rot_0", v(1.0)),
        col("float", "rot_1", v(0.1)),
        col("float", "rot_2", v(0.2)),
    ];
    for k in (0..9).rev() {
        columns.push(col("float", &format!("f_rest_{k}"), v(k as f64 * 0.01)));
    }
    columns.extend([
        col("float", "x", v(1.0)),
        col("float", "y", v(2.0)),
        col("short", "object_id", vec![-1.0, 7.0, 300.0]),
        col("float", "scale_2", v(-2.0)),
        col("float", "scale_0", v(-1.0)),
        col("float", "scale_1", v(-1.5)),
        col("float", "feat_1", v(0.75)),
        col("float", "feat_0", v(-0.75)),
        col("float", "f_dc_0", v(0.1)),
        col("float", "f_dc_1", v(0.2)),
        col("float", "f_dc_2", v(0.3)),
        col("int8", "green", vec![-5.0, 0.0, 5.0]),
    ]);
    columns
}

fn check_shuffled(g: &Gaussians) {
    assert_eq!(g.len(), 3);
    assert_eq!(g.sh_degree, 1);
    assert_eq!(g.means[1], [1.25, 2.25, 3.25]);
    assert_eq!(g.rotations[2], [1.5, 0.6, 0.7, 0.9]);
    assert_eq!(g.log_scales[0], [-1.0, -1.5, -2.0]);
    assert_eq!(g.raw_opacities, vec![0.5, 0.75, 1.0]);
    assert_eq!(g.sh_dc[0], [0.1, 0.2, 0.3]);
    // f_rest_k of Gaussian 0 is k * 0.01, whatever the file order.
    let expected: Vec<f32> = (0..9).map(|k| (k as f64 * 0.01) as f32).collect();
    assert_eq!(&g.sh_rest[..9], expected.as_slice());
    assert_eq!(g.object_ids.as_deref(), Some(&[-1, 7, 300][..]));
    let f = g.features.as_ref().unwrap();
    assert_eq!((f.dim, &f.values[..2]), (2, &[-0.75f32, 0.75][..]));
    assert_eq!(g.extra.len(), 2);
    assert_eq!((g.extra[0].name.as_str(), g.extra[0].ply_type.as_str()), ("red", "uchar"));
    assert_eq!(g.extra[0].values, vec![1.0, 2.0, 255.0]);
    assert_eq!((g.extra[1].name.as_str(), g.extra[1].ply_type.as_str()), ("green", "int8"));
    assert_eq!(g.extra[1].values, vec![-5.0, 0.0, 5.0]);
    assert!(g.normals.is_none());
}

#[test]
fn arbitrary_property_order_and_types_read_correctly() {
    let g = parse_ply_bytes(&build_ply("binary_little_endian", &shuffled_columns())).unwrap();
    check_shuffled(&g);
    // Written back in the INRIA order; reading that gives the same values.
    assert_eq!(parse_ply_bytes(&to_ply_bytes(&g).unwrap()).unwrap(), g);
}

#[test]
fn big_endian_and_ascii_bodies_read_to_the_same_values() {
    let le = parse_ply_bytes(&build_ply("binary_little_endian", &shuffled_columns())).unwrap();
    let be = parse_ply_bytes(&build_ply("binary_big_endian", &shuffled_columns())).unwrap();
    let ascii = parse_ply_bytes(&build_ply("ascii", &shuffled_columns())).unwrap();
    check_shuffled(&be);
    assert_eq!(be, le);
    assert_eq!(ascii, le);
}

#[test]
fn crlf_header_and_fixed_size_elements_around_the_vertices_are_accepted() {
    let columns = shuffled_columns();
    let plain = build_ply("binary_little_endian", &columns);
    let split = plain.windows(11).position(|w| w == b"end_header\n").unwrap();
    let (head, body) = plain.split_at(split + 11);
    let head = String::from_utf8(head.to_vec()).unwrap();
    // A 2-row element before the vertices and a 1-row element after, both fixed-size.
    let head = head
        .replace("element vertex", "element camera 2\nproperty float f\nproperty uchar u\nelement vertex")
        .replace("end_header\n", "element extra_info 1\nproperty int k\nend_header\n")
        .replace('\n', "\r\n");
    let mut bytes = head.into_bytes();
    bytes.extend_from_slice(&[0u8; 10]);
    bytes.extend_from_slice(body);
    bytes.extend_from_slice(&[0u8; 4]);
    check_shuffled(&parse_ply_bytes(&bytes).unwrap());
}

/// Features of the block, served row by row.
struct Rows<'a>(&'a FeatureBlock);

impl splatseg_scene::ply::FeatureRows for Rows<'_> {
    fn dim(&self) -> usize {
        self.0.dim
    }
    fn row(&self, i: usize, out: &mut [f32]) {
        out.copy_from_slice(&self.0.values[i * self.0.dim..(i + 1) * self.0.dim]);
    }
}

#[test]
fn features_given_row_by_row_write_the_same_bytes() {
    let shape =
        Shape { n: 70_000, sh_degree: 1, normals: false, object_ids: true, feature_dim: 5, extras: true };
    let g = random_gaussians(&shape, 11);
    let dir = tempfile::tempdir().expect("temp dir");
    let (whole, rows) = (dir.path().join("whole.ply"), dir.path().join("rows.ply"));
    splatseg_scene::ply::write_ply_rows(&whole, &g).expect("writes");
    let block = g.features.clone().expect("features");
    let bare = Gaussians { features: None, ..g.clone() };
    splatseg_scene::ply::write_ply_rows_with_features(&rows, &bare, Some(&Rows(&block))).expect("writes");
    assert_eq!(std::fs::read(&whole).expect("reads"), std::fs::read(&rows).expect("reads"));
    let err = splatseg_scene::ply::write_ply_rows_with_features(&rows, &g, Some(&Rows(&block))).unwrap_err();
    assert!(err.to_string().contains("features given twice"), "{err}");
}
