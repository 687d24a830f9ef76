//! [`Metrics`]: the paper's segmentation metrics (supplement, "Evaluation Metrics") plus the
//! cross-view ones splatseg adds, computed from per-view [`ViewCounts`].
//!
//! - **mIoU**: intersection and union pixel counts of every (ground-truth instance, predicted
//!   id) pair are summed over *all* views, the IoU matrix is matched with the Hungarian
//!   algorithm (maximum total IoU), and mIoU is the mean over ground-truth instances, an
//!   unmatched instance scoring 0. A predicted id is one mask across views, so a prediction whose
//!   ids change from view to view is penalised, as it should be for view-consistent ids.
//! - **Boundary mIoU**: for the same matched pairs, intersection and union restricted to the band
//!   `B = (M_g ⊕ D_5) \ (M_g ⊖ D_5)` of the ground-truth mask (disk of radius 5 px), summed over
//!   views. An instance whose band is empty in every view (it covers whole images) gets its
//!   mask IoU.
//! - **#masks**: distinct non-zero predicted ids over all views, against the number of
//!   ground-truth instances.
//! - **Per-view mIoU**: Hungarian matching inside each view, mean over the instances present in
//!   that view; reported per view and as the mean over views.
//! - Predictions whose ids are numbered per view (raw SAM masks, merged-only regions) are scored
//!   with [`IdScope::PerView`]: every (view, id) is a separate mask.
//! - **Cross-view consistency**: per instance, the share of its pixels (over all views) whose
//!   predicted id is its most common non-zero predicted id; pixels predicted 0 count as
//!   inconsistent. Mean over instances.

use crate::config::{EvalConfig, IdScope};
use crate::error::EvalError;
use crate::view::{BandCount, IouTable, PairCount, ViewCounts};
use serde::{Deserialize, Serialize};

/// Scores of one ground-truth instance.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InstanceScore {
    /// Ground-truth id.
    pub gt_id: u32,
    /// Pixels over all views.
    pub pixels: u64,
    /// Number of views it appears in.
    pub views: usize,
    /// The predicted id the Hungarian matching gave it (None: unmatched).
    pub matched_pred: Option<u32>,
    /// IoU with the matched prediction over all views (0 if unmatched).
    pub iou: f64,
    /// Boundary IoU with the matched prediction over all views (0 if unmatched).
    pub boundary_iou: f64,
    /// Share of its pixels carrying its most common non-zero predicted id.
    pub consistency: f64,
    /// That most common non-zero predicted id (None: everything predicted 0).
    pub dominant_pred: Option<u32>,
}

/// Scores of one view.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ViewScore {
    /// View name (label map stem).
    pub name: String,
    /// Ground-truth instances present.
    pub gt_instances: usize,
    /// Distinct non-zero predicted ids present.
    pub pred_ids: usize,
    /// mIoU of the view alone (None: no instance in it).
    pub miou: Option<f64>,
}

/// 3D label accuracy on Gaussians (see [`crate::accuracy3d`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LabelAccuracy3d {
    /// Share of Gaussians with a ground-truth id whose predicted id maps to it.
    pub accuracy: f64,
    /// Gaussians with a ground-truth id.
    pub labelled_gaussians: u64,
    /// Of those, how many have no predicted id (`-1`); they count as wrong.
    pub unlabelled_predictions: u64,
    /// Distinct ground-truth object ids.
    pub gt_objects: usize,
    /// Distinct predicted object ids.
    pub pred_objects: usize,
}

/// All metrics of one prediction set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Views scored.
    pub views: usize,
    /// Ground-truth instances (distinct non-zero ids over all views).
    pub gt_instances: usize,
    /// #masks: distinct non-zero predicted ids over all views.
    pub pred_masks: usize,
    /// Hungarian mIoU over all views (paper's mIoU).
    pub miou: f64,
    /// Boundary mIoU in the disk band (paper's boundary mIoU).
    pub boundary_miou: f64,
    /// Mean over views of the per-view mIoU (None when no view has an instance).
    pub per_view_miou: Option<f64>,
    /// Cross-view consistency, mean over instances.
    pub consistency: f64,
    /// 3D label accuracy, when per-Gaussian ground truth was given.
    pub label_accuracy_3d: Option<LabelAccuracy3d>,
    /// Per ground-truth instance, by id.
    pub instances: Vec<InstanceScore>,
    /// Per view, in input order.
    pub per_view: Vec<ViewScore>,
    /// Things worth knowing that did not stop scoring (e.g. views without a prediction).
    pub warnings: Vec<String>,
    /// The settings used.
    pub config: EvalConfig,
}

