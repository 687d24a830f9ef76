//! Markdown tables of [`Metrics`]: one row per prediction set (raw → merged → matched →
//! lifted), and the per-instance detail of one set.

use crate::metrics::Metrics;
use std::fmt::Write;

fn ratio(x: f64) -> String {
    format!("{x:.3}")
}

fn opt_ratio(x: Option<f64>) -> String {
    x.map_or_else(|| "–".to_string(), ratio)
}

/// A summary table with one row per named prediction set, in the given order.
pub fn summary_table(rows: &[(&str, &Metrics)]) -> String {
    let mut out = String::from(
        "| prediction | mIoU | boundary mIoU | per-view mIoU | #masks | GT instances | consistency | 3D label acc. |\n\
         | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
    );
    for (name, m) in rows {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} | {} | {} |",
            name.replace('|', "\\|"),
            ratio(m.miou),
            ratio(m.boundary_miou),
            opt_ratio(m.per_view_miou),
            m.pred_masks,
            m.gt_instances,
            ratio(m.consistency),
            opt_ratio(m.label_accuracy_3d.as_ref().map(|a| a.accuracy)),
        );
    }
    out
}

impl Metrics {
    /// The summary row and the per-instance table, as Markdown.
    pub fn to_markdown(&self) -> String {
        let mut out = summary_table(&[("prediction", self)]);
        out.push_str(
            "\n| GT id | pixels | views | matched pred | IoU | boundary IoU | consistency | dominant pred |\n\
             | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
        );
        let id = |x: Option<u32>| x.map_or_else(|| "–".to_string(), |v| v.to_string());
        for i in &self.instances {
            let _ = writeln!(
                out,
                "| {} | {} | {} | {} | {} | {} | {} | {} |",
                i.gt_id,
                i.pixels,
                i.views,
                id(i.matched_pred),
                ratio(i.iou),
                ratio(i.boundary_iou),
                ratio(i.consistency),
                id(i.dominant_pred),
            );
        }
        if !self.warnings.is_empty() {
            out.push_str("\nWarnings:\n");
            for w in &self.warnings {
                let _ = writeln!(out, "- {w}");
            }
        }
        out
    }
}

/// One named prediction set's metrics (e.g. `raw`, `merged`, `matched`, `lifted`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NamedMetrics {
    /// Name of the prediction set.
    pub name: String,
    /// Its metrics.
    pub metrics: Metrics,
}

/// The result of scoring one or more prediction sets against the same ground truth: what
/// `splatseg eval --json` writes.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EvalReport {
    /// The sets, in the order given.
    pub sets: Vec<NamedMetrics>,
}

impl EvalReport {
    /// The summary table of all sets, then each set's per-instance table and warnings.
    pub fn to_markdown(&self) -> String {
        let rows: Vec<(&str, &Metrics)> = self.sets.iter().map(|s| (s.name.as_str(), &s.metrics)).collect();
        let mut out = summary_table(&rows);
        for s in &self.sets {
            let _ = write!(out, "\n### {}\n\n", s.name);
            // Skip the one-row summary: it is already in the table above.
            let detail = s.metrics.to_markdown();
            let per_instance = detail.split_once("\n\n").map_or(detail.as_str(), |(_, rest)| rest);
            out.push_str(per_instance);
        }
        out
    }
}
