//! [`ViewCounts`]: everything the metrics need from one view (a ground-truth and a predicted
//! label map), as sparse pixel counts. Views are counted independently (in parallel) and
//! combined in view order, so results do not depend on scheduling.

use crate::band::BandScanner;
use crate::config::EvalConfig;
use crate::error::EvalError;
use crate::hungarian::max_weight_matching_sparse;
use serde::{Deserialize, Serialize};
use splatseg_scene::Plane;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// Number of pixels with ground-truth id `gt` and predicted id `pred` (0 = none on either side).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PairCount {
    /// Ground-truth id (0 = unlabelled).
    pub gt: u32,
    /// Predicted id (0 = no prediction).
    pub pred: u32,
    /// Pixels.
    pub pixels: u64,
}

/// Pixels of the boundary band of ground-truth instance `gt` predicted as `pred`, split by what
/// the ground truth says at the pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct BandCount {
    /// The ground-truth instance whose band this is (never 0).
    pub gt: u32,
    /// Predicted id at the pixel (0 = none).
    pub pred: u32,
    /// Pixels whose ground truth is `gt` itself.
    pub in_gt: u64,
    /// Pixels whose ground truth is 0 (unlabelled).
    pub on_unlabelled: u64,
    /// Pixels whose ground truth is another instance.
    pub on_other: u64,
}

/// The sparse counts of one view.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ViewCounts {
    /// View name (the label map's file stem).
    pub name: String,
    /// All (gt, pred) pairs present, sorted by `(gt, pred)`.
    pub pixels: Vec<PairCount>,
    /// Band counts, sorted by `(gt, pred)`.
    pub band: Vec<BandCount>,
}

impl ViewCounts {
    /// Counts view `name`. `gt`, `pred`: `[H, W]` label maps of the same size.
    pub fn compute(
        name: &str,
        gt: &Plane<u32>,
        pred: &Plane<u32>,
        cfg: &EvalConfig,
    ) -> Result<Self, EvalError> {
        if gt.size() != pred.size() {
            return Err(EvalError::SizeMismatch {
                view: name.to_string(),
                gt_width: gt.width,
                gt_height: gt.height,
                pred_width: pred.width,
                pred_height: pred.height,
                path: None,
            });
        }
        Ok(ViewCounts {
            name: name.to_string(),
            pixels: count_pairs(gt, pred),
            band: count_band(gt, pred, cfg),
        })
    }

    /// The counts of a view with no prediction at all (every pixel predicted 0).
    pub fn without_prediction(name: &str, gt: &Plane<u32>, cfg: &EvalConfig) -> Self {
        let zeros = Plane::filled(gt.width, gt.height, 0u32);
        ViewCounts {
            name: name.to_string(),
            pixels: count_pairs(gt, &zeros),
            band: count_band(gt, &zeros, cfg),
        }
    }

    /// mIoU of this view alone: Hungarian matching on this view's IoU matrix, mean over the
    /// ground-truth instances present in it (unmatched = 0). `None` if it has no instance.
    pub fn miou(&self, cfg: &EvalConfig) -> Option<f64> {
        let table = IouTable::new(&self.pixels, cfg);
        if table.gt_ids.is_empty() {
            return None;
        }
        let matches = table.hungarian();
        Some(matches.iter().map(|m| m.map_or(0.0, |(_, iou)| iou)).sum::<f64>() / table.gt_ids.len() as f64)
    }
}

/// Packs a (gt, pred) pair into one sortable key.
#[inline]
fn pair_key(gt: u32, pred: u32) -> u64 {
    ((gt as u64) << 32) | pred as u64
}

/// Counts (gt, pred) pairs with run-length accumulation along rows (label maps are piecewise
/// constant), then sorts and merges the runs. `gt`, `pred`: `[H, W]`.
fn count_pairs(gt: &Plane<u32>, pred: &Plane<u32>) -> Vec<PairCount> {
    let mut runs: Vec<(u64, u64)> = Vec::new();
    let mut current: Option<(u64, u64)> = None;
    for (&g, &p) in gt.data.iter().zip(&pred.data) {
        let key = pair_key(g, p);
        match &mut current {
            Some((k, n)) if *k == key => *n += 1,
            _ => {
                if let Some(run) = current.take() {
                    runs.push(run);
                }
                current = Some((key, 1));
            }
        }
    }
    runs.extend(current);
    runs.sort_unstable_by_key(|r| r.0);
    let mut out: Vec<PairCount> = Vec::new();
    for (key, n) in runs {
        let (g, p) = ((key >> 32) as u32, key as u32);
        match out.last_mut() {
            Some(last) if last.gt == g && last.pred == p => last.pixels += n,
            _ => out.push(PairCount { gt: g, pred: p, pixels: n }),
        }
    }
    out
}

