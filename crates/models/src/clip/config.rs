//! CLIP hyper-parameters: the shapes from the checkpoint's tensors, the rest (heads, activation) from
//! `open_clip_config.json` or the caller.

use serde::{Deserialize, Serialize};

use crate::error::{ModelsError, ModelsResult};
use crate::weights::Weights;

/// The MLP's activation: the one thing about a CLIP that its weights cannot tell.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Activation {
    /// `x · σ(1.702 x)`: OpenAI's CLIPs and OpenCLIP's `*-quickgelu` models.
    QuickGelu,
    /// The exact (erf) GELU: OpenCLIP's own models such as ViT-B-16 (LAION-2B).
    Gelu,
}

/// What the weights' shapes do not say, from `open_clip_config.json` or given by the caller.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ClipHints {
    /// The activation; required (from here or the config file).
    pub activation: Option<Activation>,
    /// Image-tower heads (default: width / 64, as every released CLIP).
    pub vision_heads: Option<usize>,
    /// Text-tower heads (default: width / 64, as every released CLIP).
    pub text_heads: Option<usize>,
}

impl ClipHints {
    /// Reads open_clip's hub config (`{"model_cfg": {"quick_gelu": .., "vision_cfg": {"width", "head_width"},
    /// "text_cfg": {"heads"}}}`); what it lacks stays `None` (the `quick_gelu` default of open_clip is
    /// `false`, so a `model_cfg` without it means GELU).
    pub fn from_open_clip_config(config: &serde_json::Value) -> Self {
        let model = config.get("model_cfg").unwrap_or(config);
        let activation = model.get("vision_cfg").map(|_| {
            match model.get("quick_gelu").and_then(|v| v.as_bool()).unwrap_or(false) {
                true => Activation::QuickGelu,
                false => Activation::Gelu,
            }
        });
        let number = |v: Option<&serde_json::Value>| v.and_then(|v| v.as_u64()).map(|v| v as usize);
        let vision = model.get("vision_cfg");
        let vision_heads = match (
            number(vision.and_then(|v| v.get("width"))),
            number(vision.and_then(|v| v.get("head_width"))),
        ) {
            (Some(width), Some(head)) if head > 0 => Some(width / head),
            (Some(width), None) => Some(width / 64),
            _ => None,
        };
        let text_heads = number(model.get("text_cfg").and_then(|t| t.get("heads")));
        Self { activation, vision_heads, text_heads }
    }

    /// `self`, with the fields it lacks taken from `other`.
    pub fn or(self, other: ClipHints) -> Self {
        Self {
            activation: self.activation.or(other.activation),
            vision_heads: self.vision_heads.or(other.vision_heads),
            text_heads: self.text_heads.or(other.text_heads),
        }
    }
}

/// The image tower's shapes (ViT-B/32: width 768, 12 layers, 12 heads, patch 32, 224 px).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VisionConfig {
    /// Token width.
    pub width: usize,
    /// Residual blocks.
    pub layers: usize,
    /// Attention heads.
    pub heads: usize,
    /// Patch side in pixels (32, 16 or 14 for the released models).
    pub patch_size: usize,
    /// Side of the square input the positional table is for (224, 336).
    pub image_size: usize,
    /// MLP hidden width (4 × width).
    pub mlp_hidden: usize,
}

/// The text tower's shapes (ViT-B: width 512, 12 layers, 8 heads, 77 tokens, 49,408 ids).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TextConfig {
    /// Token ids the embedding table holds.
    pub vocab_size: usize,
    /// Positions (77).
    pub context_length: usize,
    /// Token width.
    pub width: usize,
    /// Residual blocks.
    pub layers: usize,
    /// Attention heads.
    pub heads: usize,
    /// MLP hidden width (4 × width).
    pub mlp_hidden: usize,
}

/// A whole CLIP's configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClipConfig {
    /// The image tower, when the checkpoint has one.
    pub vision: Option<VisionConfig>,
    /// The text tower, when the checkpoint has one.
    pub text: Option<TextConfig>,
    /// Width of the joint embedding space (512 for ViT-B, 768 for ViT-L).
    pub embed_dim: usize,
    /// The MLP activation of both towers.
    pub activation: Activation,
    /// LayerNorm epsilon (PyTorch's default 1e-5 in both references).
    pub layer_norm_eps: f64,
}

