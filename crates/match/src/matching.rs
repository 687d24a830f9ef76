//! [`match_masks`]: view-local masks → global object ids.
//!
//! 1. Every pair of masks from different views is scored: descriptor cosine, and — when
//!    Gaussian observations are given and the pair has enough support — the 3D containment
//!    overlap of [`crate::evidence`]. Views are scored in parallel, each mask against every
//!    mask of the other views.
//! 2. A pair becomes a candidate edge when
//!    - it has 3D support, overlap ≥ `tau_overlap` and cos ≥ `tau_match_with_3d` (tier 0), or
//!    - it has no 3D support and cos > `tau_match` (tier 1, the paper's rule).
//!
//!    A pair with support and overlap < `tau_reject` becomes a cannot-link instead.
//!
//!    Memory does not grow with the pairs of masks: each mask keeps its best
//!    `max(MIN_KEPT_PER_MASK, max_candidate_edges / n_masks)` edges (in the order of step 4) and as
//!    many cannot-links (the best-looking pairs first: those a descriptor chain could join), and a
//!    pair is kept when either of its masks keeps it. On captures where no mask has more candidates
//!    than that (every capture of up to ~700 masks) nothing is dropped and the result is that
//!    of scoring every pair.
//! 3. Edges are taken in order (tier, score descending, then mask indices) and fed to a
//!    union-find that refuses to join clusters holding masks of the same view or spanning a
//!    cannot-link.
//! 4. Clusters are numbered 1, 2, … by their first mask in (view, local label) order, and each
//!    gets an identity feature: the area-weighted mean of its masks' unit descriptors,
//!    re-normalised.

use crate::cluster::{ConstrainedUnionFind, JoinOutcome};
use crate::config::MatchConfig;
use crate::error::{MatchError, MatchResult};
use crate::evidence::{gather_evidence, mask_offsets, Evidence, MaskCounts};
use crate::input::{MatchInput, ViewMasks};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The result of matching.
#[derive(Clone, Debug, PartialEq)]
pub struct Matching {
    /// `[n_views]`, each `[n_masks + 1]`: the global id of local label `l` of view `v` is
    /// `global_of_label[v][l]`; entry 0 (unlabelled) is 0.
    pub global_of_label: Vec<Vec<u32>>,
    /// Number of global objects (ids `1..=n_objects`).
    pub n_objects: usize,
    /// Descriptor dimension D.
    pub dim: usize,
    /// `[n_objects, dim]` unit identity features; row `k − 1` belongs to id `k`.
    pub object_features: Vec<f32>,
    /// What happened, for reports.
    pub stats: MatchStats,
}

impl Matching {
    /// The identity feature of global id `id` (`[dim]`), or `None` for 0 / unknown ids.
    pub fn object_feature(&self, id: u32) -> Option<&[f32]> {
        (id >= 1 && id as usize <= self.n_objects)
            .then(|| &self.object_features[(id as usize - 1) * self.dim..id as usize * self.dim])
    }
}

/// Counts of what matching decided.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MatchStats {
    /// Masks over all views.
    pub masks: usize,
    /// Candidate edges backed by 3D overlap.
    pub edges_3d: usize,
    /// Candidate edges from descriptors alone.
    pub edges_descriptor: usize,
    /// Pairs declared cannot-link by 3D evidence.
    pub cannot_links: usize,
    /// Edges that joined two clusters.
    pub joins: usize,
    /// Edges refused because both clusters hold a mask of one view.
    pub refused_same_view: usize,
    /// Edges refused because of a cannot-link.
    pub refused_cannot_link: usize,
    /// Every `evidence_stride`-th Gaussian was counted for 3D evidence (0 = no Gaussians).
    pub evidence_stride: u32,
}

#[derive(Clone, Copy, Debug)]
struct Edge {
    tier: u8,
    score: f32,
    i: u32,
    j: u32,
}

