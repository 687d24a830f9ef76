//! Segment Anything (Kirillov et al. 2023): image encoder, point prompt encoder, mask decoder, and the
//! automatic mask generator ([`amg`]) with the reference's algorithm and defaults.
//!
//! Loads the official `sam_vit_{b,l,h}_*.pth` checkpoints and MobileSAM's `mobile_sam.pt` (TinyViT image
//! encoder, [`tiny_vit`]; same prompt encoder and mask decoder), told apart by their tensor names, sizes
//! inferred from the tensors.

pub mod amg;
pub mod image_encoder;
mod image_panels;
mod image_update;
pub mod mask_decoder;
pub mod mask_output;
pub mod masks;
mod packed_decoder;
pub mod prompt_encoder;
pub mod rel_pos_attention;
mod second_block;
pub mod shared_decoder;
pub mod stability_bound;
pub mod tiny_vit;

use std::path::Path;

use candle_core::{Device, Tensor};

use crate::checkpoint;
use crate::error::{ModelKind, ModelsError, ModelsResult};
use crate::resample::{resize_rgb8_like_pil, AxisResize, AxisTaps, Resample};
use crate::weights::Weights;
pub use amg::{generate_masks, generate_masks_using, AmgConfig, DecoderPath};
use image_encoder::ImageEncoderConfig;
use mask_decoder::MaskDecoder;
use prompt_encoder::PromptEncoder;
use shared_decoder::{DecodedTokens, DecoderImage};
use tiny_vit::{TinyVit, TinyVitConfig};

/// Input side of the released SAM and MobileSAM models.
pub const DEFAULT_IMG_SIZE: usize = 1024;

/// SAM's pixel mean (RGB, 0–255).
pub const PIXEL_MEAN: [f32; 3] = [123.675, 116.28, 103.53];
/// SAM's pixel standard deviation (RGB, 0–255).
pub const PIXEL_STD: [f32; 3] = [58.395, 57.12, 57.375];

/// A loaded Segment Anything model.
#[derive(Debug, Clone)]
pub struct Sam {
    encoder: ImageEncoder,
    prompt: PromptEncoder,
    decoder: MaskDecoder,
}

/// The image encoder of a checkpoint: SAM's ViT or MobileSAM's TinyViT.
#[derive(Debug, Clone)]
pub enum ImageEncoder {
    /// `sam_vit_{b,l,h}` (`image_encoder.patch_embed.proj.*`, `image_encoder.blocks.*`).
    Vit(image_encoder::ImageEncoder),
    /// `mobile_sam.pt` (`image_encoder.patch_embed.seq.*`, `image_encoder.layers.*`).
    TinyVit(TinyVit),
}

impl ImageEncoder {
    /// Builds the encoder the `image_encoder.`-stripped tensors describe.
    pub fn from_weights(enc: &Weights) -> ModelsResult<Self> {
        if enc.contains("patch_embed.seq.0.c.weight") {
            let config = TinyVitConfig::infer(enc, DEFAULT_IMG_SIZE)?;
            Ok(Self::TinyVit(TinyVit::new(enc, config)?))
        } else {
            let config = ImageEncoderConfig::infer(enc)?;
            Ok(Self::Vit(image_encoder::ImageEncoder::new(enc, config)?))
        }
    }

    /// Square input side.
    pub fn img_size(&self) -> usize {
        match self {
            Self::Vit(e) => e.config().img_size,
            Self::TinyVit(e) => e.config().img_size,
        }
    }

    /// `pixels`: `[3, S, S]` normalised and padded. Returns `[out_chans, h, w]`.
    pub fn forward(&self, pixels: &Tensor) -> ModelsResult<Tensor> {
        match self {
            Self::Vit(e) => e.forward(pixels),
            Self::TinyVit(e) => e.forward(pixels),
        }
    }
}

/// An image run through the encoder, ready for prompts.
#[derive(Debug, Clone)]
pub struct ImageEmbedding {
    /// The image encoder's output, `[D, h, w]`.
    pub features: Tensor,
    /// Image embedding plus the "no mask" dense prompt, `[D, h, w]`.
    pub embedding: Tensor,
    /// Positional encoding of the embedding grid, `[D, h, w]`.
    pub dense_pe: Tensor,
    /// (height, width) of the resized image inside the padded square input.
    pub input_size: (usize, usize),
    /// (height, width) of the image given.
    pub original_size: (usize, usize),
}

