//! [`LiftConfig`]: parameters of visibility, fusion and filtering. Defaults are the paper's
//! where it gives one (τ_var = 0.05) and documented choices elsewhere.

use crate::refine::RefineRule;
use crate::snap::SnapRule;
use serde::{Deserialize, Serialize};

/// Parameters of the lifting stage.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct LiftConfig {
    /// Visibility: a Gaussian is visible in a view when its camera depth `z` satisfies
    /// `z ≤ D · (1 + depth_rel_tol) + depth_sigma_tol · σ_ray`, where `D` is the surface depth
    /// at its centre pixel and `σ_ray` its own standard deviation along the viewing ray.
    pub depth_rel_tol: f32,
    /// See `depth_rel_tol`.
    pub depth_sigma_tol: f32,
    /// Surface depth `D` of a pixel: the depth at which front-to-back transmittance first drops
    /// below this (0.5 = the "median depth" of the composited footprints).
    pub surface_transmittance: f32,
    /// Paper τ_var: Gaussians whose identity-feature variance over their views exceeds this are
    /// unreliable and get no id (`-1`). The paper gives 0.05 for the variance of its 768-d fused
    /// DINOv2 features; ours is the variance of the unit identity features of the matched ids a
    /// Gaussian's views vote for (0 when they agree, about 2·(1 − cos) spread between two ids),
    /// so the number does not carry over. Measured on the stress suite's tuning seeds 3..5 (18
    /// scenes): 0.05 → 3D label accuracy 0.781 with 16.9 % of the Gaussians unlabelled, 0.1 →
    /// 0.851 / 7.2 %, **0.2 → 0.885 / 2.3 %**, 0.3 → 0.890 / 1.5 %; mIoU 0.832–0.834 and ids /
    /// GT 1.30–1.34 throughout (BENCHMARKS.md, "τ_var").
    pub tau_var: f32,
    /// Rendering label maps back, unreliable Gaussians vote for their majority id with their
    /// blending weight scaled by this (reliable ones: 1).
    pub unreliable_render_weight: f32,
    /// Touching objects ([`crate::touching`]) whose identity features have at least this
    /// cosine become one object (values above 1, with `tau_seam` above 1 too, switch the step off). 0.95 is measured, not
    /// the paper's: on the synthetic scenes (seeds 0–4) pieces of one object left apart by the
    /// per-view merge have cos 0.99–1.0, while the two different boxes touching at the same
    /// depth reach 0.88–0.94 (their patch features mix at the seam).
    pub tau_touching: f32,
    /// Voxel edge of the contact test, in median Gaussian standard deviations.
    pub contact_voxel_factor: f32,
    /// Neighbouring voxel pairs two objects must share to touch.
    pub min_contact_voxels: u32,
    /// Touching objects are joined only when at least this share of the views seeing both
    /// has one merged mask over both (see [`crate::touching`]).
    pub min_together_share: f32,
    /// Touching objects whose contact is a smooth seam (one surface continuing: the normals on
    /// both sides within `seam_max_angle_deg`, no step between them, on at least
    /// `seam_smooth_share` of the measured contact voxel pairs) join when their identity
    /// features have at least this cosine: a floor or a wall left in pieces by the per-view
    /// merge (SAM's cuts) and by matching's one-mask-per-view rule continues itself in 3D,
    /// where a box standing on the floor or another box meets it at a crease.
    pub tau_seam: f32,
    /// `tau_seam` of runs without dense features (the model-free colour/texture descriptors): the
    /// pieces of a striped or two-tone wall differ in colour (cos 0.55–0.65 on the stress suite)
    /// while their 3D seam is as smooth as with features. On the tuning seeds 0..7 without
    /// features: mean mIoU 0.812 → 0.833 (0..2) and 0.825 → 0.843 (3..7), ids / GT 2.17 → 1.83 and
    /// 2.11 → 1.82. With features the looser value joined a wall to the floor (seed 3), so it
    /// applies only without them ([`LiftConfig::for_model_free_descriptors`]).
    pub tau_seam_model_free: f32,
    /// See `tau_seam`.
    pub seam_smooth_share: f32,
    /// Touching objects that the views often see in one merged mask (at least
    /// `part_min_together_share` of the views seeing both) and that meet at convex or smooth
    /// edges only (at most `part_max_concave_share` of their oriented contact voxel pairs
    /// concave) are parts of one object, joined at this looser cosine ([`crate::touching`]): a
    /// cylinder's cap and side, a box cut by the image border. Above 1: off.
    pub tau_part: f32,
    /// See `tau_part`.
    pub part_min_together_share: f32,
    /// See `tau_part`.
    pub part_max_concave_share: f32,
    /// Two touching objects whose Gaussians both lie along one line, each spread along it at
    /// least this many times more than across it, are pieces of one thin structure (a post cut
    /// by SAM where the background behind it changes) and join at `tau_seam` ([`crate::touching`]).
    /// 0 = off.
    pub thin_min_elongation: f32,
    /// See `tau_part`: at least this share of the oriented contact voxel pairs must be convex
    /// (two boxes side by side at one depth meet flush, at a smooth edge, not a convex one).
    pub part_min_convex_share: f32,
    /// See `tau_seam`.
    pub seam_max_angle_deg: f32,
    /// Split objects whose labelled Gaussians form clusters apart in 3D ([`crate::split`]): a
    /// per-view merge that joined two objects meeting in the image in most views (a thin post in
    /// front of a cylinder) leaves one id over both, which only 3D can undo.
    pub split_disconnected: bool,
    /// Voxel edge of the split's connectivity, in median Gaussian standard deviations.
    pub split_voxel_factor: f32,
    /// A cluster split off an object must hold at least this many Gaussians (smaller ones are
    /// strays and keep their id).
    pub min_split_gaussians: usize,
    /// Objects covering fewer pixels than this over all rendered-back label maps are specks
    /// and are dropped (pixels 0, Gaussians -1): less than two minimal SAM regions. In pixels of
    /// a 320×240 view: larger views scale it by their mean pixel count / 76,800
    /// ([`LiftConfig::min_object_px_for`]).
    pub min_object_px: u64,
    /// Gaussians seen in fewer views than this get no id.
    pub min_views: u32,
    /// Floor of the frontal factor of the fusion weight (so grazing views still count a little).
    pub min_frontal: f32,
    /// Near plane: Gaussians closer to the camera than this are skipped.
    pub near: f32,
    /// What the final per-view label maps are: `"rendered"` = rendered back from the labelled
    /// Gaussians as they are; `"snapped-raw"` (default) = each of the view's SAM masks resolved
    /// into regions takes the majority id the rendered map gives its pixels ([`crate::snap`]);
    /// `"snapped"` = the same onto the merged regions. Either way the final maps have SAM's
    /// boundaries with the 3D consensus ids (views without masks keep the rendered map).
    pub final_maps: FinalMaps,
    /// Snapping: a region in which the second most rendered id covers at least this share of
    /// the labelled pixels is taken for one mask over two objects and keeps the rendered labels
    /// ([`crate::snap`]); values above 1 snap every region. Measured on the stress suite's
    /// tuning seeds 0–2 (18 scenes; mean / p10 mIoU, boundary mIoU): every region snapped 0.894 /
    /// 0.836 / 0.866; 0.4 → 0.902 / 0.845 / 0.870; **0.25 → 0.920 / 0.865 / 0.879**; 0.15 →
    /// 0.918 / 0.861 / 0.869; 0.08 → 0.908 / 0.848 / 0.850 (below 0.25, regions split by the
    /// blur of the rendered labels at their own outline).
    pub snap_split_share: f32,
    /// In a region split between objects, a band of a neighbouring region's id along that
    /// region at most this thick (its pixels / its contact length) is that object's splats
    /// bleeding across SAM's boundary, and goes to the region's own objects ([`crate::snap`]).
    /// In pixels of a 320×240 view; larger views scale it by the square root of their pixel
    /// count / 76,800 ([`LiftConfig::snap_bleed_px_for`]). 0 = keep every rendered label.
    pub snap_bleed_px: f32,
    /// Boundary refinement of the final maps by colour ([`crate::refine`]): the half-width of the
    /// window whose interior pixels give each id's mean colour (pixels, not scaled); 0 = off.
    /// Measured on the stress suite's tuning seeds 0–2 (18 scenes; mean of the scenes' mean
    /// instance IoU, by a prototype on the final maps): off 0.952; 1 px 0.954; **2 px 0.971**;
    /// 3 px 0.973; with the images blurred (σ 0.5 / 0.8 / 1.2 px, as a lens or anti-aliasing
    /// would; the synthetic images are not) 2 px still gives 0.972 / 0.971 / 0.964. As landed,
    /// `bench quality` mIoU 0.947 → 0.966 (tuning seeds 4–7: 0.944 → 0.960); with a thin
    /// object's own mean taken over all its pixels when it has no interior one (a post two
    /// pixels wide), 0.970 (4–7: 0.966).
    pub refine_window_px: usize,
    /// Refinement passes in a 320×240 view (each moves a boundary by at most one pixel); larger
    /// views scale it by the square root of their pixel count / 76,800, rounded
    /// ([`LiftConfig::refine_rule_for`]), as the blur of the splats grows with the image side.
    pub refine_passes: usize,
    /// Snapping: a region is also taken for two objects when an id other than its winner has at
    /// least this share of all its rendered pixels in the view inside the region (an object SAM
    /// merged into its neighbour's mask in that view), and covers at least
    /// `snap_contained_min_share` of the region's labelled pixels ([`crate::snap`]); above 1 =
    /// off. Measured on the stress suite's tuning seeds 0–2 (18 scenes; mIoU mean / p10 / min,
    /// boundary mIoU, consistency): off 0.936 / 0.900 / 0.856, 0.901, 0.970; **0.5 → 0.947 /
    /// 0.909 / 0.884, 0.911, 0.979**; 0.3 and 0.7 the same within 0.001. With the ground-truth
    /// labels on the Gaussians, mean mIoU 0.947 → 0.957: the final maps, not the 3D labels, were
    /// what lost most.
    pub snap_contained_share: f32,
    /// See `snap_contained_share` (0.02 and 0.05 give the same scores; 0.1 loses 0.002).
    pub snap_contained_min_share: f32,
    /// …and at least this many pixels of the region, in a 320×240 view (larger views scale it by
    /// their pixel count / 76,800): smaller ids inside a region are fragments of its own object
    /// that kept an id of their own in 3D (without it, the fragments left 0.03 more ids per GT
    /// instance on tuning seeds 4–7).
    pub snap_contained_min_px: u64,
}

