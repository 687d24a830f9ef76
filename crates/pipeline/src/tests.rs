//! End-to-end tests of the pipeline on synthetic scenes (quality floors) and its bad-input
//! errors.

use super::{run_pipeline, PipelineConfig, RunConfig, RunSummary};
use splatseg_cues::DepthKind;
use splatseg_synth::SynthConfig;
use std::path::Path;

/// Writes the synthetic scene of `config` into `dir`.
fn synth(dir: &Path, config: &SynthConfig) {
    let scene = splatseg_synth::generate(config).expect("synthetic scene");
    splatseg_synth::write(dir, &scene).expect("write synthetic scene");
}

fn run_config(scene: &Path, out: &Path) -> RunConfig {
    RunConfig {
        scene: scene.to_path_buf(),
        masks: scene.join("sam"),
        features: Some(scene.join("features")),
        depth: None,
        depth_kind: DepthKind::InverseRelative,
        resize_depth: false,
        gaussians: None,
        gt: Some(scene.join("gt")),
        pipeline: PipelineConfig::default(),
        out: out.to_path_buf(),
        options: Default::default(),
    }
}

fn metrics<'a>(summary: &'a RunSummary, stage: &str) -> &'a splatseg_eval::Metrics {
    let report = summary.report.as_ref().expect("ground truth was given");
    &report.sets.iter().find(|s| s.name == stage).expect("stage scored").metrics
}

/// Floors of issue 4 on two seeds, with depth rendered from the Gaussians (the default) and
/// with the scene's monocular-like depth maps (`--depth`).
#[test]
fn synthetic_scenes_meet_the_quality_floors() {
    floors_on_seeds(&[0, 1]);
}

/// The same floors on seeds no setting was tuned on (the look-alike join's τ_touching was chosen on
/// seeds 0–4).
#[test]
fn held_out_synthetic_scenes_meet_the_quality_floors() {
    floors_on_seeds(&[7]);
}

fn floors_on_seeds(seeds: &[u64]) {
    for &seed in seeds {
        let tmp = tempfile::tempdir().expect("temp dir");
        let scene = tmp.path().join("scene");
        synth(&scene, &SynthConfig { seed, ..SynthConfig::default() });
        for depth in [None, Some(scene.join("depth"))] {
            let out = tmp.path().join(if depth.is_some() { "out_npy_depth" } else { "out" });
            let config = RunConfig { depth: depth.clone(), ..run_config(&scene, &out) };
            check_floors(seed, &run_pipeline(&config).expect("pipeline runs"));
        }
    }
}

fn check_floors(seed: u64, summary: &RunSummary) {
    {
        let table = summary.table().unwrap_or_default();
        println!("seed {seed}\n{table}");
        let (raw, lifted) = (metrics(summary, "raw"), metrics(summary, "lifted"));
        let acc = lifted.label_accuracy_3d.as_ref().expect("per-Gaussian ground truth").accuracy;
        assert!(lifted.miou >= 0.85, "seed {seed}: mIoU {:.3}\n{table}", lifted.miou);
        assert!(lifted.consistency >= 0.95, "seed {seed}: consistency {:.3}\n{table}", lifted.consistency);
        assert!(
            lifted.pred_masks as f64 <= 1.5 * lifted.gt_instances as f64,
            "seed {seed}: {} masks for {} instances\n{table}",
            lifted.pred_masks,
            lifted.gt_instances
        );
        assert!(acc >= 0.9, "seed {seed}: 3D label accuracy {acc:.3}\n{table}");
        assert!(lifted.miou > raw.miou + 0.1, "seed {seed}: no clear gain over raw masks\n{table}");
        assert!(lifted.consistency > raw.consistency + 0.1, "seed {seed}\n{table}");
        assert!(lifted.pred_masks * 3 < raw.pred_masks, "seed {seed}\n{table}");
    }
}

/// A small scene for the error tests.
fn small_scene(dir: &Path) {
    synth(dir, &SynthConfig { seed: 3, views: 3, width: 96, height: 72, ..SynthConfig::default() });
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("mkdir");
    for entry in std::fs::read_dir(from).expect("list") {
        let path = entry.expect("entry").path();
        if path.is_file() {
            std::fs::copy(&path, to.join(path.file_name().expect("name"))).expect("copy");
        }
    }
}

