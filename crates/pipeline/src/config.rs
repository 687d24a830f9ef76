//! The `--config` TOML file: [`PipelineConfig`], one table per stage. Kept free of the rest of
//! the crate so the fuzz target `fuzz/fuzz_targets/config_toml.rs` can call it cheaply.

use crate::error::Context;
use serde::{Deserialize, Serialize};
use splatseg_cues::RegionOptions;
use splatseg_eval::EvalConfig;
use splatseg_lift::LiftConfig;
use splatseg_match::MatchConfig;
use splatseg_merge::MergeConfig;
use std::path::Path;

/// Every stage's settings; the `--config` TOML file has one table per stage
/// (`[regions]`, `[merge]`, `[matching]`, `[lift]`, `[eval]`, `[train]`), each optional.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PipelineConfig {
    /// SAM masks → regions.
    pub regions: RegionOptions,
    /// Multi-Cue-Guided Mask Merging.
    pub merge: MergeConfig,
    /// Cross-view matching.
    pub matching: MatchConfig,
    /// Lifting onto the Gaussians.
    pub lift: LiftConfig,
    /// Metrics.
    pub eval: EvalConfig,
    /// Training and the joint optimisation (`splatseg train`).
    pub train: splatseg_train::TrainConfig,
}

impl PipelineConfig {
    /// Reads a TOML config file.
    pub fn from_file(path: &Path) -> crate::Result<Self> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
        Self::from_toml(&text, path)
    }

    /// Parses the text of a TOML config file and checks the settings that have rules
    /// (`[merge]`, `[train]`); `path` is only named in errors.
    pub fn from_toml(text: &str, path: &Path) -> crate::Result<Self> {
        let config: Self =
            toml::from_str(text).with_context(|| format!("invalid pipeline config: {}", path.display()))?;
        config.merge.validate().with_context(|| format!("invalid [merge] settings: {}", path.display()))?;
        config.train.validate().with_context(|| format!("invalid [train] settings: {}", path.display()))?;
        Ok(config)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The committed fuzz corpus of `fuzz/fuzz_targets/config_toml.rs`, replayed on stable: no
    /// file may panic, and the seed (the `splatseg config` output) must parse.
    #[test]
    fn the_config_fuzz_corpus_replays_and_the_seed_parses() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus/config_toml");
        let mut files: Vec<_> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
            .map(|e| e.expect("entry").path())
            .collect();
        files.sort();
        assert!(!files.is_empty());
        for file in &files {
            let bytes = std::fs::read(file).expect("corpus file");
            if let Ok(text) = std::str::from_utf8(&bytes) {
                let _ = PipelineConfig::from_toml(text, file);
            }
        }
        let seed = std::fs::read_to_string(dir.join("seed_defaults.toml")).expect("seed");
        PipelineConfig::from_toml(&seed, Path::new("seed_defaults.toml")).expect("the defaults parse");
    }
}
