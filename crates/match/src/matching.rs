//! [`match_masks`]: view-local masks → global object ids.
//!
//! 1. Every pair of masks from different views is scored: descriptor cosine, and — when
//!    Gaussian observations are given and the pair has enough support — the 3D containment
//!    overlap of [`crate::evidence`].
//! 2. A pair becomes a candidate edge when
//!    - it has 3D support, overlap ≥ `tau_overlap` and cos ≥ `tau_match_with_3d` (tier 0), or
//!    - it has no 3D support and cos > `tau_match` (tier 1, the paper's rule).
//!
//!    A pair with support and overlap < `tau_reject` becomes a cannot-link instead.
//! 3. With 3D evidence, masks of one view that other views see inside one mask are joined
//!    first, as fragments of one object ([`crate::fragments`]).
//! 4. Edges are taken in order (tier, score descending, then mask indices; each mask's list sorted,
//!    the lists merged lazily) and fed to a union-find that
//!    refuses to join clusters holding masks of the same view or spanning a cannot-link.
//! 5. Clusters are numbered 1, 2, … by their first mask in (view, local label) order, and each
//!    gets an identity feature: the area-weighted mean of its masks' unit descriptors,
//!    re-normalised.

use crate::cluster::{ConstrainedUnionFind, JoinOutcome};
use crate::config::MatchConfig;
use crate::error::{MatchError, MatchResult};
use crate::evidence::{gather_evidence, mask_offsets, Evidence};
use crate::fragments::fragment_pairs;
use crate::input::MatchInput;
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
    /// Masks of one view joined as fragments of one object ([`crate::fragments`]).
    pub fragment_joins: usize,
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

/// The head of one mask's sorted edge list in the k-way merge (a min-heap on [`edge_order`]).
struct Head {
    edge: Edge,
    list: usize,
    pos: usize,
}

impl PartialEq for Head {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == std::cmp::Ordering::Equal
    }
}
impl Eq for Head {}
impl PartialOrd for Head {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Head {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        edge_order(&other.edge, &self.edge)
    }
}

/// Every edge of the sorted `lists` in [`edge_order`], as sorting them all into one list would
/// give (edges of different lists differ in `i`, so there are no ties).
fn merged_in_order(lists: &[Vec<Edge>]) -> impl Iterator<Item = Edge> + '_ {
    let mut heap: std::collections::BinaryHeap<Head> = lists
        .iter()
        .enumerate()
        .filter_map(|(list, l)| l.first().map(|&edge| Head { edge, list, pos: 0 }))
        .collect();
    std::iter::from_fn(move || {
        let head = heap.pop()?;
        if let Some(&edge) = lists[head.list].get(head.pos + 1) {
            heap.push(Head { edge, list: head.list, pos: head.pos + 1 });
        }
        Some(head.edge)
    })
}

/// Unit-length copies of all descriptors, `[n_masks, dim]`; zero vectors stay zero.
fn unit_features(input: &MatchInput) -> MatchResult<Vec<f32>> {
    let dim = input.dim;
    let mut out = Vec::new();
    for (view, masks) in input.views.iter().enumerate() {
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
    }
    Ok(out)
}

fn cosine(unit: &[f32], dim: usize, i: usize, j: usize) -> f32 {
    unit[i * dim..(i + 1) * dim].iter().zip(&unit[j * dim..(j + 1) * dim]).map(|(a, b)| a * b).sum()
}

/// Scores all cross-view pairs of mask `i`; returns its edges and cannot-link partners.
fn edges_of_mask(
    i: usize,
    view_of_mask: &[u32],
    unit: &[f32],
    dim: usize,
    evidence: Option<&Evidence>,
    config: &MatchConfig,
) -> (Vec<Edge>, Vec<u32>) {
    let mut edges = Vec::new();
    let mut cannot = Vec::new();
    let a = view_of_mask[i] as usize;
    for (j, &b) in view_of_mask.iter().enumerate().skip(i + 1) {
        let b = b as usize;
        if a == b {
            continue;
        }
        let cos = if dim > 0 { cosine(unit, dim, i, j) } else { 0.0 };
        let support = evidence.map_or(0, |e| e.covisible(i, b).min(e.covisible(j, a)));
        if let (Some(e), true) = (evidence, support >= config.min_support.max(1)) {
            let overlap = e.shared(i, j) as f32 / support as f32;
            if overlap >= config.tau_overlap && (dim == 0 || cos >= config.tau_match_with_3d) {
                edges.push(Edge { tier: 0, score: overlap + cos, i: i as u32, j: j as u32 });
            } else if overlap < config.tau_reject {
                cannot.push(j as u32);
            }
        } else if dim > 0 && cos > config.tau_match {
            edges.push(Edge { tier: 1, score: cos, i: i as u32, j: j as u32 });
        }
    }
    (edges, cannot)
}

/// Matches the masks of all views into global objects (see the module docs for the rule).
pub fn match_masks(input: &MatchInput, config: &MatchConfig) -> MatchResult<Matching> {
    let unit = unit_features(input)?;
    let dim = input.dim;
    let offsets = mask_offsets(input);
    let view_of_mask: Vec<u32> =
        input.views.iter().enumerate().flat_map(|(v, m)| std::iter::repeat_n(v as u32, m.len())).collect();
    let evidence = match &input.observations {
        Some(obs) => Some(gather_evidence(input, obs, config.max_pair_samples)?),
        None => None,
    };
    // Each mask's edges sorted; they are merged lazily into the global order below (no global
    // list: at 1,000 views the candidate edges are tens of millions).
    let per_mask: Vec<(Vec<Edge>, Vec<u32>)> = (0..view_of_mask.len())
        .into_par_iter()
        .map(|i| {
            let (mut edges, cannot) = edges_of_mask(i, &view_of_mask, &unit, dim, evidence.as_ref(), config);
            edges.sort_by(edge_order);
            // Kept until the merge: no growth slack (up to half of a list's capacity).
            edges.shrink_to_fit();
            (edges, cannot)
        })
        .collect();
    let mut stats = MatchStats {
        masks: view_of_mask.len(),
        evidence_stride: evidence.as_ref().map_or(0, |e| e.stride),
        ..MatchStats::default()
    };
    let mut uf = ConstrainedUnionFind::new(&view_of_mask);
    let mut lists: Vec<Vec<Edge>> = Vec::with_capacity(per_mask.len());
    for (i, (e, cannot)) in per_mask.into_iter().enumerate() {
        for j in cannot {
            uf.add_cannot_link(i as u32, j);
            stats.cannot_links += 1;
        }
        stats.edges_3d += e.iter().filter(|e| e.tier == 0).count();
        stats.edges_descriptor += e.iter().filter(|e| e.tier != 0).count();
        lists.push(e);
    }
    if let Some(e) = &evidence {
        let similar = |i: usize, j: usize| dim == 0 || cosine(&unit, dim, i, j) >= config.tau_match;
        for (i, j) in fragment_pairs(e, &view_of_mask, &offsets, similar, config) {
            if uf.union_fragments(i, j) == JoinOutcome::Joined {
                stats.fragment_joins += 1;
            }
        }
    }
    drop(evidence);
    for e in merged_in_order(&lists) {
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
