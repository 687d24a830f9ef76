//! The `--config` TOML file: one table per stage of the paper's pipeline (`[merge]`, `[match]`,
//! `[lift]`, `[objects]`, `[final_maps]`, `[eval]`, `[train]`), read into a [`PipelineConfig`]
//! and written by [`PipelineConfig::to_file_text`] (what `splatseg config` prints: every key
//! with its meaning, unit and the source of its default). Keys of earlier versions get an error
//! naming the new key, or saying the key became a constant ([`retired_setting`]). Kept free of
//! the rest of the crate so the fuzz target `fuzz/fuzz_targets/config_toml.rs` can call it
//! cheaply.

use crate::error::Context;
use serde::{Deserialize, Serialize};
use splatseg_cues::RegionOptions;
use splatseg_eval::EvalConfig;
use splatseg_lift::config::{FinalMapsTable, LiftTable, ObjectsTable};
use splatseg_lift::LiftConfig;
use splatseg_match::MatchConfig;
use splatseg_merge::MergeConfig;
use std::fmt::Write as _;
use std::path::Path;

/// Every stage's settings. Serialised whole (cache keys); read from the `--config` file's tables.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(from = "ConfigFile")]
pub struct PipelineConfig {
    /// SAM masks → regions. Code only: no file key (`RegionOptions::default()`).
    pub regions: RegionOptions,
    /// Multi-Cue-Guided Mask Merging (`[merge]`).
    pub merge: MergeConfig,
    /// Cross-view matching (`[match]`).
    pub matching: MatchConfig,
    /// Lifting, the 3D object steps and the final maps (`[lift]`, `[objects]`, `[final_maps]`).
    pub lift: LiftConfig,
    /// Metrics (`[eval]`).
    pub eval: EvalConfig,
    /// Training and the joint optimisation (`[train]`, `splatseg train`).
    pub train: splatseg_train::TrainConfig,
}

/// The file's tables, each optional.
#[derive(Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct ConfigFile {
    merge: MergeConfig,
    #[serde(rename = "match")]
    matching: MatchConfig,
    lift: LiftTable,
    objects: ObjectsTable,
    final_maps: FinalMapsTable,
    eval: EvalConfig,
    train: splatseg_train::TrainConfig,
}

impl From<ConfigFile> for PipelineConfig {
    fn from(f: ConfigFile) -> Self {
        PipelineConfig {
            regions: RegionOptions::default(),
            merge: f.merge,
            matching: f.matching,
            lift: LiftConfig::from_tables(f.lift, f.objects, f.final_maps),
            eval: f.eval,
            train: f.train,
        }
    }
}

