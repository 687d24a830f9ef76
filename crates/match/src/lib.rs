//! `match` stage: cross-view mask matching (paper §4.3, "Cross-View Mask Matching").
//!
//! Merged masks are view-local; this crate gives every mask a global object id so one object
//! carries one id in every view. The paper's rule — masks of different views share an id when
//! the cosine of their mean descriptors exceeds τ_match = 0.7 — is applied soundly:
//!
//! - **Union-find that refuses unsound joins** ([`cluster`]): candidate edges are processed best
//!   first; two clusters that both hold a mask of one view are never joined (after merging, a
//!   view holds at most one mask per object; a leftover fragment stays a separate cluster and is
//!   absorbed later by the lifting stage's majority vote).
//! - **3D evidence** ([`evidence`]) when Gaussians are available: masks of two views whose
//!   co-visible Gaussians mostly coincide are the same object (even when their descriptors
//!   differ somewhat), and masks whose co-visible Gaussians are disjoint are a cannot-link pair,
//!   however alike they look — this is what keeps the white-on-white pair apart.
//! - **Stable ids**: clusters are numbered by their first mask in (view, local label) order;
//!   every step is deterministic (sorted edges, index tie-breaking, exact integer counting).
//!
//! ```
//! use splatseg_match::{match_masks, MatchConfig, MatchInput, ViewMasks};
//! // Two views with one mask each, descriptors pointing the same way: one object.
//! let view = ViewMasks { features: vec![1.0, 0.0], areas_px: vec![100] };
//! let input = MatchInput { dim: 2, views: vec![view.clone(), view], observations: None };
//! let m = match_masks(&input, &MatchConfig::default()).unwrap();
//! assert_eq!(m.global_of_label, vec![vec![0, 1], vec![0, 1]]);
//! ```

pub mod cluster;
pub mod config;
pub mod error;
pub mod evidence;
pub mod input;
pub mod matching;
#[cfg(test)]
mod matching_tests;

pub use config::MatchConfig;
pub use error::{MatchError, MatchResult};
pub use input::{MatchInput, ViewMasks, ViewObservations};
pub use matching::{match_masks, match_masks_owned, MatchStats, Matching};