/// The order edges are tried in: tier, score descending, then mask indices (a total order).
fn edge_order(x: &Edge, y: &Edge) -> std::cmp::Ordering {
    x.tier.cmp(&y.tier).then(y.score.total_cmp(&x.score)).then(x.i.cmp(&y.i)).then(x.j.cmp(&y.j))
}

/// An edge ranked by [`edge_order`] (greater = tried later), for [`BestK`].
#[derive(Clone, Copy, Debug)]
struct RankedEdge(Edge);

impl PartialEq for RankedEdge {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == std::cmp::Ordering::Equal
    }
}
impl Eq for RankedEdge {}
impl PartialOrd for RankedEdge {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for RankedEdge {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        edge_order(&self.0, &other.0)
    }
}

/// A cannot-link pair `(lo, hi)` ranked by descriptor cosine, most alike first (greater = less
/// alike), for [`BestK`].
#[derive(Clone, Copy, Debug)]
struct RankedCannot {
    cos: f32,
    pair: (u32, u32),
}

impl PartialEq for RankedCannot {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == std::cmp::Ordering::Equal
    }
}
impl Eq for RankedCannot {}
impl PartialOrd for RankedCannot {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for RankedCannot {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        other.cos.total_cmp(&self.cos).then(self.pair.cmp(&other.pair))
    }
}

/// The `k` smallest items pushed (a max-heap of at most `k` items; the largest is dropped).
struct BestK<T: Ord> {
    k: usize,
    heap: std::collections::BinaryHeap<T>,
}

impl<T: Ord> BestK<T> {
    fn new(k: usize) -> Self {
        BestK { k, heap: std::collections::BinaryHeap::new() }
    }

    fn push(&mut self, item: T) {
        if self.heap.len() < self.k {
            self.heap.push(item);
        } else if self.heap.peek().is_some_and(|worst| item < *worst) {
            self.heap.pop();
            self.heap.push(item);
        }
    }

    /// The kept items (in no particular order); the heap is left empty for the next mask.
    fn drain(&mut self) -> impl Iterator<Item = T> + '_ {
        self.heap.drain()
    }
}

/// Fewest edges (and cannot-links) each mask keeps, whatever the number of masks.
pub const MIN_KEPT_PER_MASK: usize = 16;

/// Unit-length copies of all descriptors, `[n_masks, dim]`; zero vectors stay zero.
fn unit_features(input: &MatchInput) -> MatchResult<Vec<f32>> {
    let mut out = Vec::with_capacity(input.views.iter().map(|v| v.len() * input.dim).sum());
    for (view, masks) in input.views.iter().enumerate() {
        append_unit(view, masks, input.dim, &mut out)?;
    }
    Ok(out)
}

/// Appends the unit-length copies of `masks`' descriptors (`[n_masks, dim]`) of view `view` to
/// `out`, after checking their shape and values.
fn append_unit(view: usize, masks: &ViewMasks, dim: usize, out: &mut Vec<f32>) -> MatchResult<()> {
    if masks.features.len() != masks.len() * dim {
        return Err(MatchError::Shape {
            view,
            what: "features",
            got: masks.features.len(),
            expected: masks.len() * dim,
        });
    }
    for (k, f) in masks.features.chunks(dim.max(1)).enumerate().take(masks.len()) {
        if f.iter().any(|x| !x.is_finite()) {
            return Err(MatchError::NonFinite { view, label: k as u32 + 1 });
        }
        let norm = f.iter().map(|x| x * x).sum::<f32>().sqrt();
        let scale = if norm > 1e-12 { 1.0 / norm } else { 0.0 };
        out.extend(f.iter().map(|x| x * scale));
    }
    Ok(())
}

fn cosine(unit: &[f32], dim: usize, i: usize, j: usize) -> f32 {
    unit[i * dim..(i + 1) * dim].iter().zip(&unit[j * dim..(j + 1) * dim]).map(|(a, b)| a * b).sum()
}

