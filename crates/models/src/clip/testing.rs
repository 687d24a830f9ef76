//! Small random-weight CLIP checkpoints for tests and benchmarks, written as open_clip's hub folders
//! hold them: `open_clip_model.safetensors` (OpenAI-named state dict) beside `open_clip_config.json`.
//!
//! The values come from a counter-based generator (SplitMix64) seeded by the caller, so the same seed
//! writes the same bytes on every machine. Not a trained model: embeddings are arbitrary but fixed.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use candle_core::{Device, Tensor};

use crate::error::{ModelsError, ModelsResult};

/// The shapes of a random CLIP (one head width for both towers).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RandomClipSpec {
    /// Joint embedding width.
    pub embed_dim: usize,
    /// Image side the image tower sees.
    pub image_size: usize,
    /// Patch side.
    pub patch_size: usize,
    /// Image-tower width.
    pub vision_width: usize,
    /// Image-tower blocks.
    pub vision_layers: usize,
    /// Text-tower width.
    pub text_width: usize,
    /// Text-tower blocks.
    pub text_layers: usize,
    /// Width of one attention head (both towers).
    pub head_width: usize,
    /// Token ids (must match the merges file the tokenizer reads).
    pub vocab_size: usize,
    /// Token positions.
    pub context_length: usize,
}

impl RandomClipSpec {
    /// A tiny CLIP (width 32, 2 blocks, 32² images in 8² patches, embeddings of 16) for `vocab_size` ids.
    pub fn tiny(vocab_size: usize) -> Self {
        Self {
            embed_dim: 16,
            image_size: 32,
            patch_size: 8,
            vision_width: 32,
            vision_layers: 2,
            text_width: 32,
            text_layers: 2,
            head_width: 8,
            vocab_size,
            context_length: 77,
        }
    }

    /// ViT-B/16's shapes (image width 768, 12 blocks, 224² in 16² patches; text width 512, 12 blocks;
    /// embeddings of 512) for `vocab_size` ids (49,408 in the released models).
    pub fn vit_b16(vocab_size: usize) -> Self {
        Self {
            embed_dim: 512,
            image_size: 224,
            patch_size: 16,
            vision_width: 768,
            vision_layers: 12,
            text_width: 512,
            text_layers: 12,
            head_width: 64,
            vocab_size,
            context_length: 77,
        }
    }
}

/// SplitMix64: uniform values in ±`scale`, one counter per draw.
struct Draws(u64);

impl Draws {
    fn next(&mut self, scale: f32) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        let unit = (z >> 40) as f32 / (1u64 << 24) as f32; // [0, 1)
        (2.0 * unit - 1.0) * scale
    }

    fn tensor(&mut self, shape: &[usize], scale: f32) -> ModelsResult<Tensor> {
        let n: usize = shape.iter().product();
        let values: Vec<f32> = (0..n).map(|_| self.next(scale)).collect();
        Ok(Tensor::from_vec(values, shape, &Device::Cpu)?)
    }
}

fn add_blocks(
    tensors: &mut HashMap<String, Tensor>,
    draws: &mut Draws,
    prefix: &str,
    (width, layers): (usize, usize),
) -> ModelsResult<()> {
    let s = 1.0 / (width as f32).sqrt();
    for i in 0..layers {
        let shapes: [(&str, Vec<usize>, f32); 12] = [
            ("ln_1.weight", vec![width], 1.0),
            ("ln_1.bias", vec![width], 0.1),
            ("attn.in_proj_weight", vec![3 * width, width], s),
            ("attn.in_proj_bias", vec![3 * width], 0.1),
            ("attn.out_proj.weight", vec![width, width], s),
            ("attn.out_proj.bias", vec![width], 0.1),
            ("ln_2.weight", vec![width], 1.0),
            ("ln_2.bias", vec![width], 0.1),
            ("mlp.c_fc.weight", vec![4 * width, width], s),
            ("mlp.c_fc.bias", vec![4 * width], 0.1),
            ("mlp.c_proj.weight", vec![width, 4 * width], s / 2.0),
            ("mlp.c_proj.bias", vec![width], 0.1),
        ];
        for (name, shape, scale) in shapes {
            tensors.insert(format!("{prefix}{i}.{name}"), draws.tensor(&shape, scale)?);
        }
    }
    Ok(())
}

