//! The crate's one error type.

use std::path::PathBuf;

/// Which model a checkpoint is for: decides the messages users see when a file is wrong.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelKind {
    /// DINOv2 backbone (ViT-S/B/L/g 14, with or without registers).
    Dinov2,
    /// Depth Anything V2 (DINOv2 backbone + DPT head).
    DepthAnythingV2,
    /// Segment Anything (image encoder, prompt encoder, mask decoder).
    Sam,
    /// CLIP (image and text towers), OpenAI's or OpenCLIP's.
    Clip,
}

impl ModelKind {
    /// Short human name.
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::Dinov2 => "DINOv2",
            ModelKind::DepthAnythingV2 => "Depth Anything V2",
            ModelKind::Sam => "Segment Anything",
            ModelKind::Clip => "CLIP",
        }
    }

    /// Which file is expected and where users get it.
    pub fn expected_file(self) -> &'static str {
        match self {
            ModelKind::Dinov2 => {
                "a DINOv2 backbone: `model.safetensors` (+ `config.json`) of the Hugging Face model \
                 `facebook/dinov2-small` / `-base` / `-large` (or `facebook/dinov2-with-registers-*`), \
                 or `dinov2_vits14_pretrain.pth` / `dinov2_vitb14_pretrain.pth` (`*_reg4_pretrain.pth`) \
                 from the facebookresearch/dinov2 release"
            }
            ModelKind::DepthAnythingV2 => {
                "a Depth Anything V2 relative-depth model: `depth_anything_v2_vits.pth` / `_vitb` / `_vitl` \
                 from the DepthAnything/Depth-Anything-V2 release, or `model.safetensors` (+ `config.json`) \
                 of the Hugging Face model `depth-anything/Depth-Anything-V2-Small-hf` (`-Base-hf`, `-Large-hf`)"
            }
            ModelKind::Sam => {
                "a Segment Anything checkpoint: `sam_vit_b_01ec64.pth`, `sam_vit_l_0b3195.pth` or \
                 `sam_vit_h_4b8939.pth` from the facebookresearch/segment-anything release, or MobileSAM's \
                 `mobile_sam.pt`"
            }
            ModelKind::Clip => {
                "a CLIP checkpoint as a state dict with OpenAI's names (`visual.conv1.weight`, \
                 `transformer.resblocks.N...`): OpenCLIP's `open_clip_model.safetensors` or \
                 `open_clip_pytorch_model.bin` (+ `open_clip_config.json`) from a Hugging Face repository such as \
                 `laion/CLIP-ViT-B-16-laion2B-s34B-b88K` or `timm/vit_base_patch16_clip_224.openai`"
            }
        }
    }
}

/// Everything that can go wrong in this crate.
#[derive(Debug, thiserror::Error)]
pub enum ModelsError {
    /// The checkpoint file could not be read at all.
    #[error("cannot read the {} checkpoint ({reason}); expected {}: {}", kind.name(), kind.expected_file(), path.display())]
    Unreadable {
        /// Model the file was meant for.
        kind: ModelKind,
        /// What went wrong.
        reason: String,
        /// The file.
        path: PathBuf,
    },
    /// A tensor the model needs is absent.
    #[error("the {} checkpoint has no tensor `{name}`{}; is it the right file? expected {}: {}", kind.name(), shape_note(expected), kind.expected_file(), path.display())]
    MissingTensor {
        /// Model the file was meant for.
        kind: ModelKind,
        /// Tensor name (in the file's own naming).
        name: String,
        /// Shape the model needs.
        expected: Vec<usize>,
        /// The file.
        path: PathBuf,
    },
    /// A tensor has the wrong shape.
    #[error("the {} checkpoint's tensor `{name}` has shape {found:?}, expected {expected:?}: {}", kind.name(), path.display())]
    ShapeMismatch {
        /// Model the file was meant for.
        kind: ModelKind,
        /// Tensor name.
        name: String,
        /// Shape the model needs.
        expected: Vec<usize>,
        /// Shape in the file.
        found: Vec<usize>,
        /// The file.
        path: PathBuf,
    },
    /// A tensor holds NaN or ±Inf values (a damaged or diverged checkpoint).
    #[error("the {} checkpoint's tensor `{name}` holds {count} NaN or ±Inf values (of {total}); the file is damaged or \
             not a trained model: {}", kind.name(), path.display())]
    NonFinite {
        /// Model the file was meant for.
        kind: ModelKind,
        /// Tensor name.
        name: String,
        /// Values that are not finite.
        count: usize,
        /// Values in the tensor.
        total: usize,
        /// The file.
        path: PathBuf,
    },
    /// A text query CLIP cannot embed as it is: empty, or longer than the text tower's context.
    #[error("{0}")]
    Query(String),
    /// A checkpoint path or cache lookup found nothing.
    #[error("no {} checkpoint found ({reason}); expected {}: {}", kind.name(), kind.expected_file(), path.display())]
    NotFound {
        /// Model looked for.
        kind: ModelKind,
        /// Where we looked.
        reason: String,
        /// The path given.
        path: PathBuf,
    },
    /// A `config.json` beside the weights is malformed.
    #[error("invalid model config ({reason}): {}", path.display())]
    Config {
        /// What is wrong.
        reason: String,
        /// The file.
        path: PathBuf,
    },
    /// A CLIP tokenizer file (merges or `tokenizer.json`) is unreadable or malformed.
    #[error("cannot read the CLIP tokenizer ({reason}); expected the `bpe_simple_vocab_16e6.txt.gz` or \
             `tokenizer.json` that comes with the checkpoint (OpenAI's CLIP, open_clip, transformers): {}", path.display())]
    Tokenizer {
        /// What is wrong.
        reason: String,
        /// The file.
        path: PathBuf,
    },
    /// The caller's input does not fit the model (size, channel count, ...).
    #[error("invalid model input: {0}")]
    Input(String),
    /// Tensor arithmetic failed (a bug or out of memory).
    #[error("tensor operation failed: {0}")]
    Candle(#[from] candle_core::Error),
}

fn shape_note(expected: &[usize]) -> String {
    if expected.is_empty() {
        String::new()
    } else {
        format!(" (expected shape {expected:?})")
    }
}

/// Result alias of this crate.
pub type ModelsResult<T> = Result<T, ModelsError>;
