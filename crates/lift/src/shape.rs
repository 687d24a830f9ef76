//! What the Gaussians' 3D shape says about objects, for the joins of [`crate::touching`] and the
//! split of [`crate::split`]: the typical Gaussian size, which objects are planes, the line a
//! thin object lies along, and what two objects share where they touch (voxel pairs, smooth,
//! concave and convex contacts).

use crate::config::LiftConfig;
use crate::facing::{Facing, MIN_FLATNESS};
use crate::project::PreparedGaussians;
use crate::voxels::{self_and_forward_neighbours, voxel_of};
use glam::Vec3;
use std::collections::{BTreeMap, HashMap};

/// Two planes (or lines) continue one surface when their normals (axes) are within this many
/// degrees: the normals of one flat surface's Gaussians scatter a few degrees; a box on a floor
/// meets it at 90°.
pub(crate) const SEAM_MAX_ANGLE_DEG: f32 = 10.0;

/// An object is a plane when at least this share of its flat Gaussians' normals lie within
/// [`SEAM_MAX_ANGLE_DEG`] of its normal; a seam is smooth when this share of its measured
/// contact voxel pairs is.
pub(crate) const SEAM_SMOOTH_SHARE: f32 = 0.9;

/// Two touching objects whose Gaussians both spread along one line at least this many times more
/// than across it are pieces of one thin structure (a post SAM cut where the background behind
/// it changes) and join at `tau_seam`; 0 would switch the rule off.
pub(crate) const THIN_MIN_ELONGATION: f32 = 5.0;

fn voxel_key(v: [i64; 3]) -> u64 {
    let m = |x: i64| (x as u64) & 0x1f_ffff;
    (m(v[0]) << 42) | (m(v[1]) << 21) | m(v[2])
}

/// Typical Gaussian standard deviation: median of `sqrt(trace(Σ) / 3)`.
pub(crate) fn typical_sigma(gaussians: &PreparedGaussians) -> f32 {
    let mut s: Vec<f32> =
        gaussians.cov3d.iter().map(|c| ((c[0] + c[3] + c[5]) / 3.0).max(0.0).sqrt()).collect();
    if s.is_empty() {
        return 0.0;
    }
    let mid = s.len() / 2;
    *s.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1
}

/// What two objects share in 3D (see [`contacts`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Contact {
    /// Pairs of 26-neighbouring voxels holding one of each.
    pub voxel_pairs: u32,
    /// Of those, the pairs where both sides have a surface normal (flat Gaussians).
    pub measured: u32,
    /// Of the measured pairs, those where the two surfaces continue each other: normals within
    /// `SEAM_MAX_ANGLE_DEG` and each side's mean point within half a voxel of the other's plane.
    pub smooth: u32,
    /// Pairs where both sides have an outward normal ([`Facing`]).
    pub oriented: u32,
    /// Of those, the pairs at a concave edge: each side's mean point lies in front of the
    /// other side's surface (a box standing beside a box), not behind it (convex: a cylinder's
    /// cap and side) or on it (smooth).
    pub concave: u32,
    /// Of those, the pairs at a convex edge: each side's mean point behind the other's surface.
    pub convex: u32,
}

/// One object's Gaussians in one voxel: sums of their means and of their (sign-aligned) normals.
#[derive(Clone, Copy, Debug)]
struct VoxelPart {
    id: u32,
    mean_sum: Vec3,
    count: u32,
    normal_sum: Vec3,
    flat: u32,
    outward_sum: Vec3,
    outward: u32,
}

impl VoxelPart {
    /// Mean point and unit normal (`None` without flat Gaussians).
    fn surface(&self) -> (Vec3, Option<Vec3>) {
        let mean = self.mean_sum / self.count.max(1) as f32;
        let normal =
            (self.flat > 0).then(|| self.normal_sum.normalize_or_zero()).filter(|n| *n != Vec3::ZERO);
        (mean, normal)
    }

    /// Unit outward normal (`None` without oriented Gaussians).
    fn outward(&self) -> Option<Vec3> {
        (self.outward > 0).then(|| self.outward_sum.normalize_or_zero()).filter(|n| *n != Vec3::ZERO)
    }
}

/// A contact voxel pair is concave when each side's mean point lies in front of the other's
/// surface by at least this share of their distance (sine of ≈ 11.5°).
const CONCAVE_MIN_SINE: f32 = 0.2;