/// An OpenAI-named state dict of `spec`'s shapes, values seeded by `seed`.
pub fn random_state_dict(spec: RandomClipSpec, seed: u64) -> ModelsResult<HashMap<String, Tensor>> {
    if spec.patch_size == 0 || !spec.image_size.is_multiple_of(spec.patch_size) {
        return Err(ModelsError::Input(format!(
            "a random CLIP needs the image side {} to be a multiple of the patch side {}",
            spec.image_size, spec.patch_size
        )));
    }
    let mut draws = Draws(seed);
    let (vw, tw, embed) = (spec.vision_width, spec.text_width, spec.embed_dim);
    let grid = spec.image_size / spec.patch_size;
    let mut t = HashMap::new();
    t.insert("visual.class_embedding".into(), draws.tensor(&[vw], 0.1)?);
    t.insert("visual.positional_embedding".into(), draws.tensor(&[grid * grid + 1, vw], 0.1)?);
    t.insert("visual.conv1.weight".into(), draws.tensor(&[vw, 3, spec.patch_size, spec.patch_size], 0.05)?);
    for (ln, width) in [("visual.ln_pre", vw), ("visual.ln_post", vw), ("ln_final", tw)] {
        t.insert(format!("{ln}.weight"), draws.tensor(&[width], 1.0)?);
        t.insert(format!("{ln}.bias"), draws.tensor(&[width], 0.1)?);
    }
    add_blocks(&mut t, &mut draws, "visual.transformer.resblocks.", (vw, spec.vision_layers))?;
    t.insert("visual.proj".into(), draws.tensor(&[vw, embed], 0.05)?);
    t.insert("token_embedding.weight".into(), draws.tensor(&[spec.vocab_size, tw], 0.1)?);
    t.insert("positional_embedding".into(), draws.tensor(&[spec.context_length, tw], 0.1)?);
    add_blocks(&mut t, &mut draws, "transformer.resblocks.", (tw, spec.text_layers))?;
    t.insert("text_projection".into(), draws.tensor(&[tw, embed], 0.05)?);
    t.insert("logit_scale".into(), Tensor::new(&[4.6052f32], &Device::Cpu)?.reshape(())?);
    Ok(t)
}

/// Writes a random CLIP of `spec` into folder `dir` (created): `open_clip_model.safetensors` and an
/// `open_clip_config.json` saying QuickGELU and the heads. Returns the weights file. The tokenizer's
/// merges (`bpe_simple_vocab_16e6.txt.gz`, with `spec.vocab_size` ids) are the caller's to put beside.
pub fn write_random_checkpoint(dir: &Path, spec: RandomClipSpec, seed: u64) -> ModelsResult<PathBuf> {
    write_checkpoint(dir, spec, &random_state_dict(spec, seed)?)
}

/// [`write_random_checkpoint`] with every value of the tensor `poisoned` NaN: a damaged checkpoint,
/// for the tests of the error that names it.
pub fn write_random_checkpoint_with_nan(
    dir: &Path,
    spec: RandomClipSpec,
    seed: u64,
    poisoned: &str,
) -> ModelsResult<PathBuf> {
    let mut tensors = random_state_dict(spec, seed)?;
    let tensor = tensors
        .get(poisoned)
        .ok_or_else(|| ModelsError::Input(format!("a random CLIP has no tensor `{poisoned}`")))?;
    let nan = Tensor::full(f32::NAN, tensor.dims(), &Device::Cpu)?;
    tensors.insert(poisoned.to_string(), nan);
    write_checkpoint(dir, spec, &tensors)
}

