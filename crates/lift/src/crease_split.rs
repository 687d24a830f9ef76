//! Splitting objects where two colours meet at a concave crease.
//!
//! When the per-view merge joins two touching objects in most views (two boxes side by side with
//! flush fronts, a box and the cylinder leaning on it, alike in colour and features), matching and
//! voting give both one id, and [`crate::split`] cannot separate them: their Gaussians touch. In 3D
//! they still differ in two ways at once: in colour, and in the edge where they meet, which is
//! concave (a box beside a taller box, a box on a box: each side's surface in front of the
//! other's). The parts of one body meet at convex edges (a box's faces) or continue one surface (a
//! two-tone cylinder's colour edge, a checker's cells). A colour edge the shape confirms is an
//! object's edge; one it does not is texture.
//!
//! Rule: an object's Gaussians (those labelled with it, and the unreliable ones whose majority it
//! is) are clustered by their chromaticity `rgb / (r + g + b)`, which shading does not change,
//! into at most [`COLOURS`] colours (bisecting 2-means: the widest cluster split at a time, each
//! 2-means started from the two halves along its principal axis), and each Gaussian takes the
//! colour most of its voxel's Gaussians have (the joins' contact voxel, 3 × the median Gaussian
//! standard deviation). Colours that meet at anything but a concave edge are one body (the
//! look-alike join's test, `touching::meet_at_concave_edge`: concave pairs over
//! `part_max_concave_share` of the oriented contact pairs and outnumbering the convex ones by more
//! than three standard deviations of a fair sign). The largest body keeps the id; every other body
//! of at least `min_split_gaussians` Gaussians that meets another at a concave edge becomes an
//! object of its own; the rest stay with the largest. A piece cut off that touches another object
//! at an edge that is not concave (oriented contacts, not the concave-edge test's) continues that
//! object (a sphere's Gaussians spilled onto the box under it, a ring of floor around a box's foot)
//! and joins it. Colours are clustered rather than cut in two once so that a third thing
//! on one side (that ring, a few Gaussians of a neighbour) cannot lend its crease to a colour edge
//! that has none: a two-tone box with a floor ring is one body and a ring.
//!
//! No constant of its own is tuned: the colours are a clustering, the edge test and the sizes are
//! the joins' and the split's. Deterministic: objects are cut independently, pieces get new ids in
//! order of (object id, smallest Gaussian index).

use crate::config::LiftConfig;
use crate::facing::Facing;
use crate::lifting::{GaussianStatus, Lifted};
use crate::project::PreparedGaussians;
use crate::shape::{contacts, contacts_among, principal_axis, typical_sigma};
use crate::split::{first_free_id, rename_ids, SplitStats};
use crate::touching::{meet_at_concave_edge, CONTACT_VOXEL_FACTOR, MIN_CONTACT_VOXELS};
use crate::voxels::{voxel_of, DisjointSets};
use glam::DVec3;
use rayon::prelude::*;
use std::collections::{BTreeMap, HashMap};

/// Colours an object's Gaussians are clustered into: enough for a pair, the floor ring around
/// its feet and a stray neighbour; more colours than an object has only split one colour, and
/// its halves meet smoothly.
const COLOURS: usize = 4;

/// Lloyd iterations of the 2-means (two colours settle in a few).
const ITERATIONS: usize = 8;

/// Splits the objects of `lifted` whose colours meet at a concave crease (module docs). New ids
/// follow the largest id in use or `reserved`; `object_ids` (labelled Gaussians) and
/// `majority_ids` take them. `facing`: the Gaussians' outward normals, which the edge test needs.
pub fn split_at_coloured_creases(
    gaussians: &PreparedGaussians,
    lifted: &mut Lifted,
    facing: &Facing,
    reserved: u32,
    config: &LiftConfig,
) -> SplitStats {
    let voxel = CONTACT_VOXEL_FACTOR * typical_sigma(gaussians);
    if gaussians.base_colours.len() != gaussians.len() || voxel <= 0.0 || !voxel.is_finite() {
        return SplitStats::default();
    }
    let mut members: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
    for i in 0..lifted.object_ids.len() {
        if let Some(id) = object_of(lifted, i) {
            members.entry(id).or_default().push(i as u32);
        }
    }
    let cutter = Cutter { gaussians, facing, voxel, config };
    let pieces: Vec<(u32, Vec<Vec<u32>>)> = members
        .into_par_iter()
        .map(|(id, all)| (id, cutter.pieces(all)))
        .filter(|(_, pieces)| pieces.len() > 1)
        .collect();
    let mut next_id = first_free_id(lifted, reserved);
    let mut stats = SplitStats::default();
    for (id, mut pieces) in pieces {
        // The largest piece keeps the id (ties: the one with the smaller first index); the others
        // are numbered by their first Gaussian.
        pieces.sort_by_key(|p| (std::cmp::Reverse(p.len()), p[0]));
        let mut rest: Vec<Vec<u32>> = pieces.split_off(1);
        rest.sort_by_key(|p| p[0]);
        stats.objects_split += 1;
        for piece in rest {
            next_id += 1;
            tracing::debug!(
                "object {id}: {} Gaussians of another colour beyond a concave crease are object {next_id}",
                piece.len()
            );
            for &g in &piece {
                let g = g as usize;
                if lifted.object_ids[g] > 0 {
                    lifted.object_ids[g] = next_id as i32;
                }
                lifted.majority_ids[g] = next_id;
            }
            stats.parents.push((next_id, id));
        }
    }
    stats.continued = join_bodies_they_continue(gaussians, lifted, facing, &stats.parents, voxel, config);
    stats
}