/// Per object id: its dominant surface normal and the share of its flat Gaussians whose normal
/// lies within `max_angle_deg` of it (1 for a plane: a floor, a wall, a piece of either).
pub(crate) fn planarity(
    gaussians: &PreparedGaussians,
    ids: &[i32],
    max_angle_deg: f32,
) -> HashMap<u32, (Vec3, f32)> {
    let flat_normal = |i: usize| -> Option<Vec3> {
        let n = gaussians.normals.get(i).copied()?;
        (gaussians.flatness.get(i).copied().unwrap_or(0.0) >= MIN_FLATNESS && n != Vec3::ZERO).then_some(n)
    };
    let mut sums: HashMap<u32, Vec3> = HashMap::new();
    for (i, &id) in ids.iter().enumerate() {
        let Some(n) = flat_normal(i).filter(|_| id > 0) else { continue };
        let sum = sums.entry(id as u32).or_insert(Vec3::ZERO);
        *sum += if sum.dot(n) < 0.0 { -n } else { n };
    }
    let cos_max = max_angle_deg.to_radians().cos();
    let mut counts: HashMap<u32, (u32, u32)> = HashMap::new();
    for (i, &id) in ids.iter().enumerate() {
        let Some(n) = flat_normal(i).filter(|_| id > 0) else { continue };
        let dominant = sums[&(id as u32)].normalize_or_zero();
        let c = counts.entry(id as u32).or_insert((0, 0));
        c.0 += (n.dot(dominant).abs() >= cos_max) as u32;
        c.1 += 1;
    }
    counts
        .into_iter()
        .map(|(id, (within, all))| (id, (sums[&id].normalize_or_zero(), within as f32 / all as f32)))
        .collect()
}

/// The line an object's Gaussians lie along: their mean, principal axis and spreads.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ObjectLine {
    centre: Vec3,
    axis: Vec3,
    /// Standard deviation along the axis.
    along: f32,
    /// Root mean square spread across the axis (over the two other directions).
    across: f32,
}

impl ObjectLine {
    /// Both thin (spread along ≥ `THIN_MIN_ELONGATION` × across), parallel (axes within
    /// `SEAM_MAX_ANGLE_DEG`) and on one line (each centre within `THIN_LINE_TOLERANCE` × the
    /// larger cross spread of the other's line): two pieces of one post.
    pub(crate) fn continues(&self, other: &ObjectLine, _config: &LiftConfig) -> bool {
        let thin = |l: &ObjectLine| l.along >= THIN_MIN_ELONGATION * l.across;
        let parallel = self.axis.dot(other.axis).abs() >= SEAM_MAX_ANGLE_DEG.to_radians().cos();
        let tolerance = THIN_LINE_TOLERANCE * self.across.max(other.across);
        let off_line = |l: &ObjectLine, p: Vec3| {
            let d = p - l.centre;
            (d - d.dot(l.axis) * l.axis).length()
        };
        thin(self)
            && thin(other)
            && parallel
            && off_line(self, other.centre) <= tolerance
            && off_line(other, self.centre) <= tolerance
    }
}

/// Centres of two pieces of one thin structure lie within this many cross spreads of each
/// other's line.
const THIN_LINE_TOLERANCE: f32 = 2.0;

/// Per object id (of at least 3 Gaussians), the line its Gaussians lie along (principal axis by
/// power iteration on the 3×3 covariance from a fixed start, so the result is deterministic).
pub(crate) fn object_lines(gaussians: &PreparedGaussians, ids: &[i32]) -> HashMap<u32, ObjectLine> {
    // id → (count, Σx, Σxxᵀ as rows), in f64 for the second moments.
    let mut sums: BTreeMap<u32, (u32, glam::DVec3, glam::DMat3)> = BTreeMap::new();
    for (i, &id) in ids.iter().enumerate() {
        if id <= 0 {
            continue;
        }
        let x = gaussians.mean(i).as_dvec3();
        let e = sums.entry(id as u32).or_insert((0, glam::DVec3::ZERO, glam::DMat3::ZERO));
        e.0 += 1;
        e.1 += x;
        e.2 += glam::DMat3::from_cols(x * x.x, x * x.y, x * x.z);
    }
    sums.into_iter()
        .filter(|(_, (n, _, _))| *n >= 3)
        .map(|(id, (n, sum, outer))| {
            let n = n as f64;
            let mean = sum / n;
            let cov = outer * (1.0 / n) - glam::DMat3::from_cols(mean * mean.x, mean * mean.y, mean * mean.z);
            let mut axis = glam::DVec3::new(0.577, 0.578, 0.579);
            for _ in 0..64 {
                axis = (cov * axis).normalize_or_zero();
                if axis == glam::DVec3::ZERO {
                    break;
                }
            }
            let along_var = axis.dot(cov * axis).max(0.0);
            let trace = cov.x_axis.x + cov.y_axis.y + cov.z_axis.z;
            let across_var = ((trace - along_var) / 2.0).max(0.0);
            let line = ObjectLine {
                centre: mean.as_vec3(),
                axis: axis.as_vec3(),
                along: along_var.sqrt() as f32,
                across: across_var.sqrt() as f32,
            };
            (id, line)
        })
        .collect()
}

