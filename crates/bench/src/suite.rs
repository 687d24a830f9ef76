//! The quality suite: one scene of a family and seed scored end to end as a user would run it
//! (`synth` → `run` with features, Gaussians and ground truth), and the distributions over
//! many scenes (per metric, per family, per failure class).

use crate::error::Context;
use serde::Serialize;
use splatseg_cues::DepthKind;
use splatseg_pipeline::{run_pipeline, PipelineConfig, RunConfig};
use splatseg_synth::{generate, write, FailureClass, Family, SynthConfig};
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

/// Seeds settings may be tuned on.
pub const TUNING_SEEDS: std::ops::Range<u64> = 0..16;
/// Seeds the numbers are reported on (never tuned on).
pub const REPORT_SEEDS: std::ops::Range<u64> = 100..132;
/// Families run when none is named (the 320×240 ones; `hires` and `many_views` cost more).
pub const DEFAULT_FAMILIES: [Family; 6] =
    [Family::Rooms, Family::MultiTone, Family::Thin, Family::Border, Family::Clutter, Family::SamNoise];

/// Which region descriptors a run used.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Descriptors {
    /// The scene's DINOv2-like features (`--features`).
    Features,
    /// The model-free colour/texture descriptors (no `--features`).
    ModelFree,
}

impl Descriptors {
    /// Name in tables.
    pub fn name(self) -> &'static str {
        match self {
            Descriptors::Features => "with features",
            Descriptors::ModelFree => "without features (model-free descriptors)",
        }
    }
}

/// Which depth a run's merge reads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DepthSource {
    /// Metric depth rendered from the scene's Gaussians (`run` without `--depth`, the default).
    #[default]
    Rendered,
    /// The scene's simulated monocular depth (`depth/`: relative inverse depth with the family's
    /// error and blur, as Depth Anything V2 gives; `run --depth DIR --depth-kind inverse`).
    Monocular,
}

impl DepthSource {
    /// Name in tables.
    pub fn name(self) -> &'static str {
        match self {
            DepthSource::Rendered => "depth rendered from the Gaussians",
            DepthSource::Monocular => "the scene's monocular depth (`depth/`, inverse relative)",
        }
    }
}

/// Overrides of a family's config.
#[derive(Clone, Copy, Debug, Default)]
pub struct SceneOverrides {
    /// Image size (SAM's pixel settings scale with it).
    pub size: Option<(u32, u32)>,
    /// Number of views.
    pub views: Option<usize>,
}

/// The config of one suite scene.
pub fn scene_config(family: Family, seed: u64, overrides: SceneOverrides) -> SynthConfig {
    let mut c = family.config(seed);
    if let Some((w, h)) = overrides.size {
        let scale = (w as f64 / c.width as f64 * h as f64 / c.height as f64).sqrt();
        c.sam = c.sam.scaled(scale);
        c.width = w;
        c.height = h;
    }
    if let Some(v) = overrides.views {
        c.views = v;
    }
    c
}

/// One ground-truth instance's result.
#[derive(Clone, Debug, Serialize)]
pub struct InstanceResult {
    /// Instance id.
    pub id: u32,
    /// Object name.
    pub name: String,
    /// Its failure classes.
    pub classes: Vec<FailureClass>,
    /// IoU with its Hungarian-matched prediction over all views (0 if unmatched).
    pub iou: f64,
    /// Mean share of the image it covers in the views that show it (its ground-truth pixels over
    /// all views / (views showing it × width × height)).
    pub image_share: f64,
}

/// One scene's scores (the final, lifted label maps and Gaussians).
#[derive(Clone, Debug, Serialize)]
pub struct SceneScore {
    /// Family.
    pub family: Family,
    /// Seed.
    pub seed: u64,
    /// Descriptors used.
    pub descriptors: Descriptors,
    /// The depth the run's merge read.
    pub depth: DepthSource,
    /// Views, width, height.
    pub views: usize,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// mIoU.
    pub miou: f64,
    /// Boundary mIoU.
    pub boundary_miou: f64,
    /// Mean per-view mIoU.
    pub per_view_miou: f64,
    /// Cross-view consistency.
    pub consistency: f64,
    /// Distinct ids in the final maps / ground-truth instances.
    pub ids_per_gt: f64,
    /// 3D label accuracy.
    pub accuracy_3d: f64,
    /// Share of Gaussians left unlabelled (object_id −1).
    pub unlabelled_share: f64,
    /// mIoU of the SAM regions with oracle ids (each region its majority ground-truth id).
    pub ceiling_sam_regions: f64,
    /// mIoU of the merged regions with oracle ids.
    pub ceiling_merged: f64,
    /// Per instance.
    pub instances: Vec<InstanceResult>,
    /// Seconds for generating and running.
    pub seconds: f64,
}

