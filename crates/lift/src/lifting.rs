//! [`lift_labels`]: per-view contributions ([`crate::contributions`]) → one object id (and a
//! fused feature) per Gaussian.
//!
//! Every view `v` with masks gives, per Gaussian `g` and per global id `k` (0 = pixels in no
//! mask), the summed blending weight `W_v(g, k) = Σ α·T` of `g` over the pixels of `k`: how much
//! `g` is rendered into that object's pixels. Then
//! - `ID_g = argmax_k S(g, k)` over objects `k ≥ 1`; it is "no object" (`-1`) when
//!   `background_weight · S(g, 0)` is larger (ties → smaller id). With `id_rule = "contribution"`,
//!   `S(g, k) = Σ_v W_v(g, k)` (FlashSplat's closed-form assignment: the id that maximises the
//!   Gaussian's total contribution to the pixels of that id); with `"soft_vote"` (default),
//!   `S(g, k) = Σ_v W_v(g, k) / W_v(g)` over the views that see it: each view one vote, split by
//!   contribution, so one view that sees the Gaussian large cannot outvote many that agree; only
//!   the views that see it *clearly* (one label holds at least `min_view_purity` of its weight)
//!   vote when there are any — a Gaussian on an object's silhouette spills half its footprint
//!   over the object behind in grazing views, while the views facing it see it inside its own
//!   object (equal votes go to the larger soft vote of all views, then to the larger summed
//!   contribution);
//! - a view *sees* the Gaussian when `W_v(g) = Σ_k W_v(g, k) ≥ min_view_weight` and its
//!   visibility (mean transmittance over its pixels) is at least `min_visibility`: a Gaussian
//!   behind a surface that lets some light through is not seen there; each such view
//!   with object pixels gives its mean identity feature `f_v = Σ_{k≥1} s_vk f_k`, with
//!   `s_vk = W_v(g, k) / Σ_{k≥1} W_v(g, k)` the Gaussian's object shares in that view and `f_k`
//!   the unit identity feature of global object `k`; the paper's fusion and variance filter run
//!   over these, weighted by `W_v(g)`: `f_g = Σ_v W_v f_v / Σ_v W_v` and
//!   `σ²_feat = Σ_v W_v ‖f_v − f̄‖² / Σ_v W_v` over the *pure* views (largest object share
//!   `≥ min_view_purity`, f̄ their weighted mean): 0 when they agree, larger the more views
//!   disagree and the more dissimilar the ids they disagree on; `σ²_feat > τ_var` makes the
//!   Gaussian unreliable (`-1`), as does being seen in fewer than `min_views` views. Views that
//!   see a Gaussian on an object's silhouette, its footprint half over the next object, are not
//!   pure and do not count as disagreeing.
//!
//! Splitting a Gaussian's weight across the pixels of a mask boundary within one view is no
//! disagreement (its footprint straddles the edge, and every view says so alike); views that see
//! it in different objects are.
//!
//! Per Gaussian at most [`SLOTS`] ids are tracked (for the sums and the votes alike); a Gaussian
//! reaching more distinct ids drops the weakest (rare: it would be unreliable anyway).
//! Accumulation runs over Gaussian ranges in parallel, views in fixed order inside, so the result
//! does not depend on the thread count.

use crate::config::{IdRule, LiftConfig};
use crate::contributions::ViewContributions;
use crate::error::{LiftError, LiftResult};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use splatseg_scene::gaussians::FeatureBlock;

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
    /// Which ids the pure views of one Gaussian share it between (evidence that two ids are
    /// pieces of one object, see [`crate::touching::covote_joins`]).
    pub covotes: CoVotes,
    /// Counts per status.
    pub stats: LiftStats,
}

/// Share of a Gaussian's pure-view weight an id needs to count as voted for in [`CoVotes`].
pub const COVOTE_SHARE: f32 = 0.2;

/// Per id, the Gaussians whose pure views vote for it (with at least [`COVOTE_SHARE`] of their
/// weight), and per pair of ids the Gaussians voted for by both.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CoVotes {
    /// id → Gaussians voted for it.
    pub voted: std::collections::BTreeMap<u32, u32>,
    /// `(a, b)` with `a < b` → Gaussians voted for both.
    pub both: std::collections::BTreeMap<(u32, u32), u32>,
}

