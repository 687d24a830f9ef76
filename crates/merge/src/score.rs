//! The merge decision for one pair of adjacent regions: gates and the composite score.
//!
//! # The paper's score and why it cannot be used as printed
//!
//! Paper §4.2: `S = w_sem·cos(f_i, f_j) + w_depth·exp(−Δd²/(2σ_d²)) − w_dbound·max(∇D ∩ ∂m_ij)
//! − w_edge·max(∇edge ∩ ∂m_ij)`, merge if `|d̄_i − d̄_j| < τ_depth` and `S > τ_merge`, with
//! `w = (0.5, 0.2, 0.1, 0.2)`, `σ_d² = 0.05`, `τ_depth = 0.15`, `τ_merge = 0.85` and
//! `∂m_ij = ∂m_i ∪ ∂m_j`. Two problems:
//! 1. `S ≤ w_sem + w_depth = 0.7 < 0.85`: the printed formula never merges (the [`Literal`]
//!    profile keeps it, and a test shows it merges nothing).
//! 2. On `∂m_i ∪ ∂m_j` the maxima of LoG and `∇D` sit on each region's *own* outline (every object
//!    has a strong edge somewhere around it), so the penalty does not look at the boundary between
//!    the two regions at all.
//!
//! # The default reading ([`Paper`] profile)
//!
//! Same weights and thresholds, two changes that make the formula self-consistent:
//! - **Normalisation:** `S = (w_sem·cos + w_depth·aff − w_dbound·B_D − w_edge·B_E) / (w_sem + w_depth)`,
//!   so `S ≤ 1` and `τ_merge = 0.85` means "85 % of a perfect match". With cos = 1 and equal
//!   depths a pair merges iff `0.1·B_D + 0.2·B_E < 0.105`, i.e. a shared LoG edge below ≈ half the
//!   image's strongest edge.
//! - **Shared boundary:** `B_E`, `B_D` are taken on the band where the two regions meet,
//!   `dil(m_i) ∩ dil(m_j)` with the adjacency test's two 3×3 dilations (a 5-px band), minus the
//!   junction pixels whose 5×5 window also holds a third region (there the third region's own
//!   outline reaches in). Not the 1-px band: `|LoG|` with σ = 2 is zero *on* a step and peaks
//!   ≈ σ px either side, so a narrow band would sit in the zero crossing and miss the edge.
//! - **Statistic: the median**, not the max. Measured: the max is too noisy — `|LoG|` (σ = 2) and
//!   the smoothed `∇D` of an object's outline reach ~3σ px inside it, so wherever a split meets
//!   the outline the max sees the outline, not the split (hand-built test: a faint-stripe split
//!   scores S = 0.78 with the max, 0.985 with the median; a real strong edge still blocks, 0.79).
//!   On the synthetic scene (`splatseg ablate`, seed 0, 12 views, 47.8 SAM masks/view, raw
//!   per-view mIoU 0.441): max 27.2 masks/view, mIoU 0.743; quantile 0.9 19.4 / 0.889;
//!   quantile 0.75 16.5 / 0.931; **median 14.4 / 0.946**; mean 15.0 / 0.943. Code may set
//!   `MergeConfig::boundary_statistic` (`splatseg ablate` does); files cannot.
//!
//! Measured with these choices (same scene): literal profile 46.2 masks/view (nothing merged),
//! paper profile 14.4 / 0.946 (a released-code profile, removed as it was not the
//! authors' merger, over-merged: 7.8 / 0.487). Cue ablation:
//! semantic only 10.4 / 0.856 (white-on-white pair merged in 10 of 12 views), + LoG 14.9 /
//! 0.904 (4/12), + depth 14.4 / 0.946 (1/12, the view where the simulated SAM itself produced a
//! single mask over both objects). Sensitivity: aggressive (0.70, 0.30) 9.2 / 0.732, conservative
//! (0.95, 0.05) 30.8 / 0.674, w_sem 0.2 16.6 / 0.863, w_sem 0.8 13.9 / 0.948.
//!
//! # Other gates
//!
//! - Adjacency: bounding-box gap ≤ `τ_gap` (4 px), non-empty dilated intersection and contact
//!   ratio `|dil(m_i) ∩ dil(m_j)| / min(|m_i|, |m_j|) ≥ τ_contact` (0.01) — the released code's
//!   values, as the paper omits them.
//! - Hard depth gate `|Δd| < τ_depth` on per-image normalised depth. As printed, `Δd` is the
//!   gap between the regions' mean depths; by default ([`crate::DepthGapAt::Contact`]) it is
//!   the gap between the two sides' median depths on the band where they meet, and the depth
//!   affinity reads the same `Δd`. Region means split every floor and wall whose texture cuts
//!   it into a near and a far part (on the stress suite's tuning seeds 0–2, 2,506 of the
//!   3,701 pairs of one instance left unmerged were stopped by the mean-depth gate).
//! - Depth-step gate (not in the paper): reject when the boundary statistic of `∇D` on the
//!   contact exceeds `max_depth_boundary` (0.12). Depth maps smooth a step over a few pixels,
//!   so the contact medians of an object and what stands behind it come closer than the step;
//!   `∇D` there does not.
//! - Concave-crease gate (not in the paper; with metric depth and intrinsics): the surface
//!   normal on each side of the contact (averaged over the band pixels of that side, each the
//!   mean of its own region's rendered normals around it when the Gaussians give them,
//!   [`splatseg_cues::region_mean_normal`], else estimated from its own region's points,
//!   [`splatseg_cues::region_normal_at`]) and the
//!   sides' mean points `x`. The crease is concave when `(n_i − n_j)·(x_i − x_j) < 0` (the
//!   local-convexity criterion of LCCP, Stein et al. 2014): reject when it is concave and the
//!   normals differ by more than `max_concave_crease_deg` (45°). Objects are mostly convex;
//!   where two of them meet — a box on the floor, stacked boxes, walls at a corner — the crease
//!   is concave and the depth is continuous, so the depth gates cannot see it.
//! - A relative metric-depth gate (`|z̃_i − z̃_j| / min(z̃_i, z̃_j) ≤ 0.1` at the contact) was here
//!   until issue 27's ablation: with depth rendered from the Gaussians (alpha blending mixes the
//!   two surfaces across a contact, shrinking the gap to 0.00–0.21 where ground truth has
//!   0.25–0.31) it changed no result on the tuning or the blind families, so it went with its key.
//!
//! Which gate separates the white-on-white pair (synthetic scene, seed 0): its 37 adjacent
//! evaluations have normalised `|Δd̄|` 0.136–0.258, so the normalised gate (0.15) rejects 34 with
//! a thin margin and 3 slip through (the score, S ≤ 0.847, rejects those). The normalised gate
//! also costs accuracy elsewhere: it splits floors and walls whose halves have different mean
//! depths (no depth gate: 13.7 masks/view, mIoU 0.964; normalised gate: 14.4 / 0.946). The
//! default keeps the paper's gate.
//!
//!
//! # Separate wholes
//!
//! The last gate (not in the paper; when the pipeline gives the other views' SAM masks through
//! the Gaussians, [`crate::ViewWholes`]): a pair every other rule accepts is refused when other
//! views' masks hold its two sides in different wholes and seldom in one
//! ([`crate::wholes`] has the rule and why; [`ScoreTerms::wholes`] the counts). It is asked when
//! the pair comes up for merging, not when it is scored: the answer is the same (neither region
//! has changed since), and most accepted evaluations are superseded before they come up.
//!
//! [`Literal`]: crate::Profile::Literal
//! [`Paper`]: crate::Profile::Paper

