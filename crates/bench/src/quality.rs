//! `bench quality`: the stress suite's distributions over families and seeds (see [`crate::suite`]),
//! as a Markdown report.

use crate::error::Context;
use crate::suite::{
    markdown, parse_seeds, score_scene, DepthSource, Descriptors, SceneOverrides, SceneScore,
    DEFAULT_FAMILIES, REPORT_SEEDS, TUNING_SEEDS,
};
use splatseg_pipeline::PipelineConfig;
use splatseg_synth::Family;
use std::path::PathBuf;
use std::time::Instant;

/// What to measure.
#[derive(Clone, Debug)]
pub struct QualityRequest {
    /// Seeds: `A..B` (B excluded), `A..=B`, `1,5,9`, `tuning` (0..16) or `report` (100..132).
    pub seeds: String,
    /// Families to run; empty: [`DEFAULT_FAMILIES`].
    pub families: Vec<Family>,
    /// Scene overrides (size, views).
    pub overrides: SceneOverrides,
    /// Also run every scene with the model-free descriptors.
    pub no_features: bool,
    /// The depth every run's merge reads.
    pub depth: DepthSource,
    /// Output folder for `quality.md` and `quality.json` (and with `keep` the scenes).
    pub out: Option<PathBuf>,
    /// Keep every scene and run folder under `OUT/scenes`.
    pub keep: bool,
    /// Pipeline settings of every run.
    pub pipeline: PipelineConfig,
    /// How many of the worst scenes to list.
    pub worst: usize,
}

/// The seeds `text` names (`tuning`, `report`, or as [`parse_seeds`]).
pub fn seeds_of(text: &str) -> crate::Result<Vec<u64>> {
    match text.trim() {
        "tuning" => Ok(TUNING_SEEDS.collect()),
        "report" => Ok(REPORT_SEEDS.collect()),
        t => parse_seeds(t).map_err(crate::BenchError::Invalid).context("--seeds"),
    }
}

/// Copies each run's object graph (`cache/graph.json`, with its ground truth) of the scene in
/// `work` to `dest/<name>_<descriptors>.json`, for `tools/edge_study.py` (issue 58).
fn keep_graphs(work: &std::path::Path, dest: &std::path::Path, name: &str) -> crate::Result<()> {
    for run in ["run_features", "run_model_free"] {
        let graph = work.join(run).join("cache").join("graph.json");
        if graph.is_file() {
            std::fs::create_dir_all(dest).with_context(|| format!("cannot create {}", dest.display()))?;
            let to = dest.join(format!("{name}_{}.json", run.trim_start_matches("run_")));
            std::fs::copy(&graph, &to)
                .with_context(|| format!("cannot copy {} to {}", graph.display(), to.display()))?;
        }
    }
    Ok(())
}

