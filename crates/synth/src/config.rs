//! [`SynthConfig`]: everything that shapes a synthetic scene. One seed gives one scene.

use serde::{Deserialize, Serialize};

/// How to generate a synthetic scene. Every field has a default (`#[serde(default)]`), so a
/// config file only needs the fields it changes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SynthConfig {
    /// Seed of every random choice (layout jitter, extra objects, SAM simulation, cue noise).
    pub seed: u64,
    /// Number of views on the camera arc.
    pub views: usize,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Horizontal field of view of the pinhole cameras, degrees.
    pub fov_x_deg: f64,
    /// Angle the camera arc spans around the scene centre, degrees.
    pub arc_deg: f64,
    /// Spacing of the Gaussians on the surfaces, in pixels at the orbit radius (smaller = more
    /// Gaussians).
    pub gaussian_spacing_px: f64,
    /// Channels of the simulated DINOv2-like patch features.
    pub feature_dim: usize,
    /// Patch size of the simulated feature grid (DINOv2: 14): the grid is
    /// `[ceil(H / patch), ceil(W / patch), C]`.
    pub feature_patch_px: u32,
    /// How the simulated SAM masks over-segment.
    pub sam: SamSimConfig,
}

impl Default for SynthConfig {
    fn default() -> Self {
        SynthConfig {
            seed: 0,
            views: 12,
            width: 320,
            height: 240,
            fov_x_deg: 60.0,
            arc_deg: 80.0,
            gaussian_spacing_px: 2.5,
            feature_dim: 32,
            feature_patch_px: 14,
            sam: SamSimConfig::default(),
        }
    }
}

/// Knobs of the simulated Segment Anything output (see [`crate::sam_sim`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SamSimConfig {
    /// Connected pieces smaller than this many pixels get no mask (left uncovered).
    pub min_area_px: usize,
    /// A piece larger than this fraction of the image is cut by 1–3 random near-vertical lines
    /// (floor, walls).
    pub large_cut_fraction: f64,
    /// Probability that an object piece larger than [`Self::object_cut_min_px`] gets one
    /// random line cut.
    pub object_cut_probability: f64,
    /// Minimum area (pixels) of an object piece that may be cut.
    pub object_cut_min_px: usize,
    /// Probability that a cut object piece of at least 4 × [`Self::object_cut_min_px`] gets a
    /// second line.
    pub object_second_cut_probability: f64,
    /// Probability that a mask gets a small hole punched into it.
    pub hole_probability: f64,
    /// Probability that a mask is eroded by one pixel (uncovered pixels along its outline).
    pub erode_probability: f64,
    /// Probability that an object made of several masks also gets one whole-object mask
    /// overlapping its parts.
    pub whole_object_probability: f64,
    /// Probability, per view where the white-on-white pair touches, of a wrong merged mask
    /// covering both objects.
    pub wrong_merge_probability: f64,
    /// Given a wrong merge, probability that it replaces the pair's masks (otherwise it is an
    /// extra overlapping mask, as SAM's multi-granularity output often is).
    pub wrong_merge_replaces_probability: f64,
}

impl Default for SamSimConfig {
    fn default() -> Self {
        SamSimConfig {
            min_area_px: 24,
            large_cut_fraction: 0.06,
            object_cut_probability: 0.85,
            object_cut_min_px: 400,
            object_second_cut_probability: 0.5,
            hole_probability: 0.25,
            erode_probability: 0.2,
            whole_object_probability: 0.35,
            wrong_merge_probability: 0.35,
            wrong_merge_replaces_probability: 0.5,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn partial_config_files_fill_in_defaults_and_typos_are_rejected() {
        let c: SynthConfig =
            serde_json::from_str(r#"{"seed": 9, "sam": {"hole_probability": 0.0}}"#).expect("parse");
        assert_eq!(c.seed, 9);
        assert_eq!(c.views, SynthConfig::default().views);
        assert_eq!(c.sam.hole_probability, 0.0);
        assert_eq!(c.sam.min_area_px, SamSimConfig::default().min_area_px);
        assert!(serde_json::from_str::<SynthConfig>(r#"{"sed": 9}"#).is_err());
    }
}
