//! `lift` stage: visibility-aware lifting of global object ids and features onto the 3D
//! Gaussians (paper §4.3, "Feature Lifting", "3D Mask ID Assignment", "Variance-based
//! Reliability Filtering").
//!
//! - [`prepared`]: the Gaussians' geometry, checked once.
//! - [`contributions`]: per view, each Gaussian's summed blending weight `α·T` over the pixels
//!   of each mask, from the renderer's own compositor (`splatseg_render::visit_contributions`:
//!   lift has none of its own); the surface depth of a view.
//! - [`lifting`]: the id of largest summed contribution (FlashSplat's assignment), weighted
//!   feature fusion and the variance filter over the views' votes.
//! - [`render_labels`]: label maps rendered back from the labelled Gaussians.
//! - [`snap`]: rendered ids snapped onto a view's merged regions (optional final maps).
//! - [`touching`]: objects that touch in 3D and look alike become one.
//! - [`numbering`]: final stable renumbering of the ids.
//!
//! Views are independent and run in parallel with rayon ([`render_all`]); per-Gaussian work runs over Gaussian ranges in parallel with views in fixed
//! order, so results do not depend on the thread count.

pub mod config;
pub mod contributions;
pub mod error;
pub mod lifting;
pub mod numbering;
pub mod prepared;
pub mod render_labels;
pub mod snap;
pub mod touching;

pub use config::{FinalMaps, IdRule, LiftConfig};
pub use contributions::{view_contributions, view_surface_depth, DominantLabel, ViewContributions};
pub use error::{LiftError, LiftResult};
pub use lifting::{lift_labels, CoVotes, GaussianStatus, LiftStats, LiftView, Lifted, ObjectFeatures};
pub use numbering::{drop_small_objects, renumber};
pub use prepared::PreparedGaussians;
pub use render_labels::{render_label_map, render_votes, RenderVotes};
pub use snap::snap_to_regions;
pub use touching::{covote_joins, join_touching_objects, seen_apart, touching_joins};

use rayon::prelude::*;
use splatseg_scene::{Camera, Plane, Pose};

/// One posed camera.
#[derive(Clone, Copy, Debug)]
pub struct PosedCamera<'a> {
    /// Intrinsics and image size.
    pub camera: &'a Camera,
    /// Camera-to-world pose.
    pub world_from_cam: &'a Pose,
}

/// [`render_label_map`] for every view, in parallel.
pub fn render_all(
    gaussians: &PreparedGaussians,
    votes: &RenderVotes,
    cameras: &[PosedCamera],
    config: &LiftConfig,
) -> LiftResult<Vec<Plane<u32>>> {
    cameras
        .par_iter()
        .map(|c| render_label_map(gaussians, votes, c.camera, c.world_from_cam, config))
        .collect()
}

/// Checks that every per-view map (`[n_views]`) has its camera's size.
pub fn check_map_sizes<T>(cameras: &[PosedCamera], maps: &[Plane<T>]) -> LiftResult<()> {
    if maps.len() != cameras.len() {
        return Err(LiftError::Count { what: "per-view maps", got: maps.len(), expected: cameras.len() });
    }
    for (view, (c, m)) in cameras.iter().zip(maps).enumerate() {
        let (want_w, want_h) = (c.camera.width as usize, c.camera.height as usize);
        if m.width != want_w || m.height != want_h {
            return Err(LiftError::LabelMapSize { view, got_w: m.width, got_h: m.height, want_w, want_h });
        }
    }
    Ok(())
}
