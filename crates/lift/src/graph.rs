//! The object graph (issue 58): the objects after the vote as nodes, the pairs whose Gaussians
//! touch in 3D as edges, and for every edge the evidence gathered once over the whole capture,
//! kept as named terms for the decision to weigh ([`crate::touching`] reads them):
//!
//! - **surface** ([`Surface`]): what the Gaussians say where the two meet — the contact voxel
//!   pairs and how many are smooth (one surface continuing), concave or convex (an edge, and its
//!   sign), whether both objects are one plane, whether both lie on one thin line;
//! - **views** ([`Views`]): in how many of the views that see both one merged mask holds a good
//!   part of each, against how many see both;
//! - **appearance**: the cosine of the two objects' identity features (or the model-free
//!   descriptors).
//!
//! The graph holds evidence only; what is joined is the decision's ([`crate::touching`]).

use crate::facing::Facing;
use crate::lifting::ObjectFeatures;
use crate::project::PreparedGaussians;
use crate::shape::{contacts, coplanar_ids, planes_and_lines, Contact, THIN_MIN_ELONGATION};
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet, HashMap};

/// A view counts for a pair only when it sees at least this many Gaussians of each object: fewer
/// are a glimpse, whatever mask holds them.
pub(crate) const MIN_SEEN: u32 = 10;

/// Share of an object's Gaussians seen in a view that one mask must hold for the mask to hold
/// the object (a mask over a fifth of it; an object cut by a few masks still has one that does).
const MASK_SHARE: f32 = 0.2;

/// One view's per-mask object counts: `(mask, object)` → Gaussians, and object → Gaussians
/// (what the graph reads of a view: small, so a caller streaming views keeps one per view).
#[derive(Clone, Debug, Default)]
pub struct ViewCounts {
    by_mask: HashMap<(u32, u32), u32>,
    total: HashMap<u32, u32>,
}

impl ViewCounts {
    /// The counts of one view: `gaussians: [n_visible]` its visible Gaussians, `masks:
    /// [n_visible]` the merged (view-local) mask at each one's centre pixel (0 = none), `ids: [N]`
    /// the lifted object ids.
    pub fn new(gaussians: &[u32], masks: &[u32], ids: &[i32]) -> Self {
        let mut counts = ViewCounts::default();
        for (&g, &mask) in gaussians.iter().zip(masks) {
            let id = ids.get(g as usize).copied().unwrap_or(-1);
            if id <= 0 || mask == 0 {
                continue;
            }
            *counts.by_mask.entry((mask, id as u32)).or_insert(0) += 1;
            *counts.total.entry(id as u32).or_insert(0) += 1;
        }
        counts
    }

    /// Gaussians of `id` this view sees (with a mask).
    fn seen(&self, id: u32) -> u32 {
        self.total.get(&id).copied().unwrap_or(0)
    }

    /// The pairs `(a, b)`, `a < b`, that one mask of this view holds together (a good part of
    /// each: [`MASK_SHARE`] of what the view sees of it).
    fn held_together(&self) -> BTreeSet<(u32, u32)> {
        let mut held: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
        for (&(mask, id), &n) in &self.by_mask {
            if n as f32 >= MASK_SHARE * self.seen(id) as f32 {
                held.entry(mask).or_default().push(id);
            }
        }
        let mut pairs = BTreeSet::new();
        for ids in held.values_mut() {
            ids.sort_unstable();
            for (k, &a) in ids.iter().enumerate() {
                for &b in &ids[k + 1..] {
                    pairs.insert((a, b));
                }
            }
        }
        pairs
    }
}

/// The views term of each pair of `pairs` (`[n_pairs]`, each `(a, b)` with `a < b`) over every
/// view's counts (`[n_views]`): one pass over the views, each mask's pairs listed once per view.
fn views_terms(counts: &[ViewCounts], pairs: &[(u32, u32)]) -> Vec<Views> {
    let mut out = vec![Views::default(); pairs.len()];
    for view in counts {
        let together = view.held_together();
        for (&(a, b), views) in pairs.iter().zip(out.iter_mut()) {
            if view.seen(a) < MIN_SEEN || view.seen(b) < MIN_SEEN {
                continue;
            }
            views.seeing_both += 1;
            views.together += together.contains(&(a, b)) as u32;
        }
    }
    out
}

/// What the Gaussians say where two objects meet.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Surface {
    /// The contact: voxel pairs, and of those the smooth, concave and convex ones.
    pub contact: Contact,
    /// Both objects are planes with parallel normals ([`crate::shape::ObjectPlane::coplanar`]).
    pub coplanar: bool,
    /// Both objects are thin and lie on one line ([`crate::shape::ObjectLine::continues`]).
    pub thin_line: bool,
}

