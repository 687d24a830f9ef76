//! DINOv2 hyper-parameters, inferred from a checkpoint's tensor shapes (and `config.json` when there is one).

use serde::{Deserialize, Serialize};

use super::names::Layout;
use crate::error::{ModelsError, ModelsResult};
use crate::weights::Weights;

/// How the learnt `M × M` positional-embedding grid is resized to the image's patch grid.
///
/// Both references use PyTorch's bicubic `interpolate` (align_corners = False); they differ in how the
/// output grid maps onto the input grid and in antialiasing:
/// - Hugging Face `Dinov2Model`: `size = (h, w)`, no antialias; with registers: antialias.
/// - facebookresearch/dinov2 (and Depth Anything V2's copy): `scale_factor = ((h + 0.1) / M, (w + 0.1) / M)`,
///   no antialias; the register models use `size` with antialias.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum PosEmbedResize {
    /// PyTorch `size = (h, w)`.
    Size {
        /// Antialiased bicubic (PIL-style, a = −0.5).
        antialias: bool,
    },
    /// PyTorch `scale_factor = ((h + offset) / M, (w + offset) / M)`; source positions use that factor.
    ScaleWithOffset {
        /// Added to the target grid size (0.1 in facebookresearch/dinov2).
        offset: f64,
        /// Antialiased bicubic.
        antialias: bool,
    },
}

impl PosEmbedResize {
    /// The reference's rule for a checkpoint `layout`, with or without register tokens.
    pub fn reference(layout: Layout, has_registers: bool) -> Self {
        match (layout, has_registers) {
            (Layout::HuggingFace, registers) => PosEmbedResize::Size { antialias: registers },
            (Layout::Original, true) => PosEmbedResize::Size { antialias: true },
            (Layout::Original, false) => PosEmbedResize::ScaleWithOffset { offset: 0.1, antialias: false },
        }
    }
}

/// Shapes and constants of a DINOv2 ViT.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Dinov2Config {
    /// Token width C (384 S, 768 B, 1024 L, 1536 g).
    pub hidden_size: usize,
    /// Transformer blocks (12 S/B, 24 L, 40 g).
    pub num_layers: usize,
    /// Attention heads (C / 64 for the released models).
    pub num_heads: usize,
    /// Patch side in pixels (14).
    pub patch_size: usize,
    /// Side M of the learnt positional-embedding grid (37 for 518-px training).
    pub pos_grid: usize,
    /// Register tokens (0 or 4).
    pub num_registers: usize,
    /// MLP hidden width (4 C).
    pub mlp_hidden: usize,
    /// LayerNorm epsilon (1e-6 in both references).
    pub layer_norm_eps: f64,
    /// Positional-embedding resize rule.
    pub pos_embed_resize: PosEmbedResize,
    /// Where the weights came from.
    pub layout: Layout,
}

impl Dinov2Config {
    /// Infers the configuration from canonical (facebookresearch-named) `weights` and the optional
    /// Hugging Face `config.json` (`num_attention_heads`, `layer_norm_eps`).
    pub fn infer(
        weights: &Weights,
        layout: Layout,
        hf_config: Option<&serde_json::Value>,
    ) -> ModelsResult<Self> {
        let cls = weights.get_any("cls_token")?;
        let hidden_size = *cls.dims().last().unwrap_or(&0);
        let patch = weights.get_any("patch_embed.proj.weight")?;
        let patch_size = patch.dims().get(2).copied().unwrap_or(0);
        let pos = weights.get_any("pos_embed")?;
        let positions = pos.dims().get(1).copied().unwrap_or(1).saturating_sub(1);
        let pos_grid = (positions as f64).sqrt().round() as usize;
        if pos_grid * pos_grid != positions || hidden_size == 0 || patch_size == 0 {
            return Err(ModelsError::ShapeMismatch {
                kind: weights.kind(),
                name: "pos_embed".into(),
                expected: vec![1, 1 + 37 * 37, hidden_size],
                found: pos.dims().to_vec(),
                path: weights.path().to_path_buf(),
            });
        }
        let num_layers = (0..).take_while(|i| weights.contains(&format!("blocks.{i}.norm1.weight"))).count();
        if num_layers == 0 {
            return Err(weights.missing("blocks.0.norm1.weight", &[hidden_size]));
        }
        if weights.contains("blocks.0.mlp.w12.weight") {
            return Err(ModelsError::Unreadable {
                kind: weights.kind(),
                reason: "SwiGLU feed-forward (ViT-g) is not supported; use ViT-S/B/L".into(),
                path: weights.path().to_path_buf(),
            });
        }
        let mlp_hidden = weights.get_any("blocks.0.mlp.fc1.weight")?.dims()[0];
        let num_registers =
            weights.shape_of("register_tokens").map(|s| s.get(1).copied().unwrap_or(0)).unwrap_or(0);
        let from_json = |key: &str| hf_config.and_then(|c| c.get(key));
        let num_heads = from_json("num_attention_heads")
            .and_then(|v| v.as_u64())
            .map(|v| v as usize)
            .unwrap_or((hidden_size / 64).max(1));
        if num_heads == 0 || hidden_size % num_heads != 0 {
            return Err(ModelsError::Input(format!(
                "{hidden_size} channels cannot be split into {num_heads} heads"
            )));
        }
        let layer_norm_eps = from_json("layer_norm_eps").and_then(|v| v.as_f64()).unwrap_or(1e-6);
        Ok(Self {
            hidden_size,
            num_layers,
            num_heads,
            patch_size,
            pos_grid,
            num_registers,
            mlp_hidden,
            layer_norm_eps,
            pos_embed_resize: PosEmbedResize::reference(layout, num_registers > 0),
            layout,
        })
    }
}
