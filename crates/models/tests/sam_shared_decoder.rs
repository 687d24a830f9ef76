//! The shared-work mask decoder against the one-prompt-at-a-time decoder, on the random-weight SAM and
//! MobileSAM fixtures: logits and IoU predictions within 1e-4 (relative to max(1, |value|)), and the
//! automatic mask generator keeps exactly the same masks (stability scores equal up to one pixel of
//! each count flipping by rounding).

use crate::common::{check_shared_decoder_over_tiles, fixture, random, read_io, worst_difference};
use candle_core::DType;
use rand::SeedableRng;
use splatseg_models::sam::mask_decoder::MaskDecoder;
use splatseg_models::sam::{generate_masks_using, AmgConfig, DecoderPath, Sam};
use splatseg_models::weights::Weights;
use splatseg_models::ModelKind;

/// Random image embedding (non-square grid), positional encoding and prompt tokens: every mask
/// output of every prompt, and the IoU head, through both decoders.
#[test]
fn shared_decoder_matches_the_per_prompt_decoder() {
    for checkpoint in ["sam_tiny.pth", "mobile_sam_tiny.pth"] {
        let weights = Weights::load(&fixture(checkpoint), ModelKind::Sam).unwrap();
        let decoder = MaskDecoder::new(&weights.sub("mask_decoder.")).unwrap();
        let d = decoder.dim();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
        let (h, w, prompts) = (6, 9, 5);
        let image = random(&[d, h, w], &mut rng);
        let pe = random(&[d, h, w], &mut rng);
        let sparse = random(&[prompts, 2, d], &mut rng);
        let (masks, iou) = decoder.forward(&image, &pe, &sparse).unwrap();
        let prepared = decoder.prepare_image(&image, &pe).unwrap();
        let decoded = decoder.decode_tokens(&prepared, &sparse).unwrap();
        let worst_iou = worst_difference(&decoded.iou, &iou);
        assert!(worst_iou <= 1e-4, "{checkpoint}: IoU predictions differ by {worst_iou}");
        let outputs: Vec<usize> = (0..masks.dims()[1]).collect();
        let mut worst = 0f32;
        for p in 0..prompts {
            let ours = decoder.masks_of(&prepared, &decoded, p, &outputs).unwrap();
            worst = worst.max(worst_difference(&ours, &masks.get(p).unwrap()));
            // a subset of the outputs gives the same logits for those outputs
            let one = decoder.masks_of(&prepared, &decoded, p, &[2]).unwrap();
            assert_eq!(one.dims(), &[1, 4 * h, 4 * w]);
            assert!(worst_difference(&one.get(0).unwrap(), &masks.get(p).unwrap().get(2).unwrap()) <= 1e-4);
        }
        println!("{checkpoint}: worst logit difference {worst:e}, IoU {worst_iou:e}");
        assert!(worst <= 1e-4, "{checkpoint}: logits differ by {worst}");
        assert!(
            masks.to_dtype(DType::F32).unwrap().abs().unwrap().max_all().unwrap().to_scalar::<f32>().unwrap()
                > 0.1
        );
    }
}

/// Grids of several tiles of cells (the tiled image-token updates and the running-maximum final
/// attention) and batches of prompts (decoded together against one at a time), on both fixtures.
#[test]
fn shared_decoder_over_several_tiles_and_batches() {
    for checkpoint in ["sam_tiny.pth", "mobile_sam_tiny.pth"] {
        let worst = check_shared_decoder_over_tiles(checkpoint, (19, 31), 6, 5);
        println!("{checkpoint}, 19×31 grid: worst logit difference {worst:e}");
    }
}

/// The automatic mask generator with every filter and NMS active keeps the same masks, in the same
/// order, with either decoder.
#[test]
fn shared_decoder_keeps_the_same_automatic_masks() {
    let io = read_io("sam_tiny_io.safetensors");
    let img = &io["image"];
    let (h, w, _) = img.dims3().unwrap();
    let rgb = img.flatten_all().unwrap().to_vec1::<u8>().unwrap();
    let sam = Sam::load(&fixture("sam_tiny.pth")).unwrap();
    let text = std::fs::read_to_string(fixture("sam_tiny_amg_crops.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let mut config: AmgConfig = serde_json::from_value(json["params"].clone()).unwrap();
    for (iou_thresh, stability) in
        [(config.pred_iou_thresh, config.stability_score_thresh), (0.0, 0.0), (0.5, 0.5)]
    {
        config.pred_iou_thresh = iou_thresh;
        config.stability_score_thresh = stability;
        let shared =
            generate_masks_using(DecoderPath::Shared, &sam, &rgb, (h, w), &config, &|_, _| {}).unwrap();
        let single =
            generate_masks_using(DecoderPath::OneAtATime, &sam, &rgb, (h, w), &config, &|_, _| {}).unwrap();
        assert!(!single.is_empty(), "thresholds {iou_thresh}/{stability}: the comparison needs masks");
        assert_eq!(shared.len(), single.len(), "thresholds {iou_thresh}/{stability}: mask count");
        for (a, b) in shared.iter().zip(&single) {
            assert_eq!(a.segmentation, b.segmentation, "thresholds {iou_thresh}/{stability}: mask differs");
            assert_eq!(a.point_coords, b.point_coords);
            assert!((a.predicted_iou - b.predicted_iou).abs() < 1e-4);
            // the stability score counts pixels above ±1: a logit within rounding of ±1 may flip one
            // pixel of each count, which moves the score by at most 2 / (pixels above −1) ≤ 2 / area
            let tolerance = 2.0 / a.area.max(1) as f64;
            assert!(
                (a.stability_score - b.stability_score).abs() <= tolerance,
                "stability {} vs {} (area {})",
                a.stability_score,
                b.stability_score,
                a.area
            );
        }
    }
}
