//! Depth cues (paper §4.1 "Monocular Depth Estimation"): a depth map from some source, normalised
//! per image to [0, 1] with 0 = near and 1 = far (see `CONVENTIONS.md`), and its gradient magnitude
//! `minmax(Sobel(GaussianBlur(D, σ = 1.5)))`, the `∇D` of the merge score.

use crate::error::{CuesError, CuesResult};
use crate::filter::{gaussian_blur, normalise_min_max, resize_bilinear, sobel_magnitude};
use splatseg_scene::Plane;
use std::path::PathBuf;

/// Smoothing applied before the depth gradient (the released code's σ = 1.5 px).
pub const DEPTH_GRADIENT_SIGMA_PX: f32 = 1.5;

/// What the values of a depth map mean.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DepthKind {
    /// Metric camera-space z (rendered from Gaussians, synthetic ground truth); 0 or non-finite
    /// means no surface.
    MetricZ,
    /// Relative inverse depth up to scale and shift (monocular models): larger = nearer.
    InverseRelative,
}

/// Parses a `--depth-kind` value: `inverse` (or `inverse-relative`) or `metric` (or `metric-z`).
pub fn parse_depth_kind(text: &str) -> Result<DepthKind, String> {
    match text {
        "inverse" | "inverse-relative" => Ok(DepthKind::InverseRelative),
        "metric" | "metric-z" => Ok(DepthKind::MetricZ),
        other => Err(format!("`{other}`: expected `inverse` (relative inverse depth, e.g. Depth Anything) or `metric` (camera z)")),
    }
}

/// A depth map of one view at image resolution.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthMap {
    /// `[H, W]` depth values, meaning given by `kind`.
    pub values: Plane<f32>,
    /// How to read `values`.
    pub kind: DepthKind,
}

impl DepthMap {
    /// A depth map read at any size (`[h, w]`, e.g. a model's output) resampled bilinearly to
    /// the `width × height` image, as the `--depth` folder's maps are; an error when `values` is
    /// empty.
    pub fn at_image_size(
        values: &Plane<f32>,
        kind: DepthKind,
        width: usize,
        height: usize,
    ) -> Result<Self, String> {
        if values.width == 0 || values.height == 0 {
            return Err("empty array".to_string());
        }
        Ok(DepthMap { values: resize_bilinear(values, width, height), kind })
    }

    /// Metric z when the map holds it (pixels without a surface are 0 / non-finite).
    pub fn metric(&self) -> Option<&Plane<f32>> {
        (self.kind == DepthKind::MetricZ).then_some(&self.values)
    }
}

/// Normalised depth in [0, 1], 0 = near, 1 = far, per image.
///
/// Metric z: `(z − zmin)/(zmax − zmin)` over valid pixels (z > 0, finite); pixels without a
/// surface become 1 (farthest). Inverse depth d: `1 − (d − dmin)/(dmax − dmin)`; non-finite
/// pixels become 1. A constant map becomes all 0.
pub fn normalise_depth(depth: &DepthMap) -> Plane<f32> {
    let valid = |v: f32| match depth.kind {
        DepthKind::MetricZ => v.is_finite() && v > 0.0,
        DepthKind::InverseRelative => v.is_finite(),
    };
    let (lo, hi) = depth
        .values
        .data
        .iter()
        .filter(|&&v| valid(v))
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    let range = hi - lo;
    depth.values.map(|&v| {
        if !valid(v) {
            return 1.0;
        }
        let t = if range > 0.0 { (v - lo) / range } else { 0.0 };
        match depth.kind {
            DepthKind::MetricZ => t,
            DepthKind::InverseRelative if range > 0.0 => 1.0 - t,
            DepthKind::InverseRelative => 0.0,
        }
    })
}

/// Depth-gradient magnitude map `∇D`: Gaussian blur (`sigma_px`), Sobel magnitude, min–max to
/// [0, 1]. `normalised_depth`: `[H, W]` from [`normalise_depth`]. Returns `[H, W]`.
pub fn depth_gradient(normalised_depth: &Plane<f32>, sigma_px: f32) -> Plane<f32> {
    let mut grad = sobel_magnitude(&gaussian_blur(normalised_depth, sigma_px));
    normalise_min_max(&mut grad);
    grad
}

/// Where a view's depth comes from: a `.npy` per view, depth rendered from the scene's Gaussians,
/// or a monocular model. Implementations return the map resized to the image size.
pub trait DepthSource: Sync {
    /// Depth of the view whose image stem is `stem`, at `width × height`.
    fn depth(&self, stem: &str, width: usize, height: usize) -> CuesResult<DepthMap>;
}

/// Depth maps already in memory, keyed by image stem.
#[derive(Clone, Debug, Default)]
pub struct InMemoryDepthSource {
    /// `(stem, map)` pairs; maps on another grid are resized bilinearly.
    pub maps: Vec<(String, DepthMap)>,
}

impl DepthSource for InMemoryDepthSource {
    fn depth(&self, stem: &str, width: usize, height: usize) -> CuesResult<DepthMap> {
        let (_, map) = self.maps.iter().find(|(s, _)| s == stem).ok_or_else(|| CuesError::Missing {
            what: "depth map",
            stem: stem.to_string(),
            path: PathBuf::from("<memory>"),
        })?;
        Ok(DepthMap { values: resize_bilinear(&map.values, width, height), kind: map.kind })
    }
}