impl CoVotes {
    fn add_gaussian(&mut self, slots: &[Slot]) {
        let total: f32 = slots.iter().filter(|s| s.id > 0).map(|s| s.pure_weight).sum();
        if total <= 0.0 {
            return;
        }
        let mut ids: Vec<u32> = slots
            .iter()
            .filter(|s| s.id > 0 && s.pure_weight >= COVOTE_SHARE * total)
            .map(|s| s.id)
            .collect();
        ids.sort_unstable();
        for (k, &a) in ids.iter().enumerate() {
            *self.voted.entry(a).or_insert(0) += 1;
            for &b in &ids[k + 1..] {
                *self.both.entry((a, b)).or_insert(0) += 1;
            }
        }
    }

    fn merge(&mut self, other: CoVotes) {
        for (k, v) in other.voted {
            *self.voted.entry(k).or_insert(0) += v;
        }
        for (k, v) in other.both {
            *self.both.entry(k).or_insert(0) += v;
        }
    }
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

/// One view's contributions with the table from its labels to global ids.
#[derive(Clone, Copy, Debug)]
pub struct LiftView<'a> {
    /// Contributions keyed by the view's own labels.
    pub contributions: &'a ViewContributions,
    /// `[n_labels + 1]` global id of each label (index 0 = pixels in no mask → 0); labels past
    /// the end map to 0.
    pub global_of_label: &'a [u32],
}

impl LiftView<'_> {
    fn global(&self, label: u32) -> u32 {
        self.global_of_label.get(label as usize).copied().unwrap_or(0)
    }
}

/// One id tracked for one Gaussian.
#[derive(Clone, Copy, Default)]
struct Slot {
    id: u32,
    /// `Σ_v W_v(g, id)`.
    total: f32,
    /// `Σ_v W_v(g, id) / W_v(g)` over the views that see the Gaussian (soft votes).
    soft: f32,
    /// The same over the views that see it purely (largest share ≥ `min_view_purity`).
    pure_soft: f32,
    /// Views that see the Gaussian in this object.
    votes: u32,
    /// `Σ_v W_v(g) · s_v(id)` over those views (its share of the fused feature).
    vote_weight: f32,
    /// The same over the views whose largest object share reaches `min_view_purity`.
    pure_weight: f32,
}

/// The slot of `id`, taking a free one or replacing the weakest (smallest total, then larger
/// id) when full; `None` when every slot is stronger than a new id could be.
fn slot_for<'a>(slots: &'a mut [Slot; SLOTS], used: &mut usize, id: u32) -> Option<&'a mut Slot> {
    if let Some(k) = slots[..*used].iter().position(|s| s.id == id) {
        return Some(&mut slots[k]);
    }
    if *used < SLOTS {
        slots[*used] = Slot { id, ..Slot::default() };
        *used += 1;
        return Some(&mut slots[*used - 1]);
    }
    let weakest = (0..SLOTS)
        .min_by(|&a, &b| slots[a].total.total_cmp(&slots[b].total).then(slots[b].id.cmp(&slots[a].id)))
        .unwrap_or(0);
    (slots[weakest].votes == 0).then(|| {
        slots[weakest] = Slot { id, ..Slot::default() };
        &mut slots[weakest]
    })
}

/// Checks the global ids against the object features.
fn validate(views: &[LiftView], features: &ObjectFeatures) -> LiftResult<()> {
    if features.dim > 0 {
        for (view, v) in views.iter().enumerate() {
            if let Some(&id) = v.global_of_label.iter().find(|&&id| id as usize > features.n_objects()) {
                return Err(LiftError::UnknownObject { view, id, n_objects: features.n_objects() });
            }
        }
    }
    Ok(())
}