impl Metrics {
    /// Combines per-view counts (in the given order) into the metrics. Fails if no view holds a
    /// labelled ground-truth pixel.
    pub fn from_views(views: &[ViewCounts], cfg: &EvalConfig) -> Result<Metrics, EvalError> {
        let relabelled;
        let views = match cfg.pred_id_scope {
            IdScope::Global => views,
            IdScope::PerView => {
                relabelled = make_ids_global(views);
                &relabelled[..]
            }
        };
        let pixels = merge_pairs(views.iter().flat_map(|v| v.pixels.iter().copied()));
        let band = merge_band(views.iter().flat_map(|v| v.band.iter().copied()));
        let table = IouTable::new(&pixels, cfg);
        if table.gt_ids.is_empty() {
            return Err(EvalError::NoGroundTruth { path: None });
        }
        let matches = table.hungarian();
        let mut pred_ids: Vec<u32> = pixels.iter().filter(|c| c.pred != 0).map(|c| c.pred).collect();
        pred_ids.sort_unstable();
        pred_ids.dedup();
        // Views each instance appears in (view pixel lists are sorted by gt).
        let mut views_per_gt: std::collections::BTreeMap<u32, usize> = Default::default();
        for v in views {
            let mut ids: Vec<u32> =
                v.pixels.iter().filter(|c| c.gt != 0 && c.pixels > 0).map(|c| c.gt).collect();
            ids.dedup();
            for id in ids {
                *views_per_gt.entry(id).or_default() += 1;
            }
        }

        let instances: Vec<InstanceScore> = table
            .gt_ids
            .iter()
            .zip(&matches)
            .map(|(&g, m)| {
                let own = slice_by_gt(&pixels, |c| c.gt, g);
                let total: u64 = own.iter().map(|c| c.pixels).sum();
                let dominant = own
                    .iter()
                    .filter(|c| c.pred != 0)
                    // Ties go to the smaller id: max_by_key keeps the last maximum, so reverse.
                    .rev()
                    .max_by_key(|c| c.pixels);
                let iou = m.map_or(0.0, |(_, iou)| iou);
                InstanceScore {
                    gt_id: g,
                    pixels: total,
                    views: views_per_gt.get(&g).copied().unwrap_or(0),
                    matched_pred: m.map(|(p, _)| p),
                    iou,
                    boundary_iou: m.map_or(0.0, |(p, _)| boundary_iou(&band, g, p, cfg).unwrap_or(iou)),
                    consistency: dominant.map_or(0.0, |c| c.pixels as f64 / total as f64),
                    dominant_pred: dominant.map(|c| c.pred),
                }
            })
            .collect();
        let n = instances.len() as f64;
        let per_view: Vec<ViewScore> = views
            .iter()
            .map(|v| ViewScore {
                name: v.name.clone(),
                gt_instances: count_distinct(v.pixels.iter().filter(|c| c.gt != 0).map(|c| c.gt)),
                pred_ids: count_distinct(v.pixels.iter().filter(|c| c.pred != 0).map(|c| c.pred)),
                miou: v.miou(cfg),
            })
            .collect();
        let scored: Vec<f64> = per_view.iter().filter_map(|v| v.miou).collect();
        Ok(Metrics {
            views: views.len(),
            gt_instances: instances.len(),
            pred_masks: pred_ids.len(),
            miou: instances.iter().map(|i| i.iou).sum::<f64>() / n,
            boundary_miou: instances.iter().map(|i| i.boundary_iou).sum::<f64>() / n,
            per_view_miou: (!scored.is_empty()).then(|| scored.iter().sum::<f64>() / scored.len() as f64),
            consistency: instances.iter().map(|i| i.consistency).sum::<f64>() / n,
            label_accuracy_3d: None,
            instances,
            per_view,
            warnings: Vec::new(),
            config: cfg.clone(),
        })
    }
}

