//! The greedy merging loop (paper §4.2 "Iterative Refinement") over the region adjacency graph.
//!
//! Scores live in a max-heap with lazy invalidation: every region has a version counter, bumped
//! when it absorbs a neighbour; a heap entry records the versions it was computed with and is
//! skipped when popped if either region changed or died. After a merge only the merged region's
//! edges are re-scored (no other pair's inputs changed). Ties are broken by the smaller pair of
//! ids, so the result is deterministic. Cost: one pass over the pixels to build the graph, then
//! per merge `O(Σ band lengths of the merged region's edges + degree · log E)`.
//!
//! **A crease the view confirmed stays an edge.** When the concave-crease gate refuses two
//! regions, the regions on either side are kept apart for the rest of the view's merge, however
//! each grows: a later merge that would put them in one region is refused ([`Outcome::KeptApart`]),
//! as the matching's cannot-links do across views. Without it two touching objects whose contact
//! the view sees as a crease in one place merge through a pair of their regions meeting where the
//! crease is not measured, and the grown regions' mean normals blur the crease. Only the crease
//! counts: on the demo scene's views (regions judged by the ground truth of their first input
//! region) it refused regions of one object in 2 of 694 refusals, the depth step in 67 of 1,574,
//! and a misfire kept for the rest of the merge would split an object for good (the depth gates
//! kept too: tuning seeds 0..7 lost 0.006 mIoU on multi_tone and clutter). It needs a crease
//! that does not misfire: with normals from finite differences of the surface depth it cost
//! multi_tone 3 0.004; with normals rendered from the Gaussians, nothing (tuning seeds 0..7:
//! 0.9741 → 0.9743; `docs/benchmarks/20-rendered-normals.md`). The literal profile has no
//! crease gate, so nothing changes there.

use crate::config::MergeConfig;
use crate::error::{MergeError, MergeResultOf};
use crate::graph::{build_edges, sorted_union, Edge, Junctions};
use crate::score::{evaluate, BoundaryMaps, Outcome, RegionState, ScoreTerms, Scratch, SurfaceMaps};
use crate::wholes::{ViewWholes, WholesScratch};
use serde::{Deserialize, Serialize};
use splatseg_cues::{
    region_mean_normal, region_normal_at, DepthJumps, NormalWindow, RegionDescriptors, Regions,
};
use splatseg_scene::Plane;
use std::cmp::Ordering;
use std::collections::{BTreeMap, BinaryHeap};

/// Everything the merge needs for one view. All maps are `[H, W]` of the same size.
#[derive(Clone, Debug)]
pub struct ViewInputs {
    /// The initial partition (from [`splatseg_cues::regions_from_sam_masks`]).
    pub regions: Regions,
    /// `[n, C]` mean descriptor per region (`n = regions.count()`).
    pub descriptors: RegionDescriptors,
    /// `[H, W]` normalised depth in [0, 1], 0 = near.
    pub depth: Plane<f32>,
    /// `[H, W]` `∇D` in [0, 1].
    pub depth_gradient: Plane<f32>,
    /// `[H, W]` LoG edge strength in [0, 1].
    pub edges: Plane<f32>,
    /// `[H, W]` camera-space points (NaN = no depth), when metric depth and the intrinsics are
    /// known (enables the crease gate).
    pub points: Option<Plane<[f32; 3]>>,
    /// `[H, W]` rendered camera-space unit normals facing the camera (NaN = none), when the
    /// Gaussians give them: the crease gate then reads them instead of normals from the points'
    /// differences.
    pub normals: Option<Plane<[f32; 3]>>,
}

/// One final region.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RegionSummary {
    /// Label in [`MergeResult::labels`] (1-based).
    pub id: u32,
    /// Pixel count.
    pub area: u64,
    /// `[C]` L2-normalised area-weighted mean descriptor.
    pub descriptor: Vec<f32>,
    /// Mean normalised depth.
    pub mean_depth: f32,
    /// Inclusive `[x0, y0, x1, y1]` in pixels.
    pub bbox_px: [u32; 4],
    /// Input region labels merged into this region (sorted).
    pub merged_from: Vec<u32>,
}

