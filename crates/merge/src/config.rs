//! [`MergeConfig`]: the numbers of Multi-Cue-Guided Mask Merging (paper §4.2), read from the
//! `[merge]` table of the `--config` TOML. The score's weights and thresholds default to the
//! paper's (§5 "Hyperparameters"); the two gates not in the paper (`max_depth_boundary`,
//! `max_concave_crease_deg`) to values measured on the stress suite; the
//! adjacency numbers the paper leaves out are the released code's, as constants ([`TAU_GAP_PX`],
//! [`TAU_CONTACT`], [`DILATION_STEPS`]).
//!
//! A table may name a `profile` (`paper`, `literal`); the profile's preset is the starting point
//! and any other key overrides it. This holds for every way a `MergeConfig` is deserialised
//! (e.g. as the `[merge]` table of a pipeline config), not only for [`MergeConfig::from_toml_str`]:
//!
//! ```toml
//! profile = "paper"
//! tau_merge = 0.9
//! ```

use crate::error::MergeError;
use serde::{Deserialize, Serialize};

/// Which reading of the paper's score to use (see the `score` module for the formulas).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Profile {
    /// The self-consistent reading (default): S normalised by `w_sem + w_depth`, boundary terms
    /// (their median) on the band where the two regions meet, `Δd` at the contact, and the
    /// three gates not in the paper.
    #[default]
    Paper,
    /// The formula exactly as printed: un-normalised, maxima over `∂m_i ∪ ∂m_j`, `Δd` between the
    /// region means, none of the added gates. It can never exceed `w_sem + w_depth = 0.7 <
    /// τ_merge`, so it merges nothing.
    Literal,
}

/// The statistic of LoG and `∇D` over the shared boundary band (paper profile).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BoundaryStatistic {
    /// The maximum (the paper's `max`).
    Max,
    /// The mean (the released code's).
    Mean,
    /// A quantile in [0, 1] (robust maximum, e.g. 0.9).
    Quantile(f32),
}

/// Where the normalised depth gap `Δd` of the depth gate and the depth affinity is measured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DepthGapAt {
    /// Between the two sides of the band where the regions meet (the median normalised depth
    /// of each side there). A floor or wall split by its texture has the same depth on both
    /// sides of the split, however far apart the two halves' means are; an object in front of
    /// another has a step there. The default of the paper profile (see [`crate::score`]).
    #[default]
    Contact,
    /// Between the regions' mean normalised depths `d̄_i`, `d̄_j` (the formula as printed).
    RegionMeans,
}

/// Adjacency: the regions' bounding boxes must be within this many pixels (the released code's
/// 4; the paper gives no value).
pub const TAU_GAP_PX: u32 = 4;

/// Adjacency: the contact ratio `|dil(A) ∩ dil(B)| / min(|A|, |B|)` must reach this (the
/// released code's 0.01; the paper gives no value).
pub const TAU_CONTACT: f32 = 0.01;

/// Adjacency: 3×3 dilations of each region (the released code's 2, a 5×5 window).
pub const DILATION_STEPS: u32 = 2;

/// At most this many merges per view (the paper's 1000; no view of ours comes near it).
pub const MAX_MERGES: usize = 1000;

/// Default of [`MergeConfig::max_concave_crease_deg`].
pub const CONCAVE_CREASE_DEG: f32 = 45.0;

/// All parameters of Multi-Cue-Guided Mask Merging. The `[merge]` keys are the fields up to
/// `max_concave_crease_deg`; `boundary_statistic`, `depth_gap_at` and `separate_wholes` follow
/// the profile (code such as `splatseg ablate` may set them).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(from = "MergeConfigTable")]
pub struct MergeConfig {
    /// Score variant: `paper` or `literal` (default `paper`).
    pub profile: Profile,
    /// Merge when the score exceeds this; unitless, score ≤ 1 (paper: 0.85).
    pub tau_merge: f32,
    /// Hard gate on the normalised depth gap `Δd < tau_depth`; depth normalised to [0, 1] per
    /// image (paper: 0.15).
    pub tau_depth: f32,
    /// Weight of the descriptor cosine (paper: 0.5).
    pub w_sem: f32,
    /// Weight of the depth affinity (paper: 0.2).
    pub w_depth: f32,
    /// Weight of the depth-gradient penalty on the boundary (paper: 0.1).
    pub w_dbound: f32,
    /// Weight of the LoG penalty on the boundary (paper: 0.2).
    pub w_edge: f32,
    /// `σ_d²` of the depth affinity `exp(−Δd²/(2σ_d²))`, in normalised depth squared (paper: 0.05).
    pub sigma_d_sq: f32,
    /// Reject when the boundary statistic of `∇D` (normalised per image, 0–1) on the shared band
    /// exceeds this: a box on the floor it stands on. Omitted = off. Ours: 0.12 (tuning seeds
    /// 0–2: mean mIoU 0.844 at 0.08, 0.838 at 0.12, 0.783 off; 0.08 costs the default synthetic
    /// scene 0.03, 0.12 does not).
    pub max_depth_boundary: Option<f32>,
    /// With metric depth and intrinsics: reject a pair meeting at a concave crease sharper than
    /// this, in degrees between the two sides' normals (a box on the floor, two walls at a
    /// corner). Omitted or 180 = off. Ours: 45 (tuning seeds 0–2 mean mIoU 0.877 off, 0.881 at
    /// 45°, 0.885 at 30°; the CI's reduced suite 0.886 / 0.885 / 0.879: 45° holds on both).
    pub max_concave_crease_deg: Option<f32>,
    /// Statistic of the boundary terms (paper profile; literal always uses the max on the
    /// outlines). Follows the profile: the median.
    pub boundary_statistic: BoundaryStatistic,
    /// Where `Δd` is measured. Follows the profile: `contact` (paper), `region-means` (literal).
    pub depth_gap_at: DepthGapAt,
    /// Refuse pairs other views' SAM masks hold in different wholes, when the caller gives them
    /// ([`crate::merge_view_with_wholes`], [`crate::wholes`]). Follows the profile: on (paper),
    /// off (literal); code may set it, files cannot.
    pub separate_wholes: bool,
}

