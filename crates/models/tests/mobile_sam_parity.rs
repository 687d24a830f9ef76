//! MobileSAM (TinyViT image encoder) against ultralytics' `TinyViT` inside `segment-anything`'s `Sam` and
//! `SamPredictor` (tiny random model with randomised batch-norm statistics, built by
//! tools/fixtures/make_mobile_sam_fixtures.py, loaded from its pickled `.pth` state dict with
//! `mobile_sam.pt`'s tensor names).
//!
//! Tolerances: image embedding |ours − reference| ≤ 1e-4 + 1e-4·|reference| (f32 both sides); low-res
//! logits ≤ 1e-3 + 1e-4·|reference| (the decoder's ×100 hypernetwork scale amplifies rounding), IoU
//! predictions ≤ 1e-4 + 1e-4·|reference|.

use crate::common::{assert_close, fixture, read_io};
use splatseg_models::sam::{ImageEncoder, Sam};

fn load() -> Sam {
    Sam::load(&fixture("mobile_sam_tiny.pth")).unwrap().with_input_size(128).unwrap()
}

#[test]
fn tiny_vit_checkpoint_is_detected_and_its_shapes_inferred() {
    let sam = Sam::load(&fixture("mobile_sam_tiny.pth")).unwrap();
    assert!(sam.encoder_config().is_none());
    let ImageEncoder::TinyVit(enc) = sam.image_encoder() else { panic!("expected a TinyViT encoder") };
    let cfg = enc.config();
    assert_eq!(cfg.img_size, 1024, "loaded at the released input side");
    assert_eq!(cfg.embed_dims, vec![16, 32, 40, 48]);
    assert_eq!(cfg.depths, vec![1, 1, 2, 1]);
    assert_eq!(cfg.num_heads, vec![0, 2, 2, 2]);
    assert_eq!(cfg.window_sizes, vec![0, 7, 14, 7]);
    assert_eq!(cfg.out_chans, 32);
    assert!(sam.clone().with_input_size(100).is_err());
    let sam = sam.with_input_size(128).unwrap();
    assert_eq!(sam.input_size_for(96, 128), (96, 128));
}

#[test]
fn encoder_and_decoder_match_reference() {
    let sam = load();
    let io = read_io("mobile_sam_tiny_io.safetensors");
    let img = &io["image"];
    let (h, w, _) = img.dims3().unwrap();
    let rgb = img.flatten_all().unwrap().to_vec1::<u8>().unwrap();
    let embedded = sam.embed_image(&rgb, h, w).unwrap();
    let worst = assert_close("embedding", &embedded.features, &io["image_embedding"], 1e-4, 1e-4);
    println!("image embedding max |diff| = {worst:e}");
    let points: Vec<[f32; 2]> =
        io["points"].to_vec2::<f32>().unwrap().into_iter().map(|p| [p[0], p[1]]).collect();
    let (low, iou) = sam.predict_points(&embedded, &points).unwrap();
    let worst = assert_close("low-res logits", &low, &io["low_res_logits"], 1e-3, 1e-4);
    println!("low-res logits max |diff| = {worst:e}");
    let worst = assert_close("iou", &iou, &io["iou_predictions"], 1e-4, 1e-4);
    println!("iou max |diff| = {worst:e}");
}
