//! CLIP (Radford et al. 2021, "Learning Transferable Visual Models From Natural Language Supervision"):
//! the ViT image tower and the text tower, read from OpenAI-layout state dicts (OpenAI's CLIPs as
//! open_clip stores them, and OpenCLIP's own ViTs), with the BPE tokenizer and the LERF relevancy
//! ranking of object embeddings against a text query.
//!
//! ViT-B/32, B/16 and L/14 are configurations of one implementation: width, depth, patch size and image
//! size come from the tensors' shapes, the heads from `open_clip_config.json` (or width / 64), the
//! activation (QuickGELU or GELU) from that file or the caller ([`ClipHints`]).

mod block;
pub mod clean;
pub mod config;
pub mod hf_names;
mod image_tower;
mod pretokens;
pub mod relevancy;
pub mod testing;
mod text_tower;
pub mod tokenizer;

use std::path::{Path, PathBuf};

pub use block::{l2_normalise_rows, quick_gelu};
pub use config::{Activation, ClipConfig, ClipHints, TextConfig, VisionConfig};
pub use image_tower::{ClipImageTower, CLIP_MEAN, CLIP_STD};
pub use text_tower::ClipTextTower;
pub use tokenizer::{ClipTokenizer, CONTEXT_LENGTH, HF_SPECIALS};

use crate::checkpoint;
use crate::error::{ModelKind, ModelsError, ModelsResult};
use crate::weights::Weights;

/// Weight files a CLIP folder or Hugging Face snapshot may hold, in order of preference: open_clip's
/// hub names (OpenAI's layout), then transformers' `CLIPModel` files ([`hf_names`]).
pub const CLIP_WEIGHT_NAMES: [&str; 5] = [
    "open_clip_model.safetensors",
    "open_clip_pytorch_model.bin",
    "open_clip_model.pth",
    "model.safetensors",
    "pytorch_model.bin",
];
/// The config open_clip's hub repositories hold beside the weights.
pub const OPEN_CLIP_CONFIG: &str = "open_clip_config.json";
/// The merges file OpenAI's CLIP and open_clip ship.
pub const MERGES_FILE: &str = "bpe_simple_vocab_16e6.txt.gz";
/// The tokenizer file of Hugging Face's CLIP repositories (OpenAI's and open_clip's on the hub).
pub const HF_TOKENIZER_FILE: &str = "tokenizer.json";
/// The tokenizer files looked for beside a checkpoint, in order of preference.
pub const TOKENIZER_FILES: [&str; 2] = [MERGES_FILE, HF_TOKENIZER_FILE];

/// A loaded CLIP: whichever towers the checkpoint has.
#[derive(Debug, Clone)]
pub struct Clip {
    config: ClipConfig,
    image: Option<ClipImageTower>,
    text: Option<ClipTextTower>,
}

impl Clip {
    /// Loads a checkpoint: a `.safetensors` / `.bin` / `.pt` state dict, a folder or Hugging Face
    /// snapshot holding one of [`CLIP_WEIGHT_NAMES`], or an `org/name` in the local Hugging Face cache.
    /// `hints` complete (and take precedence over) the `open_clip_config.json` beside the weights, or
    /// for transformers' `CLIPModel` names its `config.json`.
    pub fn load(path: &Path, hints: ClipHints) -> ModelsResult<Self> {
        let (weights, hints) = read_checkpoint(path, hints)?;
        Self::from_weights(&weights, hints)
    }

    /// Loads only the text tower of a checkpoint (as [`Clip::load`], the `visual.*` tensors dropped
    /// before anything is built): what a text query needs, without ViT-B/16's 86 M image parameters.
    pub fn load_text_only(path: &Path, hints: ClipHints) -> ModelsResult<Self> {
        let (weights, hints) = read_checkpoint(path, hints)?;
        let weights = openai_named(&weights)?.renamed(|n| (!n.starts_with("visual.")).then(|| n.to_string()));
        Self::from_weights(&weights, hints)
    }

    /// Builds the model from already-read tensors: OpenAI names, possibly under a prefix such as
    /// `module.`, or transformers' `CLIPModel` names.
    pub fn from_weights(weights: &Weights, hints: ClipHints) -> ModelsResult<Self> {
        let weights = openai_named(weights)?;
        let config = ClipConfig::infer(&weights, hints)?;
        let image = match config.vision {
            Some(_) => Some(ClipImageTower::new(&weights, &config)?),
            None => None,
        };
        let text = match config.text {
            Some(_) => Some(ClipTextTower::new(&weights, &config)?),
            None => None,
        };
        Ok(Self { config, image, text })
    }

    /// The configuration.
    pub fn config(&self) -> &ClipConfig {
        &self.config
    }

    /// The image tower, or an error naming the file's lack of one.
    pub fn image_tower(&self) -> ModelsResult<&ClipImageTower> {
        self.image.as_ref().ok_or_else(|| ModelsError::Input("the CLIP checkpoint has no image tower".into()))
    }

    /// The text tower, or an error naming the file's lack of one.
    pub fn text_tower(&self) -> ModelsResult<&ClipTextTower> {
        self.text.as_ref().ok_or_else(|| ModelsError::Input("the CLIP checkpoint has no text tower".into()))
    }

