//! Measuring the merge on views with ground truth: masks per view, per-view mIoU, and whether a
//! pair of instances that must stay apart (the white-on-white pair) ended up in one region.
//! Used by the ablation / sensitivity commands and the scene-level tests. The metric is passed
//! in (the `eval` crate's Hungarian per-view mIoU), so this crate does not depend on it.

use crate::config::MergeConfig;
use crate::error::MergeResultOf;
use crate::merge::{merge_view, ViewInputs};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use splatseg_scene::Plane;

/// One view with its ground truth.
#[derive(Clone, Debug)]
pub struct StudyView {
    /// Image stem.
    pub stem: String,
    /// Merge inputs.
    pub inputs: ViewInputs,
    /// `[H, W]` ground-truth instance ids (0 = none).
    pub gt: Plane<u32>,
    /// Two instance ids that must not share a region (e.g. the white-on-white pair), if any.
    pub keep_apart: Option<[u32; 2]>,
}

/// Per-view mIoU of a prediction against ground truth (`None` when the view has no instance).
pub type MiouFn = dyn Fn(&str, &Plane<u32>, &Plane<u32>) -> Option<f64> + Sync;

/// One line of a study table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StudyRow {
    /// Row name.
    pub name: String,
    /// Mean number of regions per view.
    pub masks_per_view: f64,
    /// Mean per-view mIoU.
    pub miou: f64,
    /// Views where the keep-apart pair shares a region (of those where both are visible).
    pub pair_merged_views: usize,
    /// Views where both instances of the keep-apart pair are visible.
    pub pair_views: usize,
}

/// True if some region holds at least 10 % of each instance's pixels.
fn pair_shares_a_region(labels: &Plane<u32>, gt: &Plane<u32>, [a, b]: [u32; 2]) -> Option<bool> {
    let (mut area_a, mut area_b) = (0u64, 0u64);
    let mut counts: std::collections::BTreeMap<u32, (u64, u64)> = Default::default();
    for (&l, &g) in labels.data.iter().zip(&gt.data) {
        if g == a || g == b {
            let e = counts.entry(l).or_default();
            if g == a {
                area_a += 1;
                e.0 += 1;
            } else {
                area_b += 1;
                e.1 += 1;
            }
        }
    }
    if area_a == 0 || area_b == 0 {
        return None;
    }
    Some(counts.iter().any(|(&l, &(ca, cb))| l != 0 && ca * 10 >= area_a && cb * 10 >= area_b))
}

fn row_from(name: &str, views: &[StudyView], labels: &[Plane<u32>], miou: &MiouFn) -> StudyRow {
    let masks: f64 = labels.iter().map(|l| region_count(l) as f64).sum::<f64>() / views.len().max(1) as f64;
    let scores: Vec<f64> = views.iter().zip(labels).filter_map(|(v, l)| miou(&v.stem, &v.gt, l)).collect();
    let pair: Vec<bool> = views
        .iter()
        .zip(labels)
        .filter_map(|(v, l)| v.keep_apart.and_then(|p| pair_shares_a_region(l, &v.gt, p)))
        .collect();
    StudyRow {
        name: name.to_string(),
        masks_per_view: masks,
        miou: scores.iter().sum::<f64>() / scores.len().max(1) as f64,
        pair_merged_views: pair.iter().filter(|&&m| m).count(),
        pair_views: pair.len(),
    }
}

fn region_count(labels: &Plane<u32>) -> usize {
    let mut ids: Vec<u32> = labels.data.iter().copied().filter(|&l| l > 0).collect();
    ids.sort_unstable();
    ids.dedup();
    ids.len()
}

/// A decision between a region mostly of one keep-apart instance and a region mostly of the
/// other (the first evaluation of such a pair in the merge log).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairDecision {
    /// View stem.
    pub stem: String,
    /// The decision as logged.
    pub decision: crate::merge::Decision,
}

/// Majority ground-truth id of each input region (index = label − 1).
fn majority_gt(labels: &Plane<u32>, gt: &Plane<u32>, n: usize) -> Vec<u32> {
    let mut counts: std::collections::BTreeMap<(u32, u32), u64> = Default::default();
    for (&l, &g) in labels.data.iter().zip(&gt.data) {
        if l > 0 {
            *counts.entry((l, g)).or_default() += 1;
        }
    }
    let mut best = vec![(0u32, 0u64); n];
    for (&(l, g), &c) in &counts {
        if c > best[l as usize - 1].1 {
            best[l as usize - 1] = (g, c);
        }
    }
    best.into_iter().map(|(g, _)| g).collect()
}

