//! Joining objects that touch in 3D and look alike.
//!
//! Mask matching keeps two masks of one view apart, so an object the per-view merge left in
//! pieces (a wall cut where the depth gate stops merging, a two-tone box split at its colour
//! edge) stays in pieces after matching — consistently in every view. In 3D the pieces are
//! visible as what they are: labelled Gaussians of two objects that *touch* (their Gaussians
//! share a voxel neighbourhood along a seam) and whose identity features agree. Rule: objects
//! `P`, `Q` become one when
//! - they touch: at least `min_contact_voxels` pairs of 26-neighbouring voxels hold one of
//!   each (voxel edge = `contact_voxel_factor` × the median Gaussian standard deviation);
//! - they look alike: `cos(f_P, f_Q) ≥ tau_touching`;
//! - the views agree: among the views that see at least `MIN_SEEN` Gaussians of each, a share
//!   of at least `min_together_share` has one merged mask holding ≥ 20 % of the Gaussians of
//!   each it sees (pieces of a randomly cut wall are one mask wherever the cut fell elsewhere;
//!   two touching objects are one mask only where the per-view merge erred).
//!
//! Objects that look alike but are apart in depth (the white-on-white pair) never touch, so
//! they stay apart. Pairs are joined best cosine first (ties by id) with a union-find; the
//! surviving id is the smaller one.

use crate::config::LiftConfig;
use crate::lifting::{Lifted, ObjectFeatures};
use crate::project::PreparedGaussians;
use crate::visibility::ViewVisibility;
use splatseg_scene::Plane;
use std::collections::{BTreeMap, HashMap};

/// A view counts for a pair only when it sees at least this many Gaussians of each object.
pub const MIN_SEEN: u32 = 10;

/// Share of an object's Gaussians seen in a view that one mask must hold.
const MASK_SHARE: f32 = 0.2;

/// One view's per-mask object counts: `(mask, object)` → Gaussians, and object → Gaussians
/// (what the join reads of a view: small, so a caller streaming views keeps one per view).
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
}

fn view_counts(vis: &ViewVisibility, masks: &Plane<u32>, ids: &[i32]) -> ViewCounts {
    let labels: Vec<u32> =
        vis.pixels.iter().map(|&p| masks.data.get(p as usize).copied().unwrap_or(0)).collect();
    ViewCounts::new(&vis.gaussians, &labels, ids)
}

/// Share of the views seeing both `a` and `b` in which one mask holds a good part of each.
fn together_share(views: &[ViewCounts], a: u32, b: u32) -> f32 {
    let (mut both, mut together) = (0u32, 0u32);
    for v in views {
        let (na, nb) = (v.total.get(&a).copied().unwrap_or(0), v.total.get(&b).copied().unwrap_or(0));
        if na < MIN_SEEN || nb < MIN_SEEN {
            continue;
        }
        both += 1;
        let holds = v.by_mask.iter().any(|(&(m, id), &n)| {
            id == a
                && n as f32 >= MASK_SHARE * na as f32
                && v.by_mask.get(&(m, b)).is_some_and(|&k| k as f32 >= MASK_SHARE * nb as f32)
        });
        together += holds as u32;
    }
    if both == 0 {
        0.0
    } else {
        together as f32 / both as f32
    }
}

fn voxel_key(v: [i64; 3]) -> u64 {
    let m = |x: i64| (x as u64) & 0x1f_ffff;
    (m(v[0]) << 42) | (m(v[1]) << 21) | m(v[2])
}

/// Typical Gaussian standard deviation: median of `sqrt(trace(Σ) / 3)`.
fn typical_sigma(gaussians: &PreparedGaussians) -> f32 {
    let mut s: Vec<f32> =
        gaussians.cov3d.iter().map(|c| ((c[0] + c[3] + c[5]) / 3.0).max(0.0).sqrt()).collect();
    if s.is_empty() {
        return 0.0;
    }
    let mid = s.len() / 2;
    *s.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1
}

