//! What the Gaussians' 3D shape says about objects, for the joins of [`crate::touching`] and the
//! split of [`crate::split`]: the typical Gaussian size, which objects are planes, the line a
//! thin object lies along, and what two objects share where they touch (voxel pairs, smooth,
//! concave and convex contacts).

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
/// [`SEAM_MAX_ANGLE_DEG`] of its normal, or this share of its Gaussians' centres within half a
/// voxel of the plane fitted to them; a seam is smooth when this share of its measured contact
/// voxel pairs is.
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
    median(&mut s)
}

/// The median of `values` (the upper one of an even count; 0 when empty), reordering them.
fn median(values: &mut [f32]) -> f32 {
    if values.is_empty() {
        return 0.0;
    }
    let mid = values.len() / 2;
    *values.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1
}

/// What two objects share in 3D (see [`contacts`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Contact {
    /// Pairs of 26-neighbouring voxels holding one of each.
    pub voxel_pairs: u32,
    /// Of those, the pairs where both sides have a surface normal (flat Gaussians) or both
    /// objects a plane fitted to their centres ([`ObjectPlane`]).
    pub measured: u32,
    /// Of the measured pairs, those where the two surfaces continue each other: normals within
    /// `SEAM_MAX_ANGLE_DEG` and each side's mean point within half a voxel of the other's tangent
    /// plane, or both sides' mean points within half a voxel of one of the two objects' fitted
    /// planes (the better-fitted one holds both where a small piece's own plane is tilted by its
    /// noise or by a few stray Gaussians).
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

/// One object's plane, as its Gaussians' shortest axes and as their centres say.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ObjectPlane {
    /// Unit normal (no sign): the flat Gaussians' dominant normal where they agree, else the
    /// centres' direction of least spread.
    pub normal: Vec3,
    /// The centres' mean (a point of the plane fitted to them).
    pub centre: Vec3,
    /// The fitted plane's unit normal (the centres' direction of least spread).
    fitted: Vec3,
    /// Share of the flat Gaussians whose normal lies within `SEAM_MAX_ANGLE_DEG` of the dominant
    /// one (1 for a plane reconstructed with exact normals).
    pub by_normals: f32,
    /// Share of the Gaussians whose centre lies within half a voxel of the fitted plane (1 for a
    /// plane whatever its Gaussians' orientations).
    pub by_centres: f32,
}

impl ObjectPlane {
    /// A plane by either evidence: a floor, a wall, a piece of either.
    pub(crate) fn is_plane(&self) -> bool {
        self.normal != Vec3::ZERO
            && (self.by_normals >= SEAM_SMOOTH_SHARE || self.by_centres >= SEAM_SMOOTH_SHARE)
    }

    /// Distance of `p` from the plane fitted to the centres.
    fn fitted_distance(&self, p: Vec3) -> f32 {
        self.fitted.dot(p - self.centre).abs()
    }

    /// Distance of `p` from the fitted plane, when the centres make one.
    fn centres_distance(&self, p: Vec3) -> Option<f32> {
        (self.by_centres >= SEAM_SMOOTH_SHARE && self.fitted != Vec3::ZERO).then(|| self.fitted_distance(p))
    }

    /// Both planes with normals within `SEAM_MAX_ANGLE_DEG`.
    pub(crate) fn coplanar(&self, other: &ObjectPlane) -> bool {
        self.is_plane()
            && other.is_plane()
            && self.normal.dot(other.normal).abs() >= SEAM_MAX_ANGLE_DEG.to_radians().cos()
    }
}

/// True when objects `a` and `b` both have a plane in `planes` and the two are coplanar
/// ([`ObjectPlane::coplanar`]).
pub(crate) fn coplanar_ids(planes: &HashMap<u32, ObjectPlane>, a: u32, b: u32) -> bool {
    matches!((planes.get(&a), planes.get(&b)), (Some(p), Some(q)) if p.coplanar(q))
}

/// Per object id (of at least 3 Gaussians): its plane by two evidences (see [`ObjectPlane`]).
/// The Gaussians' shortest axes say it where a reconstruction leaves them on the surface's
/// normal; a trained 3DGS scatters them by tens of degrees (the `rough` families), and there
/// the centres, which lie on the surface within a fraction of a Gaussian, say it.
pub(crate) fn planarity(gaussians: &PreparedGaussians, ids: &[i32], voxel: f32) -> HashMap<u32, ObjectPlane> {
    planes_of(gaussians, ids, voxel, &centre_moments(gaussians, ids))
}

