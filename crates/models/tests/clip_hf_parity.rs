//! CLIP's Hugging Face files against transformers (fixtures from tools/fixtures/make_clip_hf_fixtures.py):
//! the `tokenizer.json` vocabulary file (our tokenizer reading it gives transformers' ids, and the same
//! ids as reading the merges file of the same vocabulary), and a small random `transformers.CLIPModel`
//! (`model.safetensors` + `config.json`, transformers' weight names) through both towers.
//!
//! Tolerance of the towers: |ours − reference| ≤ 1e-4 + 1e-4·|reference|, the reference computed in
//! float64, ours in float32. The tokenizer must give the same ids.

use crate::common::{assert_close, fixture, read_io};
use candle_core::DType;
use splatseg_models::clip::{tokenizer_beside, Activation, Clip, ClipHints, ClipTokenizer, CONTEXT_LENGTH};
use std::path::Path;

const ATOL: f32 = 1e-4;
const RTOL: f32 = 1e-4;

fn cases() -> serde_json::Value {
    let text = std::fs::read_to_string(fixture("clip_tokenizer_hf.json"))
        .expect("clip_tokenizer_hf.json (run make_clip_hf_fixtures.py)");
    serde_json::from_str(&text).expect("json")
}

fn ids(value: &serde_json::Value) -> Vec<u32> {
    value.as_array().expect("ids").iter().map(|v| v.as_u64().expect("an id") as u32).collect()
}

fn unpadded(mut ids: Vec<u32>) -> Vec<u32> {
    while ids.last() == Some(&0) {
        ids.pop();
    }
    ids
}

/// Whether `text` holds the literal text of a special token (of either file), which the two files
/// name differently.
fn names_a_special(text: &str) -> bool {
    ["<start_of_text>", "<end_of_text>", "<|startoftext|>", "<|endoftext|>"].iter().any(|s| text.contains(s))
}

#[test]
fn tokenizer_json_gives_transformers_ids_and_the_merges_files_ids() {
    let doc = cases();
    let json =
        ClipTokenizer::load(&fixture(doc["tokenizer"].as_str().expect("path"))).expect("tokenizer.json");
    let merges = ClipTokenizer::load(&fixture(doc["merges"].as_str().expect("path"))).expect("merges");
    assert_eq!((json.vocab_size(), json.start_id(), json.end_id()), (651, 649, 650));
    assert_eq!((merges.start_id(), merges.end_id()), (649, 650));
    let (mut same_files, mut as_transformers, mut differ) = (0, 0, Vec::new());
    for case in doc["cases"].as_array().expect("cases") {
        let text = case["text"].as_str().expect("text");
        let ours = unpadded(json.tokenize(text, CONTEXT_LENGTH).expect("tokenizes"));
        if !names_a_special(text) {
            let from_merges = unpadded(merges.tokenize(text, CONTEXT_LENGTH).expect("tokenizes"));
            assert_eq!(ours, from_merges, "tokenizer.json and the merges file differ on {text:?}");
            assert_eq!(ours, ids(&case["open_clip"]), "{text:?}: not open_clip's ids");
            same_files += 1;
        }
        // where transformers' normaliser (NFC, whitespace, lower case) and open_clip's cleaning (ftfy,
        // HTML entities) agree, and for the Hugging Face specials, we give transformers' ids
        let hf_specials = text.contains("<|startoftext|>");
        if case["transformers"] == case["open_clip"] || hf_specials {
            assert_eq!(ours, ids(&case["transformers"]), "{text:?}: not transformers' ids");
            as_transformers += 1;
        } else {
            differ.push(text.chars().take(40).collect::<String>());
        }
    }
    println!(
        "{same_files} strings: both files give the same ids; {as_transformers} strings: transformers' ids; \
         {} where transformers' cleaning differs from CLIP's (ours follows CLIP's): {differ:?}",
        differ.len()
    );
    assert!(same_files >= 25 && as_transformers >= 20, "{same_files} / {as_transformers}");
}

#[test]
fn tokenizer_json_merges_as_strings_read_the_same() {
    // tokenizers ≥ 0.20 writes merges as ["a", "b"] pairs; older files hold "a b" strings
    let path = fixture("clip_tiny_hf/tokenizer.json");
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).expect("read")).expect("json");
    let merges = doc["model"]["merges"].as_array_mut().expect("merges");
    assert!(merges[0].is_array(), "the fixture has pairs: {}", merges[0]);
    for merge in merges.iter_mut() {
        let pair: Vec<&str> =
            merge.as_array().expect("pair").iter().map(|v| v.as_str().expect("str")).collect();
        *merge = serde_json::Value::String(pair.join(" "));
    }
    let strings =
        ClipTokenizer::from_tokenizer_json(&doc.to_string(), Path::new("strings.json")).expect("loads");
    let pairs = ClipTokenizer::load(&path).expect("loads");
    for text in ["a photo of a cat", "things and stuff on the floor", "supercalifragilistic"] {
        assert_eq!(
            strings.tokenize(text, 77).expect("ids"),
            pairs.tokenize(text, 77).expect("ids"),
            "{text}"
        );
    }
}