use crate::config::{BoundaryStatistic, DepthGapAt, MergeConfig, Profile, TAU_CONTACT, TAU_GAP_PX};
use serde::{Deserialize, Serialize};
use splatseg_scene::Plane;

/// Every term of one evaluation, for the merge log.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScoreTerms {
    /// `cos(f_i, f_j)`.
    pub cos: f32,
    /// The normalised depth gap `Δd` of the gate and the affinity: `|d̄_i − d̄_j|` of the region
    /// means, or of the two sides' medians on the band where they meet
    /// ([`crate::DepthGapAt`]).
    pub depth_gap: f32,
    /// Depth affinity term before weighting.
    pub depth_affinity: f32,
    /// Boundary statistic of `∇D`.
    pub depth_boundary: f32,
    /// Boundary statistic of the LoG edge map.
    pub edge_boundary: f32,
    /// Contact ratio.
    pub contact: f32,
    /// Bounding-box gap in pixels.
    pub bbox_gap_px: u32,
    /// Angle between the surface normals of the two sides of the contact, degrees, negative
    /// when the crease is concave (when metric depth and intrinsics are available).
    #[serde(default)]
    pub crease_deg: Option<f32>,
    /// The composite score `S`.
    pub score: f32,
    /// Other views where SAM's masks hold both sides, where they hold them apart in a whole, and
    /// that see both sides (`[together, apart, seen]`, [`crate::wholes`]); taken only for a pair
    /// every other rule accepts, when it comes up for merging.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wholes: Option<[u32; 3]>,
}

