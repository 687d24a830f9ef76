//! Joining objects that touch in 3D and belong together.
//!
//! Mask matching keeps two masks of one view apart, so an object the per-view merge left in
//! pieces (a wall cut where the depth gate stops merging, a floor cut by SAM's lines, a two-tone
//! box split at its colour edge) stays in pieces after matching — consistently in every view. In
//! 3D the pieces are visible as what they are: labelled Gaussians of two objects that *touch*
//! (their Gaussians share a voxel neighbourhood along a seam; voxel edge = `CONTACT_VOXEL_FACTOR`
//! × the median Gaussian standard deviation, at least `MIN_CONTACT_VOXELS` pairs of
//! 26-neighbouring voxels holding one of each). The touching pairs and their evidence — surface,
//! views, appearance — are gathered once as the object graph (`crate::graph`); the rules below
//! read each edge's terms ([`join_rule`]). Touching objects `P`, `Q` become one when either
//! - **they look alike:** `cos(f_P, f_Q) ≥ tau_touching` and the views agree: among the views
//!   that see at least `MIN_SEEN` Gaussians of each, a share of at least [`MIN_TOGETHER_SHARE`]
//!   (half) has one merged mask holding ≥ 20 % of the Gaussians of each it sees. A look-alike
//!   join has no geometry of its own, so the views must say it, as for parts whose edge is not
//!   mostly convex: one share for every join the geometry does not decide alone (before, the
//!   look-alike join asked no views, and touching objects whose features the harsher cues made
//!   alike were joined although most views kept them apart:
//!   `docs/benchmarks/24-views-for-every-look-alike.md`); or
//! - **one surface continues across the seam:** both objects are planes (at least
//!   `SEAM_SMOOTH_SHARE` of their flat Gaussians' normals within `SEAM_MAX_ANGLE_DEG` of their
//!   dominant normal, or of their centres within half a voxel of the plane fitted to them:
//!   [`crate::shape::ObjectPlane`]) with parallel normals, at least `SEAM_SMOOTH_SHARE` of the
//!   contact voxel pairs are smooth (the normals of the two sides within `SEAM_MAX_ANGLE_DEG` and
//!   each side's mean point within half a voxel of the other side's tangent plane, or both sides'
//!   mean points within half a voxel of one of the two objects' fitted planes), and
//!   `cos(f_P, f_Q) ≥ tau_seam`: a flat object lying on a plane (a rug on the floor, a poster on
//!   a wall) continues it too, and only the features tell it apart. The normals say it where the
//!   reconstruction leaves the Gaussians' shortest axes on the surface's normal; a trained 3DGS
//!   scatters them by tens of degrees, and there the centres say it (the `rough` family: ids / GT
//!   1.60 → 1.10).
//!   The pieces of a textured floor or wall have identity features that agree only loosely (cos
//!   0.53–0.99 on tuning seeds 0..3, where every one of 377 pairs meeting this geometry was two
//!   pieces of one object), too loosely for the first rule; a box standing on the floor
//!   meets it at a crease, a cylinder touching a wall meets it along a line where only the
//!   nearest normals agree, and an object whose label spilled onto the floor around its foot is
//!   not a plane, so none of these joins; or
//! - **they are parts of one object:** they meet at no concave edge:
//!   of the contact voxel pairs whose two sides have outward normals ([`Facing`]), at most
//!   `part_max_concave_share` are concave. Different objects that touch meet at concave edges (a
//!   box beside a box, a box on a box: 23–47 % of the pairs on the stress suite), the parts of one
//!   object at convex ones (a cylinder's cap and side: none) or at none (two bands of a striped
//!   cylinder, pieces of a checkered one's side). Then the views must agree (at least
//!   [`MIN_TOGETHER_SHARE`] of the views seeing both have one merged mask over both), unless
//!   the edge says it alone: most of its pairs convex (`mostly_convex`; SAM cuts a box whose faces
//!   differ in colour at its edges in most views, while two boxes sharing a face, the same-depth
//!   pair, leave only 10–38 % convex pairs at their corners). (A cosine of 0.85 of its own
//!   refused the parts of objects whose features scatter more than the tuning families', parts
//!   cos 0.83–0.84 on blind scenes: `docs/benchmarks/22-one-feature-floor.md`; the convex edge
//!   alone: `docs/benchmarks/23-edges-of-one-body.md`). Where fewer than `part_min_convex_share`
//!   of the pairs are convex the pieces meet with no edge at all, which says less (two boxes side
//!   by side meet flush, and an impure floor piece holding Gaussians of a box meets it so), and the
//!   join is asked as the pair was, against the two sets as they stand: it is refused when more
//!   than `part_max_concave_share` of the oriented pairs between them are concave (a piece joined
//!   to one box of a touching pair by its convex edge, then reaching the other: tuning
//!   `multi_tone` seed 105 0.992 → 0.897 without that check). Until 2026-12-07 such pieces were
//!   not joined at all; the three side pieces of a checkered cylinder stayed three ids
//!   (`blind_contact` seed 111, 0.935 → 0.983 with the join); or
//! - **they are pieces of one thin structure:** both thin (their Gaussians spread along a line
//!   at least `THIN_MIN_ELONGATION` times more than across it, the line fitted to the Gaussians
//!   that lie on it, so that a few strays of the id, a label spilled onto the floor at the post's
//!   foot, do not widen it), parallel and on one line, at
//!   least one contact voxel pair: a post that SAM cut where the background behind it changes
//!   (wall above, floor below).
//!
//! **The part and thin joins ask the geometry and the views, not the features.** Until
//! 2026-12-06 they also needed `cos(f_P, f_Q) ≥ tau_seam`, as the seam join does, to refuse what
//! looks unlike. With identity features it never decided: the tuning families' results are the
//! same without it, to the last digit (seeds 0..7, 56 scenes). With the model-free colour
//! descriptors it refused what the geometry had right, as the parts of a multi-coloured object
//! are unlike in colour by what makes them parts: without it 0.8905 → 0.8946 mean mIoU, ids / GT
//! 1.760 → 1.720, no failure class worse (`docs/benchmarks/28-geometry-joins.md`). Unlike a seam,
//! a convex edge or one thin line is not something two objects make by lying on each other.
//!
//! Objects that look alike but are apart in depth (the white-on-white pair) never touch, so
//! they stay apart. Pairs are joined best cosine first (ties by id) with a union-find, the part
//! joins with no edge after all the others (they say least, and are asked against the sets the
//! other rules made: joined first, an impure floor piece took a box with it into the floor, which
//! its seam joined next, `blind_trained` seed 107 0.985 → 0.827); the surviving id is the smaller
//! one.
//!
//! **SAM's wholes veto a join** ([`SeparateWholes`], from the caller: the merge's separate-wholes
//! evidence, `splatseg_merge::wholes`). Identity features of different objects can be as close as
//! those of one object's parts (objects less distinct, noisier tokens), and a chain of joins can
//! pass through a small piece that touches both. Before each join the two sets as they stand
//! (every object already joined to each side) are asked, and when either set already holds several
//! objects the two objects themselves too: when other views' SAM masks hold them in different
//! wholes (a side inside nested masks, no mask over both, in enough views), the join is refused.
//! (A set's Gaussians seldom fill a nested mask, so the evidence against a pair fades as its sets
//! grow: blind_cues seed 1 at 12 views, `docs/benchmarks/23-edges-of-one-body.md`.) The parts of a multi-coloured object sit in one whole wherever SAM gives one, floor and
//! wall pieces in none, so their joins stand. Measured: neutral on the tuning families (seeds
//! 0–7: mean mIoU 0.974 either way, 5 of 48 scenes change), and it undoes the wrong joins of
//! touching objects found on blind scenes (`docs/benchmarks/17-wholes-veto.md`).
//!
//! **A look-alike join is refused where the two sets meet at a concave edge.** The look-alike rule
//! has no geometry of its own, and a small piece (14 Gaussians of a box's top face) can look like
//! the box under it and the box on it: joined to the lower box first, it then joins the upper one
//! too (`sam_noise` seed 6: the stack's top lost, 0.880 → 0.978 with this rule). So before a join
//! by that rule alone, the contacts of every pair across the two sets as they stand are summed;
//! when more than `part_max_concave_share` of their oriented pairs are concave and the concave ones
//! outnumber the convex ones by more than three standard deviations of a fair sign, the sets are
//! two objects touching (different objects meet at concave edges: a box on a box, a box beside a
//! wall), and the join is refused (`docs/benchmarks/22-one-feature-floor.md`).