impl ClipConfig {
    /// Infers the configuration from OpenAI-named `weights` (no prefix) and `hints`.
    pub fn infer(weights: &Weights, hints: ClipHints) -> ModelsResult<Self> {
        refuse_other_architectures(weights)?;
        let activation = hints.activation.ok_or_else(|| ModelsError::Config {
            reason: "the activation (QuickGELU for OpenAI's CLIPs and OpenCLIP's `-quickgelu` models, GELU for \
                     OpenCLIP's own) cannot be read from the weights: put the checkpoint's `open_clip_config.json` \
                     beside it or say which"
                .into(),
            path: weights.path().to_path_buf(),
        })?;
        let vision = if weights.contains("visual.class_embedding") {
            Some(vision_config(weights, hints.vision_heads)?)
        } else {
            None
        };
        let text = if weights.contains("token_embedding.weight") {
            Some(text_config(weights, hints.text_heads)?)
        } else {
            None
        };
        let embed_dim = match (&vision, &text) {
            (Some(_), _) => dim(weights, "visual.proj", 1)?,
            (None, Some(_)) => dim(weights, "text_projection", 1)?,
            (None, None) => {
                return Err(weights.missing("visual.class_embedding (or token_embedding.weight)", &[]))
            }
        };
        Ok(Self { vision, text, embed_dim, activation, layer_norm_eps: 1e-5 })
    }
}

fn refuse_other_architectures(weights: &Weights) -> ModelsResult<()> {
    let unsupported = [
        ("visual.layer1.", "a ResNet image tower (RN50, RN101, ...)"),
        ("visual.trunk.", "a timm image tower"),
        ("visual.attn_pool.", "an attentional pooler (CoCa)"),
        ("text.", "a Hugging Face or custom text tower"),
    ];
    let names = weights.names();
    for (prefix, what) in unsupported {
        if names.iter().any(|n| n.starts_with(prefix)) {
            return Err(ModelsError::Unreadable {
                kind: weights.kind(),
                reason: format!(
                    "it holds {what}, which is not supported: use a ViT CLIP (ViT-B/32, B/16, L/14)"
                ),
                path: weights.path().to_path_buf(),
            });
        }
    }
    Ok(())
}

/// Dimension `axis` of tensor `name`.
fn dim(weights: &Weights, name: &str, axis: usize) -> ModelsResult<usize> {
    let shape = weights.shape_of(name).ok_or_else(|| weights.missing(name, &[]))?;
    shape.get(axis).copied().ok_or_else(|| ModelsError::ShapeMismatch {
        kind: weights.kind(),
        name: name.to_string(),
        expected: vec![0; axis + 1],
        found: shape.clone(),
        path: weights.path().to_path_buf(),
    })
}

fn count_blocks(weights: &Weights, prefix: &str) -> usize {
    (0..).take_while(|i| weights.contains(&format!("{prefix}{i}.ln_1.weight"))).count()
}

fn heads_for(weights: &Weights, width: usize, given: Option<usize>, tower: &str) -> ModelsResult<usize> {
    let heads = given.unwrap_or(width / 64);
    if heads == 0 || !width.is_multiple_of(heads) {
        return Err(ModelsError::Config {
            reason: format!("the {tower} tower's width {width} cannot be split into {heads} attention heads"),
            path: weights.path().to_path_buf(),
        });
    }
    Ok(heads)
}

fn vision_config(weights: &Weights, heads: Option<usize>) -> ModelsResult<VisionConfig> {
    let width = dim(weights, "visual.class_embedding", 0)?;
    let patch_size = dim(weights, "visual.conv1.weight", 2)?;
    let positions = dim(weights, "visual.positional_embedding", 0)?.saturating_sub(1);
    let grid = (positions as f64).sqrt().round() as usize;
    if grid * grid != positions || grid == 0 || patch_size == 0 {
        return Err(ModelsError::ShapeMismatch {
            kind: weights.kind(),
            name: "visual.positional_embedding".into(),
            expected: vec![1 + 14 * 14, width],
            found: weights.shape_of("visual.positional_embedding").unwrap_or_default(),
            path: weights.path().to_path_buf(),
        });
    }
    let layers = count_blocks(weights, "visual.transformer.resblocks.");
    if layers == 0 {
        return Err(weights.missing("visual.transformer.resblocks.0.ln_1.weight", &[width]));
    }
    let mlp_hidden = dim(weights, "visual.transformer.resblocks.0.mlp.c_fc.weight", 0)?;
    let heads = heads_for(weights, width, heads, "image")?;
    Ok(VisionConfig { width, layers, heads, patch_size, image_size: grid * patch_size, mlp_hidden })
}

fn text_config(weights: &Weights, heads: Option<usize>) -> ModelsResult<TextConfig> {
    let vocab_size = dim(weights, "token_embedding.weight", 0)?;
    let width = dim(weights, "token_embedding.weight", 1)?;
    let context_length = dim(weights, "positional_embedding", 0)?;
    let layers = count_blocks(weights, "transformer.resblocks.");
    if layers == 0 {
        return Err(weights.missing("transformer.resblocks.0.ln_1.weight", &[width]));
    }
    let mlp_hidden = dim(weights, "transformer.resblocks.0.mlp.c_fc.weight", 0)?;
    let heads = heads_for(weights, width, heads, "text")?;
    Ok(TextConfig { vocab_size, context_length, width, layers, heads, mlp_hidden })
}
