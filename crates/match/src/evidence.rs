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
//! Nothing of size `n_masks × n_views` or `n_masks²` is built: [`Evidence`] keeps the sampled
//! observations grouped by Gaussian, and the counts of one view's masks against every other mask
//! are made on demand ([`Evidence::view_counts`], [`Evidence::mask_counts`]) into scratch vectors
//! of `n_masks` and `n_views` entries, so matching's memory grows with the masks, not with the
//! pairs of masks. Counts are exact integers: the result does not depend on the thread count.

use crate::error::{MatchError, MatchResult};
use crate::input::{MatchInput, ViewObservations};

/// The sampled observations, grouped by Gaussian and by view.
#[derive(Clone, Debug, Default)]
pub struct Evidence {
    /// `[n_views + 1]` index of each view's first mask in the global numbering.
    offsets: Vec<usize>,
    /// `[n_rows + 1]` row starts into `entries`; row `r` is Gaussian `r · stride`.
    starts: Vec<usize>,
    /// `(view, local label)` of every sampled observation, grouped by Gaussian, views increasing.
    entries: Vec<(u32, u32)>,
    /// Every `stride`-th Gaussian was counted.
    pub stride: u32,
}

/// The counts of one mask `i` (of view `a`) against every view and every mask: scratch reused
/// from mask to mask.
#[derive(Clone, Debug, Default)]
pub struct MaskCounts {
    /// `[n_views]`: `covisible[v]` = `|S_i ∩ V_v|` (0 for `v = a`).
    pub covisible: Vec<u32>,
    /// `[n_masks]`: `shared[j]` = `|S_i ∩ S_j|` (0 for masks of view `a`).
    pub shared: Vec<u32>,
    /// Masks with a non-zero `shared` entry, so clearing costs what filling did.
    touched: Vec<u32>,
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

/// Greatest common divisor (`gcd(0, x) = x`).
fn gcd(mut a: u32, mut b: u32) -> u32 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// Groups the observations by Gaussian, keeping every `stride`-th Gaussian, the stride chosen so
/// that at most about `budget` Gaussian view pairs are counted.
pub fn gather_evidence(
    input: &MatchInput,
    observations: &[ViewObservations],
    budget: u64,
) -> MatchResult<Evidence> {
    validate(input, observations)?;
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
    let mut starts = Vec::with_capacity(n_gaussians / stride as usize + 2);
    let mut total = 0usize;
    for g in (0..n_gaussians).step_by(stride as usize) {
        starts.push(total);
        total += counts[g] as usize;
    }
    starts.push(total);
    drop(counts);
    let mut fill: Vec<usize> = starts[..starts.len() - 1].to_vec();
    let mut entries = vec![(0u32, 0u32); total];
    for (view, obs) in observations.iter().enumerate() {
        for (&g, &label) in obs.gaussians.iter().zip(&obs.labels) {
            if g.is_multiple_of(stride) {
                let row = (g / stride) as usize;
                entries[fill[row]] = (view as u32, label);
                fill[row] += 1;
            }
        }
    }
    Ok(Evidence { offsets: mask_offsets(input), starts, entries, stride })
}

impl Evidence {
    fn n_masks(&self) -> usize {
        *self.offsets.last().unwrap_or(&0)
    }

    fn n_views(&self) -> usize {
        self.offsets.len() - 1
    }

    /// The observations `(view, label)` of sampled row `row`.
    fn row(&self, row: usize) -> &[(u32, u32)] {
        &self.entries[self.starts[row]..self.starts[row + 1]]
    }

    /// Global index of local label `label ≥ 1` of `view`.
    fn mask(&self, view: u32, label: u32) -> usize {
        self.offsets[view as usize] + label as usize - 1
    }

    /// The sampled rows view `view` sees, grouped by the local label there: `(starts, rows)` with
    /// `starts: [n_labels + 2]` (label 0 = in no mask) and `rows` the row indices, increasing.
    pub fn rows_of_view(&self, view: usize, observations: &ViewObservations) -> (Vec<usize>, Vec<u32>) {
        let n_labels = self.offsets[view + 1] - self.offsets[view];
        let sampled = || {
            observations
                .gaussians
                .iter()
                .zip(&observations.labels)
                .filter(|(&g, _)| g.is_multiple_of(self.stride))
                .map(|(&g, &l)| (g / self.stride, l as usize))
        };
        let mut starts = vec![0usize; n_labels + 2];
        for (_, l) in sampled() {
            starts[l + 1] += 1;
        }
        for l in 0..=n_labels {
            starts[l + 1] += starts[l];
        }
        let mut fill = starts.clone();
        let mut rows = vec![0u32; starts[n_labels + 1]];
        for (row, l) in sampled() {
            rows[fill[l]] = row;
            fill[l] += 1;
        }
        (starts, rows)
    }

    /// `out[j]` = `|S_j ∩ V_view|` for every mask `j` (`[n_masks]`; 0 for masks of `view`), from
    /// `rows`: every sampled row `view` sees.
    pub fn view_counts(&self, view: usize, rows: &[u32], out: &mut Vec<u32>) {
        out.clear();
        out.resize(self.n_masks(), 0);
        for &row in rows {
            for &(v, l) in self.row(row as usize) {
                if l > 0 && v as usize != view {
                    out[self.mask(v, l)] += 1;
                }
            }
        }
    }

    /// The counts of the mask of `view` whose sampled rows are `rows` (its `S_i`) against every view
    /// and every mask of the other views, into `out`.
    pub fn mask_counts(&self, view: usize, rows: &[u32], out: &mut MaskCounts) {
        out.covisible.clear();
        out.covisible.resize(self.n_views(), 0);
        if out.shared.len() != self.n_masks() {
            out.shared = vec![0; self.n_masks()];
            out.touched.clear();
        }
        for &j in &out.touched {
            out.shared[j as usize] = 0;
        }
        out.touched.clear();
        for &row in rows {
            for &(v, l) in self.row(row as usize) {
                if v as usize == view {
                    continue;
                }
                out.covisible[v as usize] += 1;
                if l > 0 {
                    let j = self.mask(v, l);
                    if out.shared[j] == 0 {
                        out.touched.push(j as u32);
                    }
                    out.shared[j] += 1;
                }
            }
        }
    }
}