use crate::config::{Decision, LiftConfig};
use crate::decision::{agglomerate, Pooled};
use crate::facing::Facing;
use crate::graph::{EdgeRecord, Evidence, ObjectGraph, SamViews, ViewCounts};
use crate::lifting::{Lifted, ObjectFeatures};
use crate::project::PreparedGaussians;
use crate::shape::{typical_sigma, Contact, SEAM_SMOOTH_SHARE};
use crate::voxels::DisjointSets;
use std::collections::HashMap;

/// Voxel edge of the contact test, in median Gaussian standard deviations: 3 σ reaches across
/// the gap between two surfaces' footprints without bridging separate objects.
const CONTACT_VOXEL_FACTOR: f32 = 3.0;

/// Neighbouring voxel pairs (one Gaussian of each object) two objects must share to touch: fewer
/// are stray Gaussians, not a seam.
const MIN_CONTACT_VOXELS: u32 = 8;

/// A join the geometry does not decide alone (look-alike objects, parts whose edge is not mostly
/// convex) needs the two objects in one merged mask in at least half the views seeing both.
pub const MIN_TOGETHER_SHARE: f32 = 0.5;

/// True when a contact's oriented voxel pairs say two objects meet at a concave edge (a box on a
/// box, a box beside a wall): more than `part_max_concave_share` of them concave, and concave
/// ones outnumbering convex ones by more than three standard deviations of a fair sign (tilted
/// Gaussians make concave and convex pairs alike often along a smooth seam: 5–9 % each on `rough`
/// floors).
fn meet_at_concave_edge(c: &Contact, config: &LiftConfig) -> bool {
    c.oriented >= MIN_CONTACT_VOXELS
        && c.concave as f32 > config.part_max_concave_share * c.oriented as f32
        && c.concave as f32 - c.convex as f32 > 3.0 * ((c.concave + c.convex) as f32).sqrt()
}