/// A [`MergeConfig`] as written in a file (the `[merge]` table): every key optional; missing
/// keys come from the named profile's preset.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MergeConfigTable {
    #[serde(default)]
    profile: Option<Profile>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    tau_merge: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    tau_depth: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    w_sem: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    w_depth: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    w_dbound: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    w_edge: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    sigma_d_sq: Option<f32>,
    #[serde(default, with = "gate", skip_serializing_if = "Option::is_none")]
    max_depth_boundary: Option<Option<f32>>,
    #[serde(default, with = "gate", skip_serializing_if = "Option::is_none")]
    max_concave_crease_deg: Option<Option<f32>>,
}

/// A gate's key: missing (`None`: the profile's preset), a threshold (`Some(Some(t))`) or
/// `false` (`Some(None)`: the gate is off; TOML has no null).
mod gate {
    use serde::de::Error;
    use serde::{Deserialize, Deserializer, Serializer};

    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Written {
        Threshold(f32),
        Switch(bool),
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Option<f32>>, D::Error> {
        // `null` (JSON) is off too.
        match Option::<Written>::deserialize(d) {
            Ok(Some(Written::Threshold(t))) => Ok(Some(Some(t))),
            Ok(Some(Written::Switch(false)) | None) => Ok(Some(None)),
            Ok(Some(Written::Switch(true))) | Err(_) => {
                Err(D::Error::custom("expected a threshold (a number) or `false` to turn the gate off"))
            }
        }
    }

    pub fn serialize<S: Serializer>(value: &Option<Option<f32>>, s: S) -> Result<S::Ok, S::Error> {
        match value {
            Some(Some(v)) => s.serialize_f32(*v),
            _ => s.serialize_bool(false),
        }
    }
}

impl From<MergeConfigTable> for MergeConfig {
    fn from(t: MergeConfigTable) -> Self {
        let p = MergeConfig::for_profile(t.profile.unwrap_or_default());
        MergeConfig {
            tau_merge: t.tau_merge.unwrap_or(p.tau_merge),
            tau_depth: t.tau_depth.unwrap_or(p.tau_depth),
            w_sem: t.w_sem.unwrap_or(p.w_sem),
            w_depth: t.w_depth.unwrap_or(p.w_depth),
            w_dbound: t.w_dbound.unwrap_or(p.w_dbound),
            w_edge: t.w_edge.unwrap_or(p.w_edge),
            sigma_d_sq: t.sigma_d_sq.unwrap_or(p.sigma_d_sq),
            max_depth_boundary: t.max_depth_boundary.unwrap_or(p.max_depth_boundary),
            max_concave_crease_deg: t.max_concave_crease_deg.unwrap_or(p.max_concave_crease_deg),
            ..p
        }
    }
}

impl Default for MergeConfig {
    fn default() -> Self {
        MergeConfig {
            profile: Profile::Paper,
            tau_merge: 0.85,
            tau_depth: 0.15,
            w_sem: 0.5,
            w_depth: 0.2,
            w_dbound: 0.1,
            w_edge: 0.2,
            sigma_d_sq: 0.05,
            max_depth_boundary: Some(0.12),
            max_concave_crease_deg: Some(CONCAVE_CREASE_DEG),
            boundary_statistic: BoundaryStatistic::Quantile(0.5),
            depth_gap_at: DepthGapAt::Contact,
            separate_wholes: true,
        }
    }
}

/// `[merge]` keys of earlier versions and what became of them (the file reader names them in
/// its error).
pub const RETIRED_KEYS: &[(&str, &str)] = &[
    ("tau_gap_px", "is now the constant splatseg_merge::TAU_GAP_PX (4 px, the released code's)"),
    ("tau_contact", "is now the constant splatseg_merge::TAU_CONTACT (0.01, the released code's)"),
    ("dilation_steps", "is now the constant splatseg_merge::DILATION_STEPS (2, the released code's)"),
    ("max_merges", "is now the constant splatseg_merge::MAX_MERGES (1000, the paper's)"),
    ("boundary_statistic", "follows `profile` now (paper: the median; literal: the max)"),
    ("depth_gap_at", "follows `profile` now (paper: contact; literal: region-means)"),
    ("released", "was removed with the `released-code` profile"),
    (
        "relative_depth_gate",
        "was removed: the metric depth gate changed no result on the tuning or the blind families \
         (issue 27's ablation, BENCHMARKS.md); the depth-step and concave-crease gates remain",
    ),
];

/// The error for a `profile = "released-code"` in a file.
pub const RELEASED_CODE_REMOVED: &str = "profile \"released-code\" was removed: it was not the authors' released \
     merger (it lacked their score's 0.75 / 0.25 offsets, gated depth at 0.15 where theirs uses 0.20 and merged a \
     painted partition where they merge overlapping mask unions); use profile = \"paper\" (the default) or \
     \"literal\"";

/// The message for a retired `[merge]` key or profile in a TOML table, if it holds one.
pub fn retired_merge_setting(table: &toml::Table) -> Option<String> {
    if table.get("profile").and_then(|p| p.as_str()) == Some("released-code") {
        return Some(format!("[merge] {RELEASED_CODE_REMOVED}"));
    }
    RETIRED_KEYS
        .iter()
        .find(|(key, _)| table.contains_key(*key))
        .map(|(key, what)| format!("[merge] {key} {what}"))
}

impl MergeConfig {
    /// The preset of a profile.
    pub fn for_profile(profile: Profile) -> Self {
        let paper = MergeConfig::default();
        match profile {
            Profile::Paper => paper,
            Profile::Literal => MergeConfig {
                profile,
                depth_gap_at: DepthGapAt::RegionMeans,
                max_depth_boundary: None,
                max_concave_crease_deg: None,
                separate_wholes: false,
                ..paper
            },
        }
    }

