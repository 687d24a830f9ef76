//! `OUT/cache/graph.json`: the lift's object graph as the run weighed it (issue 58) — every edge
//! between two touching objects of the vote, its evidence term by term, the rule that asked for
//! the join and what became of it; with ground-truth per-Gaussian ids (`gt/gaussian_ids.npy`),
//! also what each edge *should* have been: the ground-truth object holding most of each side's
//! Gaussians and that share (its purity). Read by people asking why two objects joined (or did
//! not), and by `tools/edge_study.py`, which measures the terms against ground truth.

use serde::Serialize;
use splatseg_lift::{EdgeRecord, LiftOutput};
use splatseg_scene::ply::PlyRows;
use std::collections::HashMap;
use std::path::Path;

/// The file's name in `OUT/cache`.
pub const GRAPH_FILE: &str = "graph.json";

/// What ground truth says of one node: the object holding most of its Gaussians, and that share.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct NodeTruth {
    /// The ground-truth id with most of the node's Gaussians (-1: most have none; ties: the
    /// larger id, so an object before none).
    pub object: i64,
    /// Its share of the node's Gaussians.
    pub purity: f32,
}

/// One edge with its ground truth, when the run had some.
#[derive(Serialize)]
struct EdgeWithTruth<'a> {
    #[serde(flatten)]
    edge: &'a EdgeRecord,
    #[serde(skip_serializing_if = "Option::is_none")]
    truth: Option<[NodeTruth; 2]>,
}

#[derive(Serialize)]
struct GraphFile<'a> {
    /// Objects of the vote that have labelled Gaussians.
    nodes: usize,
    edges: Vec<EdgeWithTruth<'a>>,
}

/// Per voted object, its [`NodeTruth`]: `voted: [n_usable]` the vote's ids of the usable rows,
/// `truth: [n_rows]` ground-truth ids of every row.
pub fn node_truth(rows: Option<&PlyRows>, voted: &[i32], truth: &[i64]) -> Option<HashMap<u32, NodeTruth>> {
    let every_row;
    let voted = match rows {
        Some(rows) if rows.gaussians.len() == truth.len() => {
            every_row = splatseg_lift::ids_of_every_row(rows, voted);
            &every_row[..]
        }
        _ if voted.len() == truth.len() => voted,
        _ => return None,
    };
    let mut counts: HashMap<u32, HashMap<i64, u32>> = HashMap::new();
    for (&id, &gt) in voted.iter().zip(truth) {
        if id > 0 {
            *counts.entry(id as u32).or_default().entry(gt.max(-1)).or_insert(0) += 1;
        }
    }
    Some(
        counts
            .into_iter()
            .map(|(id, by_gt)| {
                let total: u32 = by_gt.values().sum();
                let (object, n) =
                    by_gt.into_iter().max_by(|x, y| x.1.cmp(&y.1).then(x.0.cmp(&y.0))).unwrap_or((-1, 0));
                (id, NodeTruth { object, purity: n as f32 / total.max(1) as f32 })
            })
            .collect(),
    )
}

/// Writes `cache/graph.json` under `cache_dir` for `lifted`'s graph; `truth`: [`node_truth`].
pub fn write_graph(
    cache_dir: &Path,
    lifted: &LiftOutput,
    truth: Option<&HashMap<u32, NodeTruth>>,
) -> crate::Result<()> {
    let nodes = {
        let mut ids: Vec<i32> = lifted.voted_ids.iter().copied().filter(|&i| i > 0).collect();
        ids.sort_unstable();
        ids.dedup();
        ids.len()
    };
    let edges = lifted
        .edges
        .iter()
        .map(|edge| EdgeWithTruth {
            edge,
            truth: truth.and_then(|t| Some([*t.get(&edge.a)?, *t.get(&edge.b)?])),
        })
        .collect();
    std::fs::create_dir_all(cache_dir)?;
    crate::cache::write_json(&cache_dir.join(GRAPH_FILE), &GraphFile { nodes, edges })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_node_takes_the_ground_truth_object_holding_most_of_it() {
        // Node 1: three Gaussians of object 7, one of 8; node 2: one of 8, one with none (-1).
        let voted = [1, 1, 2, 1, -1, 1, 2];
        let truth = [7, 7, 8, 8, 9, 7, -1];
        let t = node_truth(None, &voted, &truth).expect("same lengths");
        assert_eq!(t[&1], NodeTruth { object: 7, purity: 0.75 });
        assert_eq!(t[&2], NodeTruth { object: 8, purity: 0.5 }, "a tie goes to an object, not to none");
        assert!(!t.contains_key(&9), "Gaussians without a vote id are no node");
        assert!(node_truth(None, &voted, &truth[..3]).is_none(), "lengths that differ: no truth");
    }
}