/// See [`LiftConfig::final_maps`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FinalMaps {
    /// The label maps rendered back from the Gaussians.
    Rendered,
    /// Rendered ids snapped onto the merged regions (on the synthetic scenes, seeds 0, 1, 5–8,
    /// it lifts the final maps' mIoU from 0.92–0.93 to 0.96–0.99 and their boundary mIoU from
    /// 0.81–0.82 to 0.94–0.96).
    Snapped,
    /// Rendered ids snapped onto the SAM masks resolved into regions, before merging (the
    /// default): a region two objects share after a wrong merge in one view is split again
    /// where SAM had them apart, and each part takes the id the other views give it. On the
    /// stress suite's tuning seeds 0–2 (18 scenes, merge crease gate at 30°): mean mIoU 0.868 →
    /// 0.885, p10 0.815 → 0.828, boundary mIoU 0.832 → 0.849 against `snapped`.
    #[default]
    SnappedRaw,
}

impl FinalMaps {
    /// The per-view region map the rendered ids are snapped onto: `raw` (SAM masks as
    /// regions) or `merged`; `None` for rendered maps.
    pub fn snapped_onto(self) -> Option<&'static str> {
        match self {
            FinalMaps::Rendered => None,
            FinalMaps::Snapped => Some("merged"),
            FinalMaps::SnappedRaw => Some("raw"),
        }
    }
}

