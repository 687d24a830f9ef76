//! `ablate`: the merge stage's ablation and sensitivity tables on a generated synthetic scene
//! with ground truth: masks per view and per-view mIoU (Hungarian matching per view) for the score
//! profiles, boundary statistics, the cue ablation (raw / semantic only / + LoG / + depth, as the
//! paper's Table 3), the paper's supplementary sensitivity table (τ_merge, τ_depth, w_sem), the
//! depth gates on the white-on-white pair, and the rule for uncovered pixels. Cues: the scene's
//! simulated DINOv2-like features and monocular depth; metric depth for the crease gate rendered
//! from its Gaussians.

use crate::error::Context;
use rayon::prelude::*;
use splatseg_cues::{
    DenseFeatureDescriptors, DepthKind, DepthMap, FeatureGrid, FeatureGrids, RegionOptions, UncoveredPolicy,
};
use splatseg_eval::{EvalConfig, ViewCounts};
use splatseg_merge::study::{
    ablation_configs, keep_apart_decisions, markdown_table, merged_row, raw_row, sensitivity_configs,
    StudyRow, StudyView,
};
use splatseg_merge::{build_view_inputs, BoundaryStatistic, CueRequest, MergeConfig, Profile};
use splatseg_pipeline::mask_inputs;
use splatseg_render::{render, RenderCamera, RenderRequest};
use splatseg_scene::Plane;
use splatseg_synth::{generate, SynthConfig, SynthScene};
use std::fmt::Write as _;

fn miou(stem: &str, gt: &Plane<u32>, pred: &Plane<u32>) -> Option<f64> {
    let cfg = EvalConfig::default();
    ViewCounts::compute(stem, gt, pred, &cfg).ok()?.miou(&cfg)
}

/// The scene's views as merge study inputs.
fn study_views(scene: &SynthScene, region_options: RegionOptions) -> crate::Result<Vec<StudyView>> {
    let white = scene.white_pair();
    scene
        .views
        .par_iter()
        .enumerate()
        .map(|(i, v)| {
            let (w, h) = v.image.size();
            let rgb = v.image.map(|p| p.map(|c| c as f32 / 255.0));
            let masks = mask_inputs(&v.sam_masks, w, h)
                .map_err(|e| crate::BenchError::Invalid(format!("view {}: {e}", v.stem)))?;
            let f = &v.features;
            let grid =
                FeatureGrid::new(f.grid_h, f.grid_w, f.dim, f.values.clone()).context("feature grid")?;
            let descriptors =
                DenseFeatureDescriptors { grids: FeatureGrids::InMemory(vec![(v.stem.clone(), grid)]) };
            let depth = DepthMap { values: v.relative_depth.clone(), kind: DepthKind::InverseRelative };
            let view = &scene.scene.views[i];
            let camera = RenderCamera::from_scene(scene.scene.camera(view), &view.world_from_cam);
            let request = RenderRequest { rgb: false, depth: true, ..RenderRequest::default() };
            let metric = render(&scene.gaussians, &camera, &request)?.depth.context("no rendered depth")?;
            let inputs = build_view_inputs(&CueRequest {
                stem: &v.stem,
                rgb: &rgb,
                masks: &masks,
                depth: &depth,
                metric_depth: Some(&metric),
                normals: None,
                descriptors: &descriptors,
                region_options,
                intrinsics: Some(splatseg_cues::Intrinsics::of_camera(scene.scene.camera(view), w, h)),
            })?;
            Ok(StudyView { stem: v.stem.clone(), inputs, gt: v.gt_instance.clone(), keep_apart: Some(white) })
        })
        .collect()
}

type Rows = Vec<(StudyRow, Option<MergeConfig>)>;

fn rows_for(views: &[StudyView], configs: Vec<(String, MergeConfig)>) -> crate::Result<Rows> {
    configs.into_iter().map(|(name, c)| Ok((merged_row(&name, views, &c, &miou)?, Some(c)))).collect()
}

fn table(rows: &Rows) -> String {
    let refs: Vec<(StudyRow, Option<&MergeConfig>)> =
        rows.iter().map(|(r, c)| (r.clone(), c.as_ref())).collect();
    markdown_table(&refs)
}

/// The scene to measure on and the base settings.
#[derive(Clone, Debug)]
pub struct AblateRequest {
    /// Seed of the synthetic scene.
    pub seed: u64,
    /// Number of views.
    pub views: usize,
    /// Image size `(width, height)`; default: the synthetic scene's.
    pub size: Option<(u32, u32)>,
    /// Base merge settings.
    pub base: MergeConfig,
}

/// The merge settings in the TOML file `path` (a `MergeConfig`), or the paper's defaults.
pub fn base_config(path: Option<&std::path::Path>) -> crate::Result<MergeConfig> {
    match path {
        None => Ok(MergeConfig::default()),
        Some(p) => {
            let text = std::fs::read_to_string(p).with_context(|| format!("cannot read {}", p.display()))?;
            MergeConfig::from_toml_str(&text).with_context(|| format!("in {}", p.display()))
        }
    }
}

