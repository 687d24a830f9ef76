//! What the two reduced suites in CI share (`suite_tests`, `blind_suite_tests`): running a list of
//! scenes end to end at a few views, and checking floors with one message for all that fail.

use crate::suite::{score_scene, DepthSource, Descriptors, Distribution, SceneOverrides, SceneScore};
use splatseg_synth::Family;
use std::path::Path;

/// Runs each scene `(family, seed)` of `scenes` with `views` views and the default settings (with
/// features), in a temporary folder; `inspect(name, work)` sees each scene's folder (`name` =
/// `family_seed`) before it is removed. Returns the scores and their markdown table.
pub(crate) fn run_scenes(
    scenes: &[(Family, u64)],
    views: usize,
    inspect: impl FnMut(&str, &Path),
) -> (Vec<SceneScore>, String) {
    run_scenes_with(scenes, views, &[Descriptors::Features], inspect)
}

/// [`run_scenes`] with each scene run once per entry of `descriptors` (scores in that order per
/// scene).
pub(crate) fn run_scenes_with(
    scenes: &[(Family, u64)],
    views: usize,
    descriptors: &[Descriptors],
    mut inspect: impl FnMut(&str, &Path),
) -> (Vec<SceneScore>, String) {
    let tmp = tempfile::tempdir().expect("temp dir");
    let overrides = SceneOverrides { size: None, views: Some(views) };
    let mut scores = Vec::new();
    for &(family, seed) in scenes {
        let name = format!("{family}_{seed}");
        let work = tmp.path().join(&name);
        scores.extend(
            score_scene(
                family,
                seed,
                overrides,
                descriptors,
                DepthSource::Rendered,
                &Default::default(),
                &work,
            )
            .expect("scene runs"),
        );
        inspect(&name, &work);
        std::fs::remove_dir_all(&work).expect("clean up");
    }
    let table = crate::suite::markdown(&scores, 4);
    println!("{table}");
    (scores, table)
}

/// Floors checked over a suite's scores; every floor that fails is named in one panic.
pub(crate) struct Floors<'a> {
    scores: &'a [SceneScore],
    failures: Vec<String>,
}

impl<'a> Floors<'a> {
    pub(crate) fn new(scores: &'a [SceneScore]) -> Self {
        Floors { scores, failures: Vec::new() }
    }

    /// The distribution of `metric` over the scenes.
    pub(crate) fn dist(&self, metric: fn(&SceneScore) -> f64) -> Distribution {
        Distribution::of(self.scores.iter().map(metric)).expect("scores")
    }

    /// Records a failure `what` unless `ok`.
    pub(crate) fn check(&mut self, ok: bool, what: String) {
        if !ok {
            self.failures.push(what);
        }
    }

    /// Panics naming every failed floor, with the suite's table.
    pub(crate) fn assert_met(self, table: &str) {
        assert!(self.failures.is_empty(), "floors not met: {}\n{table}", self.failures.join("; "));
    }
}