/// True when most of a contact's oriented voxel pairs are convex: the convex ones outnumber all
/// the others by more than three standard deviations of a fair sign. That is the outside of one
/// body's edge (a box's top and side: 79–84 % on blind scenes); two objects that share a face (the
/// same-depth pair) leave 10–38 % convex pairs at their corners on the tuning families.
fn mostly_convex(c: &Contact) -> bool {
    let others = c.oriented.saturating_sub(c.convex);
    c.convex as f32 - others as f32 > 3.0 * (c.oriented as f32).sqrt()
}

/// What the edge between the two sets of a join (every object already joined to each side) must
/// not be for the join to stand.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SetEdge {
    /// No check: the pair's own geometry decided (a seam, a convex edge, one thin line).
    Any,
    /// Not a concave edge ([`meet_at_concave_edge`]): a look-alike join, which has no geometry.
    NotConcave,
    /// No concave pairs beyond `part_max_concave_share`, as the pair itself: a part join on a
    /// surface with no edge (fewer than `part_min_convex_share` convex pairs), whose pair says
    /// less than a convex edge does.
    NoConcave,
}

/// What the views' SAM masks say about two objects (the caller's evidence; the pipeline's is
/// the merge's separate-wholes evidence over the objects' Gaussians).
pub trait SeparateWholes: Sync {
    /// True when the masks hold the Gaussians `a` and `b` (indices, any order) in different
    /// wholes.
    fn separate(&self, a: &[u32], b: &[u32]) -> bool;

    /// The counts behind [`SeparateWholes::separate`] for each pair of `pairs` (indices into
    /// `sets`, each a set of Gaussian indices), for the graph's record: `[n_pairs]`, or empty
    /// when not given (the default).
    fn count_pairs(&self, _sets: &[&[u32]], _pairs: &[(usize, usize)]) -> Vec<SamViews> {
        Vec::new()
    }
}

/// What the join did: the joins made, and every edge of the graph with its evidence and fate.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct JoinReport {
    /// Pairs joined.
    pub joins: usize,
    /// The graph's edges, `(a, b)` ascending.
    pub edges: Vec<EdgeRecord>,
}

