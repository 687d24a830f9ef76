//! Splitting objects whose Gaussians lie in separate places in 3D.
//!
//! A per-view merge that joins two objects meeting in the image (a thin post standing in front of
//! a cylinder, two white objects one behind the other) makes one mask of both. When it does so in
//! most views, matching and voting give both objects' Gaussians one id, and nothing downstream
//! can separate them again. In 3D they are plainly two things: their Gaussians form clusters with
//! empty space between them. Rule: an object's labelled Gaussians are grouped into clusters that
//! are connected through occupied voxels (26-neighbourhood; voxel edge = `SPLIT_VOXEL_FACTOR` ×
//! the median Gaussian standard deviation, each Gaussian occupying the voxels within its largest
//! standard deviation, at most two voxels either way). The largest cluster keeps the id; every
//! other cluster of at least `min_split_gaussians` Gaussians becomes an object of its own; smaller
//! clusters (stray Gaussians, floaters) keep the id. Objects touching in 3D are one cluster, so
//! walls, floors and objects occluded in some views are never cut. One exception: in an object
//! that is a plane (by its normals or its centres, as the seam join decides: a floor, a wall), Gaussians more than
//! two voxels off its plane connect only among themselves, so a post standing on a piece of floor
//! that the per-view merge joined to it splits off, though it touches the floor.
//!
//! A cluster split off is a new object only when it does not continue another object's surface:
//! its identity features are its parent's (its own Gaussians voted with the parent's masks), so
//! they say nothing of what it is, and a piece of floor or wall that the per-view merge joined
//! to a box in most views is, in 3D, a plane flush with the floor or wall around it. A split-off
//! cluster that meets another object along a smooth seam (the seam join's test without its
//! feature cosine: both planes with parallel normals, at least `SEAM_SMOOTH_SHARE` of at least
//! `MIN_SEAM_CONTACTS` measured contact voxel pairs smooth) joins that object (the one with the
//! most smooth contacts; ties: the smaller id). A post or box split off a floor meets the floor at
//! a crease and is no plane, so it stays an object of its own.
//!
//! Deterministic: clusters are ordered by their smallest Gaussian index and new ids are handed out
//! in order of (object id, cluster), whatever the thread count.

use crate::config::LiftConfig;
use crate::lifting::Lifted;
use crate::project::PreparedGaussians;
use crate::shape::{contacts, coplanar_ids, planarity, SEAM_SMOOTH_SHARE};
use crate::voxels::{self_and_forward_neighbours, voxel_of, DisjointSets};
use rayon::prelude::*;
use std::collections::{BTreeMap, HashMap};

/// Voxel edge of the split's connectivity, in median Gaussian standard deviations: 3 σ keeps
/// one surface's Gaussians connected across their own spacing.
const SPLIT_VOXEL_FACTOR: f32 = 3.0;

/// Voxels a Gaussian may reach on each side of the one holding its mean.
const MAX_REACH_VOXELS: i64 = 2;

/// What the split did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SplitStats {
    /// Objects that were split.
    pub objects_split: usize,
    /// `[new_objects]` (new id, the id it was split from), new ids ascending.
    pub parents: Vec<(u32, u32)>,
    /// (new id, the object it joined) for the split-off clusters that continue another object's
    /// surface (module docs), new ids ascending: these ids are gone again.
    pub continued: Vec<(u32, u32)>,
}

/// Measured contact voxel pairs a split-off cluster needs with an object to continue its
/// surface: as many as two objects need to touch in the joins (`touching::MIN_CONTACT_VOXELS`).
const MIN_SEAM_CONTACTS: u32 = 8;