#[test]
fn rerun_resumes_from_the_cache() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    small_scene(&scene);
    let config = run_config(&scene, &tmp.path().join("out"));
    let first = run_pipeline(&config).expect("first run");
    assert!(!first.resumed && first.cached_views == 0);
    let second = run_pipeline(&config).expect("second run");
    assert!(second.resumed, "identical inputs: nothing recomputed");
    // A changed lift setting recomputes the run but reuses every view's merge.
    let mut changed = config.clone();
    changed.pipeline.lift.tau_var += 0.1;
    let third = run_pipeline(&changed).expect("third run");
    assert!(!third.resumed);
    assert_eq!(third.cached_views, third.views_with_masks);
    assert_eq!(
        std::fs::read(tmp.path().join("out/masks/view_000.png")).ok().map(|b| !b.is_empty()),
        Some(true)
    );
}

#[test]
fn masks_for_unknown_views_are_an_error() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    small_scene(&scene);
    let masks = tmp.path().join("masks");
    copy_dir(&scene.join("sam"), &masks);
    std::fs::copy(masks.join("view_000.json"), masks.join("holiday_042.json")).expect("copy");
    let config = RunConfig { masks, ..run_config(&scene, &tmp.path().join("out")) };
    let err = run_pipeline(&config).expect_err("unknown view").report();
    assert!(err.contains("holiday_042") && err.contains("does not have"), "{err}");
}

#[test]
fn masks_of_the_wrong_size_are_an_error() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    small_scene(&scene);
    let masks = tmp.path().join("masks");
    copy_dir(&scene.join("sam"), &masks);
    let mask = splatseg_scene::rle::Rle::encode(&splatseg_scene::Plane::filled(50, 40, true));
    splatseg_scene::sam::write_sam_json(
        &masks.join("view_001.json"),
        &[splatseg_scene::sam::SamMask::from_rle(mask)],
    )
    .expect("write");
    let config = RunConfig { masks, ..run_config(&scene, &tmp.path().join("out")) };
    let err = run_pipeline(&config).expect_err("wrong size").report();
    assert!(err.contains("[40, 50]") && err.contains("view_001.json"), "{err}");
}

#[test]
fn ground_truth_of_the_wrong_size_is_an_error() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    small_scene(&scene);
    let gt = tmp.path().join("gt");
    copy_dir(&scene.join("gt/instance"), &gt);
    splatseg_scene::labels::write_label_png(
        &gt.join("view_002.png"),
        &splatseg_scene::Plane::filled(10, 10, 1),
    )
    .expect("write");
    let config = RunConfig { gt: Some(gt), ..run_config(&scene, &tmp.path().join("out")) };
    let err = run_pipeline(&config).expect_err("wrong size").report();
    assert!(err.contains("view_002"), "{err}");
}

#[test]
fn a_ply_with_too_few_gaussians_is_an_error() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    small_scene(&scene);
    let g = splatseg_scene::ply::read_ply(&scene.join("gaussians.ply")).expect("read");
    let half: Vec<usize> = (0..g.len() / 2).collect();
    let ply = tmp.path().join("half.ply");
    splatseg_scene::ply::write_ply(&ply, &g.select(&half)).expect("write");
    let config = RunConfig { gaussians: Some(ply), ..run_config(&scene, &tmp.path().join("out")) };
    let err = run_pipeline(&config).expect_err("too few Gaussians").report();
    assert!(err.contains("fewer Gaussians") && err.contains("half.ply"), "{err}");
}

#[test]
fn final_maps_default_to_snapped_onto_sam_regions_and_others_can_be_chosen() {
    use splatseg_lift::FinalMaps;
    assert_eq!(PipelineConfig::default().lift.final_maps, FinalMaps::SnappedRaw);
    let config: PipelineConfig = toml::from_str("[final_maps]\nkind = \"snapped\"\n").expect("parses");
    assert_eq!(config.lift.final_maps, FinalMaps::Snapped);
    let config: PipelineConfig = toml::from_str("[final_maps]\nkind = \"rendered\"\n").expect("parses");
    assert_eq!(config.lift.final_maps, FinalMaps::Rendered);
    assert!(toml::from_str::<PipelineConfig>("[final_maps]\nkind = \"sharp\"\n").is_err());
}

/// The library's read side gives back what the run wrote and returned.
#[test]
fn run_outputs_read_back_what_the_run_returned() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    synth(&scene, &SynthConfig { seed: 2, views: 3, width: 160, height: 120, ..SynthConfig::default() });
    let out = tmp.path().join("out");
    let config = RunConfig { gt: None, ..run_config(&scene, &out) };
    let summary = run_pipeline(&config).expect("pipeline runs");
    let read = crate::RunOutputs::open(&out).expect("finished run");
    assert_eq!(read.summary.final_objects, summary.final_objects);
    assert_eq!(read.summary.merged_masks, summary.merged_masks);
    let ids = read.object_ids().expect("labelled PLY");
    assert_eq!(Some(ids.len()), summary.gaussians);
    let stems: Vec<String> = std::fs::read_dir(out.join("masks"))
        .expect("masks")
        .flatten()
        .map(|e| e.path().file_stem().expect("stem").to_string_lossy().to_string())
        .collect();
    let first = read.label_map(&stems[0]).expect("label map");
    assert!(first.data.iter().any(|&id| id > 0), "objects in the map");
    let err = crate::RunOutputs::open(tmp.path()).expect_err("no run there").report();
    assert!(err.contains("metrics.json"), "{err}");
}