impl Sam {
    /// Loads a checkpoint (see [`checkpoint::resolve`]).
    pub fn load(path: &Path) -> ModelsResult<Self> {
        let files = checkpoint::resolve(path, ModelKind::Sam)?;
        let weights = Weights::load(&files.weights, ModelKind::Sam)?;
        Self::from_weights(&weights)
    }

    /// Builds the model from the official tensor names (`image_encoder.*`, `prompt_encoder.*`, `mask_decoder.*`).
    pub fn from_weights(weights: &Weights) -> ModelsResult<Self> {
        let encoder = ImageEncoder::from_weights(&weights.sub("image_encoder."))?;
        let decoder = MaskDecoder::new(&weights.sub("mask_decoder."))?;
        let prompt = PromptEncoder::new(&weights.sub("prompt_encoder."), decoder.dim())?;
        Ok(Self { encoder, prompt, decoder })
    }

    /// The ViT image encoder's configuration (`None` for MobileSAM's TinyViT).
    pub fn encoder_config(&self) -> Option<&ImageEncoderConfig> {
        match &self.encoder {
            ImageEncoder::Vit(e) => Some(e.config()),
            ImageEncoder::TinyVit(_) => None,
        }
    }

    /// The image encoder.
    pub fn image_encoder(&self) -> &ImageEncoder {
        &self.encoder
    }

    /// Runs a TinyViT model at another square input side (a multiple of 16; the released models use
    /// 1024, which is also what the checkpoint is loaded with). A ViT's side is fixed by its positional
    /// embedding: only its own side is accepted.
    pub fn with_input_size(mut self, side: usize) -> ModelsResult<Self> {
        match &mut self.encoder {
            ImageEncoder::TinyVit(e) => e.set_img_size(side)?,
            ImageEncoder::Vit(e) if e.config().img_size == side => {}
            ImageEncoder::Vit(e) => {
                return Err(ModelsError::Input(format!(
                    "this SAM ViT encoder takes {0}×{0} inputs, not {side}×{side}",
                    e.config().img_size
                )))
            }
        }
        Ok(self)
    }

    /// The size the image is resized to before padding: long side = the encoder input side
    /// (`ResizeLongestSide.get_preprocess_shape`).
    pub fn input_size_for(&self, height: usize, width: usize) -> (usize, usize) {
        preprocess_shape(height, width, self.encoder.img_size())
    }

    /// Encodes an image (`rgb`: interleaved `[height, width, 3]`, 8-bit) as `SamPredictor.set_image`
    /// does: PIL-style bilinear resize to the long side, normalise, zero-pad to a square.
    pub fn embed_image(&self, rgb: &[u8], height: usize, width: usize) -> ModelsResult<ImageEmbedding> {
        if rgb.len() != height * width * 3 || height == 0 || width == 0 {
            return Err(ModelsError::Input(format!("{} bytes for a {width}×{height} RGB image", rgb.len())));
        }
        let side = self.encoder.img_size();
        let (ih, iw) = self.input_size_for(height, width);
        let resized = resize_rgb8_like_pil(rgb, (height, width), (ih, iw));
        let mut chw = vec![0f32; 3 * side * side];
        for y in 0..ih {
            for x in 0..iw {
                for c in 0..3 {
                    chw[(c * side + y) * side + x] =
                        (resized[(y * iw + x) * 3 + c] as f32 - PIXEL_MEAN[c]) / PIXEL_STD[c];
                }
            }
        }
        let pixels = Tensor::from_vec(chw, (3, side, side), &Device::Cpu)?;
        let features = self.encoder.forward(&pixels)?;
        let (d, h, w) = features.dims3()?;
        let embedding = features.broadcast_add(&self.prompt.no_mask_embedding().reshape((d, 1, 1))?)?;
        let dense_pe = self.prompt.dense_pe(h, w)?;
        Ok(ImageEmbedding {
            features,
            embedding,
            dense_pe,
            input_size: (ih, iw),
            original_size: (height, width),
        })
    }