/// The view size [`LiftConfig::min_object_px`] is given for.
pub const SPECK_REFERENCE_PX: u64 = 320 * 240;

impl LiftConfig {
    /// The settings for a run whose object descriptors are the model-free colour/texture ones:
    /// `tau_seam` becomes `tau_seam_model_free`.
    pub fn for_model_free_descriptors(&self) -> LiftConfig {
        LiftConfig { tau_seam: self.tau_seam_model_free, ..self.clone() }
    }

    /// The bleeding band's thickness in a view of `view_px` pixels: `snap_bleed_px` scaled by
    /// `sqrt(view_px / 76,800)` (footprints grow with the image's side, not its area).
    pub fn snap_bleed_px_for(&self, view_px: u64) -> f32 {
        self.snap_bleed_px * (view_px as f64 / SPECK_REFERENCE_PX as f64).sqrt() as f32
    }

    /// The snapping rule for views of `view_px` pixels (the bleeding band scaled with
    /// [`LiftConfig::snap_bleed_px_for`], the pixel minimum with the pixel count; the shares do
    /// not depend on the size).
    pub fn snap_rule_for(&self, view_px: u64) -> SnapRule {
        SnapRule {
            split_share: self.snap_split_share,
            contained_share: self.snap_contained_share,
            contained_min_share: self.snap_contained_min_share,
            contained_min_px: (self.snap_contained_min_px as u128 * view_px as u128
                / SPECK_REFERENCE_PX as u128)
                .min(u64::MAX as u128) as u64,
            bleed_px: self.snap_bleed_px_for(view_px),
        }
    }

