//! `.npy` / `.npz` reading against files NumPy wrote (`tools/fixtures/npy_arrays.py`), and
//! writing that NumPy reads back byte for byte.

use splatseg_scene::npy::{
    encode_npy_f32, read_cue_folder_entry, read_npy, read_npz, write_npy_f32, NpyArray, NpyDtype,
};
use std::path::PathBuf;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/npy")).join(name)
}

/// The fixture formula: `value[i] = i * scale + offset`, in C order.
fn ramp(n: usize, scale: f64, offset: f64) -> Vec<f64> {
    (0..n).map(|i| i as f64 * scale + offset).collect()
}

fn assert_values(array: &NpyArray, expected: &[f64], tolerance: f64) {
    assert_eq!(array.data.len(), expected.len());
    for (i, (&got, &want)) in array.data.iter().zip(expected).enumerate() {
        assert!((got as f64 - want).abs() <= tolerance, "element {i}: got {got}, want {want}");
    }
}

#[test]
fn reads_every_numpy_dtype_and_shape() {
    let cases: [(&str, &[usize], NpyDtype, Vec<f64>); 9] = [
        ("f32_2x3.npy", &[2, 3], NpyDtype::Float32, ramp(6, 0.5, -1.0)),
        ("f32_4x3x5.npy", &[4, 3, 5], NpyDtype::Float32, ramp(60, 0.25, 2.0)),
        ("f32_vector7.npy", &[7], NpyDtype::Float32, ramp(7, 0.5, -1.0)),
        ("f32_scalar.npy", &[], NpyDtype::Float32, vec![3.5]),
        ("f16_3x4.npy", &[3, 4], NpyDtype::Float16, ramp(12, 0.125, -0.5)),
        ("f64_2x2.npy", &[2, 2], NpyDtype::Float64, ramp(4, 1.0 / 3.0, 0.0)),
        ("u8_2x5.npy", &[2, 5], NpyDtype::UInt8, ramp(10, 25.0, 3.0)),
        ("i32_3x2.npy", &[3, 2], NpyDtype::Int32, ramp(6, -7.0, 10.0)),
        ("i64_4.npy", &[4], NpyDtype::Int64, ramp(4, 1000.0, -1500.0)),
    ];
    for (name, shape, dtype, expected) in cases {
        let array = read_npy(&fixture(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(array.shape, shape, "{name}");
        assert_eq!(array.dtype, dtype, "{name}");
        // Exact but for float64 → f32 rounding.
        assert_values(&array, &expected, if dtype == NpyDtype::Float64 { 1e-7 } else { 0.0 });
    }
    let bools = read_npy(&fixture("bool_2x3.npy")).expect("bool reads");
    assert_eq!((bools.dtype, bools.data), (NpyDtype::Bool, vec![1.0, 0.0, 1.0, 0.0, 0.0, 1.0]));
}

#[test]
fn reads_big_endian_and_header_versions_2_and_3() {
    for name in ["f32_be_2x3.npy", "f32_v2_2x3.npy", "f32_v3_2x3.npy"] {
        let array = read_npy(&fixture(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(array.shape, vec![2, 3], "{name}");
        assert_values(&array, &ramp(6, 0.5, -1.0), 0.0);
    }
}

#[test]
fn fortran_order_is_rejected_with_advice() {
    let err = read_npy(&fixture("f32_fortran_2x3.npy")).expect_err("Fortran order must be refused");
    let msg = err.to_string();
    assert!(msg.contains("Fortran") && msg.contains("f32_fortran_2x3.npy"), "{msg}");
}

#[test]
fn written_files_equal_numpy_bytes_and_read_back() {
    for (name, shape, scale, offset) in [
        ("f32_2x3.npy", vec![2, 3], 0.5, -1.0),
        ("f32_4x3x5.npy", vec![4, 3, 5], 0.25, 2.0),
        ("f32_vector7.npy", vec![7], 0.5, -1.0),
    ] {
        let n = shape.iter().product();
        let data: Vec<f32> = ramp(n, scale, offset).into_iter().map(|v| v as f32).collect();
        let ours = encode_npy_f32(&shape, &data).expect("lengths agree");
        let numpy = std::fs::read(fixture(name)).expect("fixture");
        assert_eq!(ours, numpy, "{name}: our bytes differ from numpy.save's");
    }
    let scalar = encode_npy_f32(&[], &[3.5]).expect("scalar");
    assert_eq!(scalar, std::fs::read(fixture("f32_scalar.npy")).expect("fixture"));

    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("features").join("view_01.npy");
    let data: Vec<f32> = (0..2 * 3 * 4).map(|i| i as f32 * -0.75).collect();
    write_npy_f32(&path, &[2, 3, 4], &data).expect("writes");
    let back =
        read_cue_folder_entry(&dir.path().join("features"), "view_01").expect("reads").expect("present");
    assert_eq!((back.shape, back.data), (vec![2, 3, 4], data));
    assert!(read_cue_folder_entry(&dir.path().join("features"), "view_02")
        .expect("absent is fine")
        .is_none());
    assert!(write_npy_f32(&path, &[5], &[1.0]).is_err(), "shape and data length disagree");
}

#[test]
fn reads_npz_stored_and_deflated() {
    for name in ["pair_stored.npz", "pair_compressed.npz"] {
        let arrays = read_npz(&fixture(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(arrays.keys().collect::<Vec<_>>(), ["depth", "ids"], "{name}");
        assert_eq!(arrays["depth"].shape, vec![2, 3]);
        assert_values(&arrays["depth"], &ramp(6, 0.5, -1.0), 0.0);
        assert_eq!(arrays["ids"].dtype, NpyDtype::Int64);
        assert_values(&arrays["ids"], &[0.0, 1.0, 2.0, 3.0], 0.0);
        assert_eq!(arrays["depth"].hwc(), Some((2, 3, 1)));
        assert_eq!(arrays["ids"].hwc(), None);
        let plane = arrays["depth"].to_plane().expect("2-D");
        assert_eq!((plane.width, plane.height, *plane.get(2, 1)), (3, 2, 1.5));
    }
}