/// Generates scene (`family`, `seed`) into `work/scene`, runs the pipeline with `pipeline` and
/// the `depth` source into `work/run_*` once per entry of `descriptors`, and scores each run.
pub fn score_scene(
    family: Family,
    seed: u64,
    overrides: SceneOverrides,
    descriptors: &[Descriptors],
    depth: DepthSource,
    pipeline: &PipelineConfig,
    work: &Path,
) -> crate::Result<Vec<SceneScore>> {
    let started = Instant::now();
    let config = scene_config(family, seed, overrides);
    let synth = generate(&config).with_context(|| format!("generating {family} seed {seed}"))?;
    let classes = synth.failure_classes();
    let scene_dir = work.join("scene");
    write(&scene_dir, &synth).with_context(|| format!("writing {}", scene_dir.display()))?;
    let generated = started.elapsed().as_secs_f64();
    let mut out = Vec::new();
    for &d in descriptors {
        let run_started = Instant::now();
        let run = RunConfig {
            scene: scene_dir.clone(),
            masks: scene_dir.join("sam"),
            features: (d == Descriptors::Features).then(|| scene_dir.join("features")),
            depth: (depth == DepthSource::Monocular).then(|| scene_dir.join("depth")),
            depth_kind: DepthKind::InverseRelative,
            resize_depth: false,
            gaussians: None,
            gt: Some(scene_dir.join("gt")),
            pipeline: pipeline.clone(),
            out: work.join(match d {
                Descriptors::Features => "run_features",
                Descriptors::ModelFree => "run_model_free",
            }),
            options: Default::default(),
        };
        let summary = run_pipeline(&run).with_context(|| format!("running {family} seed {seed}"))?;
        let report = summary.report.as_ref().context("the run scored no ground truth")?;
        let lifted = report.sets.last().context("no scored stage")?;
        let m = &lifted.metrics;
        let (accuracy_3d, unlabelled_share) = match &m.label_accuracy_3d {
            Some(a) => (a.accuracy, a.unlabelled_predictions as f64 / a.labelled_gaussians.max(1) as f64),
            None => (f64::NAN, f64::NAN),
        };
        let gt: Vec<(&str, &splatseg_scene::Plane<u32>)> =
            synth.views.iter().map(|v| (v.stem.as_str(), &v.gt_instance)).collect();
        let ceilings = crate::ceiling::ceilings(&run.out.join("cache").join("merge"), &gt)
            .with_context(|| format!("the ceilings of {family} seed {seed}"))?;
        let instances = m
            .instances
            .iter()
            .map(|i| {
                let k = (i.gt_id as usize).wrapping_sub(1);
                InstanceResult {
                    id: i.gt_id,
                    name: synth.objects.get(k).map_or_else(|| "?".to_string(), |o| o.name.clone()),
                    classes: classes.get(k).cloned().unwrap_or_default(),
                    iou: i.iou,
                    image_share: i.pixels as f64
                        / (i.views.max(1) as f64 * config.width as f64 * config.height as f64),
                }
            })
            .collect();
        out.push(SceneScore {
            family,
            seed,
            descriptors: d,
            depth,
            views: config.views,
            width: config.width,
            height: config.height,
            miou: m.miou,
            boundary_miou: m.boundary_miou,
            per_view_miou: m.per_view_miou.unwrap_or(0.0),
            consistency: m.consistency,
            ids_per_gt: m.pred_masks as f64 / m.gt_instances.max(1) as f64,
            accuracy_3d,
            unlabelled_share,
            ceiling_sam_regions: ceilings.sam_regions,
            ceiling_merged: ceilings.merged,
            instances,
            seconds: generated + run_started.elapsed().as_secs_f64(),
        });
    }
    Ok(out)
}

