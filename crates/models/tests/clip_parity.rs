//! CLIP against open_clip (fixtures from tools/fixtures/make_clip_fixtures.py): both towers of two small
//! random models (OpenAI layout with QuickGELU, safetensors + open_clip_config.json; OpenCLIP's GELU,
//! patch 14, a pickled state dict without config), and the tokenizer on tricky strings.
//!
//! Tolerance of the towers: |ours − reference| ≤ 1e-4 + 1e-4·|reference|, the reference computed in
//! float64, ours in float32 (observed max printed by the tests). The tokenizer must give the same ids.

use crate::common::{assert_close, fixture, read_io};
use candle_core::{DType, Device, Tensor};
use splatseg_models::clip::{Activation, Clip, ClipHints, ClipTokenizer, CONTEXT_LENGTH};
use splatseg_models::weights::Weights;
use splatseg_models::ModelKind;

const ATOL: f32 = 1e-4;
const RTOL: f32 = 1e-4;

/// The texts `model_fixtures` in make_clip_fixtures.py tokenizes with the tiny merges.
const TEXTS: [&str; 4] = ["a photo of a cat", "A red mug on the table!", "", "things and stuff"];

fn token_rows(tokens: &Tensor) -> Vec<Vec<u32>> {
    tokens
        .to_dtype(DType::I64)
        .unwrap()
        .to_vec2::<i64>()
        .unwrap()
        .into_iter()
        .map(|r| r.into_iter().map(|v| v as u32).collect())
        .collect()
}

fn texts() -> Vec<String> {
    let mut texts: Vec<String> = TEXTS.iter().map(|t| t.to_string()).collect();
    texts[3] = vec!["things and stuff"; 30].join(" ");
    texts
}

fn tokenizer_cases() -> serde_json::Value {
    let text = std::fs::read_to_string(fixture("clip_tokenizer.json"))
        .expect("clip_tokenizer.json (run make_clip_fixtures.py)");
    serde_json::from_str(&text).unwrap()
}

/// Every case's ids under `key` against ours with `tokenizer`; returns the mismatches.
fn mismatches(tokenizer: &ClipTokenizer, key: &str) -> Vec<String> {
    let doc = tokenizer_cases();
    let mut bad = Vec::new();
    for case in doc["cases"].as_array().unwrap() {
        let text = case["text"].as_str().unwrap();
        let mut expected: Vec<u32> =
            case[key].as_array().unwrap().iter().map(|v| v.as_u64().unwrap() as u32).collect();
        expected.resize(CONTEXT_LENGTH, 0);
        let ours = tokenizer.tokenize(text, CONTEXT_LENGTH).unwrap();
        if ours != expected {
            bad.push(format!("{text:?}:\n  ours      {ours:?}\n  open_clip {expected:?}"));
        }
    }
    bad
}

#[test]
fn tokenizer_matches_open_clip_on_tricky_strings() {
    let doc = tokenizer_cases();
    for (key, vocab) in [("tiny", 651), ("openai_subset", 1167)] {
        let file = doc["merges"][key].as_str().unwrap();
        let tokenizer = ClipTokenizer::load(&fixture(file)).unwrap();
        assert_eq!(tokenizer.vocab_size(), vocab, "{key}");
        assert_eq!(doc["vocab_sizes"][key].as_u64(), Some(vocab as u64));
        assert_eq!((tokenizer.start_id(), tokenizer.end_id()), (vocab as u32 - 2, vocab as u32 - 1));
        let bad = mismatches(&tokenizer, key);
        assert!(
            bad.is_empty(),
            "{key}: {} of {} strings differ:\n{}",
            bad.len(),
            doc["cases"].as_array().unwrap().len(),
            bad.join("\n")
        );
    }
}

#[test]
fn tokenizer_matches_the_full_openai_vocabulary_when_at_hand() {
    let Some(path) = std::env::var_os("SPLATSEG_CLIP_BPE") else {
        eprintln!(
            "SKIPPED: set SPLATSEG_CLIP_BPE to OpenAI's bpe_simple_vocab_16e6.txt.gz (it is not committed) to \
             compare the full vocabulary's ids too; the committed subset of its merges is tested above"
        );
        return;
    };
    let tokenizer = ClipTokenizer::load(std::path::Path::new(&path)).unwrap();
    assert_eq!(tokenizer.vocab_size(), 49_408);
    assert_eq!((tokenizer.start_id(), tokenizer.end_id()), (49_406, 49_407));
    let bad = mismatches(&tokenizer, "openai");
    assert!(bad.is_empty(), "{} strings differ:\n{}", bad.len(), bad.join("\n"));
}