/// One evaluation of a pair.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Decision {
    /// Smaller region id (input-region label of the surviving representative).
    pub a: u32,
    /// Larger region id.
    pub b: u32,
    /// Merges done before this evaluation.
    pub after_merges: usize,
    /// Score terms.
    pub terms: ScoreTerms,
    /// Accepted into the queue, or the rule that rejected it. A pair accepted here is merged
    /// unless a later merge changes one of its regions first; `merged` entries are the merges.
    pub outcome: Outcome,
    /// True for the evaluation that was executed as a merge.
    pub merged: bool,
}

/// Everything the merge decided, for debugging (`merge/<stem>.json`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MergeLog {
    /// Regions before merging.
    pub regions_before: usize,
    /// Regions after merging.
    pub regions_after: usize,
    /// Merges executed.
    pub merges: usize,
    /// Every evaluation in order.
    pub decisions: Vec<Decision>,
    /// `[n]` final id of each input region (index = input label − 1).
    pub final_id_of_input: Vec<u32>,
}

/// The merged view.
#[derive(Clone, Debug, PartialEq)]
pub struct MergeResult {
    /// `[H, W]` final labels, 0 = unlabelled, regions numbered 1..=k by first pixel in raster order.
    pub labels: Plane<u32>,
    /// `[k]` final regions, `regions[i].id == i + 1`.
    pub regions: Vec<RegionSummary>,
    /// Every decision.
    pub log: MergeLog,
}

#[derive(PartialEq)]
struct Candidate {
    score: f32,
    a: u32,
    b: u32,
    version_a: u32,
    version_b: u32,
    terms: ScoreTerms,
}

impl Eq for Candidate {}

impl Ord for Candidate {
    fn cmp(&self, other: &Self) -> Ordering {
        self.score.total_cmp(&other.score).then_with(|| (other.a, other.b).cmp(&(self.a, self.b)))
    }
}

impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

fn check_inputs(inputs: &ViewInputs) -> MergeResultOf<()> {
    let size = inputs.regions.labels.size();
    let n = inputs.regions.count();
    let mut maps = vec![
        ("depth", inputs.depth.size()),
        ("depth gradient", inputs.depth_gradient.size()),
        ("edges", inputs.edges.size()),
    ];
    if let Some(m) = &inputs.points {
        maps.push(("points", m.size()));
    }
    if let Some(m) = &inputs.normals {
        maps.push(("normals", m.size()));
    }
    for (name, s) in maps {
        if s != size {
            return Err(MergeError::Inputs(format!("{name} map is {s:?} but the label map is {size:?}")));
        }
    }
    if inputs.descriptors.len() != n {
        return Err(MergeError::Inputs(format!("{} descriptors for {n} regions", inputs.descriptors.len())));
    }
    if let Some(l) = inputs.regions.labels.data.iter().find(|&&l| l as usize > n) {
        return Err(MergeError::Inputs(format!("label {l} exceeds the region count {n}")));
    }
    Ok(())
}

/// Initial per-region state (area, depth sum, descriptor sum, bbox, outline maxima).
/// Outline maxima are computed only when `outlines` is set (the literal profile reads them).
fn initial_states(inputs: &ViewInputs, outlines: bool) -> Vec<RegionState> {
    let labels = &inputs.regions.labels;
    let d = &inputs.descriptors;
    let mut states: Vec<RegionState> = (0..inputs.regions.count())
        .map(|r| RegionState {
            area: 0,
            depth_sum: 0.0,
            descriptor_sum: d.mean(r).iter().map(|v| v * d.areas[r] as f32).collect(),
            bbox: [u32::MAX, u32::MAX, 0, 0],
            outline_edge_max: 0.0,
            outline_depth_grad_max: 0.0,
        })
        .collect();
    let (w, h) = labels.size();
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            let l = labels.data[p];
            if l == 0 {
                continue;
            }
            let s = &mut states[l as usize - 1];
            s.area += 1;
            s.depth_sum += inputs.depth.data[p] as f64;
            s.bbox = [
                s.bbox[0].min(x as u32),
                s.bbox[1].min(y as u32),
                s.bbox[2].max(x as u32),
                s.bbox[3].max(y as u32),
            ];
            if !outlines {
                continue;
            }
            let outline = (x > 0 && labels.data[p - 1] != l)
                || (x + 1 < w && labels.data[p + 1] != l)
                || (y > 0 && labels.data[p - w] != l)
                || (y + 1 < h && labels.data[p + w] != l);
            if outline {
                s.outline_edge_max = s.outline_edge_max.max(inputs.edges.data[p]);
                s.outline_depth_grad_max = s.outline_depth_grad_max.max(inputs.depth_gradient.data[p]);
            }
        }
    }
    states
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let grand = parent[parent[x as usize] as usize];
        parent[x as usize] = grand;
        x = grand;
    }
    x
}