    /// The `[merge]` table of a file holding these settings (every key written; a gate that is
    /// off as `false`).
    pub fn table(&self) -> MergeConfigTable {
        MergeConfigTable {
            profile: Some(self.profile),
            tau_merge: Some(self.tau_merge),
            tau_depth: Some(self.tau_depth),
            w_sem: Some(self.w_sem),
            w_depth: Some(self.w_depth),
            w_dbound: Some(self.w_dbound),
            w_edge: Some(self.w_edge),
            sigma_d_sq: Some(self.sigma_d_sq),
            max_depth_boundary: Some(self.max_depth_boundary),
            max_concave_crease_deg: Some(self.max_concave_crease_deg),
        }
    }

    /// Reads a TOML config: the named `profile`'s preset (default `paper`), overridden by the
    /// file's other keys.
    pub fn from_toml_str(text: &str) -> Result<Self, MergeError> {
        let table: toml::Table = toml::from_str(text).map_err(|e| MergeError::Config(e.to_string()))?;
        if let Some(message) = retired_merge_setting(&table) {
            return Err(MergeError::Config(format!("{message}; remove it from the file")));
        }
        let config: MergeConfig = toml::from_str(text).map_err(|e| MergeError::Config(e.to_string()))?;
        config.validate()?;
        Ok(config)
    }