/// Splits the objects of `lifted` whose labelled Gaussians form separate clusters in 3D (module
/// docs). New ids follow the largest id in use or `reserved` (callers with `[n_objects, dim]` object
/// features give each new id its parent's row, [`SplitStats::parents`]). `object_ids`, and `majority_ids` of Gaussians
/// whose centre voxel belongs to a split-off cluster, take the new ids.
pub fn split_disconnected_objects(
    gaussians: &PreparedGaussians,
    lifted: &mut Lifted,
    reserved: u32,
    config: &LiftConfig,
) -> SplitStats {
    let voxel = SPLIT_VOXEL_FACTOR * crate::shape::typical_sigma(gaussians);
    if !config.split_disconnected || voxel <= 0.0 || !voxel.is_finite() {
        return SplitStats::default();
    }
    let layers = PlaneLayers::new(gaussians, &lifted.object_ids, voxel);
    let group = |i: usize, id: u32| ((id as u64) << 1) | layers.off_plane(gaussians, i, id) as u64;
    let groups: Vec<u64> = lifted
        .object_ids
        .par_iter()
        .enumerate()
        .map(|(i, &id)| if id > 0 { group(i, id as u32) } else { 0 })
        .collect();
    let cells = occupied_voxels(gaussians, &groups, voxel);
    let mut sets = DisjointSets::new(cells.len());
    for (&(g, v), &index) in &cells {
        for n in self_and_forward_neighbours(v).filter(|&n| n != v) {
            if let Some(&other) = cells.get(&(g, n)) {
                sets.union(index, other);
            }
        }
    }
    // Per object: clusters keyed by root, with (size, smallest Gaussian index).
    let centre = |i: usize| voxel_of(gaussians.mean(i).to_array(), voxel);
    let mut clusters: BTreeMap<u32, BTreeMap<u32, (usize, usize)>> = BTreeMap::new();
    for (i, &id) in lifted.object_ids.iter().enumerate() {
        if id <= 0 {
            continue;
        }
        let Some(&cell) = cells.get(&(groups[i], centre(i))) else { continue };
        let entry = clusters.entry(id as u32).or_default().entry(sets.find(cell)).or_insert((0, i));
        entry.0 += 1;
    }
    let mut next_id = lifted
        .object_ids
        .iter()
        .map(|&id| id.max(0) as u32)
        .chain(lifted.majority_ids.iter().copied())
        .max()
        .unwrap_or(0)
        .max(reserved);
    let mut new_id_of_root: HashMap<(u32, u32), u32> = HashMap::new();
    let mut stats = SplitStats::default();
    for (&id, roots) in &clusters {
        let mut ordered: Vec<(u32, usize, usize)> =
            roots.iter().map(|(&r, &(n, first))| (r, n, first)).collect();
        ordered.sort_by_key(|&(_, n, first)| (std::cmp::Reverse(n), first));
        let mut split_off: Vec<(u32, usize)> = ordered[1..]
            .iter()
            .filter(|&&(_, n, _)| n >= config.min_split_gaussians)
            .map(|&(r, _, first)| (r, first))
            .collect();
        if split_off.is_empty() {
            continue;
        }
        split_off.sort_by_key(|&(_, first)| first);
        stats.objects_split += 1;
        for (root, _) in split_off {
            next_id += 1;
            new_id_of_root.insert((id, root), next_id);
            stats.parents.push((next_id, id));
        }
    }
    if new_id_of_root.is_empty() {
        return stats;
    }
    for i in 0..lifted.object_ids.len() {
        let id = lifted.object_ids[i];
        let old = if id > 0 { id as u32 } else { lifted.majority_ids[i] };
        if old == 0 {
            continue;
        }
        let Some(&cell) = cells.get(&(group(i, old), centre(i))) else { continue };
        if let Some(&new) = new_id_of_root.get(&(old, sets.find(cell))) {
            if id > 0 {
                lifted.object_ids[i] = new as i32;
            }
            if lifted.majority_ids[i] == old {
                lifted.majority_ids[i] = new;
            }
        }
    }
    stats.continued = join_continued_surfaces(gaussians, lifted, &stats.parents, voxel);
    stats
}