/// Adds one view's entries `range` (all of one Gaussian) into its slots.
/// Adds one view's entries `range` (all of one Gaussian) into its slots and its spread; returns
/// whether the view sees the Gaussian.
fn add_view(
    view: &LiftView,
    range: std::ops::Range<usize>,
    slots: &mut [Slot; SLOTS],
    used: &mut usize,
    spread: &mut Spread,
    features: &ObjectFeatures,
    config: &LiftConfig,
) -> bool {
    let c = view.contributions;
    let range_all = range.clone();
    // Per global id in this view (local labels may share one).
    let mut here: [(u32, f32); SLOTS] = [(0, 0.0); SLOTS];
    let mut n_here = 0;
    for k in range {
        let id = view.global(c.labels[k]);
        match here[..n_here].iter_mut().find(|e| e.0 == id) {
            Some(e) => e.1 += c.weights[k],
            None if n_here < SLOTS => {
                here[n_here] = (id, c.weights[k]);
                n_here += 1;
            }
            None => {}
        }
    }
    let here = &here[..n_here];
    let total: f32 = here.iter().map(|e| e.1).sum();
    let sees = c.sees(range_all, config);
    let clear = sees && here.iter().map(|e| e.1).fold(0.0f32, f32::max) >= config.min_view_purity * total;
    for &(id, w) in here {
        if let Some(s) = slot_for(slots, used, id) {
            s.total += w;
            if sees {
                s.soft += w / total;
            }
            if clear {
                s.pure_soft += w / total;
            }
        }
    }
    if !sees {
        return false;
    }
    // The view's vote: its object shares s_k = W_v(g, k) / Σ_objects W_v(g, ·), at weight W_v(g).
    let objects: f32 = here.iter().filter(|e| e.0 > 0).map(|e| e.1).sum();
    if objects <= 0.0 {
        return true;
    }
    let purity = here.iter().filter(|e| e.0 > 0).map(|e| e.1).fold(0.0f32, f32::max) / objects;
    let pure = purity >= config.min_view_purity;
    for &(id, w) in here.iter().filter(|e| e.0 > 0) {
        if let Some(s) = slot_for(slots, used, id) {
            s.votes += 1;
            s.vote_weight += total * w / objects;
            if pure {
                s.pure_weight += total * w / objects;
            }
        }
    }
    if features.dim > 0 && pure {
        // ‖f_v‖² of the view's mean feature f_v = Σ_k s_k f_k.
        let mut sq = 0.0f32;
        for &(a, wa) in here.iter().filter(|e| e.0 > 0) {
            for &(b, wb) in here.iter().filter(|e| e.0 > 0) {
                let dot: f32 = features.row(a).iter().zip(features.row(b)).map(|(x, y)| x * y).sum();
                sq += (wa / objects) * (wb / objects) * dot;
            }
        }
        spread.weight += total;
        spread.sq += total * sq;
    }
    true
}

/// Per Gaussian, `Σ_v W_v` and `Σ_v W_v ‖f_v‖²` over the pure views with object votes.
#[derive(Clone, Copy, Default)]
struct Spread {
    weight: f32,
    sq: f32,
}

