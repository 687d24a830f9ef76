//! What matching reads: per view, the merged masks' descriptors, and optionally which Gaussians
//! each view sees in which mask (the 3D evidence).

/// The merged masks of one view. Mask `k` has the local label `k + 1` in the view's label map
/// (label 0 = unlabelled).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ViewMasks {
    /// `[n_masks, dim]` row-major mask descriptors f̄ (mean feature; need not be normalised).
    pub features: Vec<f32>,
    /// `[n_masks]` mask areas in pixels (weights of the global descriptor mean).
    pub areas_px: Vec<u64>,
}

impl ViewMasks {
    /// Number of masks of the view.
    pub fn len(&self) -> usize {
        self.areas_px.len()
    }

    /// True when the view has no masks.
    pub fn is_empty(&self) -> bool {
        self.areas_px.is_empty()
    }
}

/// Which Gaussians one view sees, and in which of its masks. Built by the lifting stage's
/// visibility test (depth test against a z-buffer of Gaussian footprints).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ViewObservations {
    /// `[n_visible]` indices of the Gaussians visible in the view, strictly increasing.
    pub gaussians: Vec<u32>,
    /// `[n_visible]` local label of the mask each visible Gaussian's centre falls in
    /// (0 = visible but in no mask).
    pub labels: Vec<u32>,
}

/// Everything [`crate::match_masks`] reads.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MatchInput {
    /// Descriptor dimension D (may be 0: then only 3D evidence can join masks).
    pub dim: usize,
    /// `[n_views]` masks per view, in the scene's view order.
    pub views: Vec<ViewMasks>,
    /// `[n_views]` Gaussian observations per view, when Gaussians are available.
    pub observations: Option<Vec<ViewObservations>>,
}