/// The band pixels of edge `(a, b)` whose window holds no region other than `a` and `b` (in the
/// current partition): the boundary proper, without the ends where a third region's outline
/// (and its strong LoG response) reaches in. Falls back to the whole band when that is empty.
fn shared_boundary(
    band: &[u32],
    (a, b): (u32, u32),
    junctions: &Junctions,
    parent: &mut [u32],
    out: &mut Vec<u32>,
) {
    out.clear();
    for &p in band {
        let pure = match junctions.labels(p) {
            None => true,
            Some(window) => window.iter().all(|&l| {
                let r = find(parent, l);
                r == a || r == b
            }),
        };
        if pure {
            out.push(p);
        }
    }
    if out.is_empty() {
        out.extend_from_slice(band);
    }
}

/// Relative depth jump between neighbouring pixels near a band pixel above which it is taken to
/// be on an occlusion edge and left out of the crease test (an object's outline against the
/// floor behind it is an occlusion edge; where it stands on the floor is a contact).
const OCCLUSION_DEPTH_JUMP: f32 = 0.1;

/// `[H, W]` unit surface normals of the band pixels of `edges` (NaN elsewhere and near occlusion
/// edges), each from its own input region's rendered normals (`rendered`) or else its points
/// (`points`, `labels`, `rendered`: `[H, W]`), in a window scaled with the image.
fn band_normals(
    points: &Plane<[f32; 3]>,
    rendered: Option<&Plane<[f32; 3]>>,
    labels: &Plane<u32>,
    edges: &[Edge],
) -> Plane<[f32; 3]> {
    let (w, h) = labels.size();
    let window = NormalWindow::for_size(w, h);
    let mut normals = Plane::filled(w, h, [f32::NAN; 3]);
    let mut done = vec![false; w * h];
    let jumps = DepthJumps::new(points, OCCLUSION_DEPTH_JUMP);
    for e in edges {
        for &p in &e.band {
            let p = p as usize;
            if !std::mem::replace(&mut done[p], true) && !jumps.near_edge(p, window) {
                let normal = match rendered {
                    Some(rendered) => region_mean_normal(rendered, labels, p, window),
                    None => region_normal_at(points, labels, p, window),
                };
                if let Some(n) = normal {
                    normals.data[p] = n;
                }
            }
        }
    }
    normals
}

/// Runs Multi-Cue-Guided Mask Merging on one view (without other views: no separate-wholes
/// gate).
pub fn merge_view(inputs: &ViewInputs, config: &MergeConfig) -> MergeResultOf<MergeResult> {
    merge_view_with_wholes(inputs, config, None)
}

