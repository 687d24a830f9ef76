//! `splatseg eval`: score predicted label maps (and optionally per-Gaussian ids) against ground
//! truth with the paper's metrics and splatseg's cross-view ones.

use anyhow::Context;
use clap::Args as ClapArgs;
use splatseg_eval::{evaluate_named_sets, EvalConfig, IdScope, NamedSets};
use splatseg_scene::atomic::write_bytes_atomic;
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
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Folder of ground-truth label maps (`<stem>.png`).
    #[arg(long)]
    pub gt: PathBuf,
    /// Folder of predicted label maps, as `DIR` or `NAME=DIR`. Repeat to compare several sets in
    /// one table (e.g. `--pred raw=A --pred merged=B --pred lifted=C`).
    #[arg(long, required = true, value_name = "[NAME=]DIR")]
    pub pred: Vec<String>,
    /// Name of a --pred set whose ids are numbered per view (raw SAM masks, merged-only
    /// regions): each (view, id) is then its own mask. Repeat for several sets.
    #[arg(long, value_name = "NAME")]
    pub view_local: Vec<String>,
    /// Ground-truth object id per Gaussian (`.npy`, shape [N], integers, ≤ 0 = no object), for
    /// the 3D label accuracy.
    #[arg(long, requires = "pred_ply", value_name = "NPY")]
    pub gt_gaussian_ids: Option<PathBuf>,
    /// Labelled PLY (with `object_id`, same Gaussian order) scored against --gt-gaussian-ids, as
    /// `PLY` (attached to the last --pred set) or `NAME=PLY` (attached to that set).
    #[arg(long, requires = "gt_gaussian_ids", value_name = "[NAME=]PLY")]
    pub pred_ply: Option<String>,
    /// Also write the report to this file: all metrics as JSON (`.json`) or the Markdown tables
    /// (`.md`). Repeat for both.
    #[arg(long, value_name = "FILE")]
    pub write: Vec<PathBuf>,
    /// TOML settings: the `[eval]` table of `splatseg config`'s output (`band_radius_px`, the
    /// boundary band's radius, default 5 px; `unlabelled_gt = "ignore"` to leave ground-truth 0
    /// out of every union instead of counting it as background).
    #[arg(long)]
    pub config: Option<PathBuf>,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let cfg = EvalConfig {
        pred_id_scope: IdScope::Global,
        ..match &args.config {
            Some(path) => splatseg_pipeline::PipelineConfig::from_file(path)?.eval,
            None => EvalConfig::default(),
        }
    };
    let sets = NamedSets {
        gt: args.gt.clone(),
        pred: args.pred,
        view_local: args.view_local,
        gaussian_ids: args.gt_gaussian_ids.zip(args.pred_ply),
    };
    let report = evaluate_named_sets(&sets, &cfg)
        .with_context(|| format!("cannot score predictions against {}", args.gt.display()))?;
    let markdown = report.to_markdown();
    for set in &report.sets {
        for w in &set.metrics.warnings {
            tracing::warn!("{}: {w}", set.name);
        }
    }
    for path in &args.write {
        match path.extension().and_then(|e| e.to_str()) {
            Some("json") => {
                let json = serde_json::to_string_pretty(&report).context("cannot serialise the metrics")?;
                write_bytes_atomic(path, json.as_bytes())?;
            }
            Some("md") => write_bytes_atomic(path, markdown.as_bytes())?,
            _ => anyhow::bail!("--write takes a `.json` or `.md` file: {}", path.display()),
        }
    }
    print!(
        "{}",
        splatseg_eval::summary_table(
            &report.sets.iter().map(|s| (s.name.as_str(), &s.metrics)).collect::<Vec<_>>(),
        )
    );
    Ok(())
}
