//! [`lift_labels`]: per-view global-id maps → one object id (and a fused feature) per Gaussian.
//!
//! For Gaussian `g` and every view `v` that sees it ([`crate::visibility`]), the id `k_v` of the
//! mask its centre falls in is one vote (0 = the centre falls in no mask). Then
//! - `ID_g` = the id with most votes (paper: majority vote; ties → larger summed fusion weight,
//!   then smaller id); a winning 0 means "no object" (`-1`);
//! - `f_g = Σ_v w_v f_{k_v} / Σ_v w_v` over the views with `k_v ≥ 1`, where `f_k` is the unit
//!   identity feature of global object `k` (the matched cluster's mean descriptor);
//! - `σ²_feat = Σ_v w_v ‖f_{k_v} − f_g‖² / Σ_v w_v` (= 1 − ‖f_g‖² for unit features: 0 when all views
//!   agree, larger the more and the more dissimilar the ids they disagree on); a Gaussian with
//!   `σ²_feat > τ_var` is unreliable and gets `-1`, as does one seen in fewer than `min_views`.
//!
//! Votes are kept in [`SLOTS`] slots per Gaussian (id, count, weight); a Gaussian voted for by
//! more distinct ids than that drops the id with the fewest votes (rare: it would be unreliable
//! anyway). Accumulation runs over Gaussian ranges in parallel, views in fixed order inside, so
//! the result does not depend on the thread count.

use crate::config::LiftConfig;
use crate::error::{LiftError, LiftResult};
use crate::visibility::ViewVisibility;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use splatseg_scene::gaussians::FeatureBlock;
use splatseg_scene::Plane;

/// Vote slots per Gaussian.
pub const SLOTS: usize = 8;

/// Identity features of the global objects.
#[derive(Clone, Copy, Debug)]
pub struct ObjectFeatures<'a> {
    /// Feature dimension D (0 = no features: variance is 0, nothing is fused).
    pub dim: usize,
    /// `[n_objects, dim]` unit features; row `k − 1` belongs to id `k`.
    pub values: &'a [f32],
}

impl ObjectFeatures<'_> {
    /// Number of objects covered.
    pub fn n_objects(&self) -> usize {
        self.values.len().checked_div(self.dim).unwrap_or(usize::MAX)
    }

    /// The feature of object `id` (`[dim]`; `id` in `1..=n_objects`).
    pub fn row(&self, id: u32) -> &[f32] {
        &self.values[(id as usize - 1) * self.dim..id as usize * self.dim]
    }
}

/// What lifting decided for one Gaussian.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum GaussianStatus {
    /// Seen in no view.
    Unseen,
    /// Seen in fewer than `min_views` views.
    TooFewViews,
    /// The majority of its views put it in no mask.
    NoObject,
    /// Its feature variance exceeds τ_var.
    Unreliable,
    /// It carries an object id.
    Labelled,
}

/// Per-Gaussian results of lifting.
#[derive(Clone, Debug, PartialEq)]
pub struct Lifted {
    /// `[N]` object id (≥ 1) or -1.
    pub object_ids: Vec<i32>,
    /// `[N]` why each Gaussian got what it got.
    pub status: Vec<GaussianStatus>,
    /// `[N]` majority id before the variance filter (0 = no object / unseen).
    pub majority_ids: Vec<u32>,
    /// `[N]` feature variance σ²_feat (0 when seen in no labelled view).
    pub variances: Vec<f32>,
    /// `[N]` number of views that see each Gaussian.
    pub views_seen: Vec<u32>,
    /// `[N, dim]` fused features f_g, when object features were given (dim > 0).
    pub fused_features: Option<FeatureBlock>,
    /// Counts per status.
    pub stats: LiftStats,
}

/// How many Gaussians ended in each state.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LiftStats {
    /// Gaussians with an id.
    pub labelled: usize,
    /// Filtered by the variance test.
    pub unreliable: usize,
    /// Majority "no mask".
    pub no_object: usize,
    /// Seen in too few views (including none).
    pub unseen: usize,
}

#[derive(Clone, Copy, Default)]
struct Slot {
    id: u32,
    count: u32,
    weight: f32,
}

fn vote(slots: &mut [Slot; SLOTS], used: &mut usize, id: u32, weight: f32) {
    if let Some(s) = slots[..*used].iter_mut().find(|s| s.id == id) {
        s.count += 1;
        s.weight += weight;
        return;
    }
    if *used < SLOTS {
        slots[*used] = Slot { id, count: 1, weight };
        *used += 1;
        return;
    }
    // Full: replace the weakest slot (fewest votes, then least weight, then larger id).
    let weakest = (0..SLOTS)
        .min_by(|&a, &b| {
            let (x, y) = (slots[a], slots[b]);
            x.count.cmp(&y.count).then(x.weight.total_cmp(&y.weight)).then(y.id.cmp(&x.id))
        })
        .unwrap_or(0);
    if slots[weakest].count <= 1 {
        slots[weakest] = Slot { id, count: 1, weight };
    }
}

/// Checks sizes and ids of the per-view global-id maps.
fn validate(
    visibility: &[ViewVisibility],
    id_maps: &[Plane<u32>],
    features: &ObjectFeatures,
) -> LiftResult<()> {
    if id_maps.len() != visibility.len() {
        return Err(LiftError::Count { what: "label maps", got: id_maps.len(), expected: visibility.len() });
    }
    if features.dim > 0 {
        for (view, map) in id_maps.iter().enumerate() {
            if let Some(&id) = map.data.iter().find(|&&id| id as usize > features.n_objects()) {
                return Err(LiftError::UnknownObject { view, id, n_objects: features.n_objects() });
            }
        }
    }
    Ok(())
}