/// Contacts between object ids: `(a, b)` with `a < b` → what they share.
pub(crate) fn contacts(
    gaussians: &PreparedGaussians,
    ids: &[i32],
    voxel: f32,
    facing: Option<&Facing>,
    _config: &LiftConfig,
) -> BTreeMap<(u32, u32), Contact> {
    let mut cells: HashMap<u64, ([i64; 3], Vec<VoxelPart>)> = HashMap::new();
    for (i, &id) in ids.iter().enumerate() {
        if id <= 0 {
            continue;
        }
        let mean = gaussians.mean(i);
        let v = voxel_of(mean.to_array(), voxel);
        let cell = cells.entry(voxel_key(v)).or_insert_with(|| (v, Vec::new()));
        let part = match cell.1.iter_mut().position(|part| part.id == id as u32) {
            Some(k) => &mut cell.1[k],
            None => {
                let empty = VoxelPart {
                    id: id as u32,
                    mean_sum: Vec3::ZERO,
                    count: 0,
                    normal_sum: Vec3::ZERO,
                    flat: 0,
                    outward_sum: Vec3::ZERO,
                    outward: 0,
                };
                cell.1.push(empty);
                cell.1.last_mut().expect("just pushed")
            }
        };
        part.mean_sum += mean;
        part.count += 1;
        let normal = gaussians.normals.get(i).copied().unwrap_or(Vec3::ZERO);
        if gaussians.flatness.get(i).copied().unwrap_or(0.0) >= MIN_FLATNESS && normal != Vec3::ZERO {
            // Normals have no sign: align each with the voxel's sum so far.
            part.normal_sum += if part.normal_sum.dot(normal) < 0.0 { -normal } else { normal };
            part.flat += 1;
        }
        if let Some(n) = facing.and_then(|f| f.outward_normal(gaussians, i)) {
            part.outward_sum += n;
            part.outward += 1;
        }
    }
    let cos_max_angle = SEAM_MAX_ANGLE_DEG.to_radians().cos();
    let smooth = |a: &VoxelPart, b: &VoxelPart| -> Option<bool> {
        let ((pa, na), (pb, nb)) = (a.surface(), b.surface());
        let (na, nb) = (na?, nb?);
        let d = pb - pa;
        Some(
            na.dot(nb).abs() >= cos_max_angle
                && na.dot(d).abs() <= 0.5 * voxel
                && nb.dot(d).abs() <= 0.5 * voxel,
        )
    };
    // (concave, convex) of a voxel pair whose sides both have outward normals.
    let edge = |a: &VoxelPart, b: &VoxelPart| -> Option<(bool, bool)> {
        let (na, nb) = (a.outward()?, b.outward()?);
        let d = b.surface().0 - a.surface().0;
        let min = CONCAVE_MIN_SINE * d.length();
        let (front_of_a, front_of_b) = (na.dot(d), -nb.dot(d));
        Some((
            min > 0.0 && front_of_a >= min && front_of_b >= min,
            min > 0.0 && front_of_a <= -min && front_of_b <= -min,
        ))
    };
    let mut out: BTreeMap<(u32, u32), Contact> = BTreeMap::new();
    for (v, parts) in cells.values() {
        // Each unordered voxel pair once (and the voxel with itself).
        for n in self_and_forward_neighbours(*v) {
            let Some((_, other)) = cells.get(&voxel_key(n)) else { continue };
            for a in parts {
                for b in other.iter().filter(|b| b.id != a.id) {
                    let c = out.entry((a.id.min(b.id), a.id.max(b.id))).or_default();
                    c.voxel_pairs += 1;
                    if let Some(s) = smooth(a, b) {
                        c.measured += 1;
                        c.smooth += s as u32;
                    }
                    if let Some((concave, convex)) = edge(a, b) {
                        c.oriented += 1;
                        c.concave += concave as u32;
                        c.convex += convex as u32;
                    }
                }
            }
        }
    }
    out
}