#[test]
fn truncation_keeps_eot_last_and_pads_with_zeros() {
    let tokenizer = ClipTokenizer::load(&fixture("clip_bpe_tiny.txt.gz")).unwrap();
    let long = tokenizer.tokenize(&"cat ".repeat(200), CONTEXT_LENGTH).unwrap();
    assert_eq!(long.len(), CONTEXT_LENGTH);
    assert_eq!((long[0], long[76]), (tokenizer.start_id(), tokenizer.end_id()));
    let empty = tokenizer.tokenize("", CONTEXT_LENGTH).unwrap();
    assert_eq!(&empty[..3], &[tokenizer.start_id(), tokenizer.end_id(), 0]);
    assert!(empty[2..].iter().all(|&v| v == 0));
    assert!(tokenizer.tokenize("x", 1).is_err());
}

#[test]
fn queries_that_are_blank_or_too_long_are_refused_not_cut() {
    let tokenizer = ClipTokenizer::load(&fixture("clip_bpe_tiny.txt.gz")).unwrap();
    for blank in ["", "   ", "\t\n"] {
        let err = tokenizer.tokenize_query(blank, CONTEXT_LENGTH).unwrap_err().to_string();
        assert!(err.contains("is empty or blank"), "{blank:?}: {err}");
    }
    // 75 tokens fit beside SOT and EOT; 76 do not
    let fits = "a ".repeat(75);
    assert_eq!(tokenizer.encode(&fits).unwrap().len(), 75);
    assert_eq!(
        tokenizer.tokenize_query(&fits, CONTEXT_LENGTH).unwrap(),
        tokenizer.tokenize(&fits, 77).unwrap()
    );
    let err = tokenizer.tokenize_query(&"a ".repeat(76), CONTEXT_LENGTH).unwrap_err().to_string();
    assert!(err.contains("76 tokens long, more than the 75 CLIP reads"), "{err}");
    assert!(err.contains("152 characters") && err.contains("shorten it"), "{err}");
    let a_red_mug = tokenizer.tokenize_query("a red mug", CONTEXT_LENGTH).unwrap();
    assert_eq!(a_red_mug, tokenizer.tokenize("a red mug", CONTEXT_LENGTH).unwrap());
}

#[test]
fn openai_layout_with_quick_gelu_matches_open_clip() {
    let model = Clip::load(&fixture("clip_tiny_openai"), ClipHints::default()).unwrap();
    let config = model.config();
    assert_eq!(config.activation, Activation::QuickGelu, "from open_clip_config.json");
    let vision = config.vision.as_ref().unwrap();
    assert_eq!(
        (vision.width, vision.layers, vision.heads, vision.patch_size, vision.image_size),
        (32, 2, 4, 8, 32)
    );
    let text = config.text.as_ref().unwrap();
    assert_eq!((text.vocab_size, text.context_length, text.width, text.heads), (651, 77, 32, 4));
    assert_eq!(config.embed_dim, 16);
    let io = read_io("clip_tiny_openai_io.safetensors");
    check_towers(&model, &io, "openai");
    // the fixture's token ids are what our tokenizer makes of the texts
    let tokenizer = ClipTokenizer::load(&fixture("clip_bpe_tiny.txt.gz")).unwrap();
    let ours: Vec<Vec<u32>> = texts().iter().map(|t| tokenizer.tokenize(t, 77).unwrap()).collect();
    assert_eq!(ours, token_rows(&io["tokens"]));
    // and the normalised text embeddings through the tokenizer
    let owned = texts();
    let refs: Vec<&str> = owned.iter().map(String::as_str).collect();
    let normalised = model.embed_texts(&tokenizer, &refs).unwrap();
    let expected = splatseg_models::clip::l2_normalise_rows(&io["text_features"]).unwrap();
    assert_close("normalised text", &normalised, &expected, ATOL, RTOL);
}

#[test]
fn openclip_gelu_patch_14_pickle_matches_open_clip() {
    let weights = Weights::load(&fixture("clip_tiny_openclip.bin"), ModelKind::Clip).unwrap();
    let hints = ClipHints { activation: Some(Activation::Gelu), vision_heads: Some(3), text_heads: Some(2) };
    let model = Clip::from_weights(&weights, hints).unwrap();
    let vision = model.config().vision.as_ref().unwrap();
    assert_eq!((vision.width, vision.patch_size, vision.image_size), (48, 14, 42));
    check_towers(&model, &read_io("clip_tiny_openclip_io.safetensors"), "openclip");
}