/// Per object id, its plane ([`planarity`]) and its line ([`ObjectLine`]), from one pass over
/// the centres' moments.
pub(crate) fn planes_and_lines(
    gaussians: &PreparedGaussians,
    ids: &[i32],
    voxel: f32,
) -> (HashMap<u32, ObjectPlane>, HashMap<u32, ObjectLine>) {
    let moments = centre_moments(gaussians, ids);
    let lines = robust_lines(gaussians, ids, &moments);
    (planes_of(gaussians, ids, voxel, &moments), lines)
}

/// A Gaussian lies on its object's line when it is within this many times the median distance of
/// the object's Gaussians from the line.
const LINE_INLIER_FACTOR: f32 = 3.0;

/// Share of an object's Gaussians that must lie on its line for the line to be fitted to them
/// alone.
const LINE_MIN_INLIER_SHARE: f32 = 0.9;

/// The lines of the objects (first fitted to all of each object's Gaussians, [`lines_of`]) fitted again to the Gaussians
/// that lie on them ([`LINE_INLIER_FACTOR`]), where those are at least [`LINE_MIN_INLIER_SHARE`]
/// of the object's: a few stray Gaussians (a label spilled onto the floor at a post's foot, a
/// floater) widen a line's cross spread by moments alone (a post's 0.016 m to 0.10 m with 3 of
/// 155 Gaussians on the floor, thin seed 3), and the post then is no thin structure.
fn robust_lines(
    gaussians: &PreparedGaussians,
    ids: &[i32],
    moments: &BTreeMap<u32, Moments>,
) -> HashMap<u32, ObjectLine> {
    let first = lines_of(moments);
    let mut distances: BTreeMap<u32, Vec<f32>> = BTreeMap::new();
    for (i, &id) in ids.iter().enumerate() {
        if let Some(line) = (id > 0).then(|| first.get(&(id as u32))).flatten() {
            distances.entry(id as u32).or_default().push(line.distance(gaussians.mean(i)));
        }
    }
    let limits: HashMap<u32, f32> =
        distances.into_iter().map(|(id, mut d)| (id, LINE_INLIER_FACTOR * median(&mut d))).collect();
    let mut inliers: BTreeMap<u32, Moments> = BTreeMap::new();
    for (i, &id) in ids.iter().enumerate() {
        let Some((line, limit)) =
            (id > 0).then(|| first.get(&(id as u32)).zip(limits.get(&(id as u32)))).flatten()
        else {
            continue;
        };
        let x = gaussians.mean(i);
        if line.distance(x) <= *limit {
            inliers.entry(id as u32).or_insert_with(Moments::empty).add(x.as_dvec3());
        }
    }
    let refitted = lines_of(&inliers);
    first
        .iter()
        .map(|(&id, &line)| {
            let total = moments.get(&id).map_or(0, |m| m.count);
            let kept = inliers.get(&id).map_or(0, |m| m.count);
            let holds = kept as f32 >= LINE_MIN_INLIER_SHARE * total as f32;
            (id, if holds { refitted.get(&id).copied().unwrap_or(line) } else { line })
        })
        .collect()
}

/// [`planarity`] from the objects' centre `moments`.
fn planes_of(
    gaussians: &PreparedGaussians,
    ids: &[i32],
    voxel: f32,
    moments: &BTreeMap<u32, Moments>,
) -> HashMap<u32, ObjectPlane> {
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
    let mut planes: HashMap<u32, ObjectPlane> = moments
        .iter()
        .filter(|(_, m)| m.count >= 3)
        .map(|(&id, m)| {
            let (mean, cov) = m.mean_and_covariance();
            let first = principal_axis(cov);
            let outer = glam::DMat3::from_cols(first * first.x, first * first.y, first * first.z);
            let second = principal_axis(cov - outer * first.dot(cov * first));
            let fitted = first.cross(second).normalize_or_zero().as_vec3();
            let dominant = sums.get(&id).map_or(Vec3::ZERO, |s| s.normalize_or_zero());
            let plane = ObjectPlane {
                normal: dominant,
                centre: mean.as_vec3(),
                fitted,
                by_normals: 0.0,
                by_centres: 0.0,
            };
            (id, plane)
        })
        .collect();
    let cos_max = SEAM_MAX_ANGLE_DEG.to_radians().cos();
    // id → (normals within, flat Gaussians, centres within, Gaussians).
    let mut counts: HashMap<u32, [u32; 4]> = HashMap::new();
    for (i, &id) in ids.iter().enumerate() {
        let Some(plane) = (id > 0).then(|| planes.get(&(id as u32))).flatten() else { continue };
        let c = counts.entry(id as u32).or_insert([0; 4]);
        if let Some(n) = flat_normal(i) {
            c[0] += (n.dot(plane.normal).abs() >= cos_max) as u32;
            c[1] += 1;
        }
        c[2] += (plane.fitted_distance(gaussians.mean(i)) <= 0.5 * voxel) as u32;
        c[3] += 1;
    }
    for (id, plane) in planes.iter_mut() {
        let c = counts.get(id).copied().unwrap_or([0; 4]);
        plane.by_normals = if c[1] > 0 { c[0] as f32 / c[1] as f32 } else { 0.0 };
        plane.by_centres = if c[3] > 0 { c[2] as f32 / c[3] as f32 } else { 0.0 };
        if plane.by_normals < SEAM_SMOOTH_SHARE {
            plane.normal = plane.fitted;
        }
    }
    planes
}

