//! Foundation models for splatseg's cues, written on candle-core / candle-nn (CPU):
//!
//! - [`dinov2`]: DINOv2 ViT-S/B/L 14 (with or without registers), patch features `[h/14, w/14, C]`.
//! - [`resample`]: PyTorch-exact bicubic / bilinear resizing.
//! - [`checkpoint`] + [`weights`]: finding and reading `.safetensors` / `.pth` checkpoints, original and
//!   Hugging Face names, with errors that say which file and which tensor is wrong.

pub mod attention;
pub mod checkpoint;
pub mod conv;
pub mod depth_anything;
pub mod dinov2;
pub mod error;
pub mod image;
pub mod resample;
pub mod sam;
pub mod weights;

pub use error::{ModelKind, ModelsError, ModelsResult};
