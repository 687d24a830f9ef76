//! 3D evidence for matching: how many Gaussians two masks of different views share.
//!
//! Rule (documented in the crate docs): for a mask `i` of view `a` and a mask `j` of view `b`,
//! let `S_i` be the Gaussians visible in view `a` whose centre falls in mask `i`, and `V_b` the
//! Gaussians visible in view `b`. The *support* of the pair is `min(|S_i ∩ V_b|, |S_j ∩ V_a|)`:
//! how many of each mask's Gaussians the other view can see at all. With enough support, the
//! pair's *overlap* is the containment `|S_i ∩ S_j| / support`: 1 when every co-visible Gaussian
//! of the smaller mask lies in the other mask (same object, or a fragment of it), 0 when the two
//! masks cover disjoint Gaussians (different objects, however alike they look).
//!
//! Work is split over Gaussians: each thread's share counts into its own tables, and the integer
//! tables are summed afterwards (exact, so the result does not depend on the split).

use crate::error::{MatchError, MatchResult};
use crate::input::{MatchInput, ViewObservations};
use rayon::prelude::*;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// A multiply-shift hasher for `u64` pair keys (std's SipHash is several times slower here).
#[derive(Default)]
struct PairKeyHasher(u64);

impl Hasher for PairKeyHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(5) ^ b as u64).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
        }
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (x ^ (x >> 29)).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    }
}

type PairMap = HashMap<u64, u32, BuildHasherDefault<PairKeyHasher>>;

/// Gaussian co-occurrence counts between masks, over (a deterministic subsample of) the Gaussians.
#[derive(Clone, Debug, Default)]
pub struct Evidence {
    n_views: usize,
    /// `[n_masks, n_views]`: `covisible[m * n_views + v]` = `|S_m ∩ V_v|`.
    covisible: Vec<u32>,
    /// `|S_i ∩ S_j|` keyed by `(i << 32) | j` with `i < j` (global mask indices).
    shared: PairMap,
    /// Every `stride`-th Gaussian was counted.
    pub stride: u32,
}

impl Evidence {
    /// `|S_mask ∩ V_view|`: Gaussians of `mask` that `view` sees.
    pub fn covisible(&self, mask: usize, view: usize) -> u32 {
        self.covisible[mask * self.n_views + view]
    }

    /// Every pair with shared Gaussians: `(i, j, |S_i ∩ S_j|)`, `i < j` (in no particular order).
    pub fn shared_pairs(&self) -> impl Iterator<Item = (u32, u32, u32)> + '_ {
        self.shared.iter().map(|(&k, &n)| ((k >> 32) as u32, k as u32, n))
    }

    /// `|S_i ∩ S_j|` for global mask indices `i`, `j`.
    pub fn shared(&self, i: usize, j: usize) -> u32 {
        let (lo, hi) = if i < j { (i, j) } else { (j, i) };
        self.shared.get(&(((lo as u64) << 32) | hi as u64)).copied().unwrap_or(0)
    }
}

/// Index of each view's first mask in the global mask numbering: `[n_views + 1]`.
pub fn mask_offsets(input: &MatchInput) -> Vec<usize> {
    let mut offsets = Vec::with_capacity(input.views.len() + 1);
    let mut total = 0;
    offsets.push(0);
    for v in &input.views {
        total += v.len();
        offsets.push(total);
    }
    offsets
}

/// Checks the observations against the masks (lengths, sorted ids, labels in range).
fn validate(input: &MatchInput, observations: &[ViewObservations]) -> MatchResult<()> {
    if observations.len() != input.views.len() {
        return Err(MatchError::ViewCount { got: observations.len(), expected: input.views.len() });
    }
    for (view, (obs, masks)) in observations.iter().zip(&input.views).enumerate() {
        if obs.labels.len() != obs.gaussians.len() {
            return Err(MatchError::Shape {
                view,
                what: "observation labels",
                got: obs.labels.len(),
                expected: obs.gaussians.len(),
            });
        }
        if obs.gaussians.windows(2).any(|w| w[0] >= w[1]) {
            return Err(MatchError::Unsorted { view });
        }
        if let Some(&label) = obs.labels.iter().find(|&&l| l as usize > masks.len()) {
            return Err(MatchError::UnknownLabel { view, label, masks: masks.len() });
        }
    }
    Ok(())
}

/// Per-Gaussian observation lists `(view, label)` of the sampled Gaussians, CSR layout.
struct ObservationsByGaussian {
    /// `[n_sampled + 1]` row starts into `entries`.
    starts: Vec<usize>,
    /// `(view, local label)` pairs, grouped by Gaussian, views increasing within a group.
    entries: Vec<(u32, u32)>,
}

