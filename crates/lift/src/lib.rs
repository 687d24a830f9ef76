//! `lift` stage: visibility-aware lifting of global object ids and features onto the 3D
//! Gaussians (paper §4.3, "Feature Lifting", "3D Mask ID Assignment", "Variance-based
//! Reliability Filtering").
//!
//! - [`project`]: Gaussians prepared once, and projected per view by the renderer
//!   (`splatseg_render::ProjectedView`; its compositor `visit_contributions` is the only one).
//! - [`visibility`]: which Gaussians a view sees (depth test against the composited surface),
//!   where their centre lands, and their fusion weight (frontal, near views weigh more).
//! - [`lifting`]: majority vote of the global ids, weighted feature fusion, variance filter.
//! - [`render_labels`]: label maps rendered back from the labelled Gaussians.
//! - [`snap`]: rendered ids snapped onto a view's merged regions (optional final maps).
//! - [`touching`]: objects that touch in 3D and look alike (or meet as parts of one object) become one.
//! - `shape`: the typical Gaussian size, planes, thin lines and contacts between objects in 3D.
//! - [`facing`]: which way each Gaussian's surface faces (towards the cameras that see it).
//! - [`numbering`]: final stable renumbering of the ids.
//!
//! Views are independent and run in parallel with rayon ([`visibility_all`],
//! [`render_all`]); per-Gaussian work runs over Gaussian ranges in parallel with views in fixed
//! order, so results do not depend on the thread count.

pub mod config;
pub mod error;
pub mod facing;
pub mod lifting;
pub mod numbering;
pub mod project;
pub mod refine;
pub mod render_labels;
mod shape;
pub mod snap;
pub mod split;
pub mod touching;
pub mod visibility;
mod voxels;

pub use config::{FinalMaps, LiftConfig};
pub use error::{LiftError, LiftResult};
pub use facing::Facing;
pub use lifting::{
    lift_labels, FusedFeatures, GaussianStatus, LiftStats, Lifted, ObjectFeatures, VoteAccumulator,
};
pub use numbering::{drop_small_objects, renumber};
pub use project::{project_view, project_view_binned, raster_settings, PreparedGaussians};
pub use refine::{refine_boundaries, RefineRule};
pub use render_labels::{
    label_map_of_view, render_label_map, render_label_map_binned, render_votes, RenderVotes,
};
pub use snap::{snap_to_regions, snap_view, SnapRule, Snapped};
pub use split::{split_disconnected_objects, SplitStats};
pub use touching::{join_touching_counted, join_touching_objects, ViewCounts};
pub use visibility::{
    surface_depth, view_depth_and_visibility, view_depth_visibility_and_bins, view_surface_depth,
    view_visibility, visible_gaussians, ViewVisibility,
};

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

/// [`view_visibility`] for every view, in parallel. `depths`: optional per-view surface depth
/// maps (`[n_views]`, each `[height, width]`), otherwise the Gaussians' own footprints are used.
pub fn visibility_all(
    gaussians: &PreparedGaussians,
    cameras: &[PosedCamera],
    depths: Option<&[Plane<f32>]>,
    config: &LiftConfig,
) -> LiftResult<Vec<ViewVisibility>> {
    if let Some(d) = depths {
        check_map_sizes(cameras, d)?;
    }
    Ok(cameras
        .par_iter()
        .enumerate()
        .map(|(v, c)| view_visibility(gaussians, c.camera, c.world_from_cam, depths.map(|d| &d[v]), config))
        .collect())
}

/// [`render_label_map`] for every view, in parallel.
pub fn render_all(
    gaussians: &PreparedGaussians,
    votes: &RenderVotes,
    cameras: &[PosedCamera],
    config: &LiftConfig,
) -> Vec<Plane<u32>> {
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
