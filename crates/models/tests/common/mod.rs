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

/// The shared-work decoder over a grid of several of its tiles of cells (256 per tile; `h·w` > 512
/// gives three, the last one partial) against the one-prompt-at-a-time candle decoder (IoU within
/// 1e-4 and logits within 2.5e-4 relative to max(1, |value|): the rounding of the attention sums grows
/// with the cells, and before the tiling the decoder was 1.8e-4 off on the 19×31 SAM grid of
/// `sam_shared_decoder.rs`, 1.1e-4 after), and a batch of prompts decoded together against each
/// prompt decoded alone (within 1e-4 too: products over more rows may block their sums differently,
/// as `gemm` does). Returns the worst
/// logit difference against the candle decoder.
pub fn check_shared_decoder_over_tiles(
    checkpoint: &str,
    (h, w): (usize, usize),
    prompts: usize,
    seed: u64,
) -> f32 {
    use rand::SeedableRng;
    use splatseg_models::sam::mask_decoder::MaskDecoder;
    use splatseg_models::weights::Weights;

    let weights = Weights::load(&fixture(checkpoint), splatseg_models::ModelKind::Sam).unwrap();
    let decoder = MaskDecoder::new(&weights.sub("mask_decoder.")).unwrap();
    let d = decoder.dim();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let image = random(&[d, h, w], &mut rng);
    let pe = random(&[d, h, w], &mut rng);
    let sparse = random(&[prompts, 2, d], &mut rng);
    let (masks, iou) = decoder.forward(&image, &pe, &sparse).unwrap();
    let prepared = decoder.prepare_image(&image, &pe).unwrap();
    let batch = decoder.decode_tokens(&prepared, &sparse).unwrap();
    let worst_iou = worst_difference(&batch.iou, &iou);
    assert!(worst_iou <= 1e-4, "{checkpoint}: IoU predictions differ by {worst_iou}");
    let outputs: Vec<usize> = (0..masks.dims()[1]).collect();
    let mut worst = 0f32;
    for p in 0..prompts {
        let ours = decoder.masks_of(&prepared, &batch, p, &outputs).unwrap();
        worst = worst.max(worst_difference(&ours, &masks.get(p).unwrap()));
        let alone = decoder.decode_tokens(&prepared, &sparse.narrow(0, p, 1).unwrap()).unwrap();
        let batch_iou = batch.iou.get(p).unwrap();
        let alone_iou = alone.iou.get(0).unwrap();
        let iou_gap = worst_difference(&batch_iou, &alone_iou);
        let alone_masks = decoder.masks_of(&prepared, &alone, 0, &outputs).unwrap();
        let logit_gap = worst_difference(&ours, &alone_masks);
        println!("{checkpoint}, prompt {p}: batch against alone: IoU {iou_gap:e}, logits {logit_gap:e}");
        assert!(iou_gap <= 1e-4 && logit_gap <= 1e-4, "{checkpoint}, prompt {p}: batch against alone");
    }
    assert!(worst <= 2.5e-4, "{checkpoint}: logits differ by {worst}");
    worst
}