    /// Multimask prediction for single positive points (`SamPredictor.predict_torch` with
    /// `multimask_output=True`, low-resolution logits).
    ///
    /// `points`: `[B, 2]` (x, y) in original-image pixels. Returns (`[B, 3, 4h, 4w]` low-res logits,
    /// `[B, 3]` IoU predictions).
    pub fn predict_points(
        &self,
        image: &ImageEmbedding,
        points: &[[f32; 2]],
    ) -> ModelsResult<(Tensor, Tensor)> {
        let sparse = self.point_tokens(image, points)?;
        let (masks, iou) = self.decoder.forward(&image.embedding, &image.dense_pe, &sparse)?;
        let m = masks.dims()[1];
        Ok((masks.narrow(1, 1, m - 1)?, iou.narrow(1, 1, m - 1)?))
    }

    /// Sparse prompt tokens of single positive points given in original-image pixels: `[B, 2, D]`.
    fn point_tokens(&self, image: &ImageEmbedding, points: &[[f32; 2]]) -> ModelsResult<Tensor> {
        let (oh, ow) = image.original_size;
        let (ih, iw) = image.input_size;
        let scaled: Vec<[f32; 2]> = points
            .iter()
            .map(|p| {
                [
                    (p[0] as f64 * (iw as f64 / ow as f64)) as f32,
                    (p[1] as f64 * (ih as f64 / oh as f64)) as f32,
                ]
            })
            .collect();
        let positive = vec![true; points.len()];
        self.prompt.embed_points(&scaled, &positive, self.encoder.img_size())
    }

    /// The decoder's prompt-independent work for an image, shared by all its prompts
    /// ([`shared_decoder`]).
    pub fn prepare_decoder(&self, image: &ImageEmbedding) -> ModelsResult<DecoderImage> {
        self.decoder.prepare_image(&image.embedding, &image.dense_pe)
    }

    /// [`Sam::predict_points`] in two steps on a prepared image: this one runs the transformer and the
    /// IoU head for every point; [`Sam::point_masks`] then upscales only the masks wanted.
    ///
    /// `points`: `[B, 2]` (x, y) in original-image pixels. Returns the decoded batch and the IoU
    /// predictions of the 3 multimask outputs, `[B, 3]` row-major.
    pub fn decode_points(
        &self,
        image: &ImageEmbedding,
        prepared: &DecoderImage,
        points: &[[f32; 2]],
    ) -> ModelsResult<(DecodedTokens, Vec<f32>)> {
        let sparse = self.point_tokens(image, points)?;
        let decoded = self.decoder.decode_tokens(prepared, &sparse)?;
        let m = decoded.iou.dims()[1];
        let iou = decoded.iou.narrow(1, 1, m - 1)?.flatten_all()?.to_vec1::<f32>()?;
        Ok((decoded, iou))
    }

    /// Low-resolution logits `[S, 4h, 4w]` of multimask outputs `masks` (each in `0..3`) of point
    /// `point` of a batch from [`Sam::decode_points`].
    pub fn point_masks(
        &self,
        prepared: &DecoderImage,
        decoded: &DecodedTokens,
        point: usize,
        masks: &[usize],
    ) -> ModelsResult<Tensor> {
        let outputs: Vec<usize> = masks.iter().map(|&m| m + 1).collect();
        self.decoder.masks_of(prepared, decoded, point, &outputs)
    }

    /// Per-axis taps taking low-res logits (`low_h × low_w`) to the original image size: bilinear to the
    /// padded square input, crop to the resized image, bilinear to the original size
    /// (`Sam.postprocess_masks`), composed into one resize per axis.
    pub fn upscale_taps(&self, image: &ImageEmbedding, low: (usize, usize)) -> (AxisTaps, AxisTaps) {
        let side = self.encoder.img_size();
        let axis = |low_len: usize, input_len: usize, original_len: usize| {
            let to_square = AxisTaps::new(AxisResize::to_len(low_len, side), Resample::Bilinear);
            let to_original = AxisTaps::new(AxisResize::to_len(input_len, original_len), Resample::Bilinear);
            to_original.compose(&to_square, low_len)
        };
        (
            axis(low.0, image.input_size.0, image.original_size.0),
            axis(low.1, image.input_size.1, image.original_size.1),
        )
    }
}

/// `ResizeLongestSide.get_preprocess_shape`: scale so the long side is `long_side`, round half up.
pub fn preprocess_shape(height: usize, width: usize, long_side: usize) -> (usize, usize) {
    let scale = long_side as f64 / height.max(width).max(1) as f64;
    (((height as f64 * scale) + 0.5) as usize, ((width as f64 * scale) + 0.5) as usize)
}
