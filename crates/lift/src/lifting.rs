//! [`VoteAccumulator`]: the views' global ids at the visible Gaussians' centres → one object id
//! (and a fused feature) per Gaussian.
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
//! anyway). Votes are accumulated one view at a time ([`VoteAccumulator`]: memory independent of
//! the number of views), over Gaussian ranges in parallel, views in a fixed order, so the result
//! does not depend on the thread count.

use crate::config::LiftConfig;
use crate::error::{LiftError, LiftResult};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

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
    /// Fused features f_g (`[N, dim]`, made row by row on demand), when object features were
    /// given (dim > 0).
    pub fused_features: Option<FusedFeatures>,
    /// Counts per status.
    pub stats: LiftStats,
}

/// The fused features `f_g = Σ_v w_v f_{k_v} / Σ_v w_v` of every Gaussian, kept as the terms of
/// the sum (at most [`SLOTS`] ids and their normalised weights per Gaussian, 64 bytes) and the
/// `[n_objects, dim]` object features, not as an `[N, dim]` block (1.5 kB per Gaussian at D = 384):
/// rows are made when asked, e.g. while the PLY is written. Rows equal what the variance filter
/// computed, bit for bit.
#[derive(Clone, Debug, PartialEq)]
pub struct FusedFeatures {
    /// Feature dimension D.
    pub dim: usize,
    /// `[n_objects, dim]` unit object features; row `k − 1` belongs to id `k`.
    objects: Vec<f32>,
    /// `[N · SLOTS]` (object id, weight / total), id 0 = no term.
    terms: Vec<FusionTerm>,
}

impl FusedFeatures {
    /// Writes f_g of Gaussian `g` (`[dim]`) into `out`.
    pub fn row(&self, g: usize, out: &mut [f32]) {
        out.iter_mut().for_each(|x| *x = 0.0);
        for &(id, w) in &self.terms[g * SLOTS..(g + 1) * SLOTS] {
            if id == 0 {
                continue;
            }
            let f = &self.objects[(id as usize - 1) * self.dim..id as usize * self.dim];
            for (o, x) in out.iter_mut().zip(f) {
                *o += w * x;
            }
        }
    }
}

/// One term of f_g: (object id, weight / total).
type FusionTerm = (u32, f32);