/// Each piece cut off (`parents`: (new id, parent)) that touches another object (not its parent,
/// not a piece) at an edge with oriented contacts that is not concave continues that object's
/// body or surface (a sphere's Gaussians spilled onto the box under it, a ring of floor) and joins
/// it: the one with the most contact voxel pairs (ties: the smaller id). Returns (new id, the id it
/// joined), new ids ascending.
fn join_bodies_they_continue(
    gaussians: &PreparedGaussians,
    lifted: &mut Lifted,
    facing: &Facing,
    parents: &[(u32, u32)],
    voxel: f32,
    config: &LiftConfig,
) -> Vec<(u32, u32)> {
    if parents.is_empty() {
        return Vec::new();
    }
    let parent_of: BTreeMap<u32, u32> = parents.iter().copied().collect();
    let mut best: BTreeMap<u32, (u32, u32)> = BTreeMap::new();
    for ((a, b), c) in contacts(gaussians, &lifted.object_ids, voxel, &HashMap::new(), Some(facing)) {
        let continues = c.voxel_pairs >= MIN_CONTACT_VOXELS
            && c.oriented >= MIN_CONTACT_VOXELS
            && !meet_at_concave_edge(&c, config);
        if !continues {
            continue;
        }
        for (piece, other) in [(a, b), (b, a)] {
            let Some(&parent) = parent_of.get(&piece) else { continue };
            if other == parent || parent_of.contains_key(&other) {
                continue;
            }
            let e = best.entry(piece).or_insert((c.voxel_pairs, other));
            if c.voxel_pairs > e.0 || (c.voxel_pairs == e.0 && other < e.1) {
                *e = (c.voxel_pairs, other);
            }
        }
    }
    let joined: BTreeMap<u32, u32> = best.into_iter().map(|(piece, (_, other))| (piece, other)).collect();
    for (&piece, &other) in &joined {
        tracing::debug!("piece {piece} cut off {} continues object {other}", parent_of[&piece]);
    }
    rename_ids(lifted, &joined);
    joined.into_iter().collect()
}

/// The object Gaussian `i` belongs to for the cut: its id, or its majority when the variance
/// filter alone left it unlabelled.
fn object_of(lifted: &Lifted, i: usize) -> Option<u32> {
    let id = lifted.object_ids[i];
    if id > 0 {
        return Some(id as u32);
    }
    let majority = lifted.majority_ids[i];
    (majority > 0 && lifted.status[i] == GaussianStatus::Unreliable).then_some(majority)
}

/// What every cut reads.
struct Cutter<'a> {
    gaussians: &'a PreparedGaussians,
    facing: &'a Facing,
    voxel: f32,
    config: &'a LiftConfig,
}

