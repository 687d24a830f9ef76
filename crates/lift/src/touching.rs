//! Joining objects that touch in 3D and look alike.
//!
//! Mask matching keeps two masks of one view apart, so an object the per-view merge left in
//! pieces (a wall cut where the depth gate stops merging, a two-tone box split at its colour
//! edge) stays in pieces after matching — consistently in every view. In 3D the pieces are
//! visible as what they are: labelled Gaussians of two objects that *touch* (their Gaussians
//! share a voxel neighbourhood along a seam) and whose identity features agree. Rule: objects
//! `P`, `Q` become one when `cos(f_P, f_Q) ≥ tau_touching` and at least `min_contact_voxels`
//! pairs of 26-neighbouring voxels hold one of each (voxel edge = `contact_voxel_factor` ×
//! the median Gaussian standard deviation). Objects that look alike but are apart in depth
//! (the white-on-white pair) never touch, so they stay apart. Pairs are joined best cosine
//! first (ties by id) with a union-find; the surviving id is the smaller one.

use crate::config::LiftConfig;
use crate::lifting::{Lifted, ObjectFeatures};
use crate::project::PreparedGaussians;
use std::collections::{BTreeMap, HashMap};

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
        let p = gaussians.means[i] / voxel;
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
/// docs. Returns the number of joins.
pub fn join_touching_objects(
    gaussians: &PreparedGaussians,
    lifted: &mut Lifted,
    features: ObjectFeatures,
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
        .map(|((a, b), _)| {
            let cos = features.row(a).iter().zip(features.row(b)).map(|(x, y)| x * y).sum::<f32>();
            (cos, a, b)
        })
        .filter(|&(cos, _, _)| cos >= config.tau_touching)
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