/// Count, sum and sum of outer products of one object's Gaussians' centres (f64).
#[derive(Clone, Copy)]
struct Moments {
    count: u32,
    sum: glam::DVec3,
    outer: glam::DMat3,
}

impl Moments {
    fn empty() -> Moments {
        Moments { count: 0, sum: glam::DVec3::ZERO, outer: glam::DMat3::ZERO }
    }

    fn add(&mut self, x: glam::DVec3) {
        self.count += 1;
        self.sum += x;
        self.outer += glam::DMat3::from_cols(x * x.x, x * x.y, x * x.z);
    }

    fn mean_and_covariance(&self) -> (glam::DVec3, glam::DMat3) {
        let n = self.count.max(1) as f64;
        let mean = self.sum / n;
        (mean, self.outer * (1.0 / n) - glam::DMat3::from_cols(mean * mean.x, mean * mean.y, mean * mean.z))
    }
}

/// Per object id, the moments of its Gaussians' centres (ids ≤ 0 left out).
fn centre_moments(gaussians: &PreparedGaussians, ids: &[i32]) -> BTreeMap<u32, Moments> {
    let mut sums: BTreeMap<u32, Moments> = BTreeMap::new();
    for (i, &id) in ids.iter().enumerate() {
        if id <= 0 {
            continue;
        }
        sums.entry(id as u32).or_insert_with(Moments::empty).add(gaussians.mean(i).as_dvec3());
    }
    sums
}

/// The unit eigenvector of the largest eigenvalue of the symmetric `cov`, by power iteration
/// from a fixed start (deterministic; zero for a zero matrix).
fn principal_axis(cov: glam::DMat3) -> glam::DVec3 {
    let mut axis = glam::DVec3::new(0.577, 0.578, 0.579);
    for _ in 0..64 {
        axis = (cov * axis).normalize_or_zero();
        if axis == glam::DVec3::ZERO {
            break;
        }
    }
    axis
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
    pub(crate) fn continues(&self, other: &ObjectLine) -> bool {
        let thin = |l: &ObjectLine| l.along >= THIN_MIN_ELONGATION * l.across;
        let parallel = self.axis.dot(other.axis).abs() >= SEAM_MAX_ANGLE_DEG.to_radians().cos();
        let tolerance = THIN_LINE_TOLERANCE * self.across.max(other.across);
        thin(self)
            && thin(other)
            && parallel
            && self.distance(other.centre) <= tolerance
            && other.distance(self.centre) <= tolerance
    }

    /// Distance of `p` from the line.
    fn distance(&self, p: Vec3) -> f32 {
        let d = p - self.centre;
        (d - d.dot(self.axis) * self.axis).length()
    }
}

/// Centres of two pieces of one thin structure lie within this many cross spreads of each
/// other's line.
const THIN_LINE_TOLERANCE: f32 = 2.0;