/// Renumbers view-local predicted ids so that every (view, id) gets its own id: 1, 2, ... in
/// view order, then by id.
fn make_ids_global(views: &[ViewCounts]) -> Vec<ViewCounts> {
    let mut next = 1u32;
    views
        .iter()
        .map(|v| {
            let mut ids: Vec<u32> = v.pixels.iter().map(|c| c.pred).filter(|p| *p != 0).collect();
            ids.sort_unstable();
            ids.dedup();
            let first = next;
            next += ids.len() as u32;
            let map = |p: u32| {
                if p == 0 {
                    0
                } else {
                    ids.binary_search(&p).map_or(0, |i| first + i as u32)
                }
            };
            let mut out = v.clone();
            out.pixels.iter_mut().for_each(|c| c.pred = map(c.pred));
            out.band.iter_mut().for_each(|c| c.pred = map(c.pred));
            out.pixels.sort_unstable_by_key(|c| (c.gt, c.pred));
            out.band.sort_unstable_by_key(|c| (c.gt, c.pred));
            out
        })
        .collect()
}

/// Boundary IoU of instance `g` with prediction `p` from summed band counts (`band` sorted by
/// `(gt, pred)`); None when the band of `g` is empty in every view.
fn boundary_iou(band: &[BandCount], g: u32, p: u32, cfg: &EvalConfig) -> Option<f64> {
    let own = slice_by_gt(band, |c| c.gt, g);
    let gt_in_band: u64 = own.iter().map(|c| c.in_gt).sum();
    let pair = own.iter().find(|c| c.pred == p).copied().unwrap_or_default();
    let pred_outside_gt = match cfg.unlabelled_gt {
        crate::config::UnlabelledGt::Background => pair.on_unlabelled + pair.on_other,
        crate::config::UnlabelledGt::Ignore => pair.on_other,
    };
    let union = gt_in_band + pred_outside_gt;
    (union > 0).then(|| pair.in_gt as f64 / union as f64)
}

/// The sub-slice of `items` (sorted by gt) whose gt is `g`.
fn slice_by_gt<T>(items: &[T], gt: impl Fn(&T) -> u32, g: u32) -> &[T] {
    let start = items.partition_point(|c| gt(c) < g);
    let end = items.partition_point(|c| gt(c) <= g);
    &items[start..end]
}

fn count_distinct(ids: impl Iterator<Item = u32>) -> usize {
    let mut v: Vec<u32> = ids.collect();
    v.sort_unstable();
    v.dedup();
    v.len()
}

/// Sums pair counts with equal `(gt, pred)`; output sorted.
fn merge_pairs(items: impl Iterator<Item = PairCount>) -> Vec<PairCount> {
    let mut all: Vec<PairCount> = items.collect();
    all.sort_unstable_by_key(|c| (c.gt, c.pred));
    let mut out: Vec<PairCount> = Vec::with_capacity(all.len());
    for c in all {
        match out.last_mut() {
            Some(last) if (last.gt, last.pred) == (c.gt, c.pred) => last.pixels += c.pixels,
            _ => out.push(c),
        }
    }
    out
}

/// Sums band counts with equal `(gt, pred)`; output sorted.
fn merge_band(items: impl Iterator<Item = BandCount>) -> Vec<BandCount> {
    let mut all: Vec<BandCount> = items.collect();
    all.sort_unstable_by_key(|c| (c.gt, c.pred));
    let mut out: Vec<BandCount> = Vec::with_capacity(all.len());
    for c in all {
        match out.last_mut() {
            Some(last) if (last.gt, last.pred) == (c.gt, c.pred) => {
                last.in_gt += c.in_gt;
                last.on_unlabelled += c.on_unlabelled;
                last.on_other += c.on_other;
            }
            _ => out.push(c),
        }
    }
    out
}
