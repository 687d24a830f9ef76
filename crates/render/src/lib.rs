//! `render` stage: a tile-based CPU rasteriser for 3D Gaussians, forward and backward,
//! following gsplat's math (see the render section of the workspace `BENCHMARKS.md` for speed).
//!
//! Pipeline, one module per kernel (each with its backward):
//! - [`project`]: 3D Gaussians → screen-space splats (EWA, 0.3 px low-pass, culling).
//! - [`sh`]: view-dependent colour from spherical harmonics, degree 0–3.
//! - [`bin`]: 16×16 tile lists sorted by depth.
//! - [`rasterise`]: front-to-back alpha blending of any number of channels.
//! - [`render()`](render::render) / [`render_bwd`]: the whole pass, driven by
//!   a [`RenderRequest`] (rgb, expected depth, alpha, max-weight ids, features).
//! - [`contributions`]: per pixel, the Gaussians blended front to back with their weights `α·T`
//!   (the one compositor label lifting and label rendering use).
//! - [`export`]: PNG / `.npy` writers for rendered outputs.
//!
//! ```
//! use splatseg_render::{render, RenderCamera, RenderRequest};
//! use splatseg_scene::{Camera, Gaussians, Pose};
//! let mut g = Gaussians::default();
//! g.means.push([0.0, 0.0, 3.0]);
//! g.log_scales.push([-2.0; 3]);
//! g.rotations.push([1.0, 0.0, 0.0, 0.0]);
//! g.raw_opacities.push(4.0);
//! g.sh_dc.push([1.0, 0.0, 0.0]);
//! let camera = RenderCamera::from_scene(&Camera::pinhole(1, 32, 32, 30.0, 30.0, 16.0, 16.0), &Pose::IDENTITY);
//! let out = render(&g, &camera, &RenderRequest::all()).unwrap();
//! assert_eq!(out.max_weight_ids.unwrap().get(16, 16), &0);
//! ```
//!
//! Conventions: `CONVENTIONS.md` (OpenCV camera axes, pixel centres at +0.5, quaternions w,x,y,z).

pub mod bin;
pub mod camera;
pub mod contributions;
pub mod error;
pub mod export;
mod fast_exp;
mod footprint;
pub mod project;
mod project_lanes;
pub mod rasterise;
mod reach_lanes;
pub mod render;
pub mod request;
pub mod settings;
pub mod sh;

pub use camera::RenderCamera;
pub use contributions::{prefetch, visit_contributions, Contribution, ContributionVisitor, ProjectedView};
pub use error::{RenderError, RenderResult};
pub use render::{render, render_bwd, render_with_state, RenderState};
pub use request::{FeatureInput, GaussianGrads, OutputGrads, RenderOutput, RenderRequest, RenderStats};
pub use settings::{Extent, RasterSettings};