/// `out[j]` = [`cosine`]`(unit, dim, i, j)` for every mask `j` (`unit: [n_masks, dim]`, `out:
/// [n_masks]`), bit for bit: eight sums at a time, each in [`cosine`]'s order from the same
/// starting value (independent sums keep the core busy; one sum at a time waits on each add).
fn cosines_of_mask(unit: &[f32], dim: usize, i: usize, out: &mut Vec<f32>) {
    const LANES: usize = 8;
    let n = unit.len().checked_div(dim).unwrap_or(0);
    out.clear();
    out.resize(n, 0.0);
    let a = &unit[i * dim..(i + 1) * dim];
    let start: f32 = std::iter::empty::<f32>().sum();
    let mut j = 0;
    while j + LANES <= n {
        let rows: [&[f32]; LANES] = std::array::from_fn(|l| &unit[(j + l) * dim..(j + l + 1) * dim]);
        let mut acc = [start; LANES];
        for (d, &x) in a.iter().enumerate() {
            for (sum, row) in acc.iter_mut().zip(&rows) {
                *sum += x * row[d];
            }
        }
        out[j..j + LANES].copy_from_slice(&acc);
        j += LANES;
    }
    for (k, o) in out.iter_mut().enumerate().skip(j) {
        *o = cosine(unit, dim, i, k);
    }
}

/// What scoring the masks of one view found.
#[derive(Default)]
struct ViewFindings {
    /// Edges some mask of the view keeps, `i < j`.
    edges: Vec<Edge>,
    /// Cannot-link pairs `(lo, hi)` some mask of the view keeps.
    cannot: Vec<(u32, u32)>,
    /// Candidate edges `(i, j)`, `i` of this view, `j > i`: backed by 3D overlap / descriptors only.
    edges_3d: usize,
    edges_descriptor: usize,
    /// Cannot-link pairs `(i, j)`, `i` of this view, `j > i`.
    cannot_links: usize,
}

/// Everything the scoring of one view reads.
struct Scoring<'a> {
    input: &'a MatchInput,
    config: &'a MatchConfig,
    offsets: &'a [usize],
    view_of_mask: &'a [u32],
    unit: &'a [f32],
    evidence: Option<&'a Evidence>,
    /// Edges and cannot-links each mask keeps.
    keep: usize,
}

/// Scratch of one scoring task, reused from view to view.
#[derive(Default)]
struct Scratch {
    /// `[n_masks]` `|S_j ∩ V_a|` for the view `a` being scored.
    view_counts: Vec<u32>,
    counts: MaskCounts,
    /// `[n_masks]` cosines of the mask being scored with every mask.
    cosines: Vec<f32>,
}

impl Scoring<'_> {
    /// Scores every mask of view `a` against every mask of the other views.
    fn view(&self, a: usize, scratch: &mut Scratch) -> ViewFindings {
        let (dim, config) = (self.input.dim, self.config);
        let masks = self.offsets[a]..self.offsets[a + 1];
        let mut found = ViewFindings::default();
        let rows = match (self.evidence, &self.input.observations) {
            (Some(e), Some(obs)) => {
                let (starts, rows) = e.rows_of_view(a, &obs[a]);
                e.view_counts(a, &rows, &mut scratch.view_counts);
                Some((e, starts, rows))
            }
            _ => None,
        };
        let mut edges = BestK::new(self.keep);
        let mut cannot = BestK::new(self.keep);
        for (k, i) in masks.enumerate() {
            if let Some((e, starts, rows)) = &rows {
                e.mask_counts(a, &rows[starts[k + 1]..starts[k + 2]], &mut scratch.counts);
            }
            cosines_of_mask(self.unit, dim, i, &mut scratch.cosines);
            for (j, &b) in self.view_of_mask.iter().enumerate() {
                let b = b as usize;
                if a == b {
                    continue;
                }
                let cos = if dim > 0 { scratch.cosines[j] } else { 0.0 };
                let (lo, hi) = if i < j { (i as u32, j as u32) } else { (j as u32, i as u32) };
                let support =
                    rows.as_ref().map_or(0, |_| scratch.counts.covisible[b].min(scratch.view_counts[j]));
                if rows.is_some() && support >= crate::config::MIN_SUPPORT {
                    let overlap = scratch.counts.shared[j] as f32 / support as f32;
                    if overlap >= config.tau_overlap && (dim == 0 || cos >= config.tau_match_with_3d) {
                        edges.push(RankedEdge(Edge { tier: 0, score: overlap + cos, i: lo, j: hi }));
                        found.edges_3d += usize::from(j > i);
                    } else if overlap < crate::config::TAU_REJECT {
                        cannot.push(RankedCannot { cos, pair: (lo, hi) });
                        found.cannot_links += usize::from(j > i);
                    }
                } else if dim > 0 && cos > config.tau_match {
                    edges.push(RankedEdge(Edge { tier: 1, score: cos, i: lo, j: hi }));
                    found.edges_descriptor += usize::from(j > i);
                }
            }
            found.edges.extend(edges.drain().map(|r| r.0));
            found.cannot.extend(cannot.drain().map(|r| r.pair));
        }
        found
    }
}

