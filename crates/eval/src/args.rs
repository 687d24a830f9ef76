//! `splatseg eval`'s arguments (clap's `Args` with the `cli` feature).

use crate::NamedSets;
use std::path::PathBuf;

/// Score predicted label maps against ground truth.
///
/// Both folders hold `<stem>.png` label maps (8- or 16-bit, value = object id, 0 = unlabelled),
/// matched by stem; other files are ignored. Metrics: mIoU with Hungarian matching over the IoU
/// matrix accumulated across all views (mean over ground-truth instances, unmatched = 0),
/// boundary mIoU in the band (M ⊕ 5) \ (M ⊖ 5) of a 5 px disk, #masks (distinct predicted ids)
/// against the ground-truth instance count, per-view mIoU, cross-view consistency (share of each
/// instance's pixels carrying its most common non-zero predicted id) and, with
/// --gt-gaussian-ids and --pred-ply, 3D label accuracy. A ground-truth view without a
/// prediction is scored as all-unlabelled (with a warning); a prediction for a view the ground
/// truth lacks is an error.
///
/// Example: `splatseg eval --gt scene/gt/instance --pred raw=out/raw --view-local raw
/// --pred lifted=out/masks`.
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct EvalArgs {
    /// Folder of ground-truth label maps (`<stem>.png`).
    #[cfg_attr(feature = "cli", arg(long))]
    pub gt: PathBuf,
    /// Folder of predicted label maps, as `DIR` or `NAME=DIR`. Repeat to compare several sets in
    /// one table (e.g. `--pred raw=A --pred merged=B --pred lifted=C`).
    #[cfg_attr(feature = "cli", arg(long, required = true, value_name = "[NAME=]DIR"))]
    pub pred: Vec<String>,
    /// Name of a --pred set whose ids are numbered per view (raw SAM masks, merged-only
    /// regions): each (view, id) is then its own mask. Repeat for several sets.
    #[cfg_attr(feature = "cli", arg(long, value_name = "NAME"))]
    pub view_local: Vec<String>,
    /// Ground-truth object id per Gaussian (`.npy`, shape [N], integers, ≤ 0 = no object), for
    /// the 3D label accuracy.
    #[cfg_attr(feature = "cli", arg(long, requires = "pred_ply", value_name = "NPY"))]
    pub gt_gaussian_ids: Option<PathBuf>,
    /// Labelled PLY (with `object_id`, same Gaussian order) scored against --gt-gaussian-ids, as
    /// `PLY` (attached to the last --pred set) or `NAME=PLY` (attached to that set).
    #[cfg_attr(feature = "cli", arg(long, requires = "gt_gaussian_ids", value_name = "[NAME=]PLY"))]
    pub pred_ply: Option<String>,
    /// Also write the report to this file: all metrics as JSON (`.json`) or the Markdown tables
    /// (`.md`). Repeat for both.
    #[cfg_attr(feature = "cli", arg(long, value_name = "FILE"))]
    pub write: Vec<PathBuf>,
    /// TOML settings: the `[eval]` table of `splatseg config`'s output (`band_radius_px`, the
    /// boundary band's radius, default 5 px; `unlabelled_gt = "ignore"` to leave ground-truth 0
    /// out of every union instead of counting it as background).
    #[cfg_attr(feature = "cli", arg(long))]
    pub config: Option<PathBuf>,
}

impl EvalArgs {
    /// The prediction sets to score.
    pub fn sets(&self) -> NamedSets {
        NamedSets {
            gt: self.gt.clone(),
            pred: self.pred.clone(),
            view_local: self.view_local.clone(),
            gaussian_ids: self.gt_gaussian_ids.clone().zip(self.pred_ply.clone()),
        }
    }
}

impl EvalArgs {
    /// Refuses a --write file equal to an input (--config, --gt-gaussian-ids, the --pred-ply) or
    /// inside a folder of label maps (--gt, --pred), before anything is read.
    pub fn refuse_overwrite(&self) -> splatseg_scene::SceneResult<()> {
        use splatseg_scene::paths::{refuse_overwrite, Role};
        let mut inputs = vec![Role::tree("--gt", &self.gt)];
        for pred in &self.pred {
            inputs.push(Role::tree("--pred", crate::named::split_named(pred, |_| String::new()).1));
        }
        inputs.extend(self.gt_gaussian_ids.as_ref().map(|p| Role::file("--gt-gaussian-ids", p)));
        if let Some(ply) = &self.pred_ply {
            inputs.push(Role::file("--pred-ply", crate::named::split_named(ply, |_| String::new()).1));
        }
        inputs.extend(self.config.as_ref().map(|p| Role::file("--config", p)));
        let outputs: Vec<Role> = self.write.iter().map(|p| Role::file("--write", p)).collect();
        refuse_overwrite(&inputs, &outputs)
    }
}