/// [`merge_view`] with the other views' SAM masks through the Gaussians (`wholes`, this view's
/// handle): the separate-wholes gate ([`crate::wholes`]) is on when `config.separate_wholes`.
pub fn merge_view_with_wholes(
    inputs: &ViewInputs,
    config: &MergeConfig,
    wholes: Option<&ViewWholes<'_>>,
) -> MergeResultOf<MergeResult> {
    config.validate()?;
    check_inputs(inputs)?;
    if let Some(w) = wholes {
        if w.size != inputs.regions.labels.size() {
            return Err(MergeError::Inputs(format!(
                "the other views' evidence is for a {:?} image but the label map is {:?}",
                w.size,
                inputs.regions.labels.size()
            )));
        }
    }
    let n = inputs.regions.count();
    let labels = &inputs.regions.labels;
    let (built, junctions) = build_edges(labels, crate::config::DILATION_STEPS as usize);
    let normals = match (&inputs.points, config.max_concave_crease_deg) {
        (Some(points), Some(_)) => Some(band_normals(points, inputs.normals.as_ref(), labels, &built)),
        _ => None,
    };
    let maps = BoundaryMaps {
        depth: &inputs.depth,
        edges: &inputs.edges,
        depth_gradient: &inputs.depth_gradient,
        surface: inputs
            .points
            .as_ref()
            .zip(normals.as_ref())
            .map(|(points, normals)| SurfaceMaps { points, normals }),
    };
    // Region ids are input labels 1..=n; index 0 unused.
    let mut states: Vec<Option<RegionState>> = std::iter::once(None)
        .chain(
            initial_states(inputs, config.profile == crate::config::Profile::Literal).into_iter().map(Some),
        )
        .collect();
    let mut versions = vec![0u32; n + 1];
    let mut parent: Vec<u32> = (0..=n as u32).collect();
    let mut edges: Vec<Option<Edge>> = built.into_iter().map(Some).collect();
    let mut neighbours: Vec<BTreeMap<u32, usize>> = vec![BTreeMap::new(); n + 1];
    for (i, e) in edges.iter().enumerate() {
        let e = e.as_ref().expect("fresh edges are alive");
        neighbours[e.a as usize].insert(e.b, i);
        neighbours[e.b as usize].insert(e.a, i);
    }
    let mut log = MergeLog { regions_before: n, ..MergeLog::default() };
    let mut heap = BinaryHeap::new();
    let mut scratch = Scratch::default();
    let mut wholes_scratch = WholesScratch::default();
    let mut boundary: Vec<u32> = Vec::new();
    // `kept_apart[r]`: regions the crease gate refused to merge with region `r`'s set (any member
    // at the time; resolved with `find` when asked). Region `r` holds the list while it is a root.
    let mut kept_apart: Vec<Vec<u32>> = vec![Vec::new(); n + 1];

    // Scores edge `ei` and queues it if accepted.
    let mut score_edge = |ei: usize,
                          states: &[Option<RegionState>],
                          parent: &mut Vec<u32>,
                          versions: &[u32],
                          edges: &[Option<Edge>],
                          heap: &mut BinaryHeap<Candidate>,
                          log: &mut MergeLog,
                          kept_apart: &mut [Vec<u32>]| {
        let e = edges[ei].as_ref().expect("scored edges are alive");
        let (sa, sb) =
            (states[e.a as usize].as_ref().expect("alive"), states[e.b as usize].as_ref().expect("alive"));
        let (a, b) = (e.a, e.b);
        shared_boundary(&e.band, (a, b), &junctions, parent, &mut boundary);
        let side = |p: u32| match labels.data[p as usize] {
            0 => None,
            l => {
                let r = find(parent, l);
                (r == a || r == b).then_some(r == a)
            }
        };
        let (terms, outcome) = evaluate(config, (sa, sb), (&e.band, &boundary), side, &maps, &mut scratch);
        log.decisions.push(Decision { a, b, after_merges: log.merges, terms, outcome, merged: false });
        if outcome == Outcome::ConcaveCrease {
            kept_apart[a as usize].push(b);
            kept_apart[b as usize].push(a);
        }
        if outcome == Outcome::Accepted {
            heap.push(Candidate {
                score: terms.score,
                a,
                b,
                version_a: versions[a as usize],
                version_b: versions[b as usize],
                terms,
            });
        }
    };

    for ei in 0..edges.len() {
        score_edge(ei, &states, &mut parent, &versions, &edges, &mut heap, &mut log, &mut kept_apart);
    }

    while log.merges < crate::config::MAX_MERGES {
        let Some(c) = heap.pop() else { break };
        let (a, b) = (c.a as usize, c.b as usize);
        if states[a].is_none()
            || states[b].is_none()
            || versions[a] != c.version_a
            || versions[b] != c.version_b
        {
            continue;
        }
        let mut terms = c.terms;
        // A crease this view confirmed between a region of each side keeps the sides apart.
        let split_by_edge = kept_apart[a].iter().any(|&r| find(&mut parent, r) as usize == b)
            || kept_apart[b].iter().any(|&r| find(&mut parent, r) as usize == a);
        if split_by_edge {
            let outcome = Outcome::KeptApart;
            log.decisions.push(Decision {
                a: c.a,
                b: c.b,
                after_merges: log.merges,
                terms,
                outcome,
                merged: false,
            });
            continue;
        }
        // The separate-wholes gate, asked now rather than when the pair was scored: neither
        // region has changed since, so the answer is the same, for far fewer pairs.
        if let Some(w) = wholes.filter(|_| config.separate_wholes) {
            let e = neighbours[a].get(&(b as u32)).and_then(|&ei| edges[ei].as_ref());
            let band = &e.expect("a current pair's edge is alive").band;
            let mut side = |p: u32| match labels.data[p as usize] {
                0 => None,
                l => {
                    let r = find(&mut parent, l) as usize;
                    (r == a || r == b).then_some(r == a)
                }
            };
            let count = w.count(band, &mut side, &mut wholes_scratch);
            terms.wholes = Some([count.together, count.apart, count.seen]);
            if count.separate() {
                let (a, b) = (c.a, c.b);
                let outcome = Outcome::SeparateWholes;
                log.decisions.push(Decision {
                    a,
                    b,
                    after_merges: log.merges,
                    terms,
                    outcome,
                    merged: false,
                });
                continue;
            }
        }
        // Merge b into a.
        let absorbed = states[b].take().expect("checked alive");
        states[a].as_mut().expect("checked alive").absorb(&absorbed);
        let moved = std::mem::take(&mut kept_apart[b]);
        kept_apart[a].extend(moved);
        parent[b] = a as u32;
        versions[a] += 1;
        log.merges += 1;
        log.decisions.push(Decision {
            a: c.a,
            b: c.b,
            after_merges: log.merges - 1,
            terms,
            outcome: Outcome::Accepted,
            merged: true,
        });
        let of_b = std::mem::take(&mut neighbours[b]);
        if let Some(e_ab) = neighbours[a].remove(&(b as u32)) {
            edges[e_ab] = None;
        }
        for (cn, e_bc) in of_b {
            if cn as usize == a {
                continue;
            }
            neighbours[cn as usize].remove(&(b as u32));
            if let Some(&e_ac) = neighbours[a].get(&cn) {
                let band_bc = edges[e_bc].take().expect("alive edge").band;
                let e = edges[e_ac].as_mut().expect("alive edge");
                e.band = sorted_union(&e.band, &band_bc);
            } else {
                let e = edges[e_bc].as_mut().expect("alive edge");
                (e.a, e.b) = ((a as u32).min(cn), (a as u32).max(cn));
                neighbours[a].insert(cn, e_bc);
                neighbours[cn as usize].insert(a as u32, e_bc);
            }
        }
        let to_score: Vec<usize> = neighbours[a].values().copied().collect();
        for ei in to_score {
            score_edge(ei, &states, &mut parent, &versions, &edges, &mut heap, &mut log, &mut kept_apart);
        }
    }
    Ok(finish(inputs, &states, &mut parent, log))
}

