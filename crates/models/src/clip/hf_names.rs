//! Hugging Face's `CLIPModel` checkpoints (transformers' names: `text_model.*`, `vision_model.*`,
//! `visual_projection`, `text_projection`; `model.safetensors` / `pytorch_model.bin` beside a
//! `config.json`, as OpenAI's CLIPs are on the hub) read as the OpenAI-named state dict the towers
//! are built from.
//!
//! The two layouts hold the same numbers: the attention's separate `q_proj`, `k_proj`, `v_proj` are
//! stacked (in that order) into `in_proj_weight` / `in_proj_bias`, the projections are `Linear`
//! weights `[E, width]` where OpenAI keeps `[width, E]` matrices (transposed here), the rest is renamed.
//! The text tower pools at the first end-of-text token either way (transformers' `eos_token_id`, the
//! largest id of CLIP's vocabularies, where our tower pools).

use std::collections::HashMap;

use candle_core::Tensor;

use super::config::{Activation, ClipHints};
use crate::error::{ModelsError, ModelsResult};
use crate::weights::Weights;

/// Whether `weights` use transformers' names.
pub fn is_hf_layout(weights: &Weights) -> bool {
    weights.names().iter().any(|n| n.starts_with("text_model.") || n.starts_with("vision_model."))
}

/// The OpenAI name of a transformers name inside an encoder layer (`layer_norm1.weight` → `ln_1.weight`);
/// `None` for the attention's `q/k/v_proj` (stacked apart) and unknown names.
fn layer_name(rest: &str) -> Option<String> {
    let renames = [
        ("layer_norm1.", "ln_1."),
        ("layer_norm2.", "ln_2."),
        ("mlp.fc1.", "mlp.c_fc."),
        ("mlp.fc2.", "mlp.c_proj."),
        ("self_attn.out_proj.", "attn.out_proj."),
    ];
    renames.iter().find_map(|(from, to)| rest.strip_prefix(from).map(|tail| format!("{to}{tail}")))
}

/// The OpenAI name of every transformers name that is renamed as it is.
fn plain_name(name: &str) -> Option<String> {
    let fixed = [
        ("vision_model.embeddings.class_embedding", "visual.class_embedding"),
        ("vision_model.embeddings.patch_embedding.weight", "visual.conv1.weight"),
        ("vision_model.embeddings.position_embedding.weight", "visual.positional_embedding"),
        ("vision_model.pre_layrnorm.weight", "visual.ln_pre.weight"),
        ("vision_model.pre_layrnorm.bias", "visual.ln_pre.bias"),
        ("vision_model.post_layernorm.weight", "visual.ln_post.weight"),
        ("vision_model.post_layernorm.bias", "visual.ln_post.bias"),
        ("text_model.embeddings.token_embedding.weight", "token_embedding.weight"),
        ("text_model.embeddings.position_embedding.weight", "positional_embedding"),
        ("text_model.final_layer_norm.weight", "ln_final.weight"),
        ("text_model.final_layer_norm.bias", "ln_final.bias"),
        ("logit_scale", "logit_scale"),
    ];
    if let Some((_, to)) = fixed.iter().find(|(from, _)| *from == name) {
        return Some(to.to_string());
    }
    for (from, to) in [
        ("vision_model.encoder.layers.", "visual.transformer.resblocks."),
        ("text_model.encoder.layers.", "transformer.resblocks."),
    ] {
        if let Some((layer, rest)) = name.strip_prefix(from).and_then(|r| r.split_once('.')) {
            return layer_name(rest).map(|rest| format!("{to}{layer}.{rest}"));
        }
    }
    None
}

/// `weights` (transformers' names) under OpenAI's names (see the module docs). Buffers such as
/// `position_ids` and names of neither layout are left out; a layer's `q/k/v_proj` with one of the
/// three missing is an error naming it.
pub fn to_openai_names(weights: &Weights) -> ModelsResult<Weights> {
    let mut out: HashMap<String, Tensor> = HashMap::new();
    for name in weights.names() {
        if let Some(new_name) = plain_name(name) {
            out.insert(new_name, weights.get_any(name)?);
        }
    }
    for (projection, to) in
        [("visual_projection.weight", "visual.proj"), ("text_projection.weight", "text_projection")]
    {
        if weights.contains(projection) {
            out.insert(to.to_string(), weights.get_any(projection)?.t()?.contiguous()?);
        }
    }
    for (from, to) in [
        ("vision_model.encoder.layers.", "visual.transformer.resblocks."),
        ("text_model.encoder.layers.", "transformer.resblocks."),
    ] {
        let layers =
            (0..).take_while(|i| weights.contains(&format!("{from}{i}.self_attn.q_proj.weight"))).count();
        for i in 0..layers {
            for part in ["weight", "bias"] {
                let qkv = ["q", "k", "v"]
                    .map(|p| format!("{from}{i}.self_attn.{p}_proj.{part}"))
                    .iter()
                    .map(|n| weights.get_any(n))
                    .collect::<ModelsResult<Vec<_>>>()?;
                out.insert(format!("{to}{i}.attn.in_proj_{part}"), Tensor::cat(&qkv, 0)?);
            }
        }
    }
    Ok(Weights::from_tensors(out, weights.path(), weights.kind()))
}