/// Every key of the file, in the order printed, with its one-line meaning, unit and the source
/// of its default (a test checks this list and the tables hold the same keys).
const KEY_DOCS: &[(&str, &str, &str)] = &[
    ("merge", "profile", "reading of the score: \"paper\" (normalised, shared boundary, added gates) or \"literal\" (as printed; merges nothing)"),
    ("merge", "tau_merge", "merge when the score exceeds this (unitless, score ≤ 1; paper)"),
    ("merge", "tau_depth", "hard gate on the normalised depth gap (depth scaled to 0–1 per image; paper)"),
    ("merge", "w_sem", "weight of the descriptor cosine (paper)"),
    ("merge", "w_depth", "weight of the depth affinity (paper)"),
    ("merge", "w_dbound", "weight of the depth-gradient penalty on the shared boundary (paper)"),
    ("merge", "w_edge", "weight of the LoG edge penalty on the shared boundary (paper)"),
    ("merge", "sigma_d_sq", "σ_d² of the depth affinity exp(−Δd²/2σ_d²) (normalised depth²; paper)"),
    ("merge", "max_depth_boundary", "reject when ∇D on the shared boundary exceeds this (normalised 0–1; ours, measured; false = off)"),
    ("merge", "max_concave_crease_deg", "with metric depth: reject pairs meeting at a concave crease sharper than this (degrees; ours, measured; false = off)"),
    ("match", "tau_match", "masks of two views without 3D evidence match when their descriptor cosine exceeds this (paper)"),
    ("match", "tau_overlap", "masks with 3D support match when their Gaussian overlap is at least this (share; ours)"),
    ("match", "tau_match_with_3d", "descriptor cosine still required of masks matched by 3D overlap (ours)"),
    ("match", "max_pair_samples", "memory bound: Gaussian view pairs counted for 3D evidence, subsampled above (pairs; ours)"),
    ("match", "max_candidate_edges", "memory bound: candidate match edges kept (edges; ours)"),
    ("lift", "tau_var", "Gaussians whose identity-feature variance over their views exceeds this get no id (unitless; ours, measured: the paper's 0.05 is for another variance)"),
    ("lift", "min_views", "Gaussians seen in fewer views get no id (views; ours)"),
    ("objects", "tau_touching", "objects touching in 3D join when their identity features' cosine reaches this (above 1 = off; ours, measured)"),
    ("objects", "tau_seam", "cosine at which objects continuing one plane across a smooth seam join: the pieces of a floor or wall, not a rug on the floor (ours, measured)"),
    ("objects", "decision", "how touching objects are decided one or two: \"rules\" (the joins and vetoes) or \"evidence\" (one sum of log-odds over the pooled evidence, agglomerative; issue 58, measured)"),
    ("objects", "split_disconnected", "split objects whose Gaussians form clusters apart in 3D (true/false; ours)"),
    ("objects", "min_object_px", "objects covering fewer pixels over all views are dropped (pixels of a 320×240 view, scaled with the views; ours)"),
    ("final_maps", "kind", "the final label maps: \"snapped-raw\" (onto SAM's regions), \"snapped\" (onto the merged regions) or \"rendered\" (ours, measured)"),
    ("final_maps", "refine_window_px", "colour refinement of the boundaries: half-width of the window (pixels, 0 = off; ours, measured)"),
    ("final_maps", "refine_passes", "colour refinement passes in a 320×240 view, scaled with the side (passes; ours)"),
    ("eval", "band_radius_px", "radius of the boundary band of boundary mIoU (pixels; paper)"),
    ("eval", "unlabelled_gt", "ground-truth 0: \"background\" (counts against predictions) or \"ignore\" (ours)"),
    ("train", "iterations", "training iterations, one view each (iterations; paper)"),
    ("train", "lambda_dssim", "weight of D-SSIM in the render loss (unitless; 3DGS)"),
    ("train", "seed", "seed of the view order and feature initialisation"),
    ("train", "test_every", "every N-th view is held out for PSNR/SSIM (views, 0 = none; 3DGS's llffhold)"),
    ("train", "background", "RGB background the images were composited on (0–1 each)"),
    ("train", "save_iterations", "iterations after which the Gaussians are also saved (iterations; 3DGS)"),
    ("train.densify", "from", "first densification iteration (iterations; paper)"),
    ("train.densify", "until", "densification stops and the joint stage starts here (iterations; paper)"),
    ("train.densify", "grad_threshold", "view-space gradient above which a Gaussian is densified (NDC units; 3DGS)"),
    ("train.joint", "enabled", "run the joint optimisation when lifted ids are present (true/false; paper)"),
    ("train.joint", "feature_dim", "object-feature width (channels; paper)"),
    ("train.joint", "lambda_semantic", "λ_s, weight of the semantic loss (paper)"),
    ("train.joint", "lambda_reg", "λ_reg, weight of the 3D regulariser (paper)"),
    ("train.joint", "knn", "neighbours of the 3D regulariser (Gaussians; paper)"),
    ("train.joint", "identity_maps", "supervise rendered identity maps against the label maps (true/false; paper's supplement)"),
    ("train.joint", "lambda_identity", "weight of the identity maps' cross-entropy (paper's λ_s)"),
    ("train.joint", "readback", "how ids are read back: \"rendered\", \"classifier\" or \"nearest-code\" (ours)"),
];

