//! Foundation models for splatseg's cues, written on candle-core / candle-nn (CPU):
//!
//! - [`dinov2`]: DINOv2 ViT-S/B/L 14 (with or without registers), patch features `[h/14, w/14, C]`
//!   for any size that is a multiple of 14, positional embeddings resized as the references do.
//! - [`depth_anything`]: Depth Anything V2 (DPT head), relative inverse depth at the input size,
//!   and the [0, 1] normalisation (0 = near) the merging stage uses.
//! - [`sam`]: Segment Anything ViT-B/L/H, MobileSAM (TinyViT image encoder, `mobile_sam.pt`) and the
//!   automatic mask generator, output as `splatseg_scene::sam::SamMask`.
//! - [`clip`]: CLIP ViT-B/32, B/16, L/14 image and text towers (OpenAI's and OpenCLIP's state dicts,
//!   QuickGELU or GELU), the BPE tokenizer, and LERF's relevancy ranking of object embeddings.
//! - [`checkpoint`] + [`weights`]: finding (`--model PATH`, Hugging Face snapshot folders, the local
//!   Hugging Face cache) and reading `.safetensors` / `.pth` checkpoints, original and Hugging Face
//!   names, with errors that say which file is expected and which tensor is missing or mis-shaped.
//! - [`resample`]: PyTorch-exact bicubic / bilinear (antialiased or not) resizing; [`conv`]: our own
//!   2D convolution (candle-core 0.9.2's tiled CPU kernel misreads NCHW input when `C_in == W`).
//!
//! Parity with `transformers` and `segment-anything` is tested from fixtures written by
//! `tools/fixtures/make_model_fixtures.py` (MobileSAM against ultralytics' TinyViT:
//! `tools/fixtures/make_mobile_sam_fixtures.py`; CLIP against open_clip:
//! `tools/fixtures/make_clip_fixtures.py`); timings are in the models section of the workspace `BENCHMARKS.md`.

pub mod activation;
pub mod attention;
pub mod checkpoint;
pub mod clip;
pub mod conv;
pub mod dense;
pub mod depth_anything;
pub mod dinov2;
pub mod error;
pub mod image;
pub mod kernels;
mod math512;
pub mod resample;
pub mod sam;
pub mod skinny;
pub mod weights;

pub use error::{ModelKind, ModelsError, ModelsResult};