/// What the views' merged masks say about two objects.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Views {
    /// Views seeing at least [`MIN_SEEN`] Gaussians of each.
    pub seeing_both: u32,
    /// Of those, the views where one merged mask holds a good part of each.
    pub together: u32,
}

impl Views {
    /// Share of the views seeing both in which one mask holds both (0 when none sees both).
    pub fn together_share(&self) -> f32 {
        if self.seeing_both == 0 {
            0.0
        } else {
            self.together as f32 / self.seeing_both as f32
        }
    }
}

/// The evidence of one edge, each term as gathered.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Evidence {
    /// The surface term.
    pub surface: Surface,
    /// The views term.
    pub views: Views,
    /// The appearance term: cosine of the two objects' identity features.
    pub cos: f32,
}

/// Objects as nodes, touching pairs as edges with their [`Evidence`].
pub(crate) struct ObjectGraph {
    /// `(a, b)`, `a < b`, both objects of the features' table → the edge's evidence.
    pub edges: BTreeMap<(u32, u32), Evidence>,
    /// Object → its labelled Gaussians (the nodes' sizes).
    pub sizes: HashMap<u32, u32>,
}

/// What SAM's masks in every view say about two objects' Gaussians (the merge's separate-wholes
/// evidence, counted by the caller: [`crate::SeparateWholes::count`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct SamViews {
    /// Views where one mask holds both.
    pub together: u32,
    /// Views where no mask holds both and one of them is held by nested masks.
    pub apart: u32,
    /// Views that see enough of both.
    pub seen: u32,
}

/// One edge of the object graph as the run weighed it: its evidence term by term, the rule that
/// asked for the join, and what became of it. Written to `OUT/cache/graph.json` so that a join
/// (or a missing one) can be read back, and so that the terms can be measured against ground
/// truth (`tools/edge_study.py`, issue 58).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EdgeRecord {
    /// The smaller object id (the vote's ids, before any join).
    pub a: u32,
    /// The larger object id.
    pub b: u32,
    /// Labelled Gaussians of `a` and of `b`.
    pub sizes: [u32; 2],
    /// Surface: contact voxel pairs.
    pub voxel_pairs: u32,
    /// Surface: pairs with both sides' normals or planes measured.
    pub measured: u32,
    /// Surface: measured pairs where one surface continues.
    pub smooth: u32,
    /// Surface: pairs with both sides' outward normals.
    pub oriented: u32,
    /// Surface: oriented pairs at a concave edge.
    pub concave: u32,
    /// Surface: oriented pairs at a convex edge.
    pub convex: u32,
    /// Surface: both objects are planes with parallel normals.
    pub coplanar: bool,
    /// Surface: both objects are thin and lie on one line.
    pub thin_line: bool,
    /// Views: views seeing enough of both.
    pub seeing_both: u32,
    /// Views: of those, views where one merged mask holds a good part of each.
    pub together: u32,
    /// Views: SAM's masks (nested levels included) over the two objects' Gaussians, when the
    /// run had that evidence.
    pub sam: Option<SamViews>,
    /// Appearance: cosine of the identity features (or model-free descriptors).
    pub cos: f32,
    /// The rule that asks for the join (`"seam"`, `"look-alike"`, `"parts"`, `"parts, no edge"`,
    /// `"thin"`), or `"none"`.
    pub rule: &'static str,
    /// What became of it: `"joined"`, `"already one set"`, `"refused: concave edge between the
    /// sets"`, `"refused: SAM's wholes"`, or `"no join"`.
    pub outcome: &'static str,
}

impl EdgeRecord {
    /// The record of edge `(a, b)` with its evidence, before any decision (`rule` and `outcome`
    /// "none" / "no join").
    pub(crate) fn new(a: u32, b: u32, e: &Evidence, sizes: [u32; 2]) -> Self {
        let c = &e.surface.contact;
        EdgeRecord {
            a,
            b,
            sizes,
            voxel_pairs: c.voxel_pairs,
            measured: c.measured,
            smooth: c.smooth,
            oriented: c.oriented,
            concave: c.concave,
            convex: c.convex,
            coplanar: e.surface.coplanar,
            thin_line: e.surface.thin_line,
            seeing_both: e.views.seeing_both,
            together: e.views.together,
            sam: None,
            cos: e.cos,
            rule: "none",
            outcome: "no join",
        }
    }
}

