//! `splatseg synth`'s arguments (clap's `Args` with the `cli` feature), their parsers, and the
//! scene settings they make.

use crate::{Family, SynthConfig, SynthError};
use std::path::PathBuf;

/// Generate a synthetic multi-object scene with ground truth, in the formats users bring.
///
/// Writes into OUT: `images/`, `sparse/0/*.txt` (COLMAP text model), `gaussians.ply`,
/// simulated SAM masks `sam/<stem>.json`, cue maps `features/<stem>.npy` (DINOv2-like patch
/// features) and `depth/<stem>.npy` (relative inverse depth), and the ground truth in `gt/`
/// (`instance/<stem>.png` 16-bit ids equal across views, `depth/<stem>.npy` metric z,
/// `gaussian_ids.npy`, `objects.json` with the objects and where the hard cases appear).
/// The same seed always gives the same files.
///
/// `--family` draws the scene from a family of the stress suite (random rooms with
/// multi-tone walls and floors, thin posts, border-cut foreground objects, stacked and
/// touching objects, heavy SAM noise, 1280×960, 12–100 views, Gaussians as training leaves
/// them); `gt/objects.json` then tags every instance with its failure classes. Families:
/// default, rooms, multi_tone, thin, border, clutter, sam_noise, hires, many_views, rough, and
/// the blind ones (`splatseg bench quality --help`). Example:
/// `splatseg synth --family rooms --seed 7 --out room7`.
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct SynthArgs {
    /// Output folder (created if needed).
    #[cfg_attr(feature = "cli", arg(long))]
    pub out: PathBuf,
    /// Seed of the scene (layout jitter, extra objects, simulated masks and cue noise).
    #[cfg_attr(feature = "cli", arg(long))]
    pub seed: Option<u64>,
    /// Family of the stress suite to draw the scene from (its knobs drawn from the seed);
    /// --views and --size override the family's.
    #[cfg_attr(feature = "cli", arg(long, value_parser = parse_family, conflicts_with = "config"))]
    pub family: Option<Family>,
    /// Number of views on the camera arc.
    #[cfg_attr(feature = "cli", arg(long))]
    pub views: Option<usize>,
    /// Image size as WIDTHxHEIGHT.
    #[cfg_attr(feature = "cli", arg(long, value_parser = parse_size))]
    pub size: Option<(u32, u32)>,
    /// A TOML file with any `SynthConfig` fields (seed, views, width, height, fov_x_deg,
    /// arc_deg, gaussian_spacing_px, feature_dim, feature_patch_px, [sam]); flags override it.
    #[cfg_attr(feature = "cli", arg(long))]
    pub config: Option<PathBuf>,
}

impl SynthArgs {
    /// The scene's settings: the `--config` file, else `--family`'s draw for the seed; the flags
    /// given override either.
    pub fn config(&self) -> Result<SynthConfig, SynthError> {
        let mut config = match &self.config {
            Some(path) => {
                let text = std::fs::read_to_string(path)
                    .map_err(|source| SynthError::ReadConfig { path: path.clone(), source })?;
                toml::from_str(&text)
                    .map_err(|source| SynthError::ParseConfig { path: path.clone(), source })?
            }
            None => self.family.unwrap_or_default().config(self.seed.unwrap_or(0)),
        };
        if let Some(seed) = self.seed {
            config.seed = seed;
        }
        if let Some(views) = self.views {
            config.views = views;
        }
        if let Some((w, h)) = self.size {
            config.width = w;
            config.height = h;
        }
        Ok(config)
    }
}

/// Parses a family name (`rooms`, `multi_tone`, …).
pub fn parse_family(name: &str) -> Result<Family, String> {
    Family::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = Family::ALL.iter().map(|f| f.name()).collect();
        format!("unknown family `{name}`; one of: {}", names.join(", "))
    })
}

/// Parses an image size written `WIDTHxHEIGHT` (e.g. `320x240`).
pub fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let (w, h) = text.split_once(['x', 'X']).ok_or_else(|| format!("expected WIDTHxHEIGHT, got `{text}`"))?;
    let parse =
        |s: &str| s.trim().parse::<u32>().map_err(|_| format!("`{s}` is not a whole number of pixels"));
    Ok((parse(w)?, parse(h)?))
}

impl SynthArgs {
    /// Refuses a --config that is --out or lies where synth writes (OUT's `images/`, `sparse/`,
    /// `sam/`, `features/`, `depth/`, `gt/`, `gaussians.ply`), before anything is read.
    pub fn refuse_overwrite(&self) -> splatseg_scene::SceneResult<()> {
        use splatseg_scene::paths::{refuse_overwrite, Role};
        let Some(config) = &self.config else { return Ok(()) };
        let mut outputs = vec![
            Role::folder("--out", &self.out),
            Role::file("--out's gaussians.ply", self.out.join("gaussians.ply")),
        ];
        for dir in ["images", "sparse", "sam", "features", "depth", "gt"] {
            outputs.push(Role::tree(format!("--out's {dir}/"), self.out.join(dir)));
        }
        refuse_overwrite(&[Role::file("--config", config)], &outputs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args() -> SynthArgs {
        SynthArgs {
            out: PathBuf::from("out"),
            seed: None,
            family: None,
            views: None,
            size: None,
            config: None,
        }
    }

    #[test]
    fn sizes_are_width_x_height_in_whole_pixels() {
        assert_eq!(parse_size("320x240"), Ok((320, 240)));
        assert_eq!(parse_size("64X48"), Ok((64, 48)));
        assert!(parse_size("320").unwrap_err().contains("WIDTHxHEIGHT"));
        assert!(parse_size("axb").unwrap_err().contains("not a whole number"));
    }

    #[test]
    fn an_unknown_family_lists_the_known_ones() {
        assert_eq!(parse_family("rooms"), Ok(Family::from_name("rooms").expect("a family")));
        let err = parse_family("nope").unwrap_err();
        assert!(err.contains("nope") && err.contains("multi_tone"), "{err}");
    }

    #[test]
    fn flags_override_the_family_draw_and_a_missing_file_is_named() {
        let family = Family::from_name("rooms").expect("a family");
        let drawn = family.config(7);
        let config =
            SynthArgs { seed: Some(7), family: Some(family), views: Some(3), size: Some((32, 24)), ..args() }
                .config()
                .expect("a config");
        assert_eq!((config.seed, config.views, config.width, config.height), (7, 3, 32, 24));
        assert_eq!(config.fov_x_deg, drawn.fov_x_deg);
        let missing = SynthArgs { config: Some(PathBuf::from("/nonexistent/synth.toml")), ..args() };
        let err = missing.config().unwrap_err().to_string();
        assert_eq!(err, "cannot read synth config /nonexistent/synth.toml");
    }
}