/// Matches the masks of all views into global objects (see the module docs for the rule).
pub fn match_masks(input: &MatchInput, config: &MatchConfig) -> MatchResult<Matching> {
    let unit = unit_features(input)?;
    match_unit_masks(input, unit, config)
}

/// [`match_masks`] on an input it may consume: the descriptors are dropped once normalised, so one
/// copy of the `[n_masks, dim]` descriptors is held while matching instead of two.
pub fn match_masks_owned(mut input: MatchInput, config: &MatchConfig) -> MatchResult<Matching> {
    let mut unit = Vec::with_capacity(input.views.iter().map(|v| v.len() * input.dim).sum());
    for (view, masks) in input.views.iter_mut().enumerate() {
        append_unit(view, masks, input.dim, &mut unit)?;
        masks.features = Vec::new();
    }
    match_unit_masks(&input, unit, config)
}

/// Matching once the descriptors are normalised (`unit: [n_masks, dim]`); reads no
/// `input.views[_].features`.
fn match_unit_masks(input: &MatchInput, unit: Vec<f32>, config: &MatchConfig) -> MatchResult<Matching> {
    let offsets = mask_offsets(input);
    let view_of_mask: Vec<u32> =
        input.views.iter().enumerate().flat_map(|(v, m)| std::iter::repeat_n(v as u32, m.len())).collect();
    let evidence = match &input.observations {
        Some(obs) => Some(gather_evidence(input, obs, config.max_pair_samples)?),
        None => None,
    };
    let n_masks = view_of_mask.len();
    let keep = ((config.max_candidate_edges / n_masks.max(1) as u64) as usize).max(MIN_KEPT_PER_MASK);
    let scoring = Scoring {
        input,
        config,
        offsets: &offsets,
        view_of_mask: &view_of_mask,
        unit: &unit,
        evidence: evidence.as_ref(),
        keep,
    };
    let per_view: Vec<ViewFindings> = (0..input.views.len())
        .into_par_iter()
        .map_init(Scratch::default, |scratch, a| scoring.view(a, scratch))
        .collect();
    let mut stats = MatchStats {
        masks: n_masks,
        evidence_stride: evidence.as_ref().map_or(0, |e| e.stride),
        ..MatchStats::default()
    };
    drop(evidence);
    // Sized once: each view's findings are freed as they are moved in, so resident memory stays
    // about one copy of the kept edges.
    let mut edges = Vec::with_capacity(per_view.iter().map(|f| f.edges.len()).sum());
    let mut cannot = Vec::with_capacity(per_view.iter().map(|f| f.cannot.len()).sum());
    for found in per_view {
        stats.edges_3d += found.edges_3d;
        stats.edges_descriptor += found.edges_descriptor;
        stats.cannot_links += found.cannot_links;
        edges.extend(found.edges);
        cannot.extend(found.cannot);
    }
    // A pair both masks keep comes twice, with the same score (the scoring is symmetric).
    edges.sort_unstable_by(edge_order);
    edges.dedup_by(|x, y| (x.i, x.j) == (y.i, y.j));
    cannot.sort_unstable();
    cannot.dedup();
    let mut uf = ConstrainedUnionFind::new(&view_of_mask);
    for (i, j) in cannot {
        uf.add_cannot_link(i, j);
    }
    for e in edges {
        match uf.union(e.i, e.j) {
            JoinOutcome::Joined => stats.joins += 1,
            JoinOutcome::SameView => stats.refused_same_view += 1,
            JoinOutcome::CannotLink => stats.refused_cannot_link += 1,
            JoinOutcome::AlreadyJoined => {}
        }
    }
    number_clusters(input, &offsets, &unit, &mut uf, stats)
}