/// How the merge treated the keep-apart pair: the first evaluation of every pair of input
/// regions whose majority instances are the two keep-apart ids.
pub fn keep_apart_decisions(views: &[StudyView], config: &MergeConfig) -> MergeResultOf<Vec<PairDecision>> {
    let mut out = Vec::new();
    for v in views {
        let Some([a, b]) = v.keep_apart else { continue };
        let r = merge_view(&v.inputs, config)?;
        let major = majority_gt(&v.inputs.regions.labels, &v.gt, v.inputs.regions.count());
        let mut seen = std::collections::BTreeSet::new();
        for d in &r.log.decisions {
            let pair = (major[d.a as usize - 1], major[d.b as usize - 1]);
            if (pair == (a, b) || pair == (b, a)) && seen.insert((d.a, d.b)) && d.after_merges == 0 {
                out.push(PairDecision { stem: v.stem.clone(), decision: d.clone() });
            }
        }
    }
    Ok(out)
}

/// The row of the unmerged regions.
pub fn raw_row(views: &[StudyView], miou: &MiouFn) -> StudyRow {
    let labels: Vec<Plane<u32>> = views.iter().map(|v| v.inputs.regions.labels.clone()).collect();
    row_from("raw", views, &labels, miou)
}

/// Merges every view (in parallel) with `config` and measures the result.
pub fn merged_row(
    name: &str,
    views: &[StudyView],
    config: &MergeConfig,
    miou: &MiouFn,
) -> MergeResultOf<StudyRow> {
    let labels = views
        .par_iter()
        .map(|v| merge_view(&v.inputs, config).map(|r| r.labels))
        .collect::<MergeResultOf<Vec<_>>>()?;
    Ok(row_from(name, views, &labels, miou))
}

/// The ablation of the paper's Table 3 on top of `base`: semantic only (no depth, no edges, no
/// gates), + LoG, + depth (= `base`).
pub fn ablation_configs(base: &MergeConfig) -> Vec<(String, MergeConfig)> {
    let semantic =
        MergeConfig { w_depth: 0.0, w_dbound: 0.0, w_edge: 0.0, tau_depth: f32::INFINITY, ..base.clone() };
    let with_log = MergeConfig { w_edge: base.w_edge, ..semantic.clone() };
    vec![
        ("semantic only".to_string(), semantic),
        ("+ LoG".to_string(), with_log),
        ("+ depth (full)".to_string(), base.clone()),
    ]
}

/// The paper's supplementary sensitivity table (τ_merge, τ_depth, w_sem) on top of `base`.
pub fn sensitivity_configs(base: &MergeConfig) -> Vec<(String, MergeConfig)> {
    let with = |tau_merge: f32, tau_depth: f32, w_sem: f32| MergeConfig {
        tau_merge,
        tau_depth,
        w_sem,
        ..base.clone()
    };
    vec![
        ("Aggressive Merging".to_string(), with(0.70, 0.30, 0.5)),
        ("Conservative Merging".to_string(), with(0.95, 0.05, 0.5)),
        ("Structural-biased".to_string(), with(0.85, 0.15, 0.2)),
        ("Semantic-biased".to_string(), with(0.85, 0.15, 0.8)),
        ("Ours".to_string(), base.clone()),
    ]
}

/// A Markdown table of study rows; `params` adds the τ_merge / τ_depth / w_sem columns.
pub fn markdown_table(rows: &[(StudyRow, Option<&MergeConfig>)]) -> String {
    let mut out =
        String::from("| config | τ_merge | τ_depth | w_sem | masks / view | per-view mIoU | pair merged |\n");
    out.push_str("| --- | ---: | ---: | ---: | ---: | ---: | ---: |\n");
    for (row, config) in rows {
        let (tm, td, ws) = match config {
            Some(c) => {
                (format!("{:.2}", c.tau_merge), format!("{:.2}", c.tau_depth), format!("{:.1}", c.w_sem))
            }
            None => ("–".to_string(), "–".to_string(), "–".to_string()),
        };
        out.push_str(&format!(
            "| {} | {tm} | {td} | {ws} | {:.1} | {:.3} | {}/{} |\n",
            row.name, row.masks_per_view, row.miou, row.pair_merged_views, row.pair_views
        ));
    }
    out
}