#[test]
fn bad_tokenizer_json_files_give_clear_errors() {
    let path = Path::new("bad/tokenizer.json");
    let err = |text: &str| ClipTokenizer::from_tokenizer_json(text, path).unwrap_err().to_string();
    assert!(err("{ not json").contains("tokenizer.json"), "{}", err("{ not json"));
    let unigram = r#"{"model": {"type": "Unigram", "vocab": []}}"#;
    assert!(err(unigram).contains("Unigram"), "{}", err(unigram));
    let no_suffix = r#"{"model": {"type": "BPE", "vocab": {}, "merges": []}}"#;
    assert!(err(no_suffix).contains("end_of_word_suffix"), "{}", err(no_suffix));
    let bad_merge =
        r#"{"model": {"type": "BPE", "end_of_word_suffix": "</w>", "vocab": {"a": 0}, "merges": ["ab"]}}"#;
    assert!(err(bad_merge).contains("merge 0"), "{}", err(bad_merge));
    let no_specials =
        r#"{"model": {"type": "BPE", "end_of_word_suffix": "</w>", "vocab": {"a": 0}, "merges": ["a b"]}}"#;
    assert!(err(no_specials).contains("<|startoftext|>"), "{}", err(no_specials));
}

#[test]
fn the_tokenizer_file_beside_a_checkpoint_is_found() {
    // an open_clip folder with the merges file, a Hugging Face folder with tokenizer.json
    assert_eq!(
        tokenizer_beside(&fixture("clip_tiny_hf/model.safetensors")),
        Some(fixture("clip_tiny_hf/tokenizer.json"))
    );
    assert_eq!(tokenizer_beside(&fixture("clip_tiny_hf")), Some(fixture("clip_tiny_hf/tokenizer.json")));
    assert_eq!(
        tokenizer_beside(&fixture("clip_tiny_openai")),
        None,
        "that fixture folder holds no tokenizer"
    );
    let dir = std::env::temp_dir().join(format!("splatseg-clip-tokenizers-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    std::fs::copy(fixture("clip_tiny_hf/tokenizer.json"), dir.join("tokenizer.json")).expect("copy");
    assert_eq!(tokenizer_beside(&dir), Some(dir.join("tokenizer.json")));
    std::fs::copy(fixture("clip_bpe_tiny.txt.gz"), dir.join("bpe_simple_vocab_16e6.txt.gz")).expect("copy");
    assert_eq!(tokenizer_beside(&dir), Some(dir.join("bpe_simple_vocab_16e6.txt.gz")), "merges first");
    std::fs::remove_dir_all(&dir).expect("clean up");
}

#[test]
fn transformers_clip_model_matches_through_both_towers() {
    let model = Clip::load(&fixture("clip_tiny_hf"), ClipHints::default()).expect("loads the HF checkpoint");
    let config = model.config();
    assert_eq!(config.activation, Activation::QuickGelu, "from config.json's hidden_act");
    let vision = config.vision.as_ref().expect("image tower");
    assert_eq!(
        (vision.width, vision.layers, vision.heads, vision.patch_size, vision.image_size),
        (48, 2, 3, 8, 32)
    );
    let text = config.text.as_ref().expect("text tower");
    assert_eq!((text.vocab_size, text.width, text.heads, text.layers), (651, 32, 4, 2));
    assert_eq!(config.embed_dim, 16);
    let io = read_io("clip_tiny_hf_io.safetensors");
    let images = model.image_tower().expect("tower").embed(&io["images"]).expect("embeds");
    let worst = assert_close("hf image", &images, &io["image_features"], ATOL, RTOL);
    println!("transformers CLIPModel image tower: max |diff| = {worst:e}");
    let rows: Vec<Vec<u32>> = io["tokens"]
        .to_dtype(DType::I64)
        .and_then(|t| t.to_vec2::<i64>())
        .expect("tokens")
        .into_iter()
        .map(|r| r.into_iter().map(|v| v as u32).collect())
        .collect();
    let texts = model.text_tower().expect("tower").embed(&rows).expect("embeds");
    let worst = assert_close("hf text", &texts, &io["text_features"], ATOL, RTOL);
    println!("transformers CLIPModel text tower: max |diff| = {worst:e}");
    // the text only, as `find` loads it
    let text_only = Clip::load_text_only(&fixture("clip_tiny_hf"), ClipHints::default()).expect("loads");
    assert!(text_only.image_tower().is_err());
    let again = text_only.text_tower().expect("tower").embed(&rows).expect("embeds");
    assert_close("hf text only", &again, &io["text_features"], ATOL, RTOL);
}

#[test]
fn a_transformers_checkpoint_missing_a_projection_names_it() {
    let weights = splatseg_models::weights::Weights::load(
        &fixture("clip_tiny_hf/model.safetensors"),
        splatseg_models::ModelKind::Clip,
    )
    .expect("loads");
    let hints =
        ClipHints { activation: Some(Activation::QuickGelu), vision_heads: Some(3), text_heads: Some(4) };
    let without = weights
        .renamed(|n| (n != "text_model.encoder.layers.1.self_attn.k_proj.bias").then(|| n.to_string()));
    let err = Clip::from_weights(&without, hints).unwrap_err().to_string();
    assert!(
        err.contains("text_model.encoder.layers.1.self_attn.k_proj.bias")
            && err.contains("model.safetensors"),
        "{err}"
    );
}