/// The rules of the module docs over one edge's evidence: `Some((check, rule))` when they join
/// `a` and `b`, with what the two sets' edge must not be for the join to stand and the rule's
/// name.
fn join_rule(a: u32, b: u32, e: &Evidence, config: &LiftConfig) -> Option<(SetEdge, &'static str)> {
    let (c, cos, share) = (&e.surface.contact, e.cos, e.views.together_share());
    let thin = e.surface.thin_line;
    if thin {
        tracing::debug!("objects {a} and {b} are pieces of one thin structure: cos {cos:.3}");
    }
    tracing::trace!(
        "contact {a}-{b}: cos {cos:.3}, {} voxel pairs ({} measured, {} smooth; {} oriented, {} concave, {} convex), \
         coplanar {}, together in {share:.2} of views",
        c.voxel_pairs,
        c.measured,
        c.smooth,
        c.oriented,
        c.concave,
        c.convex,
        e.surface.coplanar,
    );
    if c.voxel_pairs < MIN_CONTACT_VOXELS {
        return thin.then_some((SetEdge::Any, "thin"));
    }
    let seam = c.measured >= MIN_CONTACT_VOXELS
        && e.surface.coplanar
        && c.smooth as f32 >= SEAM_SMOOTH_SHARE * c.measured as f32
        && cos >= config.tau_seam;
    let alike = cos >= config.tau_touching && share >= MIN_TOGETHER_SHARE;
    // No edge at all (a curved surface, one body's side continuing into its side): asked like a
    // look-alike join, against the two sets' edge.
    let smooth = (c.convex as f32) < config.part_min_convex_share * c.oriented as f32;
    let parts = !alike
        && c.oriented >= MIN_CONTACT_VOXELS
        && c.concave as f32 <= config.part_max_concave_share * c.oriented as f32
        && (mostly_convex(c) || share >= MIN_TOGETHER_SHARE);
    if seam {
        tracing::debug!(
            "objects {a} and {b} continue one surface: cos {cos:.3}, {} of {} contacts smooth",
            c.smooth,
            c.measured
        );
    } else if alike || parts {
        tracing::debug!(
            "objects {a} and {b} (cos {cos:.3}) join as {}: {} concave and {} convex of {} contacts, together in \
             {share:.2} of views",
            if alike { "look-alikes" } else { "parts" },
            c.concave,
            c.convex,
            c.oriented
        );
    }
    let check = if seam || thin {
        SetEdge::Any
    } else if parts && smooth {
        SetEdge::NoConcave
    } else if alike {
        SetEdge::NotConcave
    } else {
        SetEdge::Any
    };
    let rule = if seam {
        "seam"
    } else if alike {
        "look-alike"
    } else if parts && smooth {
        "parts, no edge"
    } else if parts {
        "parts"
    } else {
        "thin"
    };
    (seam || alike || parts || thin).then_some((check, rule))
}