/// Lifts the views' contributions onto `n_gaussians` Gaussians (see the module docs).
/// `views: [n_views]`, the views with masks, in a fixed order.
pub fn lift_labels(
    n_gaussians: usize,
    views: &[LiftView],
    features: ObjectFeatures,
    config: &LiftConfig,
) -> LiftResult<Lifted> {
    validate(views, &features)?;
    if let Some(&g) = views.iter().filter_map(|v| v.contributions.gaussians.last()).max() {
        if g as usize >= n_gaussians {
            return Err(LiftError::Count {
                what: "Gaussians in the contributions",
                got: g as usize + 1,
                expected: n_gaussians,
            });
        }
    }
    const CHUNK: usize = 16_384;
    let dim = features.dim;
    let chunks: Vec<(Vec<Decision>, Vec<f32>, CoVotes)> = (0..n_gaussians.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let (lo, hi) = (c * CHUNK, ((c + 1) * CHUNK).min(n_gaussians));
            let mut slots = vec![[Slot::default(); SLOTS]; hi - lo];
            let mut used = vec![0usize; hi - lo];
            let mut seen = vec![0u32; hi - lo];
            let mut spread = vec![Spread::default(); hi - lo];
            for view in views {
                let gs = &view.contributions.gaussians;
                let mut k = gs.partition_point(|&g| (g as usize) < lo);
                while k < gs.len() && (gs[k] as usize) < hi {
                    let g = gs[k];
                    let end = k + gs[k..].partition_point(|&x| x == g);
                    let i = g as usize - lo;
                    let sees = add_view(
                        view,
                        k..end,
                        &mut slots[i],
                        &mut used[i],
                        &mut spread[i],
                        &features,
                        config,
                    );
                    seen[i] += sees as u32;
                    k = end;
                }
            }
            let mut decisions = Vec::with_capacity(hi - lo);
            let mut fused_chunk = Vec::with_capacity((hi - lo) * dim);
            let mut fused = vec![0f32; dim];
            let mut covotes = CoVotes::default();
            for (((s, &u), &views), sp) in slots.iter().zip(&used).zip(&seen).zip(&spread) {
                decisions.push(decide(&s[..u], views, *sp, &features, config, &mut fused));
                fused_chunk.extend_from_slice(&fused);
                covotes.add_gaussian(&s[..u]);
            }
            (decisions, fused_chunk, covotes)
        })
        .collect();
    let mut lifted = Lifted {
        object_ids: Vec::with_capacity(n_gaussians),
        status: Vec::with_capacity(n_gaussians),
        majority_ids: Vec::with_capacity(n_gaussians),
        variances: Vec::with_capacity(n_gaussians),
        views_seen: Vec::with_capacity(n_gaussians),
        fused_features: None,
        covotes: CoVotes::default(),
        stats: LiftStats::default(),
    };
    let mut fused = Vec::with_capacity(n_gaussians * dim);
    for (decisions, f, covotes) in chunks {
        lifted.covotes.merge(covotes);
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

/// The id, fusion and variance test for one Gaussian's slots (`views`: views that see it);
/// writes f_g into `fused`.
fn decide(
    slots: &[Slot],
    views: u32,
    spread: Spread,
    features: &ObjectFeatures,
    config: &LiftConfig,
    fused: &mut [f32],
) -> Decision {
    fused.iter_mut().for_each(|x| *x = 0.0);
    if slots.is_empty() {
        return Decision { object_id: -1, status: GaussianStatus::Unseen, majority: 0, variance: 0.0, views };
    }
    // (score, tie-break) per rule: the soft vote breaks ties by summed contribution.
    let any_clear = slots.iter().any(|s| s.pure_soft > 0.0);
    let score = |s: &Slot| match config.id_rule {
        IdRule::Contribution => (s.total, 0.0),
        IdRule::SoftVote if any_clear => (s.pure_soft, s.soft),
        IdRule::SoftVote => (s.soft, s.total),
    };
    let background = slots.iter().find(|s| s.id == 0).map_or(0.0, |s| score(s).0);
    let better = |a: (u32, (f32, f32)), b: (u32, (f32, f32))| {
        let order = b.1 .0.total_cmp(&a.1 .0).then(b.1 .1.total_cmp(&a.1 .1)).then(a.0.cmp(&b.0));
        if order == std::cmp::Ordering::Greater {
            b
        } else {
            a
        }
    };
    let best = slots.iter().filter(|s| s.id > 0).map(|s| (s.id, score(s))).reduce(better);
    let majority = match best {
        Some((id, (v, _))) if v > 0.0 && v >= config.background_weight * background => id,
        _ => 0,
    };
    let variance = fuse(slots, spread, features, fused);
    // The winner's share of the score over all labels (its views' agreement).
    let all: f32 = slots.iter().map(|s| score(s).0).sum();
    let share = best.map_or(0.0, |(_, (v, _))| if all > 0.0 { v / all } else { 0.0 });
    let status = if views < config.min_views.max(1) {
        GaussianStatus::TooFewViews
    } else if majority == 0 {
        GaussianStatus::NoObject
    } else if variance > config.tau_var || share < config.min_vote_share {
        GaussianStatus::Unreliable
    } else {
        GaussianStatus::Labelled
    };
    let object_id = if status == GaussianStatus::Labelled { majority as i32 } else { -1 };
    Decision { object_id, status, majority, variance, views }
}

/// The fused feature `f_g = Σ_v W_v f_v / Σ_v W_v` (into `fused`) and the spread of the views'
/// mean features around it, `Σ_v W_v ‖f_v‖² / Σ_v W_v − ‖f_g‖²`.
fn fuse(slots: &[Slot], spread: Spread, features: &ObjectFeatures, fused: &mut [f32]) -> f32 {
    if features.dim == 0 {
        return 0.0;
    }
    let labelled = || slots.iter().filter(|s| s.id > 0 && s.votes > 0);
    let all: f32 = labelled().map(|s| s.vote_weight).sum();
    if all <= 0.0 {
        return 0.0;
    }
    for s in labelled() {
        let w = s.vote_weight / all;
        for (o, x) in fused.iter_mut().zip(features.row(s.id)) {
            *o += w * x;
        }
    }
    if spread.weight <= 0.0 {
        return 0.0;
    }
    // The spread of the pure views around their own mean.
    let dim = features.dim;
    let mut mean_sq = 0.0f32;
    for a in labelled().filter(|s| s.pure_weight > 0.0) {
        for b in labelled().filter(|s| s.pure_weight > 0.0) {
            let dot: f32 =
                features.row(a.id).iter().zip(features.row(b.id)).take(dim).map(|(x, y)| x * y).sum();
            mean_sq += (a.pure_weight / spread.weight) * (b.pure_weight / spread.weight) * dot;
        }
    }
    (spread.sq / spread.weight - mean_sq).max(0.0)
}