/// Counts, for every band pixel and every instance whose band it is in, the predicted id and
/// the ground truth's relation to the instance. `gt`, `pred`: `[H, W]`.
fn count_band(gt: &Plane<u32>, pred: &Plane<u32>, cfg: &EvalConfig) -> Vec<BandCount> {
    let scanner = BandScanner::new(gt, cfg.band_radius_px);
    // (gt, pred) key → pixels by relation [in gt, unlabelled, other instance]. The map is only
    // read back sorted.
    let mut hits: HashMap<u64, [u64; 3], BuildHasherDefault<PairHasher>> = HashMap::default();
    let mut scratch = Vec::new();
    for y in 0..gt.height {
        let gt_row = gt.row(y);
        let pred_row = pred.row(y);
        scanner.scan_row(y, &mut scratch, |x, labels| {
            let (here, p) = (gt_row[x], pred_row[x]);
            for &g in labels.iter().filter(|g| **g != 0) {
                let relation = if here == g {
                    0
                } else if here == 0 {
                    1
                } else {
                    2
                };
                hits.entry(pair_key(g, p)).or_default()[relation] += 1;
            }
        });
    }
    let mut out: Vec<BandCount> = hits
        .into_iter()
        .map(|(key, [in_gt, on_unlabelled, on_other])| BandCount {
            gt: (key >> 32) as u32,
            pred: key as u32,
            in_gt,
            on_unlabelled,
            on_other,
        })
        .collect();
    out.sort_unstable_by_key(|c| (c.gt, c.pred));
    out
}

/// A fast multiplicative hash for the `u64` pair keys (not DoS-resistant; keys are label ids).
#[derive(Default)]
struct PairHasher(u64);

impl Hasher for PairHasher {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }

    fn write_u64(&mut self, i: u64) {
        self.0 = (self.0.rotate_left(5) ^ i).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    }

    fn finish(&self) -> u64 {
        self.0 ^ (self.0 >> 29)
    }
}

/// IoU between ground-truth instances and predicted ids from summed pair counts, stored
/// sparsely (only overlapping pairs have a non-zero IoU).
pub(crate) struct IouTable {
    /// Sorted ground-truth instance ids (non-zero, with pixels).
    pub gt_ids: Vec<u32>,
    /// Sorted predicted ids overlapping at least one instance.
    pub pred_ids: Vec<u32>,
    /// `(gt index, pred index, IoU)` for every overlapping pair, sorted.
    pub entries: Vec<(usize, usize, f64)>,
}

impl IouTable {
    /// `pixels`: pair counts in any order (duplicates are summed).
    pub fn new(pixels: &[PairCount], cfg: &EvalConfig) -> Self {
        let mut gt_ids: Vec<u32> =
            pixels.iter().filter(|c| c.gt != 0 && c.pixels > 0).map(|c| c.gt).collect();
        gt_ids.sort_unstable();
        gt_ids.dedup();
        let mut pred_ids: Vec<u32> =
            pixels.iter().filter(|c| c.gt != 0 && c.pred != 0 && c.pixels > 0).map(|c| c.pred).collect();
        pred_ids.sort_unstable();
        pred_ids.dedup();
        let mut gt_area = vec![0u64; gt_ids.len()];
        let mut pred_area = vec![0u64; pred_ids.len()];
        let mut inter: Vec<(usize, usize, u64)> = Vec::new();
        let counts_unlabelled = cfg.unlabelled_gt == crate::config::UnlabelledGt::Background;
        for c in pixels.iter().filter(|c| c.pixels > 0) {
            let gi = if c.gt == 0 { None } else { gt_ids.binary_search(&c.gt).ok() };
            let pi = pred_ids.binary_search(&c.pred).ok().filter(|_| c.pred != 0);
            if let Some(gi) = gi {
                gt_area[gi] += c.pixels;
            }
            if let Some(pi) = pi {
                if c.gt != 0 || counts_unlabelled {
                    pred_area[pi] += c.pixels;
                }
                if let Some(gi) = gi {
                    inter.push((gi, pi, c.pixels));
                }
            }
        }
        inter.sort_unstable();
        let mut merged: Vec<(usize, usize, u64)> = Vec::with_capacity(inter.len());
        for (gi, pi, n) in inter {
            match merged.last_mut() {
                Some(last) if (last.0, last.1) == (gi, pi) => last.2 += n,
                _ => merged.push((gi, pi, n)),
            }
        }
        let entries = merged
            .into_iter()
            .map(|(gi, pi, i)| (gi, pi, i as f64 / (gt_area[gi] + pred_area[pi] - i) as f64))
            .collect();
        IouTable { gt_ids, pred_ids, entries }
    }

    /// For every ground-truth instance (in `gt_ids` order): its matched predicted id and IoU, or
    /// `None` when the optimal assignment gives it nothing with positive IoU.
    pub fn hungarian(&self) -> Vec<Option<(u32, f64)>> {
        // Entries are finite, positive and in range by construction.
        let assignment = max_weight_matching_sparse(&self.entries, self.gt_ids.len(), self.pred_ids.len())
            .unwrap_or_else(|_| vec![None; self.gt_ids.len()]);
        assignment
            .iter()
            .enumerate()
            .map(|(r, c)| {
                c.map(|c| {
                    let k = self.entries.partition_point(|e| (e.0, e.1) < (r, c));
                    (self.pred_ids[c], self.entries[k].2)
                })
            })
            .collect()
    }
}