/// The values a numeric key of the file may take, inclusive: (table, key, min, max); every value
/// must also be finite (no NaN or infinity), and each number of an array is checked. Values of the
/// wrong type are left to the tables' own parsing.
const RANGES: &[(&str, &str, f64, f64)] = &[
    ("merge", "tau_merge", 0.0, 1.0),
    ("merge", "tau_depth", 0.0, 1.0),
    ("merge", "w_sem", 0.0, 10.0),
    ("merge", "w_depth", 0.0, 10.0),
    ("merge", "w_dbound", 0.0, 10.0),
    ("merge", "w_edge", 0.0, 10.0),
    ("merge", "sigma_d_sq", 1e-6, 10.0),
    ("merge", "max_depth_boundary", 0.0, 1.0),
    ("merge", "max_concave_crease_deg", 0.0, 180.0),
    ("match", "tau_match", -1.0, 1.0),
    ("match", "tau_overlap", 0.0, 1.0),
    ("match", "tau_match_with_3d", -1.0, 1.0),
    ("match", "max_pair_samples", 1.0, f64::MAX),
    ("match", "max_candidate_edges", 1.0, f64::MAX),
    ("lift", "tau_var", 0.0, f64::MAX),
    ("lift", "min_views", 1.0, f64::MAX),
    ("objects", "tau_touching", -1.0, f64::MAX),
    ("objects", "tau_seam", -1.0, f64::MAX),
    ("objects", "min_object_px", 0.0, f64::MAX),
    ("final_maps", "refine_window_px", 0.0, 64.0),
    ("final_maps", "refine_passes", 0.0, 1000.0),
    ("eval", "band_radius_px", 0.0, 1000.0),
    ("train", "iterations", 1.0, f64::MAX),
    ("train", "lambda_dssim", 0.0, 1.0),
    ("train", "seed", 0.0, f64::MAX),
    ("train", "test_every", 0.0, f64::MAX),
    ("train", "background", 0.0, 1.0),
    ("train", "save_iterations", 1.0, f64::MAX),
    ("train.densify", "from", 0.0, f64::MAX),
    ("train.densify", "until", 0.0, f64::MAX),
    ("train.densify", "grad_threshold", 1e-12, f64::MAX),
    ("train.joint", "feature_dim", 1.0, 1024.0),
    ("train.joint", "lambda_semantic", 0.0, f64::MAX),
    ("train.joint", "lambda_reg", 0.0, f64::MAX),
    ("train.joint", "knn", 1.0, 1024.0),
    ("train.joint", "lambda_identity", 0.0, f64::MAX),
];

/// The first numeric value of a parsed file outside [`RANGES`], as a message.
fn out_of_range(root: &toml::Table) -> Option<String> {
    for &(table, key, min, max) in RANGES {
        let Some(value) = table_at(root, table).and_then(|t| t.get(key)) else { continue };
        let numbers: Vec<f64> = match value {
            toml::Value::Array(items) => items.iter().filter_map(number).collect(),
            other => number(other).into_iter().collect(),
        };
        if let Some(x) = numbers.into_iter().find(|x| !(x.is_finite() && (min..=max).contains(x))) {
            let bounds = match (min, max) {
                (min, f64::MAX) => format!("a finite number ≥ {min}"),
                (min, max) => format!("a number from {min} to {max}"),
            };
            return Some(format!("[{table}] {key} = {x} is out of range: expected {bounds}"));
        }
    }
    None
}

fn number(value: &toml::Value) -> Option<f64> {
    match value {
        toml::Value::Integer(i) => Some(*i as f64),
        toml::Value::Float(f) => Some(*f),
        _ => None,
    }
}

