//! [`SynthConfig`]: everything that shapes a synthetic scene. One seed gives one scene.
//!
//! Knobs added for the stress suite (the `[room]` table, the family, the extra SAM noise) are
//! left out of the serialised config while they keep their default values, so the default
//! family writes exactly the files it wrote before they existed.

use crate::family::Family;
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
    /// The family the config was drawn from (see [`crate::family`]); it salts the random
    /// layout so different families of one seed get different rooms.
    #[serde(skip_serializing_if = "Family::is_default")]
    pub family: Family,
    /// What the room holds and how it looks.
    #[serde(skip_serializing_if = "RoomConfig::is_default")]
    pub room: RoomConfig,
    /// How the simulated SAM masks over-segment.
    pub sam: SamSimConfig,
    /// How far the simulated features and monocular depth are from the truth.
    #[serde(skip_serializing_if = "CueConfig::is_default")]
    pub cues: CueConfig,
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
            family: Family::Default,
            room: RoomConfig::default(),
            sam: SamSimConfig::default(),
            cues: CueConfig::default(),
        }
    }
}

/// Statistics of the simulated cues (the `[cues]` table): the DINOv2-like features
/// ([`crate::features`]) and the Depth-Anything-like relative depth ([`crate::mono_depth`]). The
/// defaults are those every tuning family uses; the blind families ([`crate::family`]) draw
/// harsher ones.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CueConfig {
    /// Relative size of a texture part's perturbation of its object's embedding: two parts of
    /// one object have cosine ≈ `1 / (1 + p²)` (0.3: ≈ 0.92).
    pub part_perturbation: f64,
    /// Norm of the per-patch noise vector (embeddings have unit norm).
    pub patch_noise: f64,
    /// Amplitude of the smooth spatial drift, per channel.
    pub drift: f64,
    /// Range of an instance's share of the component all instances have in common: two
    /// instances have cosine `√(s_i · s_j)` (higher = objects less distinct).
    pub shared_share: [f64; 2],
    /// Peak relative size of the depth's smooth multiplicative distortion.
    pub depth_scale_error: f64,
    /// Peak size of the depth's smooth additive distortion, a fraction of the inverse-depth range.
    pub depth_shift_error: f64,
    /// Per-pixel depth noise, a fraction of the inverse-depth range.
    pub depth_pixel_noise: f64,
    /// Radius of the box blur applied to the relative depth, pixels (0: none).
    pub depth_blur_px: usize,
    /// Standard deviation of each Gaussian's tilt off the surface it was sampled on, degrees
    /// (per tangent axis): a trained 3DGS scene's Gaussians are not exact discs on the surface.
    pub gaussian_tilt_deg: f64,
    /// Each Gaussian's thickness (standard deviation along its shortest axis), a fraction of the
    /// sample spacing (in the plane: 0.6).
    pub gaussian_thickness: f64,
    /// Standard deviation of each Gaussian's displacement off the surface along its normal, a
    /// fraction of the sample spacing.
    pub gaussian_offset: f64,
    /// Standard deviation of each in-plane log scale (each axis drawn apart): a trained 3DGS's
    /// Gaussians range in size and are elongated, not equal round discs (0: all equal).
    pub gaussian_scale_spread: f64,
    /// Share of the Gaussians that are floaters: moved off their surface towards a camera by 2–8
    /// sample spacings, with opacity 0.1–0.4, as a trained 3DGS leaves some in free space (they
    /// keep the id of the surface they were sampled on).
    pub gaussian_floaters: f64,
}

impl Default for CueConfig {
    fn default() -> Self {
        CueConfig {
            part_perturbation: 0.3,
            patch_noise: 0.22,
            drift: 0.12,
            shared_share: [0.35, 0.6],
            depth_scale_error: 0.12,
            depth_shift_error: 0.05,
            depth_pixel_noise: 0.008,
            depth_blur_px: 0,
            gaussian_tilt_deg: 0.0,
            gaussian_thickness: 0.02,
            gaussian_offset: 0.0,
            gaussian_scale_spread: 0.0,
            gaussian_floaters: 0.0,
        }
    }
}

impl CueConfig {
    /// True when every knob has its default value.
    pub fn is_default(&self) -> bool {
        *self == CueConfig::default()
    }
}

/// How objects are placed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LayoutKind {
    /// The fixed plan of the default scene (7 core objects + 0–3 extras, per-seed jitter).
    #[default]
    Plan,
    /// Objects drawn at random and placed without interpenetration (see [`crate::rooms`]).
    Random,
}

/// How the two walls are painted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WallPaint {
    /// One colour with faint mottling.
    #[default]
    Plain,
    /// A lower and an upper tone, split at [`RoomConfig::wall_scale_m`] above the floor.
    TwoTone,
    /// Vertical stripes [`RoomConfig::wall_scale_m`] wide (wallpaper).
    Stripes,
}