/// Lifts per-view global-id maps onto `n_gaussians` Gaussians (see the module docs).
///
/// `visibility: [n_views]` from [`crate::view_visibility`]; `id_maps: [n_views]`, each
/// `[height, width]` of that view, value = global id (0 = none). The caller checks map sizes
/// against the cameras ([`crate::check_map_sizes`]); pixel indices out of a map are an error.
pub fn lift_labels(
    n_gaussians: usize,
    visibility: &[ViewVisibility],
    id_maps: &[Plane<u32>],
    features: ObjectFeatures,
    config: &LiftConfig,
) -> LiftResult<Lifted> {
    validate(visibility, id_maps, &features)?;
    for (view, (vis, map)) in visibility.iter().zip(id_maps).enumerate() {
        if vis.pixels.iter().any(|&p| p as usize >= map.data.len()) {
            return Err(LiftError::MapTooSmall { view, pixels: map.data.len() });
        }
    }
    const CHUNK: usize = 16_384;
    let dim = features.dim;
    let chunks: Vec<(Vec<Decision>, Vec<f32>)> = (0..n_gaussians.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let (lo, hi) = (c * CHUNK, ((c + 1) * CHUNK).min(n_gaussians));
            let mut slots = vec![[Slot::default(); SLOTS]; hi - lo];
            let mut used = vec![0usize; hi - lo];
            for (vis, map) in visibility.iter().zip(id_maps) {
                let start = vis.gaussians.partition_point(|&g| (g as usize) < lo);
                let end = vis.gaussians.partition_point(|&g| (g as usize) < hi);
                for k in start..end {
                    let g = vis.gaussians[k] as usize - lo;
                    let id = map.data[vis.pixels[k] as usize];
                    vote(&mut slots[g], &mut used[g], id, vis.weights[k]);
                }
            }
            let mut decisions = Vec::with_capacity(hi - lo);
            let mut fused_chunk = Vec::with_capacity((hi - lo) * dim);
            let mut fused = vec![0f32; dim];
            for (s, &u) in slots.iter().zip(&used) {
                decisions.push(decide(&s[..u], &features, config, &mut fused));
                fused_chunk.extend_from_slice(&fused);
            }
            (decisions, fused_chunk)
        })
        .collect();
    let mut lifted = Lifted {
        object_ids: Vec::with_capacity(n_gaussians),
        status: Vec::with_capacity(n_gaussians),
        majority_ids: Vec::with_capacity(n_gaussians),
        variances: Vec::with_capacity(n_gaussians),
        views_seen: Vec::with_capacity(n_gaussians),
        fused_features: None,
        stats: LiftStats::default(),
    };
    let mut fused = Vec::with_capacity(n_gaussians * dim);
    for (decisions, f) in chunks {
        for d in decisions {
            lifted.object_ids.push(d.object_id);
            lifted.status.push(d.status);
            lifted.majority_ids.push(d.majority);
            lifted.variances.push(d.variance);
            lifted.views_seen.push(d.views);
        }
        fused.extend(f);
    }
    if dim > 0 {
        lifted.fused_features = Some(FeatureBlock { dim, values: fused });
    }
    for s in &lifted.status {
        match s {
            GaussianStatus::Labelled => lifted.stats.labelled += 1,
            GaussianStatus::Unreliable => lifted.stats.unreliable += 1,
            GaussianStatus::NoObject => lifted.stats.no_object += 1,
            GaussianStatus::Unseen | GaussianStatus::TooFewViews => lifted.stats.unseen += 1,
        }
    }
    Ok(lifted)
}

#[derive(Clone, Copy)]
struct Decision {
    object_id: i32,
    status: GaussianStatus,
    majority: u32,
    variance: f32,
    views: u32,
}

/// Majority vote, fusion and variance test for one Gaussian's slots; writes f_g into `fused`.
fn decide(slots: &[Slot], features: &ObjectFeatures, config: &LiftConfig, fused: &mut [f32]) -> Decision {
    fused.iter_mut().for_each(|x| *x = 0.0);
    let views: u32 = slots.iter().map(|s| s.count).sum();
    let winner = slots
        .iter()
        .copied()
        .max_by(|x, y| x.count.cmp(&y.count).then(x.weight.total_cmp(&y.weight)).then(y.id.cmp(&x.id)));
    let Some(winner) = winner else {
        return Decision { object_id: -1, status: GaussianStatus::Unseen, majority: 0, variance: 0.0, views };
    };
    let variance = fuse(slots, features, fused);
    let status = if views < config.min_views {
        GaussianStatus::TooFewViews
    } else if winner.id == 0 {
        GaussianStatus::NoObject
    } else if variance > config.tau_var {
        GaussianStatus::Unreliable
    } else {
        GaussianStatus::Labelled
    };
    let object_id = if status == GaussianStatus::Labelled { winner.id as i32 } else { -1 };
    Decision { object_id, status, majority: winner.id, variance, views }
}

/// Weighted mean of the identity features of the labelled votes (into `fused`) and the
/// weighted variance around it.
fn fuse(slots: &[Slot], features: &ObjectFeatures, fused: &mut [f32]) -> f32 {
    if features.dim == 0 {
        return 0.0;
    }
    let labelled = || slots.iter().filter(|s| s.id > 0);
    let total: f32 = labelled().map(|s| s.weight).sum();
    if total <= 0.0 {
        return 0.0;
    }
    let mut mean_sq_norm = 0.0;
    for s in labelled() {
        let f = features.row(s.id);
        let w = s.weight / total;
        for (o, x) in fused.iter_mut().zip(f) {
            *o += w * x;
        }
        mean_sq_norm += w * f.iter().map(|x| x * x).sum::<f32>();
    }
    let fused_sq: f32 = fused.iter().map(|x| x * x).sum();
    (mean_sq_norm - fused_sq).max(0.0)
}