    /// L2-normalised embeddings `[B, E]` of `texts`, tokenized with `tokenizer` to the tower's context.
    pub fn embed_texts(
        &self,
        tokenizer: &ClipTokenizer,
        texts: &[&str],
    ) -> ModelsResult<candle_core::Tensor> {
        let tower = self.text_tower()?;
        let context = tower.config().context_length;
        let rows = texts.iter().map(|t| tokenizer.tokenize(t, context)).collect::<ModelsResult<Vec<_>>>()?;
        l2_normalise_rows(&tower.embed(&rows)?)
    }
}

impl Clip {
    /// Image embeddings (not normalised) of `batch` images given as plain values `[B, 3, S, S]`
    /// (normalised with [`CLIP_MEAN`] / [`CLIP_STD`], `S` the tower's image size): `[B, E]` row-major.
    pub fn embed_images_flat(&self, pixels: Vec<f32>, batch: usize) -> ModelsResult<Vec<f32>> {
        let tower = self.image_tower()?;
        let side = tower.config().image_size;
        if pixels.len() != batch * 3 * side * side {
            return Err(ModelsError::Input(format!(
                "{} values are not {batch} images of 3 × {side} × {side}",
                pixels.len()
            )));
        }
        let pixels =
            candle_core::Tensor::from_vec(pixels, (batch, 3, side, side), &candle_core::Device::Cpu)?;
        Ok(tower.embed(&pixels)?.flatten_all()?.to_vec1::<f32>()?)
    }

    /// [`Clip::embed_texts`] as plain values: `[B, E]` row-major, rows L2-normalised.
    pub fn embed_texts_flat(&self, tokenizer: &ClipTokenizer, texts: &[&str]) -> ModelsResult<Vec<f32>> {
        Ok(self.embed_texts(tokenizer, texts)?.flatten_all()?.to_vec1::<f32>()?)
    }

    /// [`Clip::embed_texts_flat`] for queries: an empty query or one longer than the tower's context is
    /// an error ([`ClipTokenizer::tokenize_query`]) instead of being embedded or cut.
    pub fn embed_queries_flat(&self, tokenizer: &ClipTokenizer, queries: &[&str]) -> ModelsResult<Vec<f32>> {
        let tower = self.text_tower()?;
        let context = tower.config().context_length;
        let rows =
            queries.iter().map(|q| tokenizer.tokenize_query(q, context)).collect::<ModelsResult<Vec<_>>>()?;
        Ok(l2_normalise_rows(&tower.embed(&rows)?)?.flatten_all()?.to_vec1::<f32>()?)
    }
}

/// The tokenizer file beside a checkpoint (or in its folder), when there is one: the merges file
/// ([`MERGES_FILE`]), else a Hugging Face [`HF_TOKENIZER_FILE`] ([`ClipTokenizer::load`] reads both,
/// and refuses what is not a regular file, so a FIFO in its place is named as such, not missed).
pub fn tokenizer_beside(checkpoint: &Path) -> Option<PathBuf> {
    let dir = if checkpoint.is_dir() { checkpoint } else { checkpoint.parent()? };
    TOKENIZER_FILES
        .iter()
        .map(|name| dir.join(name))
        .find(|p| std::fs::metadata(p).is_ok_and(|m| !m.is_dir()))
}

/// The checkpoint's tensors (refused when one holds a NaN or ±Inf, naming it) and `hints` completed by the `open_clip_config.json` beside it (or, for
/// transformers' names, its `config.json`).
fn read_checkpoint(path: &Path, hints: ClipHints) -> ModelsResult<(Weights, ClipHints)> {
    let files = checkpoint::resolve_named(path, ModelKind::Clip, &CLIP_WEIGHT_NAMES)?;
    let weights = Weights::load(&files.weights, ModelKind::Clip)?;
    weights.check_finite()?;
    let from_file = if hf_names::is_hf_layout(&weights) {
        match &files.config {
            Some(config) => ClipHints::from_hf_config(&read_json(config)?, config)?,
            None => ClipHints::default(),
        }
    } else {
        let beside = files.weights.parent().map(|dir| dir.join(OPEN_CLIP_CONFIG)).filter(|p| p.is_file());
        match beside {
            Some(config) => ClipHints::from_open_clip_config(&read_json(&config)?),
            None => ClipHints::default(),
        }
    };
    Ok((weights, hints.or(from_file)))
}

/// The tensors under OpenAI's names: transformers' renamed ([`hf_names`]), a prefix removed.
fn openai_named(weights: &Weights) -> ModelsResult<Weights> {
    match hf_names::is_hf_layout(weights) {
        true => without_prefix(&hf_names::to_openai_names(weights)?),
        false => without_prefix(weights),
    }
}

fn read_json(path: &Path) -> ModelsResult<serde_json::Value> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| ModelsError::Config { reason: e.to_string(), path: path.to_path_buf() })?;
    serde_json::from_str(&text)
        .map_err(|e| ModelsError::Config { reason: e.to_string(), path: path.to_path_buf() })
}

/// The tensors with the prefix before `visual.class_embedding` / `token_embedding.weight` removed.
fn without_prefix(weights: &Weights) -> ModelsResult<Weights> {
    let names = weights.names();
    let prefix = names
        .iter()
        .filter_map(|n| {
            n.strip_suffix("visual.class_embedding").or_else(|| n.strip_suffix("token_embedding.weight"))
        })
        .min_by_key(|p| p.len());
    match prefix {
        Some("") => Ok(weights.clone()),
        Some(prefix) => Ok(weights.sub(prefix)),
        None => Err(weights.missing("visual.class_embedding (or token_embedding.weight)", &[])),
    }
}