impl ClipHints {
    /// Reads transformers' `config.json` of a `CLIPModel` (`text_config` / `vision_config`:
    /// `hidden_act`, `num_attention_heads`, `layer_norm_eps`, with transformers' defaults: QuickGELU,
    /// 8 text heads, 12 image heads, 1e-5). Both towers must share the activation and the epsilon
    /// 1e-5 (every released CLIP does); otherwise an error naming `path`.
    pub fn from_hf_config(config: &serde_json::Value, path: &std::path::Path) -> ModelsResult<Self> {
        let error = |reason: String| ModelsError::Config { reason, path: path.to_path_buf() };
        let tower = |key: &str| config.get(key).cloned().unwrap_or(serde_json::Value::Null);
        let (text, vision) = (tower("text_config"), tower("vision_config"));
        let act = |t: &serde_json::Value| {
            t.get("hidden_act").and_then(|a| a.as_str()).unwrap_or("quick_gelu").to_string()
        };
        let activation = match (act(&text).as_str(), act(&vision).as_str()) {
            ("quick_gelu", "quick_gelu") => Activation::QuickGelu,
            ("gelu", "gelu") => Activation::Gelu,
            (t, v) => {
                return Err(error(format!(
                "hidden_act `{t}` (text) and `{v}` (vision): both `quick_gelu` or both `gelu` are supported"
            )))
            }
        };
        for (name, t) in [("text_config", &text), ("vision_config", &vision)] {
            let eps = t.get("layer_norm_eps").and_then(|e| e.as_f64()).unwrap_or(1e-5);
            if (eps - 1e-5).abs() > 1e-12 {
                return Err(error(format!(
                    "{name}.layer_norm_eps is {eps}; only 1e-5 (every released CLIP's) is supported"
                )));
            }
        }
        let heads = |t: &serde_json::Value, default: usize| {
            t.get("num_attention_heads").and_then(|h| h.as_u64()).map_or(default, |h| h as usize)
        };
        Ok(Self {
            activation: Some(activation),
            vision_heads: Some(heads(&vision, 12)),
            text_heads: Some(heads(&text, 8)),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_map_onto_openai_layout() {
        assert_eq!(
            plain_name("vision_model.encoder.layers.11.layer_norm2.bias").as_deref(),
            Some("visual.transformer.resblocks.11.ln_2.bias")
        );
        assert_eq!(
            plain_name("text_model.encoder.layers.0.mlp.fc1.weight").as_deref(),
            Some("transformer.resblocks.0.mlp.c_fc.weight")
        );
        assert_eq!(plain_name("text_model.encoder.layers.0.self_attn.q_proj.weight"), None);
        assert_eq!(plain_name("text_model.embeddings.position_ids"), None);
    }

    #[test]
    fn hf_configs_give_the_hints_or_a_clear_error() {
        let path = std::path::Path::new("config.json");
        let config = serde_json::json!({"text_config": {"num_attention_heads": 4}, "vision_config": {"num_attention_heads": 3}});
        let hints = ClipHints::from_hf_config(&config, path).unwrap();
        assert_eq!(
            hints,
            ClipHints { activation: Some(Activation::QuickGelu), vision_heads: Some(3), text_heads: Some(4) }
        );
        let mixed = serde_json::json!({"text_config": {"hidden_act": "gelu"}, "vision_config": {}});
        let err = ClipHints::from_hf_config(&mixed, path).unwrap_err().to_string();
        assert!(err.contains("hidden_act") && err.contains("config.json"), "{err}");
        let eps = serde_json::json!({"text_config": {"layer_norm_eps": 1e-6}});
        assert!(ClipHints::from_hf_config(&eps, path).unwrap_err().to_string().contains("layer_norm_eps"));
    }
}