/// Keys and tables of earlier versions and what became of them: (table, key, message). A key of
/// `""` stands for the whole table.
const RETIRED: &[(&str, &str, &str)] = &[
    ("eval", "pred_id_scope", "is no longer a file key: run's ids are global; splatseg eval takes --view-local"),
    ("regions", "", "the [regions] table was removed: SAM masks become regions with splatseg_cues::RegionOptions::default() (min_region_px 32, uncovered pixels unlabelled)"),
    ("matching", "", "the [matching] table is now [match]"),
    ("lift", "tau_touching", "moved: write it as [objects] tau_touching"),
    ("lift", "tau_seam", "moved: write it as [objects] tau_seam"),
    ("lift", "tau_part", "is gone: parts meeting at convex edges join by their geometry and the views"),
    ("objects", "tau_part", "is gone: parts meeting at convex edges join by their geometry and the views"),
    ("lift", "split_disconnected", "moved: write it as [objects] split_disconnected"),
    ("lift", "min_object_px", "moved: write it as [objects] min_object_px"),
    ("lift", "final_maps", "moved: write it as [final_maps] kind"),
    ("lift", "refine_window_px", "moved: write it as [final_maps] refine_window_px"),
    ("lift", "refine_passes", "moved: write it as [final_maps] refine_passes"),
    ("lift", "depth_rel_tol", "is now a constant (splatseg_lift::visibility, 0.03)"),
    ("lift", "depth_sigma_tol", "is now a constant (splatseg_lift::visibility, 1.0)"),
    ("lift", "surface_transmittance", "is now the constant splatseg_lift::visibility::SURFACE_TRANSMITTANCE (0.5)"),
    ("lift", "min_frontal", "is now a constant (splatseg_lift::visibility, 0.05)"),
    ("lift", "near", "is now the constant splatseg_lift::project::NEAR_PLANE (0.01)"),
    ("lift", "unreliable_render_weight", "is now a constant (splatseg_lift::render_labels, 0.25)"),
    ("lift", "contact_voxel_factor", "is now a constant (splatseg_lift::touching, 3.0)"),
    ("lift", "min_contact_voxels", "is now a constant (splatseg_lift::touching, 8)"),
    ("lift", "part_min_together_share", "is now a constant (splatseg_lift::touching::MIN_TOGETHER_SHARE, 0.5)"),
    ("lift", "seam_smooth_share", "is now a constant (splatseg_lift::shape, 0.9)"),
    ("lift", "seam_max_angle_deg", "is now a constant (splatseg_lift::shape, 10°)"),
    ("lift", "thin_min_elongation", "is now a constant (splatseg_lift::shape, 5.0)"),
    ("lift", "split_voxel_factor", "is now a constant (splatseg_lift::split, 3.0)"),
    ("lift", "tau_seam_model_free", "is gone: [objects] tau_seam (0.5) holds with and without features"),
    ("lift", "snap_split_share", "is now the constant splatseg_lift::config::SNAP_SPLIT_SHARE (0.25)"),
    ("lift", "snap_bleed_px", "is now the constant splatseg_lift::config::SNAP_BLEED_PX (4 px)"),
    ("lift", "snap_contained_share", "is now the constant splatseg_lift::config::SNAP_CONTAINED_SHARE (0.5)"),
    ("lift", "snap_contained_min_share", "is now the constant splatseg_lift::config::SNAP_CONTAINED_MIN_SHARE (0.05)"),
    ("lift", "snap_contained_min_px", "is now the constant splatseg_lift::config::SNAP_CONTAINED_MIN_PX (32 px)"),
    ("lift", "min_together_share", "is now a constant (splatseg_lift::touching::MIN_TOGETHER_SHARE, 0.5)"),
    ("lift", "part_max_concave_share", "is no longer a file key (LiftConfig field for code, default 0.05)"),
    ("lift", "part_min_convex_share", "is no longer a file key (LiftConfig field for code, default 0.1)"),
    ("lift", "min_split_gaussians", "is no longer a file key (LiftConfig field for code, default 32)"),
    ("train", "sh_degree_interval", "is no longer a file key: 3DGS's 1000 (TrainConfig field for code)"),
    ("train", "lr", "is no longer a file table: 3DGS's learning rates (TrainConfig::lr for code)"),
    ("train.densify", "interval", "is no longer a file key: 3DGS's 100 (DensifyConfig field for code)"),
    ("train.densify", "percent_dense", "is no longer a file key: 3DGS's 0.01 (DensifyConfig field for code)"),
    ("train.densify", "min_opacity", "is no longer a file key: 3DGS's 0.005 (DensifyConfig field for code)"),
    ("train.densify", "opacity_reset_interval", "is no longer a file key: 3DGS's 3000 (DensifyConfig field for code)"),
    ("train.densify", "reset_opacity", "is no longer a file key: 3DGS's 0.01 (DensifyConfig field for code)"),
    ("train.densify", "max_screen_size_px", "is no longer a file key: 3DGS's 20 px (DensifyConfig field for code)"),
    ("train.joint", "init_std", "is no longer a file key: 0.1 (JointConfig field for code)"),
    ("train.joint", "knn_refresh_interval", "is no longer a file key: 1000 (JointConfig field for code)"),
    ("train.joint", "assign_min_cosine", "is no longer a file key: 0.5 (JointConfig field for code)"),
];

/// The table at a dotted path (`train.densify`) of a parsed file.
fn table_at<'a>(root: &'a toml::Table, path: &str) -> Option<&'a toml::Table> {
    path.split('.').try_fold(root, |t, name| t.get(name).and_then(toml::Value::as_table))
}