/// Scores every scene of `request` and returns the Markdown report (also written to
/// `OUT/quality.md`, with the scores in `OUT/quality.json`, when `out` is given). `progress`
/// gets one line per scored scene.
pub fn quality(request: &QualityRequest, progress: &mut dyn FnMut(String)) -> crate::Result<String> {
    let seeds = seeds_of(&request.seeds)?;
    let families =
        if request.families.is_empty() { DEFAULT_FAMILIES.to_vec() } else { request.families.clone() };
    let descriptors: Vec<Descriptors> = if request.no_features {
        vec![Descriptors::Features, Descriptors::ModelFree]
    } else {
        vec![Descriptors::Features]
    };
    let work_root = match &request.out {
        Some(out) => out.join("scenes"),
        None => std::env::temp_dir().join(format!("splatseg-bench-{}", std::process::id())),
    };
    let started = Instant::now();
    let total = families.len() * seeds.len();
    let mut scores: Vec<SceneScore> = Vec::new();
    for (k, &family) in families.iter().enumerate() {
        for (j, &seed) in seeds.iter().enumerate() {
            let work = work_root.join(format!("{family}_{seed}"));
            let scene = score_scene(
                family,
                seed,
                request.overrides,
                &descriptors,
                request.depth,
                &request.pipeline,
                &work,
            )?;
            if let Some(out) = &request.out {
                keep_graphs(&work, &out.join("graphs"), &format!("{family}_{seed}"))?;
            }
            if !request.keep {
                std::fs::remove_dir_all(&work)
                    .with_context(|| format!("cannot remove the scene folder {}", work.display()))?;
            }
            for s in &scene {
                progress(format!(
                    "[{}/{total}] {family} seed {seed} ({}): mIoU {:.3}, boundary {:.3}, consistency {:.3}, \
                     ids/GT {:.2}, 3D acc. {:.3}, unlabelled {:.3} ({:.1} s)",
                    k * seeds.len() + j + 1,
                    if s.descriptors == Descriptors::Features { "features" } else { "model-free" },
                    s.miou,
                    s.boundary_miou,
                    s.consistency,
                    s.ids_per_gt,
                    s.accuracy_3d,
                    s.unlabelled_share,
                    s.seconds
                ));
            }
            scores.extend(scene);
        }
    }
    if request.out.is_none() || !request.keep {
        let _ = std::fs::remove_dir(&work_root);
    }
    let names: Vec<&str> = families.iter().map(|f| f.name()).collect();
    let mut text = format!(
        "# splatseg bench quality\n\nseeds {} ({} scenes per family), families {}{}{}; {}; {:.0} s in all\n",
        request.seeds,
        seeds.len(),
        names.join(" "),
        request.overrides.size.map_or(String::new(), |(w, h)| format!(", size {w}x{h}")),
        request.overrides.views.map_or(String::new(), |v| format!(", {v} views")),
        request.depth.name(),
        started.elapsed().as_secs_f64()
    );
    // tuning and blind families are never pooled: a blind result is reported on its own
    let groups = [("", false), (", blind families", true)];
    for d in &descriptors {
        for (suffix, blind) in groups {
            let of: Vec<SceneScore> = scores
                .iter()
                .filter(|s| s.descriptors == *d && s.family.is_blind() == blind)
                .cloned()
                .collect();
            if !of.is_empty() {
                text.push_str(&format!("\n## {}{suffix}\n\n{}", d.name(), markdown(&of, request.worst)));
            }
        }
    }
    if let Some(out) = &request.out {
        std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
        splatseg_scene::atomic::write_bytes_atomic(&out.join("quality.md"), text.as_bytes())?;
        let json = serde_json::to_vec_pretty(&scores).context("encoding the scores")?;
        splatseg_scene::atomic::write_bytes_atomic(&out.join("quality.json"), &json)?;
    }
    Ok(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blind_families_are_reported_apart_from_the_tuning_ones() {
        let request = QualityRequest {
            seeds: "3".into(),
            families: vec![Family::Rooms, Family::BlindLens],
            overrides: SceneOverrides { size: None, views: Some(4) },
            no_features: false,
            depth: DepthSource::Rendered,
            out: None,
            keep: false,
            pipeline: PipelineConfig::default(),
            worst: 1,
        };
        let text = quality(&request, &mut |_| {}).expect("report");
        let tuning = text.find("\n## with features\n").expect("a tuning section");
        let blind = text.find("\n## with features, blind families\n").expect("a blind section");
        assert!(tuning < blind, "{text}");
        // each family's row is in its own section only
        let (first, second) = text.split_at(blind);
        assert!(first.contains("| rooms |") && !first.contains("| blind_lens |"), "{text}");
        assert!(second.contains("| blind_lens |") && !second.contains("| rooms |"), "{text}");
    }

    #[test]
    fn the_monocular_depth_is_what_the_merge_reads_when_asked() {
        let tmp = tempfile::tempdir().expect("temp dir");
        let run = |depth: DepthSource| {
            let out = tmp.path().join(format!("{depth:?}"));
            let request = QualityRequest {
                seeds: "1".into(),
                families: vec![Family::BlindCues],
                overrides: SceneOverrides { size: None, views: Some(4) },
                no_features: false,
                depth,
                out: Some(out.clone()),
                keep: false,
                pipeline: PipelineConfig::default(),
                worst: 1,
            };
            let text = quality(&request, &mut |_| {}).expect("report");
            assert!(text.contains(depth.name()), "{text}");
            let json: serde_json::Value =
                serde_json::from_slice(&std::fs::read(out.join("quality.json")).expect("json"))
                    .expect("parses");
            let scene = &json[0];
            assert_eq!(scene["depth"], serde_json::json!(format!("{depth:?}").to_lowercase()), "{scene}");
            scene["ceiling_merged"].as_f64().expect("a number")
        };
        // The merged regions differ: the merge read another depth (the monocular one carries the
        // family's scale error, noise and blur, and without metric depth no crease gate runs).
        let (rendered, monocular) = (run(DepthSource::Rendered), run(DepthSource::Monocular));
        assert!((rendered - monocular).abs() > 1e-6, "rendered {rendered}, monocular {monocular}");
    }
}