/// What was decided for a pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Outcome {
    /// Score above `τ_merge`, all gates passed (merged when popped from the queue).
    Accepted,
    /// Bounding-box gap above `τ_gap` or contact ratio below `τ_contact`.
    NotAdjacent,
    /// `|d̄_i − d̄_j| ≥ τ_depth`.
    DepthGate,
    /// The depth-gradient statistic on the contact is above `max_depth_boundary`.
    DepthStep,
    /// The two sides meet at a concave crease sharper than `max_concave_crease_deg`.
    ConcaveCrease,
    /// `S ≤ τ_merge`.
    BelowThreshold,
    /// Other views' SAM masks hold the two sides in different wholes ([`crate::wholes`]).
    SeparateWholes,
    /// Earlier in this view the concave-crease gate refused a pair of regions that are now on
    /// either side: a crease the view confirmed keeps them apart ([`crate::merge_view`]).
    KeptApart,
}

/// What the scorer needs to know about one region.
#[derive(Clone, Debug)]
pub(crate) struct RegionState {
    /// Pixel count.
    pub area: u64,
    /// Sum of normalised depth over the region.
    pub depth_sum: f64,
    /// `[C]` sum of descriptors (area × mean).
    pub descriptor_sum: Vec<f32>,
    /// Inclusive `[x0, y0, x1, y1]`.
    pub bbox: [u32; 4],
    /// Max LoG over the region's own outline (literal profile).
    pub outline_edge_max: f32,
    /// Max `∇D` over the region's own outline (literal profile).
    pub outline_depth_grad_max: f32,
}

impl RegionState {
    pub fn mean_depth(&self) -> f32 {
        (self.depth_sum / self.area.max(1) as f64) as f32
    }

    pub fn absorb(&mut self, other: &RegionState) {
        self.area += other.area;
        self.depth_sum += other.depth_sum;
        self.descriptor_sum.iter_mut().zip(&other.descriptor_sum).for_each(|(a, b)| *a += b);
        self.bbox = [
            self.bbox[0].min(other.bbox[0]),
            self.bbox[1].min(other.bbox[1]),
            self.bbox[2].max(other.bbox[2]),
            self.bbox[3].max(other.bbox[3]),
        ];
        self.outline_edge_max = self.outline_edge_max.max(other.outline_edge_max);
        self.outline_depth_grad_max = self.outline_depth_grad_max.max(other.outline_depth_grad_max);
    }
}

/// Per-pixel maps the boundary terms read.
pub(crate) struct BoundaryMaps<'a> {
    /// `[H, W]` normalised depth in [0, 1] (the contact depth gap reads it).
    pub depth: &'a Plane<f32>,
    /// `[H, W]` LoG edge strength in [0, 1].
    pub edges: &'a Plane<f32>,
    /// `[H, W]` `∇D` in [0, 1].
    pub depth_gradient: &'a Plane<f32>,
    /// Camera-space points and normals, for the crease gate.
    pub surface: Option<SurfaceMaps<'a>>,
}