/// Writes `tensors` (of `spec`'s shapes) and open_clip's config for `spec` into `dir`.
fn write_checkpoint(
    dir: &Path,
    spec: RandomClipSpec,
    tensors: &HashMap<String, Tensor>,
) -> ModelsResult<PathBuf> {
    let io = |e: std::io::Error, path: &Path| ModelsError::Input(format!("{e}: {}", path.display()));
    std::fs::create_dir_all(dir).map_err(|e| io(e, dir))?;
    let weights = dir.join(super::CLIP_WEIGHT_NAMES[0]);
    candle_core::safetensors::save(tensors, &weights)?;
    let config = serde_json::json!({
        "model_cfg": {
            "embed_dim": spec.embed_dim,
            "quick_gelu": true,
            "vision_cfg": {
                "image_size": spec.image_size,
                "patch_size": spec.patch_size,
                "width": spec.vision_width,
                "layers": spec.vision_layers,
                "head_width": spec.head_width,
            },
            "text_cfg": {
                "context_length": spec.context_length,
                "vocab_size": spec.vocab_size,
                "width": spec.text_width,
                "heads": spec.text_width / spec.head_width.max(1),
                "layers": spec.text_layers,
            },
        },
    });
    let path = dir.join(super::OPEN_CLIP_CONFIG);
    let text = serde_json::to_string_pretty(&config).map_err(|e| ModelsError::Input(e.to_string()))?;
    std::fs::write(&path, text).map_err(|e| io(e, &path))?;
    Ok(weights)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clip::{Clip, ClipHints};

    #[test]
    fn a_written_checkpoint_loads_with_its_shapes_and_is_reproducible() {
        let dir = std::env::temp_dir().join(format!("splatseg_random_clip_{}", std::process::id()));
        let weights = write_random_checkpoint(&dir, RandomClipSpec::tiny(651), 7).unwrap();
        let model = Clip::load(&dir, ClipHints::default()).unwrap();
        let vision = model.config().vision.clone().unwrap();
        assert_eq!((vision.width, vision.heads, vision.image_size, vision.patch_size), (32, 4, 32, 8));
        assert_eq!(model.config().embed_dim, 16);
        let first = std::fs::read(&weights).unwrap();
        write_random_checkpoint(&dir, RandomClipSpec::tiny(651), 7).unwrap();
        assert_eq!(first, std::fs::read(&weights).unwrap(), "same seed, same bytes");
        write_random_checkpoint(&dir, RandomClipSpec::tiny(651), 8).unwrap();
        assert_ne!(first, std::fs::read(&weights).unwrap(), "another seed, other values");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_nan_tensor_is_refused_naming_it_and_the_file() {
        let dir = std::env::temp_dir().join(format!("splatseg_nan_clip_{}", std::process::id()));
        let weights =
            write_random_checkpoint_with_nan(&dir, RandomClipSpec::tiny(651), 7, "ln_final.weight").unwrap();
        for err in [
            Clip::load(&dir, ClipHints::default()).unwrap_err().to_string(),
            Clip::load_text_only(&dir, ClipHints::default()).unwrap_err().to_string(),
        ] {
            assert!(err.contains("`ln_final.weight` holds 32 NaN or ±Inf values (of 32)"), "{err}");
            assert!(err.contains(&weights.display().to_string()), "{err}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[cfg(unix)]
    #[test]
    fn special_files_are_refused_as_such() {
        let dir = std::env::temp_dir().join(format!("splatseg_special_clip_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let weights = dir.join(crate::clip::CLIP_WEIGHT_NAMES[3]);
        std::os::unix::fs::symlink("/dev/zero", &weights).unwrap();
        for err in [
            Clip::load(&dir, ClipHints::default()).unwrap_err().to_string(),
            Clip::load(&weights, ClipHints::default()).unwrap_err().to_string(),
        ] {
            assert!(err.contains("not a regular file") && err.contains("model.safetensors"), "{err}");
            assert!(!err.contains("holds none of"), "{err}");
        }
        let merges = dir.join(crate::clip::MERGES_FILE);
        std::os::unix::fs::symlink("/dev/zero", &merges).unwrap();
        assert_eq!(crate::clip::tokenizer_beside(&weights), Some(merges.clone()));
        let err = crate::clip::ClipTokenizer::load(&merges).unwrap_err().to_string();
        assert!(err.contains("not a regular file") && err.contains(crate::clip::MERGES_FILE), "{err}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
