//! DINOv2 against `transformers` (fixtures from tools/fixtures/make_model_fixtures.py).
//!
//! Tolerance: |ours − reference| ≤ 1e-4 + 1e-4·|reference| (both sides f32; observed max ≈ 1e-6).

use crate::common::{assert_close, fixture, read_io};
use splatseg_models::dinov2::{Dinov2, Layout, PosEmbedResize};
use splatseg_models::weights::Weights;
use splatseg_models::ModelKind;

const ATOL: f32 = 1e-4;
const RTOL: f32 = 1e-4;

#[test]
fn hf_checkpoint_matches_reference_on_non_square_and_square_inputs() {
    let model = Dinov2::load(&fixture("dinov2_tiny")).unwrap();
    assert_eq!(model.config().layout, Layout::HuggingFace);
    assert_eq!(model.config().num_heads, 2);
    assert_eq!(model.config().pos_grid, 4);
    let io = read_io("dinov2_tiny_io.safetensors");
    for case in ["nonsquare", "square", "square_up"] {
        let ours = model.patch_features(&io[&format!("{case}.input")]).unwrap();
        let worst = assert_close(case, &ours, &io[&format!("{case}.patch_tokens")], ATOL, RTOL);
        println!("{case}: max |diff| = {worst:e}");
    }
}

#[test]
fn non_square_input_is_not_transposed() {
    // 42×70 gives a 3×5 grid; transposing H and W (candle-transformers' bug) or resizing the
    // positional embeddings with another rule changes the features well beyond the tolerance.
    let model = Dinov2::load(&fixture("dinov2_tiny")).unwrap();
    let io = read_io("dinov2_tiny_io.safetensors");
    let ours = model.patch_features(&io["nonsquare.input"]).unwrap();
    assert_eq!(ours.dims(), &[3, 5, 32]);
    let reference = &io["nonsquare.patch_tokens"];
    assert_close("non-square", &ours, reference, ATOL, RTOL);
    // the positional table resized for a transposed (5×3) grid, then transposed back, is different
    let right = model.patch_positions(3, 5).unwrap();
    let swapped = model
        .patch_positions(5, 3)
        .unwrap()
        .reshape((5, 3, 32))
        .unwrap()
        .transpose(0, 1)
        .unwrap()
        .reshape((15, 32))
        .unwrap();
    let diff = (right - swapped).unwrap().abs().unwrap().max_all().unwrap().to_scalar::<f32>().unwrap();
    assert!(diff > 1e-2, "transposed grid should differ, max diff {diff}");
}

#[test]
fn original_layout_matches_reference_with_offset_interpolation() {
    let weights = Weights::load(&fixture("dinov2_tiny_original.safetensors"), ModelKind::Dinov2).unwrap();
    let config_json = serde_json::json!({"num_attention_heads": 2});
    let model = Dinov2::from_weights(&weights, Some(&config_json)).unwrap();
    assert_eq!(model.config().layout, Layout::Original);
    assert_eq!(
        model.config().pos_embed_resize,
        PosEmbedResize::ScaleWithOffset { offset: 0.1, antialias: false }
    );
    let io = read_io("dinov2_tiny_io.safetensors");
    let ours = model.patch_features(&io["nonsquare.input"]).unwrap();
    assert_close("original layout", &ours, &io["original.nonsquare.patch_tokens"], ATOL, RTOL);
    // and the offset matters: the HF rule gives the other reference output
    let hf_reference = &io["nonsquare.patch_tokens"];
    let diff = (&ours - hf_reference).unwrap().abs().unwrap().max_all().unwrap().to_scalar::<f32>().unwrap();
    assert!(diff > 1e-3, "offset 0.1 should change the features, max diff {diff}");
}

#[test]
fn registers_model_matches_reference() {
    let model = Dinov2::load(&fixture("dinov2_reg_tiny")).unwrap();
    assert_eq!(model.config().num_registers, 4);
    assert_eq!(model.config().pos_embed_resize, PosEmbedResize::Size { antialias: true });
    let io = read_io("dinov2_reg_tiny_io.safetensors");
    for case in ["nonsquare", "square_up"] {
        let ours = model.patch_features(&io[&format!("{case}.input")]).unwrap();
        let worst = assert_close(case, &ours, &io[&format!("{case}.patch_tokens")], ATOL, RTOL);
        println!("registers {case}: max |diff| = {worst:e}");
    }
}

#[test]
fn wrong_files_give_errors_naming_tensor_and_shapes() {
    let weights = Weights::load(&fixture("dinov2_tiny_original.safetensors"), ModelKind::Dinov2).unwrap();
    // drop a tensor
    let without = weights.clone().renamed(|n| (n != "blocks.1.mlp.fc2.weight").then(|| n.to_string()));
    let err = Dinov2::from_weights(&without, None).unwrap_err().to_string();
    assert!(err.contains("blocks.1.mlp.fc2.weight") && err.contains("[32, 128]"), "{err}");
    assert!(err.contains("dinov2_tiny_original.safetensors"), "{err}");
    assert!(err.contains("facebook/dinov2-small"), "should say where to get the file: {err}");
    // a depth model's head is not a DINOv2 backbone: not readable as a file of the wrong kind
    let err = Dinov2::load(&fixture("no-such-file.safetensors")).unwrap_err().to_string();
    assert!(err.contains("no such file"), "{err}");
    // inputs that are not multiples of 14
    let model = Dinov2::from_weights(&weights, Some(&serde_json::json!({"num_attention_heads": 2}))).unwrap();
    let bad =
        candle_core::Tensor::zeros((3, 40, 70), candle_core::DType::F32, &candle_core::Device::Cpu).unwrap();
    let err = model.patch_features(&bad).unwrap_err().to_string();
    assert!(err.contains("multiples of 14"), "{err}");
}