fn check_towers(model: &Clip, io: &std::collections::HashMap<String, Tensor>, label: &str) {
    let images = model.image_tower().unwrap().embed(&io["images"]).unwrap();
    let worst = assert_close(&format!("{label} image"), &images, &io["image_features"], ATOL, RTOL);
    println!("{label} image tower: max |diff| = {worst:e}");
    // one image alone gives its row of the batch
    let single = model.image_tower().unwrap().embed(&io["images"].narrow(0, 1, 1).unwrap()).unwrap();
    assert_close(
        &format!("{label} image 1 alone"),
        &single,
        &io["image_features"].narrow(0, 1, 1).unwrap(),
        ATOL,
        RTOL,
    );
    let rows = token_rows(&io["tokens"]);
    let texts = model.text_tower().unwrap().embed(&rows).unwrap();
    let worst = assert_close(&format!("{label} text"), &texts, &io["text_features"], ATOL, RTOL);
    println!("{label} text tower: max |diff| = {worst:e}");
    for (r, row) in rows.iter().enumerate() {
        let alone = model.text_tower().unwrap().embed(std::slice::from_ref(row)).unwrap();
        assert_close(
            &format!("{label} text {r} alone"),
            &alone,
            &io["text_features"].narrow(0, r, 1).unwrap(),
            ATOL,
            RTOL,
        );
    }
}

#[test]
fn the_wrong_activation_is_caught_by_the_reference() {
    let hints = ClipHints { activation: Some(Activation::Gelu), ..ClipHints::default() };
    let model = Clip::load(&fixture("clip_tiny_openai"), hints).unwrap();
    assert_eq!(model.config().activation, Activation::Gelu, "the caller's hint wins over the file");
    let io = read_io("clip_tiny_openai_io.safetensors");
    let images = model.image_tower().unwrap().embed(&io["images"]).unwrap();
    let diff = (images - &io["image_features"])
        .unwrap()
        .abs()
        .unwrap()
        .max_all()
        .unwrap()
        .to_scalar::<f32>()
        .unwrap();
    assert!(diff > 1e-2, "GELU instead of QuickGELU should change the embedding, max diff {diff}");
}

#[test]
fn bad_files_and_inputs_give_clear_errors() {
    let weights = Weights::load(&fixture("clip_tiny_openclip.bin"), ModelKind::Clip).unwrap();
    let err = Clip::from_weights(&weights, ClipHints::default()).unwrap_err().to_string();
    assert!(err.contains("activation") && err.contains("clip_tiny_openclip.bin"), "{err}");
    let hints = ClipHints { activation: Some(Activation::Gelu), vision_heads: Some(3), text_heads: Some(2) };
    let without = weights
        .clone()
        .renamed(|n| (n != "visual.transformer.resblocks.1.mlp.c_proj.weight").then(|| n.to_string()));
    let err = Clip::from_weights(&without, hints).unwrap_err().to_string();
    assert!(
        err.contains("visual.transformer.resblocks.1.mlp.c_proj.weight") && err.contains("[48, 192]"),
        "{err}"
    );
    // a prefix (DDP's `module.`) is found
    let prefixed = weights.clone().renamed(|n| Some(format!("module.{n}")));
    assert!(Clip::from_weights(&prefixed, hints).is_ok());
    // width 48 does not split into the default 48 / 64 = 0 heads
    let err = Clip::from_weights(
        &weights,
        ClipHints { activation: Some(Activation::Gelu), ..ClipHints::default() },
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("heads"), "{err}");
    let model = Clip::from_weights(&weights, hints).unwrap();
    let wrong = Tensor::zeros((1, 3, 32, 32), DType::F32, &Device::Cpu).unwrap();
    let err = model.image_tower().unwrap().embed(&wrong).unwrap_err().to_string();
    assert!(err.contains("[B, 3, 42, 42]"), "{err}");
    let err = model.text_tower().unwrap().embed(&[vec![649, 5000, 650]]).unwrap_err().to_string();
    assert!(err.contains("5000") && err.contains("651"), "{err}");
    assert!(model.text_tower().unwrap().embed(&[vec![0; 78]]).is_err());
    // a merges file with a malformed line, and one that does not exist
    let dir = std::env::temp_dir().join(format!("splatseg-clip-bpe-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.txt");
    std::fs::write(&bad, "#version: 0.2\nh e\nthree parts here\n").unwrap();
    let err = ClipTokenizer::load(&bad).unwrap_err().to_string();
    assert!(err.contains("line 3") && err.contains("bad.txt"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
    let err = ClipTokenizer::load(&fixture("no-such-merges.txt.gz")).unwrap_err().to_string();
    assert!(err.contains("no-such-merges.txt.gz") && err.contains("bpe_simple_vocab_16e6"), "{err}");
    let err = Clip::load(&fixture("no-such-clip"), ClipHints::default()).unwrap_err().to_string();
    assert!(err.contains("no such file") && err.contains("open_clip_model.safetensors"), "{err}");
}