/// A distribution's summary.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Distribution {
    /// Values.
    pub n: usize,
    /// Smallest.
    pub min: f64,
    /// 10th percentile (linear interpolation between order statistics).
    pub p10: f64,
    /// Median.
    pub median: f64,
    /// Mean.
    pub mean: f64,
    /// Largest.
    pub max: f64,
}

/// The `q` quantile of sorted values (linear interpolation).
fn quantile(sorted: &[f64], q: f64) -> f64 {
    let pos = q * (sorted.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo as f64)
}

impl Distribution {
    /// Summary of the finite values (None if there are none).
    pub fn of(values: impl Iterator<Item = f64>) -> Option<Distribution> {
        let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        Some(Distribution {
            n: v.len(),
            min: v[0],
            p10: quantile(&v, 0.1),
            median: quantile(&v, 0.5),
            mean: v.iter().sum::<f64>() / v.len() as f64,
            max: v[v.len() - 1],
        })
    }
}

/// A metric's name and how to read it off a score.
pub type Metric = (&'static str, fn(&SceneScore) -> f64);

/// The metrics of the table.
pub const METRICS: [Metric; 9] = [
    ("mIoU", |s| s.miou),
    ("boundary mIoU", |s| s.boundary_miou),
    ("per-view mIoU", |s| s.per_view_miou),
    ("consistency", |s| s.consistency),
    ("ids / GT instances", |s| s.ids_per_gt),
    ("3D label accuracy", |s| s.accuracy_3d),
    ("Gaussians unlabelled", |s| s.unlabelled_share),
    ("ceiling: SAM regions, oracle ids (mIoU)", |s| s.ceiling_sam_regions),
    ("ceiling: merged regions, oracle ids (mIoU)", |s| s.ceiling_merged),
];

/// Scores of one failure class over many scenes.
#[derive(Clone, Debug, Serialize)]
pub struct ClassScore {
    /// The class.
    pub class: FailureClass,
    /// Instances of that class.
    pub instances: usize,
    /// Mean IoU.
    pub mean_iou: f64,
    /// 10th percentile IoU.
    pub p10_iou: f64,
    /// Smallest IoU.
    pub min_iou: f64,
    /// Where the smallest was: family, seed, object name.
    pub worst: (Family, u64, String),
    /// Instances under IoU 0.5.
    pub below_half: usize,
}

/// Per failure class, over the instances of `scores`.
pub fn class_scores(scores: &[SceneScore]) -> Vec<ClassScore> {
    let mut per: BTreeMap<FailureClass, Vec<(f64, Family, u64, &str)>> = BTreeMap::new();
    for s in scores {
        for i in &s.instances {
            for &c in &i.classes {
                per.entry(c).or_default().push((i.iou, s.family, s.seed, &i.name));
            }
        }
    }
    FailureClass::ALL
        .into_iter()
        .filter_map(|class| {
            let items = per.get(&class)?;
            let d = Distribution::of(items.iter().map(|x| x.0))?;
            let worst = items.iter().min_by(|a, b| a.0.total_cmp(&b.0))?;
            Some(ClassScore {
                class,
                instances: items.len(),
                mean_iou: d.mean,
                p10_iou: d.p10,
                min_iou: d.min,
                worst: (worst.1, worst.2, worst.3.to_string()),
                below_half: items.iter().filter(|x| x.0 < 0.5).count(),
            })
        })
        .collect()
}

/// The Markdown report of one descriptor variant: distributions over all scenes, per family,
/// per failure class, and the worst scenes.
pub fn markdown(scores: &[SceneScore], worst: usize) -> String {
    let mut t = String::new();
    t.push_str("| metric | min | p10 | median | mean | max |\n| --- | ---: | ---: | ---: | ---: | ---: |\n");
    for (name, f) in METRICS {
        if let Some(d) = Distribution::of(scores.iter().map(f)) {
            t.push_str(&format!(
                "| {name} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |\n",
                d.min, d.p10, d.median, d.mean, d.max
            ));
        }
    }
    let mut families: Vec<Family> = scores.iter().map(|s| s.family).collect();
    families.sort_unstable();
    families.dedup();
    t.push_str(
        "\n| family | scenes | mIoU mean (min) | boundary | per-view | consistency | ids / GT | 3D acc. | unlabelled |\n\
         | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
    );
    for f in families {
        let of: Vec<&SceneScore> = scores.iter().filter(|s| s.family == f).collect();
        let mean = |g: fn(&SceneScore) -> f64| {
            Distribution::of(of.iter().map(|s| g(s))).map_or(f64::NAN, |d| d.mean)
        };
        let min_miou = Distribution::of(of.iter().map(|s| s.miou)).map_or(f64::NAN, |d| d.min);
        t.push_str(&format!(
            "| {f} | {} | {:.3} ({:.3}) | {:.3} | {:.3} | {:.3} | {:.2} | {:.3} | {:.3} |\n",
            of.len(),
            mean(|s| s.miou),
            min_miou,
            mean(|s| s.boundary_miou),
            mean(|s| s.per_view_miou),
            mean(|s| s.consistency),
            mean(|s| s.ids_per_gt),
            mean(|s| s.accuracy_3d),
            mean(|s| s.unlabelled_share),
        ));
    }
    t.push_str(
        "\n| failure class | instances | mean IoU | p10 IoU | min IoU | IoU < 0.5 | worst (family seed object) |\n\
         | --- | ---: | ---: | ---: | ---: | ---: | --- |\n",
    );
    for c in class_scores(scores) {
        t.push_str(&format!(
            "| {} | {} | {:.3} | {:.3} | {:.3} | {} | {} {} {} |\n",
            c.class.name(),
            c.instances,
            c.mean_iou,
            c.p10_iou,
            c.min_iou,
            c.below_half,
            c.worst.0,
            c.worst.1,
            c.worst.2
        ));
    }
    t.push_str(&lost_objects(scores));
    let mut sorted: Vec<&SceneScore> = scores.iter().collect();
    sorted.sort_by(|a, b| a.miou.total_cmp(&b.miou));
    t.push_str("\nWorst scenes by mIoU (the instances under IoU 0.7):\n\n");
    for s in sorted.iter().take(worst) {
        let bad: Vec<String> = s
            .instances
            .iter()
            .filter(|i| i.iou < 0.7)
            .map(|i| {
                let classes: Vec<&str> = i.classes.iter().map(|c| c.name()).collect();
                format!("{} {:.2} [{}]", i.name, i.iou, classes.join(","))
            })
            .collect();
        t.push_str(&format!(
            "- {} seed {}: mIoU {:.3}, ids/GT {:.2}, 3D acc. {:.3}: {}\n",
            s.family,
            s.seed,
            s.miou,
            s.ids_per_gt,
            s.accuracy_3d,
            if bad.is_empty() { "-".to_string() } else { bad.join("; ") }
        ));
    }
    t
}

/// Share of the image from which an object under IoU 0.5 counts as large (issue 27: none at all).
pub const LARGE_OBJECT_SHARE: f64 = 0.01;

/// Objects under IoU 0.5 over all scenes: (all of them, those covering at least
/// [`LARGE_OBJECT_SHARE`] of the image), each as (scene, instance).
pub fn objects_under_half(scores: &[SceneScore]) -> (Vec<(&SceneScore, &InstanceResult)>, usize) {
    let lost: Vec<(&SceneScore, &InstanceResult)> =
        scores.iter().flat_map(|s| s.instances.iter().filter(|i| i.iou < 0.5).map(move |i| (s, i))).collect();
    let large = lost.iter().filter(|(_, i)| i.image_share >= LARGE_OBJECT_SHARE).count();
    (lost, large)
}

/// The report's paragraph on objects under IoU 0.5: how many, how many of them large, and each one.
fn lost_objects(scores: &[SceneScore]) -> String {
    let total: usize = scores.iter().map(|s| s.instances.len()).sum();
    let (lost, large) = objects_under_half(scores);
    let mut t = format!(
        "\nObjects under IoU 0.5: {} of {} ({:.2} %), {} of them covering at least {:.0} % of the image \
         (mean share over the views showing them){}\n",
        lost.len(),
        total,
        100.0 * lost.len() as f64 / total.max(1) as f64,
        large,
        100.0 * LARGE_OBJECT_SHARE,
        if lost.is_empty() { "." } else { ":" }
    );
    if !lost.is_empty() {
        t.push('\n');
    }
    for (s, i) in lost {
        let classes: Vec<&str> = i.classes.iter().map(|c| c.name()).collect();
        t.push_str(&format!(
            "- {} seed {} {}: IoU {:.2}, {:.2} % of the image [{}]\n",
            s.family,
            s.seed,
            i.name,
            i.iou,
            100.0 * i.image_share,
            classes.join(",")
        ));
    }
    t
}

/// Parses seeds: `A..B` (B excluded), `A..=B`, or a comma list `1,5,9`.
pub fn parse_seeds(text: &str) -> Result<Vec<u64>, String> {
    let num = |s: &str| s.trim().parse::<u64>().map_err(|_| format!("`{s}` is not a seed (a whole number)"));
    let seeds: Vec<u64> = if let Some((a, b)) = text.split_once("..=") {
        (num(a)?..=num(b)?).collect()
    } else if let Some((a, b)) = text.split_once("..") {
        (num(a)?..num(b)?).collect()
    } else {
        text.split(',').map(num).collect::<Result<_, _>>()?
    };
    if seeds.is_empty() {
        return Err(format!("`{text}` names no seed"));
    }
    if seeds.len() > 10_000 {
        return Err(format!("`{text}` names more than 10000 seeds"));
    }
    Ok(seeds)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeds_parse_as_ranges_and_lists() {
        assert_eq!(parse_seeds("3..6"), Ok(vec![3, 4, 5]));
        assert_eq!(parse_seeds("3..=5"), Ok(vec![3, 4, 5]));
        assert_eq!(parse_seeds("7, 1"), Ok(vec![7, 1]));
        assert!(parse_seeds("5..5").is_err());
        assert!(parse_seeds("a..3").is_err());
    }

    #[test]
    fn distribution_interpolates_percentiles() {
        let d = Distribution::of((0..11).map(f64::from)).expect("values");
        assert_eq!((d.min, d.p10, d.median, d.mean, d.max), (0.0, 1.0, 5.0, 5.0, 10.0));
        let d = Distribution::of([1.0, 2.0, f64::NAN].into_iter()).expect("values");
        assert_eq!((d.n, d.p10), (2, 1.1));
        assert!(Distribution::of(std::iter::empty()).is_none());
    }

    fn scene(seed: u64, objects: &[(f64, f64)]) -> SceneScore {
        SceneScore {
            family: Family::BlindCues,
            seed,
            descriptors: Descriptors::Features,
            depth: DepthSource::Rendered,
            views: 4,
            width: 100,
            height: 100,
            miou: 0.9,
            boundary_miou: 0.9,
            per_view_miou: 0.9,
            consistency: 0.9,
            ids_per_gt: 1.0,
            accuracy_3d: 0.9,
            unlabelled_share: 0.0,
            ceiling_sam_regions: 1.0,
            ceiling_merged: 1.0,
            instances: objects
                .iter()
                .enumerate()
                .map(|(k, &(iou, image_share))| InstanceResult {
                    id: k as u32 + 1,
                    name: format!("object_{k}"),
                    classes: vec![],
                    iou,
                    image_share,
                })
                .collect(),
            seconds: 1.0,
        }
    }

    #[test]
    fn objects_under_half_are_counted_and_the_large_ones_named() {
        let scores =
            [scene(1, &[(0.9, 0.2), (0.42, 0.157), (0.3, 0.002)]), scene(2, &[(0.49, 0.01), (0.5, 0.5)])];
        let (lost, large) = objects_under_half(&scores);
        let named: Vec<(u64, &str)> = lost.iter().map(|(s, i)| (s.seed, i.name.as_str())).collect();
        assert_eq!(named, [(1, "object_1"), (1, "object_2"), (2, "object_0")]);
        assert_eq!(large, 2, "15.7 % and exactly 1 % count as large, 0.2 % does not");
        let text = markdown(&scores, 0);
        assert!(
            text.contains(
                "Objects under IoU 0.5: 3 of 5 (60.00 %), 2 of them covering at least 1 % of the image"
            ),
            "{text}"
        );
        assert!(text.contains("- blind_cues seed 1 object_1: IoU 0.42, 15.70 % of the image"), "{text}");
        let none = markdown(&[scene(3, &[(0.9, 0.2)])], 0);
        assert!(none.contains("Objects under IoU 0.5: 0 of 1 (0.00 %), 0 of them"), "{none}");
    }
}