    /// The boundary refinement for views of `view_px` pixels: `refine_passes` scaled by
    /// `sqrt(view_px / 76,800)`, rounded, at least 1 (unless `refine_passes` is 0).
    pub fn refine_rule_for(&self, view_px: u64) -> RefineRule {
        let scale = (view_px as f64 / SPECK_REFERENCE_PX as f64).sqrt();
        let passes = match self.refine_passes {
            0 => 0,
            p => ((p as f64 * scale).round() as usize).max(1),
        };
        RefineRule { window_px: self.refine_window_px, passes }
    }

    /// The speck threshold for views of `mean_view_px` pixels on average: `min_object_px` scaled
    /// by `mean_view_px / 76,800`, never below `min_object_px`.
    pub fn min_object_px_for(&self, mean_view_px: u64) -> u64 {
        let scaled = self.min_object_px as u128 * mean_view_px as u128 / SPECK_REFERENCE_PX as u128;
        (scaled.min(u64::MAX as u128) as u64).max(self.min_object_px)
    }
}

impl Default for LiftConfig {
    fn default() -> Self {
        LiftConfig {
            depth_rel_tol: 0.03,
            depth_sigma_tol: 1.0,
            surface_transmittance: 0.5,
            tau_var: 0.2,
            unreliable_render_weight: 0.25,
            tau_touching: 0.95,
            min_together_share: 0.0,
            min_object_px: 64,
            tau_seam: 0.8,
            seam_smooth_share: 0.9,
            seam_max_angle_deg: 10.0,
            split_disconnected: true,
            split_voxel_factor: 3.0,
            min_split_gaussians: 32,
            contact_voxel_factor: 3.0,
            min_contact_voxels: 8,
            min_views: 1,
            min_frontal: 0.05,
            near: 0.01,
            final_maps: FinalMaps::default(),
            tau_seam_model_free: 0.5,
            tau_part: 0.85,
            part_min_together_share: 0.5,
            part_max_concave_share: 0.05,
            part_min_convex_share: 0.1,
            thin_min_elongation: 5.0,
            snap_split_share: 0.25,
            snap_contained_share: 0.5,
            snap_contained_min_share: 0.05,
            snap_contained_min_px: 32,
            snap_bleed_px: 4.0,
            refine_window_px: 2,
            refine_passes: 1,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_speck_threshold_scales_with_the_view_size_and_never_falls_below_its_value() {
        let c = LiftConfig::default();
        assert_eq!(c.min_object_px_for(320 * 240), c.min_object_px);
        assert_eq!(c.min_object_px_for(1280 * 960), 16 * c.min_object_px);
        assert_eq!(c.min_object_px_for(100 * 100), c.min_object_px);
    }

    #[test]
    fn model_free_runs_use_their_own_seam_cosine_and_nothing_else_changes() {
        let c = LiftConfig { tau_seam: 0.8, tau_seam_model_free: 0.5, ..LiftConfig::default() };
        let m = c.for_model_free_descriptors();
        assert_eq!(m.tau_seam, 0.5);
        assert_eq!(LiftConfig { tau_seam: 0.8, ..m }, c);
    }

    #[test]
    fn the_bleeding_band_scales_with_the_image_side() {
        let c = LiftConfig { snap_bleed_px: 4.0, ..LiftConfig::default() };
        assert_eq!(c.snap_bleed_px_for(320 * 240), 4.0);
        assert_eq!(c.snap_bleed_px_for(1280 * 960), 16.0);
    }

    #[test]
    fn refinement_passes_scale_with_the_image_side_and_zero_stays_off() {
        let c = LiftConfig::default();
        assert_eq!(c.refine_rule_for(320 * 240), RefineRule { window_px: 2, passes: 1 });
        assert_eq!(c.refine_rule_for(1280 * 960), RefineRule { window_px: 2, passes: 4 });
        assert_eq!(c.refine_rule_for(64 * 48).passes, 1);
        let off = LiftConfig { refine_passes: 0, ..LiftConfig::default() };
        assert_eq!(off.refine_rule_for(1280 * 960).passes, 0);
    }
}