/// `[H, W]` camera-space points and unit surface normals (NaN = none; normals only on band
/// pixels).
#[derive(Clone, Copy)]
pub(crate) struct SurfaceMaps<'a> {
    /// Points.
    pub points: &'a Plane<[f32; 3]>,
    /// Normals.
    pub normals: &'a Plane<[f32; 3]>,
}

/// Fewest band pixels with a normal each side needs for the crease angle.
const CREASE_MIN_PIXELS: usize = 8;

/// The signed crease angle between the two sides of `band` (degrees, negative = concave; see
/// the module docs), `None` without surface maps or when a side has too few normals or
/// normals that disagree (their mean shorter than ½).
fn crease_deg(
    maps: &BoundaryMaps<'_>,
    band: &[u32],
    side: &mut impl FnMut(u32) -> Option<bool>,
) -> Option<f32> {
    let SurfaceMaps { points, normals } = maps.surface?;
    let mut n = [[0f64; 3]; 2];
    let mut x = [[0f64; 3]; 2];
    let mut count = [0usize; 2];
    for &p in band {
        let normal = normals.data[p as usize];
        if !normal[0].is_finite() {
            continue;
        }
        let k = match side(p) {
            Some(true) => 0,
            Some(false) => 1,
            None => continue,
        };
        let point = points.data[p as usize];
        for c in 0..3 {
            n[k][c] += normal[c] as f64;
            x[k][c] += point[c] as f64;
        }
        count[k] += 1;
    }
    if count[0] < CREASE_MIN_PIXELS || count[1] < CREASE_MIN_PIXELS {
        return None;
    }
    let unit = |v: [f64; 3], k: usize| -> Option<[f64; 3]> {
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        (len >= 0.5 * count[k] as f64).then(|| v.map(|c| c / len))
    };
    let (na, nb) = (unit(n[0], 0)?, unit(n[1], 1)?);
    let dot = (na[0] * nb[0] + na[1] * nb[1] + na[2] * nb[2]).clamp(-1.0, 1.0);
    let angle = dot.acos().to_degrees() as f32;
    let convexity: f64 =
        (0..3).map(|c| (na[c] - nb[c]) * (x[0][c] / count[0] as f64 - x[1][c] / count[1] as f64)).sum();
    Some(if convexity < 0.0 { -angle } else { angle })
}

/// Statistic of `map` over the band pixels.
fn band_statistic(map: &Plane<f32>, band: &[u32], stat: BoundaryStatistic, scratch: &mut Vec<f32>) -> f32 {
    if band.is_empty() {
        return 0.0;
    }
    match stat {
        BoundaryStatistic::Max => band.iter().map(|&p| map.data[p as usize]).fold(0.0, f32::max),
        BoundaryStatistic::Mean => {
            band.iter().map(|&p| map.data[p as usize] as f64).sum::<f64>() as f32 / band.len() as f32
        }
        BoundaryStatistic::Quantile(q) => {
            scratch.clear();
            scratch.extend(band.iter().map(|&p| map.data[p as usize]));
            let k = ((q * (scratch.len() - 1) as f32).round() as usize).min(scratch.len() - 1);
            *scratch.select_nth_unstable_by(k, f32::total_cmp).1
        }
    }
}

fn median(values: &mut [f32]) -> Option<f32> {
    if values.is_empty() {
        return None;
    }
    let k = values.len() / 2;
    Some(*values.select_nth_unstable_by(k, f32::total_cmp).1)
}

/// Gap in pixels between two inclusive boxes (0 if they overlap or touch).
fn bbox_gap(a: &[u32; 4], b: &[u32; 4]) -> u32 {
    let dx = (b[0] as i64 - a[2] as i64 - 1).max(a[0] as i64 - b[2] as i64 - 1).max(0);
    let dy = (b[1] as i64 - a[3] as i64 - 1).max(a[1] as i64 - b[3] as i64 - 1).max(0);
    dx.max(dy) as u32
}

/// Reusable buffers for [`evaluate`].
#[derive(Default)]
pub(crate) struct Scratch {
    values: Vec<f32>,
    side_a: Vec<f32>,
    side_b: Vec<f32>,
}