/// The split-off clusters (`parents`: (new id, parent)) that continue another object's surface
/// join it (module docs): `object_ids` and `majority_ids` of `lifted` take its id. Returns (new
/// id, the id it joined), new ids ascending.
fn join_continued_surfaces(
    gaussians: &PreparedGaussians,
    lifted: &mut Lifted,
    parents: &[(u32, u32)],
    voxel: f32,
) -> Vec<(u32, u32)> {
    if parents.is_empty() {
        return Vec::new();
    }
    let ids = &lifted.object_ids;
    let planes = planarity(gaussians, ids, voxel);
    let new_ids: BTreeMap<u32, u32> = parents.iter().copied().collect();
    // Per new id: (smooth contacts, the object) of its best seam, most smooth first, then the
    // smaller id.
    let mut best: BTreeMap<u32, (u32, u32)> = BTreeMap::new();
    for ((a, b), c) in contacts(gaussians, ids, voxel, &planes, None) {
        let seam = c.measured >= MIN_SEAM_CONTACTS
            && c.smooth as f32 >= SEAM_SMOOTH_SHARE * c.measured as f32
            && coplanar_ids(&planes, a, b);
        if !seam {
            continue;
        }
        for (piece, other) in [(a, b), (b, a)] {
            if !new_ids.contains_key(&piece) {
                continue;
            }
            let e = best.entry(piece).or_insert((c.smooth, other));
            if c.smooth > e.0 || (c.smooth == e.0 && other < e.1) {
                *e = (c.smooth, other);
            }
        }
    }
    if best.is_empty() {
        return Vec::new();
    }
    // Each piece has one edge, so a group holds at most one object that is not a piece, and
    // pieces' ids follow every other id: the smallest id of a group is what its pieces join.
    let top = new_ids.keys().next_back().copied().unwrap_or(0);
    let mut sets = DisjointSets::new(top as usize + 1);
    for (&piece, &(_, other)) in &best {
        sets.union(piece, other);
    }
    let joined: BTreeMap<u32, u32> = new_ids
        .keys()
        .map(|&piece| (piece, sets.find(piece)))
        .filter(|&(piece, root)| root != piece)
        .collect();
    for (&piece, &root) in &joined {
        tracing::debug!("piece {piece} split off {} continues the surface of object {root}", new_ids[&piece]);
    }
    for id in lifted.object_ids.iter_mut().filter(|id| **id > 0) {
        if let Some(&root) = joined.get(&(*id as u32)) {
            *id = root as i32;
        }
    }
    for id in lifted.majority_ids.iter_mut() {
        if let Some(&root) = joined.get(id) {
            *id = root;
        }
    }
    joined.into_iter().collect()
}

/// Objects that are planes (a floor, a wall; by their normals or centres, as the seam join decides) and the
/// offset of their plane: their Gaussians more than [`OFF_PLANE_VOXELS`] voxels off it (a post
/// standing on a piece of floor that was merged with it in the views) are connected only among
/// themselves, so they split off as objects of their own.
struct PlaneLayers {
    /// Object id → (unit normal, median offset `n·x` of its labelled Gaussians).
    planes: HashMap<u32, (glam::Vec3, f32)>,
    /// Off-plane distance, in world units.
    distance: f32,
}

/// See [`PlaneLayers`].
const OFF_PLANE_VOXELS: f32 = 2.0;

impl PlaneLayers {
    fn new(gaussians: &PreparedGaussians, ids: &[i32], voxel: f32) -> Self {
        let normals: HashMap<u32, glam::Vec3> = crate::shape::planarity(gaussians, ids, voxel)
            .into_iter()
            .filter(|(_, p)| p.is_plane())
            .map(|(id, p)| (id, p.normal))
            .collect();
        let mut offsets: HashMap<u32, Vec<f32>> = HashMap::new();
        for (i, &id) in ids.iter().enumerate() {
            if let Some(n) = (id > 0).then(|| normals.get(&(id as u32))).flatten() {
                offsets.entry(id as u32).or_default().push(n.dot(gaussians.mean(i)));
            }
        }
        let planes = offsets
            .into_iter()
            .map(|(id, mut o)| {
                let mid = o.len() / 2;
                let median = *o.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
                (id, (normals[&id], median))
            })
            .collect();
        PlaneLayers { planes, distance: OFF_PLANE_VOXELS * voxel }
    }

    /// True when Gaussian `i` of object `id` lies off its object's plane.
    fn off_plane(&self, gaussians: &PreparedGaussians, i: usize, id: u32) -> bool {
        self.planes.get(&id).is_some_and(|&(n, m)| (n.dot(gaussians.mean(i)) - m).abs() > self.distance)
    }
}

/// `(group, voxel)` → index of every voxel a group's labelled Gaussians occupy (`groups: [N]`,
/// 0 = none).
fn occupied_voxels(
    gaussians: &PreparedGaussians,
    groups: &[u64],
    voxel: f32,
) -> HashMap<(u64, [i64; 3]), u32> {
    let mut cells: HashMap<(u64, [i64; 3]), u32> = HashMap::new();
    for (i, &id) in groups.iter().enumerate() {
        if id == 0 {
            continue;
        }
        let mean = gaussians.mean(i).to_array();
        let c = gaussians.cov3d[i];
        let sigma = c[0].max(c[3]).max(c[5]).max(0.0).sqrt();
        let reach = ((sigma / voxel).floor() as i64).clamp(0, MAX_REACH_VOXELS);
        let v = voxel_of(mean, voxel);
        for dz in -reach..=reach {
            for dy in -reach..=reach {
                for dx in -reach..=reach {
                    let key = (id, [v[0] + dx, v[1] + dy, v[2] + dz]);
                    let next = cells.len() as u32;
                    cells.entry(key).or_insert(next);
                }
            }
        }
    }
    cells
}