/// Numbers clusters by first member (masks are already in (view, label) order) and builds the
/// identity features.
fn number_clusters(
    input: &MatchInput,
    offsets: &[usize],
    unit: &[f32],
    uf: &mut ConstrainedUnionFind,
    stats: MatchStats,
) -> MatchResult<Matching> {
    let dim = input.dim;
    let n_masks = *offsets.last().unwrap_or(&0);
    let mut id_of_root = vec![0u32; n_masks];
    let mut next = 0u32;
    let mut id_of_mask = vec![0u32; n_masks];
    for (m, id) in id_of_mask.iter_mut().enumerate() {
        let root = uf.find(m as u32) as usize;
        if id_of_root[root] == 0 {
            next += 1;
            id_of_root[root] = next;
        }
        *id = id_of_root[root];
    }
    let n_objects = next as usize;
    if n_objects > u16::MAX as usize {
        return Err(MatchError::TooManyObjects { count: n_objects });
    }
    let mut sums = vec![0f64; n_objects * dim];
    for (view, masks) in input.views.iter().enumerate() {
        for (k, &area) in masks.areas_px.iter().enumerate() {
            let m = offsets[view] + k;
            let row = (id_of_mask[m] as usize - 1) * dim;
            for d in 0..dim {
                sums[row + d] += unit[m * dim + d] as f64 * area.max(1) as f64;
            }
        }
    }
    let mut object_features = vec![0f32; n_objects * dim];
    for (out, sum) in object_features.chunks_mut(dim.max(1)).zip(sums.chunks(dim.max(1))) {
        let norm = sum.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm > 1e-12 {
            for (o, s) in out.iter_mut().zip(sum) {
                *o = (s / norm) as f32;
            }
        }
    }
    let global_of_label = input
        .views
        .iter()
        .enumerate()
        .map(|(view, masks)| {
            std::iter::once(0).chain((0..masks.len()).map(|k| id_of_mask[offsets[view] + k])).collect()
        })
        .collect();
    Ok(Matching { global_of_label, n_objects, dim, object_features, stats })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cosines_of_a_mask_equal_one_at_a_time_bit_for_bit() {
        // 21 masks (two blocks of eight and a tail), some with zero or negative descriptors.
        let dim = 13;
        let mut unit: Vec<f32> = (0..21 * dim).map(|k| ((k * 7919 % 211) as f32 - 105.0) / 37.0).collect();
        unit[3 * dim..4 * dim].iter_mut().for_each(|x| *x = 0.0);
        unit[17 * dim..18 * dim].iter_mut().for_each(|x| *x = -0.0);
        let mut out = Vec::new();
        for i in 0..21 {
            cosines_of_mask(&unit, dim, i, &mut out);
            for (j, &c) in out.iter().enumerate() {
                assert_eq!(c.to_bits(), cosine(&unit, dim, i, j).to_bits(), "masks {i}, {j}");
            }
        }
    }
}
