//! Builds a [`ViewInputs`] from one view's raw cues (image, SAM masks, depth, descriptors).

use crate::error::{MergeError, MergeResultOf};
use crate::merge::ViewInputs;
use splatseg_cues::depth::DEPTH_GRADIENT_SIGMA_PX;
use splatseg_cues::edges::LOG_SIGMA_PX;
use splatseg_cues::{
    camera_points, depth_gradient, grey_from_rgb, log_edges, normalise_depth, regions_from_sam_masks,
    DepthMap, DescribeRequest, DescriptorSource, Intrinsics, MaskInput, RegionOptions,
};
use splatseg_scene::Plane;

/// One view's raw cues.
#[derive(Clone, Copy)]
pub struct CueRequest<'a> {
    /// The image stem (key of per-view cue files).
    pub stem: &'a str,
    /// `[H, W]` RGB in [0, 1].
    pub rgb: &'a Plane<[f32; 3]>,
    /// SAM masks of the view.
    pub masks: &'a [MaskInput],
    /// `[H, W]` depth for the normalised gate, the affinity and `∇D` (monocular or rendered).
    pub depth: &'a DepthMap,
    /// `[H, W]` metric z for the crease gate's points; when `None`, `depth` is used if it is metric.
    pub metric_depth: Option<&'a Plane<f32>>,
    /// `[H, W]` rendered camera-space unit normals facing the camera (NaN = none), for the
    /// crease gate instead of normals from the points' differences.
    pub normals: Option<&'a Plane<[f32; 3]>>,
    /// Where region descriptors come from.
    pub descriptors: &'a dyn DescriptorSource,
    /// How masks become regions.
    pub region_options: RegionOptions,
    /// The view's pinhole intrinsics: with metric depth they give the camera-space points the
    /// crease gate reads (`None`: no crease gate).
    pub intrinsics: Option<Intrinsics>,
}

/// Computes regions, descriptors, normalised depth, `∇D` and LoG edges for one view.
pub fn build_view_inputs(request: &CueRequest<'_>) -> MergeResultOf<ViewInputs> {
    let (w, h) = request.rgb.size();
    if request.depth.values.size() != (w, h) {
        return Err(MergeError::Inputs(format!(
            "depth map of view `{}` is {:?} but the image is {w}×{h}",
            request.stem,
            request.depth.values.size()
        )));
    }
    let regions = regions_from_sam_masks(request.masks, w, h, &request.region_options)?;
    let descriptors = request.descriptors.describe(&DescribeRequest {
        stem: request.stem,
        rgb: Some(request.rgb),
        labels: &regions.labels,
        region_count: regions.count(),
    })?;
    let depth = normalise_depth(request.depth);
    let gradient = depth_gradient(&depth, DEPTH_GRADIENT_SIGMA_PX);
    let edges = log_edges(&grey_from_rgb(request.rgb), LOG_SIGMA_PX);
    let metric_depth = request.metric_depth.cloned().or_else(|| request.depth.metric().cloned());
    let points = match (&metric_depth, &request.intrinsics) {
        (Some(z), Some(k)) => Some(camera_points(z, k)),
        _ => None,
    };
    let normals = request.normals.cloned();
    Ok(ViewInputs { regions, descriptors, depth, depth_gradient: gradient, edges, points, normals })
}