fn transpose(observations: &[ViewObservations], budget: u64) -> (ObservationsByGaussian, u32) {
    let n_gaussians =
        observations.iter().filter_map(|o| o.gaussians.last()).map(|&g| g as usize + 1).max().unwrap_or(0);
    let mut counts = vec![0u32; n_gaussians];
    for obs in observations {
        for &g in &obs.gaussians {
            counts[g as usize] += 1;
        }
    }
    let pairs: u64 = counts.iter().map(|&k| k as u64 * (k as u64).saturating_sub(1) / 2).sum();
    // Observations the caller already sampled (every `base`-th Gaussian, e.g. to bound memory over
    // many views) are subsampled further by whole multiples of `base`.
    let base = observations.iter().flat_map(|o| &o.gaussians).fold(0u32, |d, &g| gcd(d, g)).max(1);
    let stride = (pairs.div_ceil(budget.max(1)).max(1) as u32).saturating_mul(base);
    let sampled = |g: u32| g.is_multiple_of(stride);
    let mut starts = Vec::with_capacity(n_gaussians / stride as usize + 2);
    let mut row_of = vec![u32::MAX; n_gaussians.div_ceil(stride as usize)];
    let mut total = 0usize;
    for g in (0..n_gaussians).step_by(stride as usize) {
        row_of[g / stride as usize] = starts.len() as u32;
        starts.push(total);
        total += counts[g] as usize;
    }
    starts.push(total);
    let mut fill: Vec<usize> = starts[..starts.len() - 1].to_vec();
    let mut entries = vec![(0u32, 0u32); total];
    for (view, obs) in observations.iter().enumerate() {
        for (&g, &label) in obs.gaussians.iter().zip(&obs.labels) {
            if sampled(g) {
                let row = row_of[(g / stride) as usize] as usize;
                entries[fill[row]] = (view as u32, label);
                fill[row] += 1;
            }
        }
    }
    (ObservationsByGaussian { starts, entries }, stride)
}

/// Greatest common divisor (`gcd(0, x) = x`).
fn gcd(mut a: u32, mut b: u32) -> u32 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// Counts Gaussian co-occurrence between the masks of `input` (see the module docs).
pub fn gather_evidence(
    input: &MatchInput,
    observations: &[ViewObservations],
    max_pair_samples: u64,
) -> MatchResult<Evidence> {
    validate(input, observations)?;
    let offsets = mask_offsets(input);
    let n_masks = *offsets.last().unwrap_or(&0);
    let n_views = input.views.len();
    let (by_gaussian, stride) = transpose(observations, max_pair_samples);
    let n_rows = by_gaussian.starts.len() - 1;
    // One pair of tables per thread (not per rayon split: the covisibility table alone is
    // n_masks × n_views), summed in a fixed order. Integer counts: the sums are exact, so the
    // result does not depend on the thread count.
    let parts = rayon::current_num_threads().clamp(1, n_rows.max(1));
    let per_part = n_rows.div_ceil(parts);
    let tables: Vec<(Vec<u32>, PairMap)> = (0..parts)
        .into_par_iter()
        .map(|p| {
            let (mut covisible, mut shared) = (vec![0u32; n_masks * n_views], PairMap::default());
            for row in p * per_part..((p + 1) * per_part).min(n_rows) {
                let obs = &by_gaussian.entries[by_gaussian.starts[row]..by_gaussian.starts[row + 1]];
                count_gaussian(obs, &offsets, n_views, &mut covisible, &mut shared);
            }
            (covisible, shared)
        })
        .collect();
    drop(by_gaussian);
    let mut tables = tables.into_iter();
    let (mut covisible, mut shared) = tables.next().unwrap_or_default();
    covisible.resize(n_masks * n_views, 0);
    for (c, s) in tables {
        for (t, x) in covisible.iter_mut().zip(c) {
            *t += x;
        }
        for (k, x) in s {
            *shared.entry(k).or_insert(0) += x;
        }
    }
    Ok(Evidence { n_views, covisible, shared, stride })
}

/// Adds one Gaussian's observations `(view, label)` to the tables.
fn count_gaussian(
    obs: &[(u32, u32)],
    offsets: &[usize],
    n_views: usize,
    covisible: &mut [u32],
    shared: &mut PairMap,
) {
    let mask = |(view, label): (u32, u32)| (label > 0).then(|| offsets[view as usize] + label as usize - 1);
    for (x, &a) in obs.iter().enumerate() {
        let mask_a = mask(a);
        for &b in &obs[x + 1..] {
            let mask_b = mask(b);
            if let Some(i) = mask_a {
                covisible[i * n_views + b.0 as usize] += 1;
            }
            if let Some(j) = mask_b {
                covisible[j * n_views + a.0 as usize] += 1;
            }
            if let (Some(i), Some(j)) = (mask_a, mask_b) {
                let (lo, hi) = if i < j { (i, j) } else { (j, i) };
                *shared.entry(((lo as u64) << 32) | hi as u64).or_insert(0) += 1;
            }
        }
    }
}