/// The message for the first key or table of an earlier version that a parsed file holds, if any.
pub fn retired_setting(root: &toml::Table) -> Option<String> {
    for &(table, key, what) in RETIRED {
        let found = match key {
            "" => table_at(root, table).is_some(),
            _ => table_at(root, table).is_some_and(|t| t.contains_key(key)),
        };
        if found {
            return Some(if key.is_empty() { what.to_string() } else { format!("[{table}] {key} {what}") });
        }
    }
    if let Some(message) = table_at(root, "merge").and_then(splatseg_merge::retired_merge_setting) {
        return Some(message);
    }
    let matching = table_at(root, "match")?;
    splatseg_match::config::RETIRED_KEYS
        .iter()
        .find(|(key, _)| matching.contains_key(*key))
        .map(|(key, what)| format!("[match] {key} {what}"))
}

impl PipelineConfig {
    /// Reads a TOML config file.
    pub fn from_file(path: &Path) -> crate::Result<Self> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
        Self::from_toml(&text, path)
    }

    /// Parses the text of a TOML config file and checks the settings that have rules
    /// (`[merge]`, `[train]`); `path` is only named in errors. A key of an earlier version is an
    /// error naming what became of it.
    pub fn from_toml(text: &str, path: &Path) -> crate::Result<Self> {
        let root: toml::Table =
            toml::from_str(text).with_context(|| format!("invalid pipeline config: {}", path.display()))?;
        if let Some(message) = retired_setting(&root) {
            return Err(crate::error::PipelineError::Invalid(format!(
                "{message}; remove it from the file (`splatseg config` prints the current keys): {}",
                path.display()
            )));
        }
        if let Some(message) = out_of_range(&root) {
            return Err(crate::error::PipelineError::Invalid(format!(
                "{message} (`splatseg config` describes every key): {}",
                path.display()
            )));
        }
        let config: Self =
            toml::from_str(text).with_context(|| format!("invalid pipeline config: {}", path.display()))?;
        config.merge.validate().with_context(|| format!("invalid [merge] settings: {}", path.display()))?;
        config.train.validate().with_context(|| format!("invalid [train] settings: {}", path.display()))?;
        Ok(config)
    }

    /// The settings as a `--config` file: each table in the pipeline's order, each key after a
    /// comment with its meaning, unit and the source of its default.
    pub fn to_file_text(&self) -> crate::Result<String> {
        let (lift, objects, final_maps) = self.lift.tables();
        let root = toml::Table::from_iter([
            ("merge".to_string(), to_value(&self.merge.table())?),
            ("match".to_string(), to_value(&self.matching)?),
            ("lift".to_string(), to_value(&lift)?),
            ("objects".to_string(), to_value(&objects)?),
            ("final_maps".to_string(), to_value(&final_maps)?),
            ("eval".to_string(), eval_table(&self.eval)?),
            ("train".to_string(), to_value(&self.train)?),
        ]);
        let mut out = String::from(
            "# splatseg pipeline settings, one table per stage. Every key is optional; a missing key\n\
             # keeps the default shown. Each default's source is named: the paper's value, 3DGS's,\n\
             # or ours (measured on the synthetic stress suite where marked).\n",
        );
        let mut current = "";
        for &(table, key, doc) in KEY_DOCS {
            let Some(value) = table_at(&root, table).and_then(|t| t.get(key)) else {
                continue; // an optional gate that is off has no value to print
            };
            if table != current {
                current = table;
                let _ = write!(out, "\n[{table}]\n");
            }
            let _ = write!(out, "# {doc}\n{key} = {}\n", short_value(value));
        }
        Ok(out)
    }
}

/// A table as a TOML value.
fn to_value(table: &impl Serialize) -> crate::Result<toml::Value> {
    toml::Value::try_from(table)
        .map_err(|e| crate::error::PipelineError::Invalid(format!("cannot serialise the settings: {e}")))
}

/// The `[eval]` table: the settings without `pred_id_scope` (not a file key).
fn eval_table(eval: &EvalConfig) -> crate::Result<toml::Value> {
    let mut value = to_value(eval)?;
    if let Some(table) = value.as_table_mut() {
        table.remove("pred_id_scope");
    }
    Ok(value)
}