impl ObjectGraph {
    /// The graph of the objects `ids: [N]` (Gaussian → object id, ≤ 0 none), their features, the
    /// views' counts (`[n_views]`), and the Gaussians' [`Facing`] (`None`: no edge is oriented).
    /// `voxel`: the contact voxel edge.
    pub fn new(
        gaussians: &PreparedGaussians,
        ids: &[i32],
        voxel: f32,
        features: &ObjectFeatures,
        counts: &[ViewCounts],
        facing: Option<&Facing>,
    ) -> Self {
        let n_objects = features.n_objects();
        let (planes, lines) = planes_and_lines(gaussians, ids, voxel);
        let touching = contacts(gaussians, ids, voxel, &planes, facing);
        let cos_of =
            |a: u32, b: u32| features.row(a).iter().zip(features.row(b)).map(|(x, y)| x * y).sum::<f32>();
        let mut edges: BTreeMap<(u32, u32), Evidence> = touching
            .into_iter()
            .filter(|&((a, b), c)| c.voxel_pairs >= 1 && (b as usize) <= n_objects && a >= 1)
            .map(|((a, b), contact)| {
                let thin_line = THIN_MIN_ELONGATION > 0.0
                    && matches!((lines.get(&a), lines.get(&b)), (Some(p), Some(q)) if p.continues(q));
                let surface = Surface { contact, coplanar: coplanar_ids(&planes, a, b), thin_line };
                ((a, b), Evidence { surface, views: Views::default(), cos: cos_of(a, b) })
            })
            .collect();
        let pairs: Vec<(u32, u32)> = edges.keys().copied().collect();
        for (pair, views) in pairs.iter().zip(views_terms(counts, &pairs)) {
            if let Some(e) = edges.get_mut(pair) {
                e.views = views;
            }
        }
        let mut sizes: HashMap<u32, u32> = HashMap::new();
        for &id in ids.iter().filter(|&&id| id > 0) {
            *sizes.entry(id as u32).or_insert(0) += 1;
        }
        ObjectGraph { edges, sizes }
    }

    /// Labelled Gaussians of object `id`.
    pub fn size(&self, id: u32) -> u32 {
        self.sizes.get(&id).copied().unwrap_or(0)
    }

    /// The contact of `a` and `b` (any order), if they touch (for the edge between two sets of joined objects).
    pub fn contact(&self, a: u32, b: u32) -> Option<&Contact> {
        self.edges.get(&(a.min(b), a.max(b))).map(|e| &e.surface.contact)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A view seeing `n` Gaussians of objects 1, 2 and 3 each, Gaussian `g` of object `1 + g / n`,
    /// in the masks given per Gaussian.
    fn view(n: u32, masks: &[u32]) -> ViewCounts {
        let ids: Vec<i32> = (0..3 * n).map(|g| 1 + (g / n) as i32).collect();
        let gaussians: Vec<u32> = (0..3 * n).collect();
        ViewCounts::new(&gaussians, masks, &ids)
    }

    #[test]
    fn a_mask_holds_two_objects_together_when_it_holds_a_fifth_of_each() {
        // Mask 1 over all of object 1 and 4 of object 2's 20 (a fifth); mask 2 over the rest of
        // object 2 and 3 of object 3's 20 (under a fifth); mask 3 over the rest of object 3.
        let n = 20;
        let masks: Vec<u32> = (0..3 * n)
            .map(|g| {
                if g < n + 4 {
                    1
                } else if g < 2 * n + 3 {
                    2
                } else {
                    3
                }
            })
            .collect();
        let together = view(n, &masks).held_together();
        assert_eq!(together.into_iter().collect::<Vec<_>>(), vec![(1, 2)]);
    }

    #[test]
    fn the_views_term_counts_only_views_that_see_enough_of_both() {
        // Three views: one mask over everything (seen 20 each), two masks (1 and 2 apart), and a
        // view seeing only 5 of each (under MIN_SEEN), one mask over everything.
        let all_in_one = view(20, &[1; 60]);
        let apart = view(20, &(0..60).map(|g| 1 + (g >= 20) as u32).collect::<Vec<_>>());
        let glimpse = view(5, &[1; 15]);
        let counts = [all_in_one, apart, glimpse];
        let terms = views_terms(&counts, &[(1, 2), (2, 3), (3, 4)]);
        let views = terms[0];
        assert_eq!(views, Views { seeing_both: 2, together: 1 });
        assert_eq!(
            terms[1],
            Views { seeing_both: 2, together: 2 },
            "2 and 3 share mask 2 in the second view"
        );
        assert_eq!(terms[2], Views::default(), "no view sees object 4");
        assert_eq!(views.together_share(), 0.5);
        assert_eq!(Views::default().together_share(), 0.0);
    }
}