    /// Checks the values are usable (finite, weights non-negative, quantile in [0, 1]).
    pub fn validate(&self) -> Result<(), MergeError> {
        let finite = [
            ("tau_merge", self.tau_merge),
            ("w_sem", self.w_sem),
            ("w_depth", self.w_depth),
            ("w_dbound", self.w_dbound),
            ("w_edge", self.w_edge),
            ("sigma_d_sq", self.sigma_d_sq),
        ];
        for (name, v) in finite {
            if !v.is_finite() {
                return Err(MergeError::Config(format!("{name} = {v} is not finite")));
            }
        }
        for (name, v) in [
            ("w_sem", self.w_sem),
            ("w_depth", self.w_depth),
            ("w_dbound", self.w_dbound),
            ("w_edge", self.w_edge),
        ] {
            if v < 0.0 {
                return Err(MergeError::Config(format!("{name} = {v} must not be negative")));
            }
        }
        if self.sigma_d_sq <= 0.0 {
            return Err(MergeError::Config(format!("sigma_d_sq = {} must be positive", self.sigma_d_sq)));
        }
        if self.tau_depth.is_nan() {
            return Err(MergeError::Config("tau_depth is NaN".to_string()));
        }
        if let Some(t) = self.max_concave_crease_deg {
            if !(0.0..=180.0).contains(&t) {
                return Err(MergeError::Config(format!(
                    "max_concave_crease_deg = {t} must be an angle in degrees between 0 and 180"
                )));
            }
        }
        if let BoundaryStatistic::Quantile(q) = self.boundary_statistic {
            if !(0.0..=1.0).contains(&q) {
                return Err(MergeError::Config(format!("boundary quantile {q} is outside [0, 1]")));
            }
        }
        if self.profile == Profile::Paper && self.w_sem + self.w_depth <= 0.0 {
            return Err(MergeError::Config(
                "w_sem + w_depth must be positive (the paper profile divides by it)".to_string(),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_papers_values() {
        let c = MergeConfig::default();
        assert_eq!(
            (c.tau_merge, c.tau_depth, c.w_sem, c.w_depth, c.w_dbound, c.w_edge),
            (0.85, 0.15, 0.5, 0.2, 0.1, 0.2)
        );
        assert_eq!(
            (c.sigma_d_sq, TAU_GAP_PX, TAU_CONTACT, DILATION_STEPS, MAX_MERGES),
            (0.05, 4, 0.01, 2, 1000)
        );
    }

    #[test]
    fn toml_starts_from_the_profile_preset_and_overrides() {
        let c = MergeConfig::from_toml_str("profile = \"literal\"\nw_edge = 0.3\n").unwrap();
        assert_eq!(c.profile, Profile::Literal);
        assert_eq!(c.w_edge, 0.3);
        assert_eq!((c.depth_gap_at, c.max_depth_boundary), (DepthGapAt::RegionMeans, None));
        // Through any deserialiser, e.g. as a table of a bigger config.
        let json: MergeConfig =
            serde_json::from_str(r#"{"profile": "literal", "max_depth_boundary": 0.2}"#).unwrap();
        assert_eq!((json.profile, json.max_depth_boundary), (Profile::Literal, Some(0.2)));
        let json: MergeConfig = serde_json::from_str(r#"{"max_depth_boundary": null}"#).unwrap();
        assert_eq!(json.max_depth_boundary, None);
        // A gate of the paper profile turned off in a file: `false` (leaving the key out keeps it).
        let off = MergeConfig::from_toml_str("max_depth_boundary = false\n").unwrap();
        assert_eq!((off.max_depth_boundary, off.max_concave_crease_deg), (None, Some(CONCAVE_CREASE_DEG)));
        let e = MergeConfig::from_toml_str("max_concave_crease_deg = true\n").unwrap_err().to_string();
        assert!(e.contains("max_concave_crease_deg") && e.contains("false"), "{e}");
        // Round trip through the file's table: defaults, a literal profile with one gate set, the
        // paper profile with one gate off.
        for config in [
            MergeConfig::default(),
            MergeConfig { max_depth_boundary: Some(0.2), ..c },
            MergeConfig { max_concave_crease_deg: None, ..MergeConfig::default() },
        ] {
            let text = toml::to_string(&config.table()).unwrap();
            assert_eq!(MergeConfig::from_toml_str(&text).unwrap(), config, "{text}");
        }
        assert_eq!(MergeConfig::from_toml_str("").unwrap(), MergeConfig::default());
    }

    #[test]
    fn bad_configs_are_rejected_with_the_key_named() {
        let e = MergeConfig::from_toml_str("tau_merj = 1.0").unwrap_err().to_string();
        assert!(e.contains("tau_merj"), "{e}");
        let e = MergeConfig::from_toml_str("w_sem = -1.0").unwrap_err().to_string();
        assert!(e.contains("w_sem"), "{e}");
        let e = MergeConfig::from_toml_str("profile = \"nope\"").unwrap_err().to_string();
        assert!(e.contains("profile"), "{e}");
    }

    #[test]
    fn retired_keys_and_the_released_code_profile_are_named_in_the_error() {
        let e = MergeConfig::from_toml_str("profile = \"released-code\"").unwrap_err().to_string();
        assert!(e.contains("released-code") && e.contains("removed") && e.contains("paper"), "{e}");
        let e = MergeConfig::from_toml_str("tau_gap_px = 4").unwrap_err().to_string();
        assert!(e.contains("tau_gap_px") && e.contains("TAU_GAP_PX"), "{e}");
        let e = MergeConfig::from_toml_str("boundary_statistic = \"mean\"").unwrap_err().to_string();
        assert!(e.contains("boundary_statistic") && e.contains("profile"), "{e}");
        let e = MergeConfig::from_toml_str("[released]\nmin_cos = 0.6").unwrap_err().to_string();
        assert!(e.contains("released"), "{e}");
    }
}