/// Final labels (canonical ids by first pixel), summaries and the id map.
fn finish(
    inputs: &ViewInputs,
    states: &[Option<RegionState>],
    parent: &mut [u32],
    mut log: MergeLog,
) -> MergeResult {
    let labels = &inputs.regions.labels;
    let n = inputs.regions.count();
    let mut final_of_root = vec![0u32; n + 1];
    let mut next = 0u32;
    let mut out = vec![0u32; labels.data.len()];
    let mut root_of_label = vec![0u32; n + 1];
    for l in 1..=n as u32 {
        root_of_label[l as usize] = find(parent, l);
    }
    let mut roots_in_order = Vec::new();
    for (p, &l) in labels.data.iter().enumerate() {
        if l == 0 {
            continue;
        }
        let root = root_of_label[l as usize] as usize;
        if final_of_root[root] == 0 {
            next += 1;
            final_of_root[root] = next;
            roots_in_order.push(root);
        }
        out[p] = final_of_root[root];
    }
    let mut merged_from: Vec<Vec<u32>> = vec![Vec::new(); next as usize];
    log.final_id_of_input = (1..=n).map(|l| final_of_root[root_of_label[l] as usize]).collect();
    for (i, &f) in log.final_id_of_input.iter().enumerate() {
        if f > 0 {
            merged_from[f as usize - 1].push(i as u32 + 1);
        }
    }
    let regions: Vec<RegionSummary> = roots_in_order
        .iter()
        .zip(merged_from)
        .enumerate()
        .map(|(i, (&root, merged_from))| {
            let s = states[root].as_ref().expect("roots are alive");
            let norm = s.descriptor_sum.iter().map(|v| v * v).sum::<f32>().sqrt();
            RegionSummary {
                id: i as u32 + 1,
                area: s.area,
                descriptor: s
                    .descriptor_sum
                    .iter()
                    .map(|v| if norm > 0.0 { v / norm } else { 0.0 })
                    .collect(),
                mean_depth: s.mean_depth(),
                bbox_px: s.bbox,
                merged_from,
            }
        })
        .collect();
    log.regions_after = regions.len();
    MergeResult { labels: Plane { width: labels.width, height: labels.height, data: out }, regions, log }
}
