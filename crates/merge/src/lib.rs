//! `merge` stage: Multi-Cue-Guided Mask Merging (paper §4.2), exact to a documented reading of
//! the paper and fast.
//!
//! Entry point: [`merge_view`] on a [`ViewInputs`] (regions from SAM masks, descriptors, depth,
//! `∇D`, LoG edges; built by [`cues::build_view_inputs`] from raw cues) with a [`MergeConfig`].
//! The score, its profiles and the reasons for the default reading (with measured numbers) are
//! documented in [`score`]; the other views' SAM wholes, which [`merge_view_with_wholes`] reads,
//! in [`wholes`]; the adjacency graph in `graph`; the greedy loop in `merge`;
//! measuring against ground truth (ablation, sensitivity) in [`study`], printed by
//! `splatseg ablate`. Speed and quality tables: the merge section of the workspace `BENCHMARKS.md`.

pub mod config;
pub mod cues;
pub mod error;
mod graph;
mod merge;
pub mod score;
pub mod study;
pub mod wholes;

pub use config::{
    retired_merge_setting, BoundaryStatistic, DepthGapAt, MergeConfig, MergeConfigTable, Profile,
    DILATION_STEPS, MAX_MERGES, TAU_CONTACT, TAU_GAP_PX,
};
pub use cues::{build_view_inputs, CueRequest};
pub use error::{MergeError, MergeResultOf};
pub use merge::{
    merge_view, merge_view_with_wholes, Decision, MergeLog, MergeResult, RegionSummary, ViewInputs,
};
pub use score::{Outcome, ScoreTerms};
pub use wholes::{Observed, ViewMaskSets, ViewWholes, WholesCount, WholesEvidence};