/// The Markdown tables of the study.
pub fn ablate(args: &AblateRequest) -> crate::Result<String> {
    let base = args.base.clone();
    let mut synth = SynthConfig { seed: args.seed, views: args.views, ..SynthConfig::default() };
    if let Some((w, h)) = args.size {
        (synth.width, synth.height) = (w, h);
    }
    let scene = generate(&synth).context("generating the synthetic scene")?;
    let views = study_views(&scene, RegionOptions::default())?;
    let sam_masks =
        scene.views.iter().map(|v| v.sam_masks.len()).sum::<usize>() as f64 / scene.views.len() as f64;
    let raw = (raw_row(&views, &miou), None);
    let mut out = String::new();
    writeln!(
        out,
        "Synthetic scene: seed {}, {} views of {}×{}, {sam_masks:.1} SAM masks per view; pair = the white-on-white \
         pair (views where one region holds ≥ 10 % of each).\n",
        synth.seed, synth.views, synth.width, synth.height
    )?;

    let profiles = [Profile::Literal]
        .into_iter()
        .map(|p| (format!("{p:?}"), MergeConfig::for_profile(p)))
        .chain([("Paper (default)".to_string(), base.clone())])
        .collect();
    let mut rows = vec![raw.clone()];
    rows.extend(rows_for(&views, profiles)?);
    writeln!(out, "### Score profiles\n\n{}", table(&rows))?;

    let stats = [
        ("max", BoundaryStatistic::Max),
        ("quantile 0.9", BoundaryStatistic::Quantile(0.9)),
        ("quantile 0.75", BoundaryStatistic::Quantile(0.75)),
        ("median", BoundaryStatistic::Quantile(0.5)),
        ("mean", BoundaryStatistic::Mean),
    ]
    .into_iter()
    .map(|(n, s)| (format!("boundary {n}"), MergeConfig { boundary_statistic: s, ..base.clone() }))
    .collect();
    writeln!(out, "### Boundary statistic (paper profile)\n\n{}", table(&rows_for(&views, stats)?))?;

    let mut rows = vec![raw.clone()];
    rows.extend(rows_for(&views, ablation_configs(&base))?);
    writeln!(out, "### Cue ablation (paper Table 3)\n\n{}", table(&rows))?;
    writeln!(
        out,
        "### Sensitivity (paper supplementary table)\n\n{}",
        table(&rows_for(&views, sensitivity_configs(&base))?)
    )?;

    let no_gates = MergeConfig { tau_depth: f32::INFINITY, ..base.clone() };
    let gates = vec![
        ("no depth gate".to_string(), no_gates),
        ("normalised gate (default)".to_string(), base.clone()),
        ("semantic only, no gate".to_string(), ablation_configs(&base)[0].1.clone()),
    ];
    writeln!(out, "### Depth gates\n\n{}", table(&rows_for(&views, gates)?))?;
    let pair = keep_apart_decisions(&views, &base)?;
    let adjacent: Vec<_> =
        pair.iter().filter(|d| d.decision.terms.contact >= splatseg_merge::TAU_CONTACT).collect();
    let range = |f: &dyn Fn(&splatseg_merge::ScoreTerms) -> Option<f32>| {
        let v: Vec<f32> = adjacent.iter().filter_map(|d| f(&d.decision.terms)).collect();
        let lo = v.iter().cloned().fold(f32::INFINITY, f32::min);
        let hi = v.iter().cloned().fold(f32::NEG_INFINITY, f32::max);
        format!("{lo:.3}–{hi:.3}")
    };
    let count = |o: splatseg_merge::Outcome| adjacent.iter().filter(|d| d.decision.outcome == o).count();
    writeln!(
        out,
        "White-on-white pair, {} adjacent evaluations: normalised |Δd̄| {} (τ_depth {}), score S {}; rejected by \
         the normalised gate {}, by the depth-step gate {}, by the score {}, merged {}.\n",
        adjacent.len(),
        range(&|t| Some(t.depth_gap)),
        base.tau_depth,
        range(&|t| Some(t.score)),
        count(splatseg_merge::Outcome::DepthGate),
        count(splatseg_merge::Outcome::DepthStep),
        count(splatseg_merge::Outcome::BelowThreshold),
        pair.iter().filter(|d| d.decision.merged).count(),
    )?;

    let own = study_views(
        &scene,
        RegionOptions { uncovered: UncoveredPolicy::OwnRegions, ..RegionOptions::default() },
    )?;
    let mut rows = vec![(StudyRow { name: "unlabelled: raw".into(), ..raw.0.clone() }, None)];
    rows.extend(rows_for(&views, vec![("unlabelled: merged (default)".to_string(), base.clone())])?);
    rows.push((StudyRow { name: "own regions: raw".into(), ..raw_row(&own, &miou) }, None));
    rows.extend(rows_for(&own, vec![("own regions: merged".to_string(), base.clone())])?);
    writeln!(out, "### Uncovered pixels (large SAM holes)\n\n{}", table(&rows))?;

    Ok(out)
}
