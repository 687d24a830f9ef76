//! [`EvalConfig`]: the choices the metrics depend on, defaulting to the paper's.

use serde::{Deserialize, Serialize};

/// How predicted pixels over unlabelled ground truth (value 0) are counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UnlabelledGt {
    /// Ground-truth 0 is background: a predicted mask spilling onto it is wrong and its pixels
    /// count in the union (the default; what a plain per-image IoU does).
    #[default]
    Background,
    /// Ground-truth 0 is "don't care" (e.g. void classes): those pixels are left out of every
    /// union, so predictions there are neither rewarded nor penalised.
    Ignore,
}

/// Whether predicted ids name the same object in every view.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IdScope {
    /// An id is one object in all views (matched or lifted predictions; the default).
    #[default]
    Global,
    /// Ids are numbered per view (raw SAM masks, merged-only regions): id 3 of one view and id 3
    /// of another are different masks. Each (view, id) is then scored as its own mask, so #masks
    /// is the total over views and cross-view metrics show the lack of association.
    PerView,
}

/// Metric settings (the `[eval]` table of the `--config` TOML).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EvalConfig {
    /// Radius ε of the disk of the boundary band `(M ⊕ ε) \ (M ⊖ ε)`, in pixels (paper: 5).
    pub band_radius_px: u32,
    /// Treatment of ground-truth pixels with value 0.
    pub unlabelled_gt: UnlabelledGt,
    /// Scope of the predicted ids. Not a file key: `run`'s ids are global, and `splatseg eval`
    /// sets it per prediction set (`--view-local`); a settings file naming it gets the pipeline
    /// config's retired-key error. Written and read back with the metrics (metrics.json, the run
    /// cache), so it stays a field that deserialises.
    pub pred_id_scope: IdScope,
}

impl Default for EvalConfig {
    fn default() -> Self {
        EvalConfig {
            band_radius_px: crate::band::PAPER_BAND_RADIUS_PX,
            unlabelled_gt: UnlabelledGt::Background,
            pred_id_scope: IdScope::Global,
        }
    }
}