/// A value as TOML text; settings are single precision, so `0.85`, not `0.8500000238418579`.
fn short_value(value: &toml::Value) -> String {
    match value {
        toml::Value::Float(f) => {
            let short = (*f as f32).to_string();
            if short.contains(['.', 'e', 'i', 'N']) {
                short
            } else {
                format!("{short}.0")
            }
        }
        toml::Value::Array(items) => {
            format!("[{}]", items.iter().map(short_value).collect::<Vec<_>>().join(", "))
        }
        other => other.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> crate::Result<PipelineConfig> {
        PipelineConfig::from_toml(text, Path::new("test.toml"))
    }

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
        assert_eq!(
            seed,
            PipelineConfig::default().to_file_text().expect("prints"),
            "the seed is `splatseg config`"
        );
        PipelineConfig::from_toml(&seed, Path::new("seed_defaults.toml")).expect("the defaults parse");
    }

    #[test]
    fn every_numeric_key_has_a_range_holding_its_default() {
        let text = PipelineConfig::default().to_file_text().expect("prints");
        let root: toml::Table = toml::from_str(&text).expect("parses");
        for &(table, key, _) in KEY_DOCS {
            let value = table_at(&root, table).and_then(|t| t.get(key)).expect("printed");
            let numeric = match value {
                toml::Value::Array(items) => items.iter().all(|v| number(v).is_some()),
                other => number(other).is_some(),
            };
            let ranged = RANGES.iter().any(|&(t, k, _, _)| (t, k) == (table, key));
            assert_eq!(numeric, ranged, "[{table}] {key}: a numeric key has a range, and only those");
        }
        assert_eq!(out_of_range(&root), None, "the defaults are in range");
    }

    #[test]
    fn a_merge_gate_is_turned_off_by_false_and_kept_by_a_missing_key() {
        let off = parse("[merge]\nmax_depth_boundary = false\n").expect("parses");
        assert_eq!(off.merge.max_depth_boundary, None);
        assert_eq!(off.merge.max_concave_crease_deg, PipelineConfig::default().merge.max_concave_crease_deg);
        let text = off.to_file_text().expect("prints");
        assert!(text.contains("max_depth_boundary = false"), "{text}");
        assert_eq!(parse(&text).expect("reads back").merge, off.merge);
        assert_eq!(parse("[merge]\n").expect("parses").merge, PipelineConfig::default().merge);
    }

    #[test]
    fn out_of_range_values_are_refused_with_the_key_and_the_file() {
        for (text, key) in [
            ("[merge]\ntau_merge = -0.5\n", "[merge] tau_merge = -0.5"),
            ("[match]\ntau_match = nan\n", "[match] tau_match = NaN"),
            ("[lift]\ntau_var = inf\n", "[lift] tau_var = inf"),
            ("[train]\nbackground = [0.0, 2.0, 0.0]\n", "[train] background = 2"),
            ("[train.joint]\nknn = 0\n", "[train.joint] knn = 0"),
            ("[final_maps]\nrefine_window_px = 100000\n", "[final_maps] refine_window_px = 100000"),
        ] {
            let err = parse(text).expect_err(text).to_string();
            assert!(
                err.contains(key) && err.contains("out of range") && err.contains("test.toml"),
                "{text}: {err}"
            );
        }
        parse("[merge]\ntau_merge = 0.7\n[match]\ntau_match = -0.2\n").expect("in range");
    }

    #[test]
    fn the_printed_file_parses_back_to_the_defaults_with_at_most_50_documented_keys() {
        let text = PipelineConfig::default().to_file_text().expect("prints");
        let parsed = parse(&text).expect("parses back");
        let json = |c: &PipelineConfig| serde_json::to_string(c).expect("serialises");
        assert_eq!(json(&parsed), json(&PipelineConfig::default()));
        let keys = text.lines().filter(|l| !l.starts_with('#') && l.contains(" = ")).count();
        assert!(keys <= 50, "{keys} keys:\n{text}");
        assert_eq!(keys, KEY_DOCS.len(), "every documented key is printed (no default gate is off)");
        // Every key of every table is documented (none printed without its meaning).
        let d = PipelineConfig::default();
        let (lift, objects, final_maps) = d.lift.tables();
        let tables: [(&str, toml::Value); 9] = [
            ("merge", toml::Value::try_from(d.merge.table()).expect("toml")),
            ("match", toml::Value::try_from(&d.matching).expect("toml")),
            ("lift", toml::Value::try_from(&lift).expect("toml")),
            ("objects", toml::Value::try_from(&objects).expect("toml")),
            ("final_maps", toml::Value::try_from(&final_maps).expect("toml")),
            ("eval", eval_table(&d.eval).expect("toml")),
            ("train", toml::Value::try_from(&d.train).expect("toml")),
            ("train.densify", toml::Value::try_from(&d.train.densify).expect("toml")),
            ("train.joint", toml::Value::try_from(&d.train.joint).expect("toml")),
        ];
        for (name, value) in tables {
            for (key, v) in value.as_table().expect("table") {
                if !v.is_table() {
                    assert!(
                        KEY_DOCS.iter().any(|&(t, k, _)| t == name && k == key),
                        "[{name}] {key} undocumented"
                    );
                }
            }
        }
        // The header states each default's source instead of calling them all the paper's.
        assert!(!text.contains("the paper's values"));
        assert!(
            text.contains("# Gaussians whose identity-feature variance") && text.contains("tau_var = 0.2\n")
        );
    }

    #[test]
    fn defaults_are_unchanged_by_the_new_layout() {
        let c = parse("").expect("empty file");
        assert_eq!((c.merge.tau_merge, c.merge.tau_depth, c.merge.w_sem), (0.85, 0.15, 0.5));
        assert_eq!((c.matching.tau_match, c.lift.tau_var, c.lift.min_object_px), (0.7, 0.2, 64));
        assert_eq!(c.lift, LiftConfig::default());
        assert_eq!(c.train, splatseg_train::TrainConfig::default());
    }

    #[test]
    fn the_new_tables_set_the_settings() {
        let c = parse(
            "[match]\ntau_match = 0.6\n[objects]\ntau_seam = 0.7\n[final_maps]\nkind = \"rendered\"\n\
             [lift]\ntau_var = 0.1\n[merge]\nprofile = \"literal\"\n",
        )
        .expect("parses");
        assert_eq!((c.matching.tau_match, c.lift.tau_seam, c.lift.tau_var), (0.6, 0.7, 0.1));
        assert_eq!(c.lift.final_maps, splatseg_lift::FinalMaps::Rendered);
        assert_eq!(c.merge.profile, splatseg_merge::Profile::Literal);
    }

    #[test]
    fn old_keys_get_an_error_naming_the_new_key_or_the_constant() {
        let err = |text: &str| parse(text).expect_err(text).report();
        let e = err("[lift]\nfinal_maps = \"snapped\"\n");
        assert!(e.contains("[lift] final_maps") && e.contains("[final_maps] kind"), "{e}");
        let e = err("[lift]\ntau_seam = 0.8\n");
        assert!(e.contains("[objects] tau_seam"), "{e}");
        let e = err("[objects]\ntau_part = 0.85\n");
        assert!(e.contains("[objects] tau_part") && e.contains("geometry and the views"), "{e}");
        let e = err("[lift]\nsnap_bleed_px = 4.0\n");
        assert!(e.contains("constant") && e.contains("SNAP_BLEED_PX"), "{e}");
        let e = err("[matching]\ntau_match = 0.7\n");
        assert!(e.contains("[match]"), "{e}");
        let e = err("[match]\nmin_support = 20\n");
        assert!(e.contains("MIN_SUPPORT"), "{e}");
        let e = err("[merge]\nprofile = \"released-code\"\n");
        assert!(e.contains("released-code") && e.contains("removed"), "{e}");
        let e = err("[merge]\ndilation_steps = 2\n");
        assert!(e.contains("DILATION_STEPS"), "{e}");
        let e = err("[regions]\nmin_region_px = 32\n");
        assert!(e.contains("[regions]"), "{e}");
        let e = err("[train.lr]\nsh_dc = 0.1\n");
        assert!(e.contains("[train] lr"), "{e}");
        let e = err("[train.densify]\npercent_dense = 0.01\n");
        assert!(e.contains("percent_dense") && e.contains("3DGS"), "{e}");
        // Unknown keys that never existed are still refused, by name.
        let e = err("[objects]\ntau_sam = 0.8\n");
        assert!(e.contains("tau_sam"), "{e}");
    }
}