/// Contact counts between object ids: `(a, b)` with `a < b` → voxel-neighbour pairs.
fn contacts(gaussians: &PreparedGaussians, ids: &[i32], voxel: f32) -> BTreeMap<(u32, u32), u32> {
    let mut cells: HashMap<u64, ([i64; 3], Vec<u32>)> = HashMap::new();
    for (i, &id) in ids.iter().enumerate() {
        if id <= 0 {
            continue;
        }
        let p = gaussians.mean(i) / voxel;
        let v = [p.x.floor() as i64, p.y.floor() as i64, p.z.floor() as i64];
        let cell = cells.entry(voxel_key(v)).or_insert_with(|| (v, Vec::new()));
        if !cell.1.contains(&(id as u32)) {
            cell.1.push(id as u32);
        }
    }
    let mut out = BTreeMap::new();
    for (v, labels) in cells.values() {
        for dz in -1..=1i64 {
            for dy in -1..=1i64 {
                for dx in -1..=1i64 {
                    let n = [v[0] + dx, v[1] + dy, v[2] + dz];
                    // Each unordered voxel pair once (and the voxel with itself).
                    if (dx, dy, dz) < (0, 0, 0) {
                        continue;
                    }
                    let Some((_, other)) = cells.get(&voxel_key(n)) else { continue };
                    for &a in labels {
                        for &b in other {
                            if a != b {
                                *out.entry((a.min(b), a.max(b))).or_insert(0) += 1;
                            }
                        }
                    }
                }
            }
        }
    }
    out
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        parent[x as usize] = parent[parent[x as usize] as usize];
        x = parent[x as usize];
    }
    x
}

/// Joins touching look-alike objects in `lifted` (object and majority ids), see the module
/// docs. `views`: per view, its visibility and its merged (view-local) mask map `[H, W]`.
/// Returns the number of joins.
pub fn join_touching_objects(
    gaussians: &PreparedGaussians,
    lifted: &mut Lifted,
    features: ObjectFeatures,
    views: &[(&ViewVisibility, &Plane<u32>)],
    config: &LiftConfig,
) -> usize {
    if features.dim == 0 || config.tau_touching > 1.0 {
        return 0;
    }
    let counts: Vec<ViewCounts> = views.iter().map(|(v, m)| view_counts(v, m, &lifted.object_ids)).collect();
    join_touching_counted(gaussians, lifted, features, &counts, config)
}

/// [`join_touching_objects`] with each view's counts made by the caller ([`ViewCounts::new`],
/// `[n_views]`, from the ids of `lifted` before the join), for callers that stream the views.
pub fn join_touching_counted(
    gaussians: &PreparedGaussians,
    lifted: &mut Lifted,
    features: ObjectFeatures,
    counts: &[ViewCounts],
    config: &LiftConfig,
) -> usize {
    if features.dim == 0 || config.tau_touching > 1.0 {
        return 0;
    }
    let voxel = config.contact_voxel_factor * typical_sigma(gaussians);
    if voxel <= 0.0 || !voxel.is_finite() {
        return 0;
    }
    let n_objects = features.n_objects();
    let mut pairs: Vec<(f32, u32, u32)> = contacts(gaussians, &lifted.object_ids, voxel)
        .into_iter()
        .filter(|&((a, b), count)| count >= config.min_contact_voxels && (b as usize) <= n_objects && a >= 1)
        .map(|((a, b), count)| {
            let cos = features.row(a).iter().zip(features.row(b)).map(|(x, y)| x * y).sum::<f32>();
            (cos, a, b, count)
        })
        .filter(|&(cos, _, _, _)| cos >= config.tau_touching)
        .filter(|&(cos, a, b, count)| {
            let share = together_share(counts, a, b);
            tracing::debug!("touching objects {a} and {b}: cos {cos:.3}, contact {count}, together in {share:.2} of views");
            share >= config.min_together_share
        })
        .map(|(cos, a, b, _)| (cos, a, b))
        .collect();
    pairs.sort_by(|x, y| y.0.total_cmp(&x.0).then((x.1, x.2).cmp(&(y.1, y.2))));
    let mut parent: Vec<u32> = (0..=n_objects as u32).collect();
    let mut joins = 0;
    for (_, a, b) in pairs {
        let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
        if ra != rb {
            parent[ra.max(rb) as usize] = ra.min(rb);
            joins += 1;
        }
    }
    if joins > 0 {
        for id in lifted.object_ids.iter_mut().filter(|id| **id > 0 && (**id as usize) <= n_objects) {
            *id = find(&mut parent, *id as u32) as i32;
        }
        for id in lifted.majority_ids.iter_mut().filter(|id| **id > 0 && (**id as usize) <= n_objects) {
            *id = find(&mut parent, *id);
        }
    }
    joins
}
