//! Helpers shared by the parity tests (reading the committed fixtures, comparing tensors).
#![allow(dead_code)]

use std::collections::HashMap;
use std::path::PathBuf;

use candle_core::{Device, Tensor};

/// `tests/fixtures/<name>`.
pub fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests").join("fixtures").join(name)
}

/// All tensors of a fixture safetensors file.
pub fn read_io(name: &str) -> HashMap<String, Tensor> {
    candle_core::safetensors::load(fixture(name), &Device::Cpu)
        .expect("fixture readable (run tools/fixtures/make_model_fixtures.py)")
}

/// Largest |a − b| and asserts `|a − b| ≤ atol + rtol·|b|` everywhere, printing the first failure.
pub fn assert_close(label: &str, actual: &Tensor, expected: &Tensor, atol: f32, rtol: f32) -> f32 {
    assert_eq!(actual.dims(), expected.dims(), "{label}: shapes differ");
    let a = actual.flatten_all().unwrap().to_vec1::<f32>().unwrap();
    let b = expected.flatten_all().unwrap().to_vec1::<f32>().unwrap();
    let mut worst = 0f32;
    for (i, (x, y)) in a.iter().zip(&b).enumerate() {
        let diff = (x - y).abs();
        assert!(diff <= atol + rtol * y.abs(), "{label}: index {i}: got {x}, reference {y} (|diff| {diff})");
        worst = worst.max(diff);
    }
    worst
}

/// `shape` filled with uniform values in [-1, 1) from `rng`.
pub fn random(shape: &[usize], rng: &mut rand_chacha::ChaCha8Rng) -> Tensor {
    use rand::Rng;
    let n: usize = shape.iter().product();
    let data: Vec<f32> = (0..n).map(|_| rng.gen_range(-1.0f32..1.0)).collect();
    Tensor::from_vec(data, shape, &Device::Cpu).unwrap()
}

/// Largest `|a − b| / max(1, |b|)` of two tensors of the same shape.
pub fn worst_difference(ours: &Tensor, reference: &Tensor) -> f32 {
    assert_eq!(ours.dims(), reference.dims());
    let a = ours.flatten_all().unwrap().to_vec1::<f32>().unwrap();
    let b = reference.flatten_all().unwrap().to_vec1::<f32>().unwrap();
    a.iter().zip(&b).map(|(x, y)| (x - y).abs() / y.abs().max(1.0)).fold(0.0, f32::max)
}