/// Issue 61: `run` on an SPZ made from the scene's PLY (quantised positions, colours, shapes and
/// SH) finds the same objects: per Gaussian, its object in one run is its object in the other
/// (each object of one run matched to the other run's object most of its Gaussians carry, both ways).
#[test]
fn run_on_an_spz_of_the_ply_labels_the_gaussians_as_on_the_ply() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    synth(&scene, &SynthConfig { seed: 2, views: 3, width: 160, height: 120, ..SynthConfig::default() });
    let g = splatseg_scene::ply::read_ply(&scene.join("gaussians.ply")).expect("the scene's PLY");
    let spz = tmp.path().join("scene.spz");
    splatseg_scene::splats::write_gaussians(&spz, &g).expect("writes the SPZ");
    let ids = |out: &Path, gaussians: Option<std::path::PathBuf>| {
        let config = RunConfig { gt: None, gaussians, ..run_config(&scene, out) };
        run_pipeline(&config).expect("pipeline runs");
        crate::RunOutputs::open(out).expect("finished run").object_ids().expect("labelled PLY")
    };
    let on_ply = ids(&tmp.path().join("out_ply"), None);
    let on_spz = ids(&tmp.path().join("out_spz"), Some(spz));
    assert_eq!(on_ply.len(), on_spz.len());
    // Matched both ways, so that neither a split nor a merge of objects scores well.
    let agreement = |from: &[i32], to: &[i32]| {
        let mut pairs = std::collections::BTreeMap::<(i32, i32), usize>::new();
        for (&a, &b) in from.iter().zip(to) {
            *pairs.entry((a, b)).or_default() += 1;
        }
        let mut best = std::collections::BTreeMap::<i32, usize>::new();
        for (&(a, _), &count) in &pairs {
            let slot = best.entry(a).or_default();
            *slot = (*slot).max(count);
        }
        best.values().sum::<usize>() as f64 / from.len() as f64
    };
    let agreement = agreement(&on_ply, &on_spz).min(agreement(&on_spz, &on_ply));
    let objects = |ids: &[i32]| ids.iter().collect::<std::collections::BTreeSet<_>>().len();
    eprintln!(
        "PLY vs SPZ run: agreement {agreement:.4} over {} Gaussians, {} vs {} ids, exactly equal: {}",
        on_ply.len(),
        objects(&on_ply),
        objects(&on_spz),
        on_ply == on_spz
    );
    assert!(agreement >= 0.99, "per-Gaussian label agreement {agreement:.4} < 0.99");
}

/// Issue 58: a run writes its object graph to `cache/graph.json`, every edge with its evidence,
/// rule and outcome, and with ground truth the object each side mostly is.
#[test]
fn a_run_records_its_object_graph_with_ground_truth() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    synth(&scene, &SynthConfig { seed: 3, views: 6, width: 160, height: 120, ..SynthConfig::default() });
    let out = tmp.path().join("out");
    run_pipeline(&run_config(&scene, &out)).expect("pipeline runs");
    let text =
        std::fs::read_to_string(out.join("cache").join(crate::graph_record::GRAPH_FILE)).expect("graph");
    let graph: serde_json::Value = serde_json::from_str(&text).expect("JSON");
    let edges = graph["edges"].as_array().expect("edges");
    assert!(graph["nodes"].as_u64().expect("nodes") >= 2 && !edges.is_empty(), "{text}");
    for e in edges {
        assert!(e["a"].as_u64() < e["b"].as_u64(), "{e}");
        assert!(e["voxel_pairs"].as_u64().expect("surface term") >= 1, "{e}");
        let truth = e["truth"].as_array().expect("ground truth given");
        for side in truth {
            let purity = side["purity"].as_f64().expect("purity");
            assert!(purity > 0.0 && purity <= 1.0, "{e}");
        }
        assert!(e["outcome"].as_str().is_some_and(|o| !o.is_empty()), "{e}");
    }
    let joined = edges.iter().filter(|e| e["outcome"] == "joined").count();
    let asked = edges.iter().filter(|e| e["rule"] != "none").count();
    assert!(joined <= asked, "only edges a rule asked for are joined");
}
