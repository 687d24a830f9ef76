//! DINOv2 weight names: Hugging Face `transformers` layouts (as saved on the hub, and the in-memory
//! `q_proj`/`o_proj` names of newer versions) mapped onto the facebookresearch layout, which the model
//! uses (`blocks.N.attn.qkv` fused).

use candle_core::Tensor;

use crate::error::ModelsResult;
use crate::weights::Weights;

/// Where a checkpoint came from: decides the positional-embedding resize rule by default.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Layout {
    /// facebookresearch/dinov2 (`cls_token`, `pos_embed`, `blocks.N.attn.qkv`).
    Original,
    /// Hugging Face transformers (`embeddings.cls_token`, `encoder.layer.N.attention...`).
    HuggingFace,
}

/// Finds the DINOv2 tensors in `weights` (possibly under a prefix such as `backbone.` or
/// `pretrained.`) and returns them under facebookresearch names, with the layout found.
pub fn canonical(weights: &Weights) -> ModelsResult<(Weights, Layout)> {
    let names = weights.names();
    let hf_prefix =
        names.iter().filter_map(|n| n.strip_suffix("embeddings.cls_token")).min_by_key(|p| p.len());
    if let Some(prefix) = hf_prefix {
        let sub = weights.sub(prefix);
        return Ok((from_hf(sub)?, Layout::HuggingFace));
    }
    let original_prefix = names.iter().filter_map(|n| n.strip_suffix("cls_token")).min_by_key(|p| p.len());
    match original_prefix {
        Some(prefix) => Ok((weights.sub(prefix), Layout::Original)),
        None => Err(weights.missing("cls_token (or embeddings.cls_token)", &[1, 1, 0])),
    }
}

fn hf_rename(name: &str) -> Option<String> {
    let simple = [
        ("embeddings.cls_token", "cls_token"),
        ("embeddings.mask_token", "mask_token"),
        ("embeddings.register_tokens", "register_tokens"),
        ("embeddings.position_embeddings", "pos_embed"),
        ("embeddings.patch_embeddings.projection.weight", "patch_embed.proj.weight"),
        ("embeddings.patch_embeddings.projection.bias", "patch_embed.proj.bias"),
        ("layernorm.weight", "norm.weight"),
        ("layernorm.bias", "norm.bias"),
    ];
    if let Some((_, to)) = simple.iter().find(|(from, _)| *from == name) {
        return Some((*to).to_string());
    }
    let rest = name.strip_prefix("encoder.layer.")?;
    let (index, field) = rest.split_once('.')?;
    let mapped = match field {
        "attention.output.dense.weight" | "attention.o_proj.weight" => "attn.proj.weight".to_string(),
        "attention.output.dense.bias" | "attention.o_proj.bias" => "attn.proj.bias".to_string(),
        "layer_scale1.lambda1" => "ls1.gamma".to_string(),
        "layer_scale2.lambda1" => "ls2.gamma".to_string(),
        f if f.starts_with("norm1.") || f.starts_with("norm2.") || f.starts_with("mlp.") => f.to_string(),
        // query/key/value are fused below; keep them under a temporary name
        f => format!("hf_qkv.{f}"),
    };
    Some(format!("blocks.{index}.{mapped}"))
}

fn from_hf(weights: Weights) -> ModelsResult<Weights> {
    let mut renamed = weights.renamed(hf_rename);
    let mut layer = 0;
    loop {
        let prefix = format!("blocks.{layer}.");
        if !renamed.contains(&format!("{prefix}norm1.weight")) {
            break;
        }
        for suffix in ["weight", "bias"] {
            let mut parts = Vec::with_capacity(3);
            for (old, new) in [("query", "q_proj"), ("key", "k_proj"), ("value", "v_proj")] {
                let legacy = format!("{prefix}hf_qkv.attention.attention.{old}.{suffix}");
                let modern = format!("{prefix}hf_qkv.attention.{new}.{suffix}");
                let part = renamed.take(&legacy).or_else(|| renamed.take(&modern));
                let part = part.ok_or_else(|| {
                    renamed.missing(&format!("encoder.layer.{layer}.attention.attention.{old}.{suffix}"), &[])
                })?;
                parts.push(part);
            }
            let fused = Tensor::cat(&parts, 0)?;
            renamed.insert(format!("{prefix}attn.qkv.{suffix}"), fused);
        }
        layer += 1;
    }
    Ok(renamed)
}