/// Per object id (of at least 3 Gaussians) in `moments` (its centres' moments), the line its
/// Gaussians lie along (principal axis by power iteration on the 3×3 covariance from a fixed
/// start, so the result is deterministic).
fn lines_of(moments: &BTreeMap<u32, Moments>) -> HashMap<u32, ObjectLine> {
    moments
        .iter()
        .filter(|(_, m)| m.count >= 3)
        .map(|(&id, m)| {
            let (mean, cov) = m.mean_and_covariance();
            let axis = principal_axis(cov);
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
    planes: &HashMap<u32, ObjectPlane>,
    facing: Option<&Facing>,
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
    // By the two sides' normals (each side's mean point on the other's tangent plane), or by the
    // objects' fitted planes (both sides' mean points on one of them): either evidence measures
    // the pair, and either says when one surface continues across it.
    let by_normals = |a: &VoxelPart, b: &VoxelPart| -> Option<bool> {
        let ((pa, na), (pb, nb)) = (a.surface(), b.surface());
        let (na, nb) = (na?, nb?);
        let d = pb - pa;
        Some(
            na.dot(nb).abs() >= cos_max_angle
                && na.dot(d).abs() <= 0.5 * voxel
                && nb.dot(d).abs() <= 0.5 * voxel,
        )
    };
    let by_centres = |a: &VoxelPart, b: &VoxelPart| -> Option<bool> {
        let (qa, qb) = (planes.get(&a.id)?, planes.get(&b.id)?);
        let (pa, pb) = (a.surface().0, b.surface().0);
        let holds_both = |q: &ObjectPlane| -> Option<bool> {
            Some(q.centres_distance(pa)? <= 0.5 * voxel && q.centres_distance(pb)? <= 0.5 * voxel)
        };
        Some(holds_both(qa)? || holds_both(qb)?)
    };
    let smooth = |a: &VoxelPart, b: &VoxelPart| -> Option<bool> {
        match (by_normals(a, b), by_centres(a, b)) {
            (None, None) => None,
            (n, c) => Some(n == Some(true) || c == Some(true)),
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;
    use splatseg_scene::Gaussians;

    /// Flat Gaussians (σ 0.03, 0.03, 0.003) at `points`, each disc's normal tilted off its
    /// surface's by up to `tilt_deg` (a fixed pattern of directions), as a trained 3DGS leaves a
    /// floor's; `tilt_deg` 0 gives discs lying in the xy plane.
    fn discs(points: &[[f32; 3]], tilt_deg: f32) -> PreparedGaussians {
        let n = points.len();
        let rotations = (0..n)
            .map(|i| {
                let axis = Vec3::new((i as f32 * 2.39).cos(), (i as f32 * 2.39).sin(), 0.0);
                let angle = tilt_deg.to_radians() * ((i * 7 % 11) as f32 / 10.0);
                let q = Quat::from_axis_angle(axis, angle);
                [q.w, q.x, q.y, q.z]
            })
            .collect();
        let g = Gaussians {
            means: points.to_vec(),
            normals: None,
            sh_dc: vec![[0.0; 3]; n],
            sh_degree: 0,
            sh_rest: Vec::new(),
            raw_opacities: vec![2.0; n],
            log_scales: vec![[0.03f32.ln(), 0.03f32.ln(), 0.003f32.ln()]; n],
            rotations,
            object_ids: None,
            features: None,
            extra: Vec::new(),
        };
        PreparedGaussians::new(&g).expect("finite")
    }

    /// A grid of `k × k` points 0.02 apart from `origin` along `u` and `v`.
    fn grid(origin: Vec3, u: Vec3, v: Vec3, k: usize) -> Vec<[f32; 3]> {
        (0..k * k).map(|i| (origin + 0.02 * ((i % k) as f32 * u + (i / k) as f32 * v)).to_array()).collect()
    }

    /// Two pieces (ids 1 and 2, split at x = 0.2) of one floor of discs tilted up to `tilt_deg`.
    fn floor_in_two_pieces(tilt_deg: f32) -> (PreparedGaussians, Vec<i32>) {
        let floor = grid(Vec3::ZERO, Vec3::X, Vec3::Y, 20);
        let ids = floor.iter().map(|p| if p[0] < 0.19 { 1 } else { 2 }).collect();
        (discs(&floor, tilt_deg), ids)
    }

    #[test]
    fn a_floor_is_one_plane_by_its_normals_when_exact_and_by_its_centres_when_tilted() {
        let voxel = 0.06;
        for (tilt, exact) in [(0.0, true), (30.0, false)] {
            let (g, ids) = floor_in_two_pieces(tilt);
            let planes = planarity(&g, &ids, voxel);
            for id in [1, 2] {
                let p = planes[&id];
                assert_eq!(p.by_normals >= SEAM_SMOOTH_SHARE, exact, "tilt {tilt}, piece {id}: {p:?}");
                assert!(p.by_centres >= SEAM_SMOOTH_SHARE && p.is_plane(), "tilt {tilt}, piece {id}: {p:?}");
                assert!(p.normal.z.abs() > 0.999, "tilt {tilt}, piece {id}: {p:?}");
            }
            assert!(planes[&1].coplanar(&planes[&2]));
            let c = contacts(&g, &ids, voxel, &planes, None)[&(1, 2)];
            assert!(c.measured >= 8 && c.smooth == c.measured, "tilt {tilt}: {c:?}");
        }
    }

    /// Points on a ring of radius 0.015 m around the y axis (6 per row, rows 0.02 m apart) from
    /// `y0`, for `rows` rows: a post 2–4 px wide in a 320×240 view.
    fn post(y0: f32, rows: usize) -> Vec<[f32; 3]> {
        (0..rows * 6)
            .map(|i| {
                let a = (i % 6) as f32 * std::f32::consts::PI / 3.0;
                [0.015 * a.cos(), y0 + (i / 6) as f32 * 0.02, 0.015 * a.sin()]
            })
            .collect()
    }

    #[test]
    fn a_post_is_a_thin_line_whatever_a_few_stray_gaussians_of_its_id_say() {
        // One post cut at y = 0.6 (objects 1 and 2); object 1 also holds 4 Gaussians on the floor
        // half a metre from its foot (its label spilled there: 2 % of the piece).
        let mut points = post(0.0, 30);
        points.extend([[0.5, 0.0, 0.0], [-0.5, 0.0, 0.0], [0.0, 0.0, 0.5], [0.0, 0.0, -0.5]]);
        let lower = points.len();
        points.extend(post(0.6, 30));
        let ids: Vec<i32> = (0..points.len()).map(|i| if i < lower { 1 } else { 2 }).collect();
        let g = discs(&points, 0.0);
        let (_, lines) = planes_and_lines(&g, &ids, 0.03);
        assert!(lines[&1].continues(&lines[&2]), "{:?} {:?}", lines[&1], lines[&2]);
        assert!(lines[&1].across < 0.02, "the strays are left out of the fit: {:?}", lines[&1]);
        // By its centres' moments alone, the four strays widen the piece threefold: no thin line.
        let by_moments = lines_of(&centre_moments(&g, &ids));
        assert!(by_moments[&1].across > 0.04, "{:?}", by_moments[&1]);
        assert!(!by_moments[&1].continues(&by_moments[&2]));

        // Half a piece off the line is not a few strays: a post standing on a piece of floor of
        // as many Gaussians under one id is no thin line.
        let mut points = post(0.0, 30);
        points.extend((0..180).map(|i| [0.1 + 0.02 * (i % 14) as f32, 0.0, 0.1 + 0.02 * (i / 14) as f32]));
        let lower = points.len();
        points.extend(post(0.6, 30));
        let ids: Vec<i32> = (0..points.len()).map(|i| if i < lower { 1 } else { 2 }).collect();
        let (_, lines) = planes_and_lines(&discs(&points, 0.0), &ids, 0.03);
        assert!(!lines[&1].continues(&lines[&2]), "{:?}", lines[&1]);
    }

    #[test]
    fn a_box_corner_is_no_plane_and_a_step_is_no_smooth_seam() {
        let voxel = 0.06;
        // A floor piece and a wall meeting at 90° under one id is no plane by either evidence.
        let mut corner = grid(Vec3::ZERO, Vec3::X, Vec3::Y, 12);
        corner.extend(grid(Vec3::ZERO, Vec3::X, Vec3::Z, 12));
        let planes = planarity(&discs(&corner, 30.0), &vec![1; corner.len()], voxel);
        assert!(!planes[&1].is_plane(), "{:?}", planes[&1]);
        // Two parallel planes a voxel apart (a step), touching at their edges: both planes,
        // coplanar, but no contact is smooth.
        let mut step = grid(Vec3::ZERO, Vec3::X, Vec3::Y, 10);
        step.extend(grid(Vec3::new(0.19, 0.0, voxel), Vec3::X, Vec3::Y, 10));
        let ids: Vec<i32> = (0..step.len()).map(|i| if i < 100 { 1 } else { 2 }).collect();
        let g = discs(&step, 30.0);
        let planes = planarity(&g, &ids, voxel);
        assert!(planes[&1].coplanar(&planes[&2]));
        let c = contacts(&g, &ids, voxel, &planes, None)[&(1, 2)];
        assert!(c.measured >= 8 && c.smooth == 0, "{c:?}");
    }
}