/// One `<stem>.npy` per view in a folder: `[H, W]` (or `[H, W, 1]`) float32/float16 at the
/// image's size. A map of another size (a transposed `[W, H]` one, one made for another
/// `--resolution`) is an error naming the file and both shapes, unless `resize` asks for it to be
/// resampled bilinearly (`align_corners = False`) to the image. A map without one finite value is
/// an error too (it would give the view no depth).
#[derive(Clone, Debug)]
pub struct NpyDepthSource {
    /// The folder holding `<stem>.npy`.
    pub dir: PathBuf,
    /// What the values mean (synthetic `depth/` is inverse relative, `gt/depth/` metric z).
    pub kind: DepthKind,
    /// Resample maps of another size to the image instead of refusing them.
    pub resize: bool,
}

impl DepthSource for NpyDepthSource {
    fn depth(&self, stem: &str, width: usize, height: usize) -> CuesResult<DepthMap> {
        let path = self.dir.join(format!("{stem}.npy"));
        let file_err = |reason: String| CuesError::File { what: "depth map", reason, path: path.clone() };
        let array = splatseg_scene::npy::read_cue_folder_entry(&self.dir, stem)
            .map_err(|e| file_err(e.to_string()))?
            .ok_or_else(|| CuesError::Missing {
                what: "depth map",
                stem: stem.to_string(),
                path: path.clone(),
            })?;
        let plane = array
            .to_plane()
            .ok_or_else(|| file_err(format!("shape {:?} is not [H, W] or [H, W, 1]", array.shape)))?;
        if (plane.width, plane.height) != (width, height) && !self.resize {
            let transposed =
                if (plane.width, plane.height) == (height, width) { " (transposed?)" } else { "" };
            return Err(file_err(format!(
                "shape [{}, {}]{transposed} is not the image's [{height}, {width}] (H, W); write the map at \
                 the image's size, or let `run --resize-depth` resample it",
                plane.height, plane.width
            )));
        }
        if !plane.data.iter().any(|v| v.is_finite()) {
            return Err(file_err(format!(
                "all {} values are NaN or ±Inf: the view would have no depth",
                plane.data.len()
            )));
        }
        DepthMap::at_image_size(&plane, self.kind, width, height).map_err(file_err)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    #[test]
    fn metric_and_inverse_depth_normalise_to_near_zero_far_one() {
        let metric = DepthMap {
            values: Plane::from_vec(3, 1, vec![2.0, 8.0, 0.0]).unwrap(),
            kind: DepthKind::MetricZ,
        };
        assert_eq!(normalise_depth(&metric).data, vec![0.0, 1.0, 1.0]);
        let inverse = DepthMap {
            values: Plane::from_vec(3, 1, vec![0.5, 0.1, 0.3]).unwrap(),
            kind: DepthKind::InverseRelative,
        };
        let n = normalise_depth(&inverse).data;
        assert_abs_diff_eq!(n[0], 0.0, epsilon = 1e-6); // largest inverse depth = nearest
        assert_abs_diff_eq!(n[1], 1.0, epsilon = 1e-6);
        assert_abs_diff_eq!(n[2], 0.5, epsilon = 1e-6);
    }

    #[test]
    fn depth_gradient_is_large_at_a_depth_step_and_zero_on_a_plane() {
        let data = (0..30).flat_map(|_| (0..30).map(|x| if x < 15 { 0.2 } else { 0.6 })).collect();
        let grad = depth_gradient(&Plane::from_vec(30, 30, data).unwrap(), DEPTH_GRADIENT_SIGMA_PX);
        assert!(*grad.get(14, 15) > 0.9 || *grad.get(15, 15) > 0.9);
        assert!(*grad.get(3, 15) < 1e-4 && *grad.get(27, 15) < 1e-4);
    }

    #[test]
    fn in_memory_source_resizes_and_reports_missing_views() {
        let source = InMemoryDepthSource {
            maps: vec![(
                "a".to_string(),
                DepthMap { values: Plane::filled(2, 2, 3.0), kind: DepthKind::MetricZ },
            )],
        };
        let map = source.depth("a", 5, 4).unwrap();
        assert_eq!(map.values.size(), (5, 4));
        assert!(map.values.data.iter().all(|&v| (v - 3.0).abs() < 1e-6));
        let err = source.depth("b", 5, 4).unwrap_err().to_string();
        assert!(err.contains("`b`"), "{err}");
    }

    #[test]
    fn depth_kinds_parse_by_their_short_and_long_names() {
        assert_eq!(parse_depth_kind("inverse"), Ok(DepthKind::InverseRelative));
        assert_eq!(parse_depth_kind("inverse-relative"), Ok(DepthKind::InverseRelative));
        assert_eq!(parse_depth_kind("metric"), Ok(DepthKind::MetricZ));
        assert_eq!(parse_depth_kind("metric-z"), Ok(DepthKind::MetricZ));
        assert!(parse_depth_kind("disparity").unwrap_err().contains("`disparity`"));
    }
}