impl Scratch {
    /// The medians of `map` over the band pixels of each side (`None` when a side has no
    /// usable pixel; `usable` filters the values).
    fn side_medians(
        &mut self,
        map: &Plane<f32>,
        band: &[u32],
        side: &mut impl FnMut(u32) -> Option<bool>,
        usable: impl Fn(f32) -> bool,
    ) -> Option<(f32, f32)> {
        self.side_a.clear();
        self.side_b.clear();
        for &p in band {
            let v = map.data[p as usize];
            if !usable(v) {
                continue;
            }
            match side(p) {
                Some(true) => self.side_a.push(v),
                Some(false) => self.side_b.push(v),
                None => {}
            }
        }
        Some((median(&mut self.side_a)?, median(&mut self.side_b)?))
    }
}

/// Scores the pair `(a, b)`. `band` is `dil(a) ∩ dil(b)` (contact ratio, the sides' depth
/// medians); `boundary` the part of it where the LoG and `∇D` statistics are taken. `side(p)` tells
/// which region a band pixel belongs to (`Some(true)` = a, `Some(false)` = b, `None` = neither).
/// The separate-wholes gate is not asked here (see the module docs).
pub(crate) fn evaluate(
    config: &MergeConfig,
    (a, b): (&RegionState, &RegionState),
    (band, boundary): (&[u32], &[u32]),
    mut side: impl FnMut(u32) -> Option<bool>,
    maps: &BoundaryMaps<'_>,
    scratch: &mut Scratch,
) -> (ScoreTerms, Outcome) {
    let cos = splatseg_cues::cosine(&a.descriptor_sum, &b.descriptor_sum);
    let depth_gap = match config.depth_gap_at {
        DepthGapAt::RegionMeans => (a.mean_depth() - b.mean_depth()).abs(),
        DepthGapAt::Contact => scratch
            .side_medians(maps.depth, band, &mut side, f32::is_finite)
            .map_or_else(|| (a.mean_depth() - b.mean_depth()).abs(), |(da, db)| (da - db).abs()),
    };
    let contact = band.len() as f32 / a.area.min(b.area).max(1) as f32;
    let bbox_gap_px = bbox_gap(&a.bbox, &b.bbox);
    let (depth_affinity, depth_boundary, edge_boundary) = match config.profile {
        Profile::Paper => (
            (-depth_gap * depth_gap / (2.0 * config.sigma_d_sq)).exp(),
            band_statistic(maps.depth_gradient, boundary, config.boundary_statistic, &mut scratch.values),
            band_statistic(maps.edges, boundary, config.boundary_statistic, &mut scratch.values),
        ),
        Profile::Literal => (
            (-depth_gap * depth_gap / (2.0 * config.sigma_d_sq)).exp(),
            a.outline_depth_grad_max.max(b.outline_depth_grad_max),
            a.outline_edge_max.max(b.outline_edge_max),
        ),
    };
    let raw = config.w_sem * cos + config.w_depth * depth_affinity
        - config.w_dbound * depth_boundary
        - config.w_edge * edge_boundary;
    let score = match config.profile {
        Profile::Paper => raw / (config.w_sem + config.w_depth),
        Profile::Literal => raw,
    };
    let crease_deg = match config.max_concave_crease_deg {
        Some(_) => crease_deg(maps, band, &mut side),
        None => None,
    };
    let terms = ScoreTerms {
        cos,
        depth_gap,
        depth_affinity,
        depth_boundary,
        edge_boundary,
        contact,
        bbox_gap_px,
        crease_deg,
        score,
        wholes: None,
    };
    let outcome = if band.is_empty() || bbox_gap_px > TAU_GAP_PX || contact < TAU_CONTACT {
        Outcome::NotAdjacent
    } else if depth_gap >= config.tau_depth {
        Outcome::DepthGate
    } else if config.max_depth_boundary.is_some_and(|t| depth_boundary > t) {
        Outcome::DepthStep
    } else if matches!((crease_deg, config.max_concave_crease_deg), (Some(c), Some(t)) if c < -t) {
        Outcome::ConcaveCrease
    } else if score > config.tau_merge {
        Outcome::Accepted
    } else {
        Outcome::BelowThreshold
    };
    (terms, outcome)
}