/// What the floor looks like.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FloorPattern {
    /// Planks 0.3 m wide, each a little lighter or darker.
    #[default]
    Planks,
    /// Stripes of two tones, [`RoomConfig::floor_scale_m`] wide.
    Stripes,
    /// Checkers of two tones, cells [`RoomConfig::floor_scale_m`] wide.
    Checkers,
}

/// The room's content (the `[room]` table). `walls`, `floor` apply to every layout; the
/// object counts only to the random layout.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RoomConfig {
    /// How objects are placed.
    pub layout: LayoutKind,
    /// Random layout: the number of objects (not floor and walls), drawn in `[min, max]`;
    /// the hard-case objects below count towards it.
    pub objects: [usize; 2],
    /// Wall paint.
    pub walls: WallPaint,
    /// Split height (two-tone) or stripe width (stripes) of the walls, metres.
    pub wall_scale_m: f64,
    /// Floor pattern.
    pub floor: FloorPattern,
    /// Stripe width or checker cell of the floor, metres.
    pub floor_scale_m: f64,
    /// Each tone of a two-tone wall or floor is its own SAM part (SAM cuts a coarse pattern
    /// into its tones; a fine one it keeps whole). Features of the parts agree (cos ≈ 0.9).
    pub tone_parts: bool,
    /// Random layout: posts this many pixels wide in the image (sized from the resolution).
    pub thin_posts: usize,
    /// Width of the thin posts in the image at the orbit radius, pixels.
    pub thin_post_px: f64,
    /// Random layout: large textured objects near the cameras, cut by the image border.
    pub foreground_objects: usize,
    /// Random layout: objects standing on a box.
    pub stacked: usize,
    /// Random layout: pairs of objects touching in 3D (besides the same-depth pair).
    pub touching: usize,
    /// Random layout: probability that an ordinary object gets a multi-tone texture (stripes
    /// or two tones, each band its own SAM part).
    pub multi_tone_share: f64,
    /// Random layout: factor on the stripe period and checker cell of objects (smaller = finer).
    #[serde(skip_serializing_if = "is_one")]
    pub pattern_scale: f64,
}

impl Default for RoomConfig {
    fn default() -> Self {
        RoomConfig {
            layout: LayoutKind::Plan,
            objects: [6, 14],
            walls: WallPaint::Plain,
            wall_scale_m: 1.0,
            floor: FloorPattern::Planks,
            floor_scale_m: 0.6,
            tone_parts: true,
            thin_posts: 0,
            thin_post_px: 3.0,
            foreground_objects: 0,
            stacked: 0,
            touching: 0,
            multi_tone_share: 0.3,
            pattern_scale: 1.0,
        }
    }
}

fn is_one(v: &f64) -> bool {
    *v == 1.0
}

impl RoomConfig {
    /// True when every knob has its default value.
    pub fn is_default(&self) -> bool {
        *self == RoomConfig::default()
    }
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}
fn is_default_hole_radius(v: &[i64; 2]) -> bool {
    *v == [2, 3]
}
fn is_default_hole_min(v: &usize) -> bool {
    *v == 300
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
    /// Radius of the holes, pixels, drawn in `[min, max]`.
    #[serde(skip_serializing_if = "is_default_hole_radius")]
    pub hole_radius_px: [i64; 2],
    /// Only masks larger than this many pixels get a hole.
    #[serde(skip_serializing_if = "is_default_hole_min")]
    pub hole_min_area_px: usize,
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
    /// Probability, per view and per pair of objects touching in the image (other than the
    /// white pair), of a wrong merged mask covering both (replacing their masks with
    /// [`Self::wrong_merge_replaces_probability`]).
    #[serde(skip_serializing_if = "is_zero")]
    pub adjacent_merge_probability: f64,
    /// Probability that a mask is dilated by one pixel (spilling onto its neighbours).
    #[serde(skip_serializing_if = "is_zero")]
    pub dilate_probability: f64,
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
            hole_radius_px: [2, 3],
            hole_min_area_px: 300,
            erode_probability: 0.2,
            whole_object_probability: 0.35,
            wrong_merge_probability: 0.35,
            wrong_merge_replaces_probability: 0.5,
            adjacent_merge_probability: 0.0,
            dilate_probability: 0.0,
        }
    }
}

impl SamSimConfig {
    /// The same simulation for an image `scale` times as wide and high: areas scale with
    /// `scale²`, the hole radius with `scale`; the 1-pixel erosion and dilation stay 1 pixel.
    pub fn scaled(&self, scale: f64) -> SamSimConfig {
        let area = |px: usize| (px as f64 * scale * scale).round() as usize;
        let len = |px: i64| ((px as f64 * scale).round() as i64).max(1);
        SamSimConfig {
            min_area_px: area(self.min_area_px),
            object_cut_min_px: area(self.object_cut_min_px),
            hole_min_area_px: area(self.hole_min_area_px),
            hole_radius_px: self.hole_radius_px.map(len),
            ..self.clone()
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