/// Joins touching look-alike objects in `lifted` (object and majority ids), see the module
/// docs. `counts`: per view its [`ViewCounts`] (`[n_views]`, made from the ids of `lifted`
/// before the join, one view at a time by a caller streaming the views); `facing`: the
/// Gaussians' [`Facing`] (`None`: no part join, which needs outward normals); `wholes`: SAM's
/// wholes, which veto joins (`None`: no veto). Returns the joins made and the graph's edges.
pub fn join_touching_objects(
    gaussians: &PreparedGaussians,
    lifted: &mut Lifted,
    features: ObjectFeatures,
    counts: &[ViewCounts],
    facing: Option<&Facing>,
    wholes: Option<&dyn SeparateWholes>,
    config: &LiftConfig,
) -> JoinReport {
    if features.dim == 0 {
        return JoinReport::default();
    }
    let voxel = CONTACT_VOXEL_FACTOR * typical_sigma(gaussians);
    if voxel <= 0.0 || !voxel.is_finite() {
        return JoinReport::default();
    }
    let n_objects = features.n_objects();
    let graph = ObjectGraph::new(gaussians, &lifted.object_ids, voxel, &features, counts, facing);
    let mut records: Vec<EdgeRecord> = graph
        .edges
        .iter()
        .map(|(&(a, b), e)| EdgeRecord::new(a, b, e, [graph.size(a), graph.size(b)]))
        .collect();
    // (cos, a, b, what the two sets' edge must not be, the edge's record).
    let mut pairs: Vec<(f32, u32, u32, SetEdge, usize)> = graph
        .edges
        .iter()
        .enumerate()
        .filter_map(|(k, (&(a, b), e))| {
            let (check, rule) = join_rule(a, b, e, config)?;
            records[k].rule = rule;
            Some((e.cos, a, b, check, k))
        })
        .collect();
    // Joins on a surface with no edge say least: they come last, asked against the sets every
    // other rule made (else a piece joins one object first and the floor swallows both after).
    let last = |check: SetEdge| check == SetEdge::NoConcave;
    pairs.sort_by(|x, y| {
        last(x.3).cmp(&last(y.3)).then(y.0.total_cmp(&x.0)).then((x.1, x.2).cmp(&(y.1, y.2)))
    });
    // The objects of each set as joined so far (root → ids; a root not in it is alone).
    let mut objects_of: HashMap<u32, Vec<u32>> = HashMap::new();
    // Each object's Gaussians, for SAM's wholes: joined best first, each join is asked about the
    // two sets as they stand (what is already joined to each), so that no chain of joins puts
    // together two objects that the masks keep apart.
    let mut gaussians_of: HashMap<u32, Vec<u32>> = HashMap::new();
    if let Some(wholes) = wholes {
        for (g, &id) in lifted.object_ids.iter().enumerate() {
            if id > 0 {
                gaussians_of.entry(id as u32).or_default().push(g as u32);
            }
        }
        let nodes: Vec<u32> = {
            let mut n: Vec<u32> = records.iter().flat_map(|r| [r.a, r.b]).collect();
            n.sort_unstable();
            n.dedup();
            n
        };
        let sets: Vec<&[u32]> =
            nodes.iter().map(|id| gaussians_of.get(id).map_or(&[][..], |g| &g[..])).collect();
        let at = |id: u32| nodes.binary_search(&id).unwrap_or(0);
        let pairs: Vec<(usize, usize)> = records.iter().map(|r| (at(r.a), at(r.b))).collect();
        for (r, sam) in records.iter_mut().zip(wholes.count_pairs(&sets, &pairs)) {
            r.sam = Some(sam);
        }
    }
    if config.decision == Decision::Evidence {
        let edges: Vec<(u32, u32, Pooled)> = records.iter().map(|r| (r.a, r.b, Pooled::of(r))).collect();
        let (mut sets, joins) = agglomerate(&edges, n_objects);
        for r in &mut records {
            r.rule = "evidence";
            r.outcome = if sets.find(r.a) == sets.find(r.b) { "joined" } else { "no join" };
        }
        relabel(lifted, &mut sets, n_objects);
        return JoinReport { joins, edges: records };
    }
    let mut sets = DisjointSets::new(n_objects + 1);
    let mut joins = 0;
    for (cos, a, b, check, k) in pairs {
        let (ra, rb) = (sets.find(a), sets.find(b));
        if ra == rb {
            records[k].outcome = "already one set";
            continue;
        }
        let set = |r: u32| objects_of.get(&r).map_or(vec![r], Vec::clone);
        let (set_a, set_b) = (set(ra), set(rb));
        if check != SetEdge::Any {
            let mut edge = Contact::default();
            for &x in &set_a {
                for &y in &set_b {
                    if let Some(c) = graph.contact(x, y) {
                        edge.oriented += c.oriented;
                        edge.concave += c.concave;
                        edge.convex += c.convex;
                    }
                }
            }
            let refused = match check {
                SetEdge::NotConcave => meet_at_concave_edge(&edge, config),
                SetEdge::NoConcave => {
                    edge.concave as f32 > config.part_max_concave_share * edge.oriented as f32
                }
                SetEdge::Any => false,
            };
            if refused {
                tracing::debug!(
                    "objects {a} and {b} (joined so far into {ra} and {rb}), cos {cos:.3}: the two sets meet at a \
                     concave edge ({} concave, {} convex of {} contacts), not joined",
                    edge.concave,
                    edge.convex,
                    edge.oriented
                );
                records[k].outcome = "refused: concave edge between the sets";
                continue;
            }
        }
        if let Some(wholes) = wholes {
            let own = |id: u32| gaussians_of.get(&id).map_or(&[][..], |g| &g[..]);
            let side =
                |set: &[u32]| -> Vec<u32> { set.iter().flat_map(|&id| own(id).iter().copied()).collect() };
            // The two objects themselves too, when either is already part of a larger set: a set's
            // Gaussians are seldom all inside one nested mask, so evidence against the pair can
            // fade as the sets grow (a foreground object's cap, nested in its whole in 10 of 12
            // views, joined to its side and then to the floor by a seam of 9 contacts).
            let composed = set_a.len() > 1 || set_b.len() > 1;
            if wholes.separate(&side(&set_a), &side(&set_b)) || (composed && wholes.separate(own(a), own(b)))
            {
                tracing::debug!(
                    "objects {a} and {b} (joined so far into {ra} and {rb}), cos {cos:.3}: SAM's masks \
                     hold them in different wholes, not joined"
                );
                records[k].outcome = "refused: SAM's wholes";
                continue;
            }
        }
        sets.union(a, b);
        objects_of.remove(&ra);
        objects_of.remove(&rb);
        objects_of.insert(sets.find(a), [set_a, set_b].concat());
        records[k].outcome = "joined";
        joins += 1;
    }
    if joins > 0 {
        relabel(lifted, &mut sets, n_objects);
    }
    JoinReport { joins, edges: records }
}

/// Every object and majority id of `lifted` (`1..=n_objects`) replaced by its set's root.
fn relabel(lifted: &mut Lifted, sets: &mut DisjointSets, n_objects: usize) {
    for id in lifted.object_ids.iter_mut().filter(|id| **id > 0 && (**id as usize) <= n_objects) {
        *id = sets.find(*id as u32) as i32;
    }
    for id in lifted.majority_ids.iter_mut().filter(|id| **id > 0 && (**id as usize) <= n_objects) {
        *id = sets.find(*id);
    }
}
