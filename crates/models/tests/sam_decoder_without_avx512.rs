//! The shared-work decoder's `gemm` paths — what CPUs without AVX-512 run — against the
//! one-prompt-at-a-time decoder, on the random-weight SAM and MobileSAM fixtures, with the AVX-512
//! kernels switched off by `SPLATSEG_DISABLE_AVX512` (on other CPUs they are off anyway): the test
//! runs itself again as a child process with the variable set, so nothing in this process changes. Logits and IoU
//! predictions within 1e-4 (relative to max(1, |value|)), as `sam_shared_decoder.rs` checks for the
//! default path.

use crate::common::{check_shared_decoder_over_tiles, fixture, random, worst_difference};
use rand::SeedableRng;
use splatseg_models::sam::mask_decoder::MaskDecoder;
use splatseg_models::skinny::{has_avx512, DISABLE_AVX512_ENV};
use splatseg_models::weights::Weights;
use splatseg_models::ModelKind;

/// This test's name as the test binary knows it: its module path without the binary's name.
fn test_name() -> String {
    let module = module_path!().split_once("::").map_or("", |(_, rest)| rest);
    let test = "gemm_paths_of_the_shared_decoder_match_the_per_prompt_decoder";
    if module.is_empty() {
        test.to_string()
    } else {
        format!("{module}::{test}")
    }
}

#[test]
fn gemm_paths_of_the_shared_decoder_match_the_per_prompt_decoder() {
    if std::env::var_os(DISABLE_AVX512_ENV).is_none() {
        let exe = std::env::current_exe().expect("the test binary's path");
        let output = std::process::Command::new(exe)
            .args(["--exact", &test_name(), "--nocapture", "--test-threads", "1"])
            .env(DISABLE_AVX512_ENV, "1")
            .output()
            .expect("run this test again with the AVX-512 kernels off");
        let log =
            format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
        assert!(output.status.success(), "the run with {DISABLE_AVX512_ENV}=1 failed:\n{log}");
        assert!(log.contains("1 passed"), "the child ran no test:\n{log}");
        return;
    }
    assert!(!has_avx512(), "{DISABLE_AVX512_ENV} is set, yet the AVX-512 kernels are on");
    for checkpoint in ["sam_tiny.pth", "mobile_sam_tiny.pth"] {
        let weights = Weights::load(&fixture(checkpoint), ModelKind::Sam).unwrap();
        let decoder = MaskDecoder::new(&weights.sub("mask_decoder.")).unwrap();
        let d = decoder.dim();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
        let (h, w, prompts) = (7, 5, 3);
        let image = random(&[d, h, w], &mut rng);
        let pe = random(&[d, h, w], &mut rng);
        let sparse = random(&[prompts, 2, d], &mut rng);
        let (masks, iou) = decoder.forward(&image, &pe, &sparse).unwrap();
        let prepared = decoder.prepare_image(&image, &pe).unwrap();
        let decoded = decoder.decode_tokens(&prepared, &sparse).unwrap();
        let worst_iou = worst_difference(&decoded.iou, &iou);
        assert!(worst_iou <= 1e-4, "{checkpoint}: IoU predictions differ by {worst_iou}");
        let outputs: Vec<usize> = (0..masks.dims()[1]).collect();
        for p in 0..prompts {
            let ours = decoder.masks_of(&prepared, &decoded, p, &outputs).unwrap();
            let worst = worst_difference(&ours, &masks.get(p).unwrap());
            assert!(worst <= 1e-4, "{checkpoint}, prompt {p}: logits differ by {worst}");
        }
        // several tiles of cells, a batch of prompts against each alone
        check_shared_decoder_over_tiles(checkpoint, (23, 25), 4, 22);
    }
}