/// The terms of f_g for one Gaussian's slots, in slot order (as [`fuse`] sums them).
fn fusion_terms(slots: &[Slot]) -> [(u32, f32); SLOTS] {
    let mut terms = [(0u32, 0f32); SLOTS];
    let total: f32 = slots.iter().filter(|s| s.id > 0).map(|s| s.weight).sum();
    if total <= 0.0 {
        return terms;
    }
    for (t, s) in terms.iter_mut().zip(slots.iter().filter(|s| s.id > 0)) {
        *t = (s.id, s.weight / total);
    }
    terms
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

/// Gaussians per parallel work item of the vote accumulation and the decisions.
const CHUNK: usize = 16_384;

/// The votes of every Gaussian, accumulated one view at a time (memory: `[N]` vote slots,
/// whatever the number of views). Views must be added in a fixed order (the scene's) for results
/// that do not depend on the order views finished in; inside a view the work is split over
/// Gaussian ranges, so the thread count does not matter either.
#[derive(Clone)]
pub struct VoteAccumulator {
    /// `[N]` vote slots.
    slots: Vec<[Slot; SLOTS]>,
    /// `[N]` slots in use.
    used: Vec<u8>,
    /// Largest id voted for.
    max_id: u32,
    /// Views added.
    views: usize,
}

impl VoteAccumulator {
    /// No votes yet for `n_gaussians` Gaussians.
    pub fn new(n_gaussians: usize) -> Self {
        VoteAccumulator {
            slots: vec![[Slot::default(); SLOTS]; n_gaussians],
            used: vec![0; n_gaussians],
            max_id: 0,
            views: 0,
        }
    }

    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.used.len()
    }

    /// True for no Gaussians.
    pub fn is_empty(&self) -> bool {
        self.used.is_empty()
    }

    /// Adds one view's votes: `gaussians: [n_visible]` strictly increasing indices (as
    /// [`ViewVisibility::gaussians`]), `weights: [n_visible]` fusion weights, `ids: [n_visible]` the
    /// global id at each one's centre pixel (0 = none).
    pub fn add_view(&mut self, gaussians: &[u32], weights: &[f32], ids: &[u32]) -> LiftResult<()> {
        let view = self.views;
        for (what, len) in [("fusion weights", weights.len()), ("ids", ids.len())] {
            if len != gaussians.len() {
                return Err(LiftError::Count { what, got: len, expected: gaussians.len() });
            }
        }
        if gaussians.windows(2).any(|w| w[0] >= w[1])
            || gaussians.last().is_some_and(|&g| g as usize >= self.len())
        {
            return Err(LiftError::VisibleList { view, n_gaussians: self.len() });
        }
        self.slots.par_chunks_mut(CHUNK).zip(self.used.par_chunks_mut(CHUNK)).enumerate().for_each(
            |(c, (slots, used))| {
                let (lo, hi) = (c * CHUNK, c * CHUNK + slots.len());
                let start = gaussians.partition_point(|&g| (g as usize) < lo);
                let end = gaussians.partition_point(|&g| (g as usize) < hi);
                for k in start..end {
                    let g = gaussians[k] as usize - lo;
                    let mut u = used[g] as usize;
                    vote(&mut slots[g], &mut u, ids[k], weights[k]);
                    used[g] = u as u8;
                }
            },
        );
        self.max_id = self.max_id.max(ids.iter().copied().max().unwrap_or(0));
        self.views += 1;
        Ok(())
    }

    /// The majority vote, fusion and variance filter of every Gaussian (see the module docs).
    pub fn finish(self, features: ObjectFeatures, config: &LiftConfig) -> LiftResult<Lifted> {
        if features.dim > 0 && self.max_id as usize > features.n_objects() {
            return Err(LiftError::UnknownObject {
                view: 0,
                id: self.max_id,
                n_objects: features.n_objects(),
            });
        }
        let n_gaussians = self.len();
        let dim = features.dim;
        let chunks: Vec<(Vec<Decision>, Vec<FusionTerm>)> = self
            .slots
            .par_chunks(CHUNK)
            .zip(self.used.par_chunks(CHUNK))
            .map(|(slots, used)| {
                let mut decisions = Vec::with_capacity(slots.len());
                let mut terms = Vec::with_capacity(if dim > 0 { slots.len() * SLOTS } else { 0 });
                let mut fused = vec![0f32; dim];
                for (s, &u) in slots.iter().zip(used) {
                    decisions.push(decide(&s[..u as usize], &features, config, &mut fused));
                    if dim > 0 {
                        terms.extend(fusion_terms(&s[..u as usize]));
                    }
                }
                (decisions, terms)
            })
            .collect();
        drop(self);
        let mut lifted = Lifted {
            object_ids: Vec::with_capacity(n_gaussians),
            status: Vec::with_capacity(n_gaussians),
            majority_ids: Vec::with_capacity(n_gaussians),
            variances: Vec::with_capacity(n_gaussians),
            views_seen: Vec::with_capacity(n_gaussians),
            fused_features: None,
            stats: LiftStats::default(),
        };
        let mut terms = Vec::with_capacity(if dim > 0 { n_gaussians * SLOTS } else { 0 });
        for (decisions, t) in chunks {
            for d in decisions {
                lifted.object_ids.push(d.object_id);
                lifted.status.push(d.status);
                lifted.majority_ids.push(d.majority);
                lifted.variances.push(d.variance);
                lifted.views_seen.push(d.views);
            }
            terms.extend(t);
        }
        if dim > 0 {
            lifted.fused_features = Some(FusedFeatures { dim, objects: features.values.to_vec(), terms });
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
