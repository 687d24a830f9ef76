//! `cues` stage: the per-view signals Multi-Cue-Guided Mask Merging reads (paper §4.1).
//!
//! - [`edges`]: LoG edge strength (σ = 2, |·|, per-image min–max to [0, 1]).
//! - [`depth`]: depth sources, per-image normalisation (0 = near), gradient magnitude `∇D`.
//! - [`descriptors`]: per-region semantic descriptors (dense feature grids or the model-free
//!   colour + texture fallback).
//! - [`regions`]: overlapping SAM masks resolved into a partition.
//! - [`surface`]: camera-space points and per-region surface normals from metric depth.
//! - [`filter`]: the small filters these are built from.

pub mod depth;
pub mod descriptors;
pub mod edges;
pub mod error;
#[cfg(test)]
mod files_tests;
pub mod filter;
pub mod regions;
pub mod surface;

pub use depth::{
    depth_gradient, normalise_depth, parse_depth_kind, DepthKind, DepthMap, DepthSource, InMemoryDepthSource,
    NpyDepthSource,
};
pub use descriptors::{
    cosine, ColourTextureDescriptors, DenseFeatureDescriptors, DescribeRequest, DescriptorSource,
    FeatureGrid, FeatureGrids, RegionDescriptors,
};
pub use edges::{grey_from_rgb, log_edges};
pub use error::{CuesError, CuesResult};
pub use regions::{regions_from_sam_masks, MaskInput, RegionOptions, RegionSource, Regions, UncoveredPolicy};
pub use surface::{
    camera_points, near_depth_edge, region_mean_normal, region_normal_at, DepthJumps, Intrinsics,
    NormalWindow,
};
