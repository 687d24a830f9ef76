//! `lift` stage: visibility-aware lifting of global object ids and features onto the 3D
//! Gaussians (paper §4.3, "Feature Lifting", "3D Mask ID Assignment", "Variance-based
//! Reliability Filtering").
//!
//! What `pipeline` calls: [`view_visibility`] once per view in its per-view pass, then
//! [`LiftStage::run`] ([`final_maps`]) from the votes to the final label maps, reading each
//! view's visible Gaussians back through its [`ViewStore`]; [`render_label_map`] renders ids
//! back from any labelled Gaussians (also after training).
//!
//! - [`project`]: Gaussians prepared once, and projected per view by the renderer
//!   (`splatseg_render::ProjectedView`; its compositor `visit_contributions` is the only one).
//! - [`visibility`]: which Gaussians a view sees (depth test against the composited surface),
//!   where their centre lands, and their fusion weight (frontal, near views weigh more).
//! - [`final_maps`]: the stage after the per-view pass, step by step, streaming view by view.
//! - [`lifting`]: majority vote of the global ids, weighted feature fusion, variance filter.
//! - `graph`: the object graph: touching objects as edges with their evidence (surface, views,
//!   appearance), gathered once.
//! - `decision`: one decision over the graph's pooled evidence (`[objects] decision = "evidence"`).
//! - [`touching`]: objects that touch in 3D and look alike (or meet as parts of one object) become one.
//! - [`split`]: objects whose Gaussians lie apart in 3D become several.
//! - `shape`: the typical Gaussian size, planes, thin lines and contacts between objects in 3D.
//! - [`facing`]: which way each Gaussian's surface faces (towards the cameras that see it).
//! - [`render_labels`]: label maps rendered back from the labelled Gaussians.
//! - [`snap`]: rendered ids snapped onto a view's regions (optional final maps).
//! - [`refine`]: the final maps' boundary pixels refined by the image's colours.
//! - [`run_lengths`]: label maps kept as runs until the steps that need every view.
//! - [`numbering`]: specks dropped, final stable renumbering of the ids.
//! - [`labelled_ply`]: the input PLY's rows written with their ids and fused features.
//!
//! Views are independent and run in parallel with rayon; per-Gaussian work runs over Gaussian
//! ranges in parallel with views in fixed order, so results do not depend on the thread count.

pub mod config;
mod decision;
pub mod error;
pub mod facing;
pub mod final_maps;
mod graph;
pub mod labelled_ply;
pub mod lifting;
pub mod numbering;
pub mod project;
pub mod refine;
pub mod render_labels;
pub mod run_lengths;
mod shape;
pub mod snap;
pub mod split;
pub mod touching;
pub mod visibility;
mod voxels;

pub use config::{Decision, FinalMaps, LiftConfig};
pub use error::{LiftError, LiftResult};
pub use facing::Facing;
pub use final_maps::{LiftOutput, LiftStage, MatchedViews, ViewRegions, ViewStore, VisibleGaussians};
pub use graph::{EdgeRecord, SamViews, ViewCounts};
pub use labelled_ply::{ids_of_every_row, write_labelled_ply};
pub use lifting::{FusedFeatures, GaussianStatus, LiftStats, Lifted, ObjectFeatures, VoteAccumulator};
pub use numbering::{drop_specks_and_number, renumber};
pub use project::{project_view, project_view_binned, raster_settings, PreparedGaussians};
pub use refine::{refine_boundaries, RefineRule};
pub use render_labels::{render_label_map, render_votes, RenderVotes};
pub use run_lengths::RunLengths;
pub use snap::{snap_view, SnapRule, Snapped};
pub use split::{split_disconnected_objects, SplitStats};
pub use touching::{join_touching_objects, JoinReport, SeparateWholes};
pub use visibility::{view_visibility, ViewVisibility, VisibilityPass};

use splatseg_scene::{Camera, Pose};

/// One posed camera.
#[derive(Clone, Copy, Debug)]
pub struct PosedCamera<'a> {
    /// Intrinsics and image size.
    pub camera: &'a Camera,
    /// Camera-to-world pose.
    pub world_from_cam: &'a Pose,
}
