//! Depth Anything V2 against `transformers`' DepthAnythingForDepthEstimation (tiny random config).
//!
//! The reference is computed in float64; we run in float32. With random weights the head's output
//! reaches ~80, and float32 rounding alone (PyTorch's own f32 run) moves it by ~3e-4, so the
//! tolerance is |ours − reference| ≤ 2e-5·max|reference| + 1e-4·|reference|.

use crate::common::{assert_close, fixture, read_io};
use splatseg_models::depth_anything::{model_input_size, normalise_inverse_depth, DepthAnything};

#[test]
fn hf_checkpoint_matches_reference_on_non_square_and_square_inputs() {
    let model = DepthAnything::load(&fixture("depth_anything_tiny")).unwrap();
    assert_eq!(model.head_config().layer_indices, vec![0, 1, 2, 3]);
    assert_eq!(model.head_config().neck_sizes, [8, 16, 32, 32]);
    let io = read_io("depth_anything_tiny_io.safetensors");
    for case in ["nonsquare", "square"] {
        let input = &io[&format!("{case}.input")];
        let ours = model.forward(input).unwrap();
        // output at the input resolution (candle-transformers' is 2 px larger and square-only)
        assert_eq!(ours.dims(), &input.dims()[1..]);
        let reference = &io[&format!("{case}.depth")];
        let worst = assert_close(case, &ours, reference, atol(reference), 1e-4);
        println!("{case}: max |diff| = {worst:e}");
    }
}

#[test]
fn original_head_names_load_to_the_same_model() {
    use splatseg_models::weights::Weights;
    use splatseg_models::ModelKind;
    // rename the HF head tensors to the original release's names and check the output is unchanged
    let hf =
        Weights::load(&fixture("depth_anything_tiny/model.safetensors"), ModelKind::DepthAnythingV2).unwrap();
    let inverse = |name: &str| -> Option<String> {
        let mut candidates = vec![];
        for i in 0..4 {
            for f in ["weight", "bias"] {
                candidates.push(format!("depth_head.projects.{i}.{f}"));
                candidates.push(format!("depth_head.resize_layers.{i}.{f}"));
                candidates.push(format!("depth_head.scratch.layer{}_rn.{f}", i + 1));
                candidates.push(format!("depth_head.scratch.refinenet{}.out_conv.{f}", i + 1));
                for u in ["resConfUnit1", "resConfUnit2"] {
                    for c in ["conv1", "conv2"] {
                        candidates.push(format!("depth_head.scratch.refinenet{}.{u}.{c}.{f}", i + 1));
                    }
                }
            }
        }
        for f in ["weight", "bias"] {
            candidates.push(format!("depth_head.scratch.output_conv1.{f}"));
            candidates.push(format!("depth_head.scratch.output_conv2.0.{f}"));
            candidates.push(format!("depth_head.scratch.output_conv2.2.{f}"));
        }
        let found = candidates
            .into_iter()
            .find(|c| splatseg_models::depth_anything::names::original_to_hf(c).as_deref() == Some(name));
        Some(found.unwrap_or_else(|| name.to_string()))
    };
    let original = hf.clone().renamed(inverse);
    assert!(original.contains("depth_head.scratch.refinenet4.out_conv.weight"));
    let config = serde_json::from_str::<serde_json::Value>(
        &std::fs::read_to_string(fixture("depth_anything_tiny/config.json")).unwrap(),
    )
    .unwrap();
    let model = DepthAnything::from_weights(&original, Some(&config)).unwrap();
    let io = read_io("depth_anything_tiny_io.safetensors");
    let ours = model.forward(&io["nonsquare.input"]).unwrap();
    assert_close("original names", &ours, &io["nonsquare.depth"], atol(&io["nonsquare.depth"]), 1e-4);
}

fn atol(reference: &candle_core::Tensor) -> f32 {
    2e-5 * reference.abs().unwrap().max_all().unwrap().to_scalar::<f32>().unwrap()
}

#[test]
fn input_size_and_normalisation_helpers() {
    assert_eq!(model_input_size(480, 640, 518, 14), (518, 686));
    assert_eq!(model_input_size(800, 800, 518, 14), (518, 518));
    let normalised = normalise_inverse_depth(&[2.0, 4.0, 3.0, f32::NAN]);
    assert_eq!(&normalised[..3], &[1.0, 0.0, 0.5]); // larger inverse depth = nearer = 0
    assert!(normalised[3].is_nan());
}
