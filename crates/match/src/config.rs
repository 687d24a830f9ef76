//! [`MatchConfig`]: cross-view matching (paper §4.3), the `[match]` table of the `--config`
//! TOML. τ_match is the paper's (0.7); the 3D-evidence thresholds are ours,
//! measured on the stress suite; the numbers a user has no reason to set are the constants below.

use serde::{Deserialize, Serialize};

/// 3D evidence: a mask pair's Gaussian overlap is trusted when each mask has at least this many
/// Gaussians also visible in the other's view ("support"); fewer is too few to tell overlap
/// from the depth test's noise.
pub const MIN_SUPPORT: u32 = 20;

/// 3D evidence: masks with support whose overlap is below this are a cannot-link pair (no chain
/// of descriptor-only edges may put them in one object): well under `tau_overlap` (0.5), so only
/// masks that clearly cover different Gaussians.
pub const TAU_REJECT: f32 = 0.2;

/// Thresholds of [`crate::match_masks`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MatchConfig {
    /// Paper τ_match: two masks of different views with no 3D evidence share a global id when
    /// the cosine of their mean descriptors exceeds this (unitless, paper: 0.7).
    pub tau_match: f32,
    /// 3D evidence: masks with support join when their Gaussian containment overlap
    /// `|S_i ∩ S_j| / min(|S_i ∩ V_b|, |S_j ∩ V_a|)` is at least this (a share; ours: 0.5).
    pub tau_overlap: f32,
    /// With supporting 3D overlap the descriptor gate is lowered from `tau_match` to this cosine
    /// (far-apart views of one object look different), not removed (ours: 0.5).
    pub tau_match_with_3d: f32,
    /// Memory bound: Gaussian view pairs counted for 3D evidence; above it Gaussians are
    /// subsampled with a fixed stride (pairs; keeps million-Gaussian scenes fast).
    pub max_pair_samples: u64,
    /// Memory bound: candidate edges (and cannot-links) kept; each mask keeps its best
    /// `max(16, max_candidate_edges / n_masks)` (edges; every capture up to ~700 masks keeps all).
    pub max_candidate_edges: u64,
}

/// `[matching]` keys of earlier versions (the table is `[match]` now) and what became of them.
pub const RETIRED_KEYS: &[(&str, &str)] = &[
    ("min_support", "is now the constant splatseg_match::config::MIN_SUPPORT (20)"),
    ("tau_reject", "is now the constant splatseg_match::config::TAU_REJECT (0.2)"),
    ("min_fragment_views", "was removed with the fragment joins (issue 27's ablation, BENCHMARKS.md)"),
    (
        "fragment_majority",
        "was removed with the fragment joins: they changed no result on the tuning families and \
         none for the better on the blind ones (issue 27's ablation, BENCHMARKS.md)",
    ),
];

impl Default for MatchConfig {
    fn default() -> Self {
        MatchConfig {
            tau_match: 0.7,
            tau_overlap: 0.5,
            tau_match_with_3d: 0.5,
            max_pair_samples: 40_000_000,
            max_candidate_edges: 500_000,
        }
    }
}
