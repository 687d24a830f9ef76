//! `splatseg eval`: score predicted label maps (and optionally per-Gaussian ids) against ground
//! truth with the paper's metrics and splatseg's cross-view ones.

use anyhow::Context;
use splatseg_eval::{evaluate_named_sets, EvalArgs, EvalConfig, IdScope};
use splatseg_scene::atomic::write_bytes_atomic;

/// Runs the command.
pub fn run(args: EvalArgs) -> anyhow::Result<()> {
    args.refuse_overwrite()?;
    let cfg = EvalConfig {
        pred_id_scope: IdScope::Global,
        ..match &args.config {
            Some(path) => splatseg_pipeline::PipelineConfig::from_file(path)?.eval,
            None => EvalConfig::default(),
        }
    };
    let report = evaluate_named_sets(&args.sets(), &cfg)
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
    let sets: Vec<_> = report.sets.iter().map(|s| (s.name.as_str(), &s.metrics)).collect();
    print!("{}", splatseg_eval::summary_table(&sets));
    Ok(())
}