impl Cutter<'_> {
    /// One object's Gaussians (`[n]` indices, ascending) as pieces: itself alone when no colour
    /// meets another at a concave edge.
    fn pieces(&self, set: Vec<u32>) -> Vec<Vec<u32>> {
        let min = self.config.min_split_gaussians.max(1);
        if set.len() < 2 * min {
            return vec![set];
        }
        let cluster = self.colour_clusters(&set);
        let k = cluster.iter().max().map_or(0, |&c| c as usize + 1);
        if k < 2 {
            return vec![set];
        }
        let labelled = set.iter().zip(&cluster).map(|(&g, &c)| (g as usize, c + 1));
        let edges = contacts_among(self.gaussians, labelled, self.voxel, &HashMap::new(), Some(self.facing));
        // Colours are one body where they meet at anything but a concave edge.
        let mut sets = DisjointSets::new(k + 1);
        let mut concave: Vec<(u32, u32)> = Vec::new();
        for (&(a, b), c) in &edges {
            if meet_at_concave_edge(c, self.config) {
                concave.push((a, b));
            } else {
                sets.union(a, b);
            }
        }
        let mut size: BTreeMap<u32, usize> = BTreeMap::new();
        for &c in &cluster {
            *size.entry(sets.find(c + 1)).or_insert(0) += 1;
        }
        let main = size.iter().max_by_key(|&(&root, &n)| (n, std::cmp::Reverse(root))).map_or(0, |(&r, _)| r);
        // A body is cut off when it is large enough and meets another at a concave edge; the
        // others (a few Gaussians of a colour, colours that touch nothing) stay with the main one.
        let cut: Vec<u32> = size
            .iter()
            .filter(|&(&root, &n)| {
                root != main
                    && n >= min
                    && concave.iter().any(|&(a, b)| sets.find(a) == root || sets.find(b) == root)
            })
            .map(|(&root, _)| root)
            .collect();
        if cut.is_empty() {
            return vec![set];
        }
        let mut pieces: Vec<Vec<u32>> = vec![Vec::new(); cut.len() + 1];
        for (&g, &c) in set.iter().zip(&cluster) {
            let root = sets.find(c + 1);
            let k = cut.iter().position(|&r| r == root).map_or(0, |p| p + 1);
            pieces[k].push(g);
        }
        tracing::debug!(
            "{} Gaussians in {k} colours cut into pieces of {:?} at concave edges",
            set.len(),
            pieces.iter().map(Vec::len).collect::<Vec<_>>()
        );
        pieces
    }

    /// `[set.len()]` colour cluster of each Gaussian (0..COLOURS) by bisecting 2-means of
    /// chromaticities, smoothed by voxel majority.
    fn colour_clusters(&self, set: &[u32]) -> Vec<u32> {
        let chroma: Vec<DVec3> = set
            .iter()
            .map(|&g| {
                let c = DVec3::from(self.gaussians.base_colours[g as usize].map(f64::from));
                c / (c.x + c.y + c.z).max(1e-3)
            })
            .collect();
        let mut cluster = vec![0u32; set.len()];
        for next in 1..COLOURS as u32 {
            // Bisect the cluster with the largest spread (sum of squared distances to its mean).
            let spread = |c: u32| -> (f64, usize) {
                let members: Vec<DVec3> =
                    chroma.iter().zip(&cluster).filter(|&(_, &k)| k == c).map(|(&x, _)| x).collect();
                if members.is_empty() {
                    return (0.0, 0);
                }
                let mean = members.iter().copied().sum::<DVec3>() / members.len() as f64;
                (members.iter().map(|x| x.distance_squared(mean)).sum(), members.len())
            };
            let Some(widest) = (0..next)
                .map(|c| (c, spread(c)))
                .filter(|&(_, (_, n))| n >= 2)
                .max_by(|x, y| x.1 .0.total_cmp(&y.1 .0).then(y.0.cmp(&x.0)))
                .map(|(c, _)| c)
            else {
                break;
            };
            let index: Vec<usize> = (0..set.len()).filter(|&i| cluster[i] == widest).collect();
            let points: Vec<DVec3> = index.iter().map(|&i| chroma[i]).collect();
            let Some(side) = two_means(&points) else { break };
            for (&i, &s) in index.iter().zip(&side) {
                if s {
                    cluster[i] = next;
                }
            }
        }
        // Each Gaussian takes its voxel's most common cluster (ties: the smaller).
        let key = |g: u32| voxel_of(self.gaussians.mean(g as usize).to_array(), self.voxel);
        let mut votes: HashMap<[i64; 3], [u32; COLOURS]> = HashMap::new();
        for (&g, &c) in set.iter().zip(&cluster) {
            votes.entry(key(g)).or_insert([0; COLOURS])[c as usize] += 1;
        }
        let smoothed: Vec<u32> = set
            .iter()
            .map(|&g| {
                let v = votes[&key(g)];
                (0..COLOURS).max_by_key(|&c| (v[c], std::cmp::Reverse(c))).unwrap_or(0) as u32
            })
            .collect();
        // Numbered densely in order of first appearance.
        let mut number: HashMap<u32, u32> = HashMap::new();
        smoothed
            .iter()
            .map(|&c| {
                let n = number.len() as u32;
                *number.entry(c).or_insert(n)
            })
            .collect()
    }
}

/// `[points.len()]` side of each point by 2-means, started from the two halves along the points'
/// principal axis; `None` when they do not spread or a side ends empty.
fn two_means(points: &[DVec3]) -> Option<Vec<bool>> {
    let n = points.len() as f64;
    let mean = points.iter().copied().sum::<DVec3>() / n;
    let cov = points.iter().fold(glam::DMat3::ZERO, |acc, &c| {
        let d = c - mean;
        acc + glam::DMat3::from_cols(d * d.x, d * d.y, d * d.z)
    }) * (1.0 / n);
    let axis = principal_axis(cov);
    if axis == DVec3::ZERO {
        return None;
    }
    let mut side: Vec<bool> = points.iter().map(|&c| (c - mean).dot(axis) > 0.0).collect();
    for _ in 0..ITERATIONS {
        let (mut sum, mut count) = ([DVec3::ZERO; 2], [0usize; 2]);
        for (&c, &s) in points.iter().zip(&side) {
            sum[s as usize] += c;
            count[s as usize] += 1;
        }
        if count[0] == 0 || count[1] == 0 {
            return None;
        }
        let centre = [sum[0] / count[0] as f64, sum[1] / count[1] as f64];
        let next: Vec<bool> =
            points.iter().map(|&c| c.distance_squared(centre[1]) < c.distance_squared(centre[0])).collect();
        if next == side {
            break;
        }
        side = next;
    }
    (side.iter().any(|&s| s) && side.iter().any(|&s| !s)).then_some(side)
}
