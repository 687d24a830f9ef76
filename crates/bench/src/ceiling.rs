//! Ceilings of a suite scene: what its per-view region maps would score if every region took its
//! majority ground-truth id — an oracle standing in for matching and lifting. Two maps per view
//! are scored this way: the SAM masks resolved into regions (what SAM's own masks allow at best)
//! and the merged regions (what is left after merging; a wrong merge lowers it, a missing merge
//! does not). The distance from these ceilings to the final maps says which stage loses what.

use crate::error::Context;
use splatseg_eval::{EvalConfig, Metrics, ViewCounts};
use splatseg_scene::labels::read_label_png;
use splatseg_scene::Plane;
use std::collections::HashMap;
use std::path::Path;

/// mIoU of the oracle-labelled region maps of one run.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Ceilings {
    /// The SAM masks as regions (`cache/merge/<stem>.raw.png`), each region its majority id.
    pub sam_regions: f64,
    /// The merged regions (`cache/merge/<stem>.merged.png`), each region its majority id.
    pub merged: f64,
}

/// `regions` (`[H, W]`, 0 = none) relabelled so every region carries the ground-truth id
/// (`gt`, `[H, W]`, 0 = background) most of its pixels have (ties to the smaller id); pixels
/// of no region stay 0.
pub fn oracle_labels(regions: &Plane<u32>, gt: &Plane<u32>) -> Plane<u32> {
    let mut counts: HashMap<(u32, u32), u64> = HashMap::new();
    for (&r, &g) in regions.data.iter().zip(&gt.data) {
        if r != 0 {
            *counts.entry((r, g)).or_default() += 1;
        }
    }
    let mut best: HashMap<u32, (u64, u32)> = HashMap::new();
    for (&(r, g), &n) in &counts {
        let e = best.entry(r).or_insert((0, u32::MAX));
        if n > e.0 || (n == e.0 && g < e.1) {
            *e = (n, g);
        }
    }
    regions.map(|r| if *r == 0 { 0 } else { best.get(r).map_or(0, |b| b.1) })
}

/// The ceilings of the run whose merge cache is `cache_dir` (`OUT/cache/merge`), against the
/// ground truth of `views` (`(stem, [H, W] instance ids)`).
pub fn ceilings(cache_dir: &Path, views: &[(&str, &Plane<u32>)]) -> crate::Result<Ceilings> {
    let cfg = EvalConfig::default();
    let score = |kind: &str| -> crate::Result<f64> {
        let mut counts = Vec::with_capacity(views.len());
        for &(stem, gt) in views {
            let path = cache_dir.join(format!("{stem}.{kind}.png"));
            let regions = read_label_png(&path).with_context(|| format!("reading {}", path.display()))?;
            let oracle = oracle_labels(&regions, gt);
            counts.push(ViewCounts::compute(stem, gt, &oracle, &cfg)?);
        }
        Ok(Metrics::from_views(&counts, &cfg)?.miou)
    };
    Ok(Ceilings { sam_regions: score("raw")?, merged: score("merged")? })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_region_takes_its_majority_id() {
        let regions = Plane { width: 4, height: 2, data: vec![1, 1, 1, 2, 0, 2, 2, 2] };
        let gt = Plane { width: 4, height: 2, data: vec![5, 5, 7, 7, 7, 0, 0, 7] };
        // Region 1: 5, 5, 7 → 5; region 2: 7, 0, 0, 7 → tie, the smaller id 0.
        assert_eq!(oracle_labels(&regions, &gt).data, vec![5, 5, 5, 0, 0, 0, 0, 0]);
    }

    #[test]
    fn a_wrong_merge_lowers_the_ceiling_and_a_missing_one_does_not() {
        let gt = Plane { width: 4, height: 1, data: vec![1, 1, 2, 2] };
        let split = Plane { width: 4, height: 1, data: vec![1, 2, 3, 4] };
        let wrong = Plane { width: 4, height: 1, data: vec![1, 1, 1, 2] };
        assert_eq!(oracle_labels(&split, &gt).data, gt.data);
        assert_eq!(oracle_labels(&wrong, &gt).data, vec![1, 1, 1, 2]);
    }
}
