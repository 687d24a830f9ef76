//! Analytic shapes of the synthetic scene: ray intersection, surface classification and surface
//! sampling. World frame: z up, the floor is `z = 0`. Lengths are metres.

use glam::{DVec2, DVec3};
use rand::Rng;

/// Rays closer than this do not count as hits (avoids self-intersection).
const MIN_T: f64 = 1e-6;

/// A point on a shape's surface, with what textures need to colour it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// Position in world coordinates.
    pub position: DVec3,
    /// Unit outward normal in world coordinates.
    pub normal: DVec3,
    /// Position in the shape's local frame: origin at the centre of its base (on the floor for
    /// boxes and cylinders, the lowest point for spheres), z up, x/y turned with the shape's yaw.
    pub local: DVec3,
    /// Which face the point is on (boxes: 0 −x, 1 +x, 2 −y, 3 +y, 4 bottom, 5 top; cylinders:
    /// 0 side, 1 top, 2 bottom; spheres and quads: 0).
    pub face: u8,
    /// Metric 2D coordinates within the face (for checkers and planks).
    pub face_uv: DVec2,
}

/// One analytic shape.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Shape {
    /// A rectangle `origin + s·edge_u + t·edge_v`, `s, t ∈ [0, 1]`; its normal is
    /// `edge_u × edge_v` normalised (floor, walls).
    Quad {
        /// One corner.
        origin: DVec3,
        /// First edge (full length).
        edge_u: DVec3,
        /// Second edge (full length), orthogonal to the first.
        edge_v: DVec3,
    },
    /// A box standing on its base, turned by `yaw` about the vertical axis.
    Cuboid {
        /// Centre of the bottom face.
        base_centre: DVec3,
        /// Full extents along local x, y, z.
        size: DVec3,
        /// Rotation about world z, radians.
        yaw: f64,
    },
    /// A sphere.
    Sphere {
        /// Centre.
        centre: DVec3,
        /// Radius.
        radius: f64,
    },
    /// A vertical closed cylinder.
    Cylinder {
        /// Centre of the bottom cap.
        base_centre: DVec3,
        /// Radius.
        radius: f64,
        /// Height.
        height: f64,
    },
}

/// A rotation about z by `yaw` applied to `v`.
fn rotate_z(v: DVec3, yaw: f64) -> DVec3 {
    let (s, c) = yaw.sin_cos();
    DVec3::new(c * v.x - s * v.y, s * v.x + c * v.y, v.z)
}

impl Shape {
    /// Distance `t` along `origin + t·dir` of the first hit in front of the origin, if any.
    pub fn intersect(&self, origin: DVec3, dir: DVec3) -> Option<f64> {
        match *self {
            Shape::Quad { origin: o, edge_u, edge_v } => intersect_quad(o, edge_u, edge_v, origin, dir),
            Shape::Cuboid { base_centre, size, yaw } => {
                // One sin/cos for both rotations (rotate_z would compute it twice).
                let (sn, cs) = (-yaw).sin_cos();
                let turn = |v: DVec3| DVec3::new(cs * v.x - sn * v.y, sn * v.x + cs * v.y, v.z);
                let lo = turn(origin - base_centre);
                let ld = turn(dir);
                let half = DVec3::new(size.x / 2.0, size.y / 2.0, size.z);
                intersect_slabs(lo, ld, DVec3::new(-half.x, -half.y, 0.0), half)
            }
            Shape::Sphere { centre, radius } => intersect_sphere(centre, radius, origin, dir),
            Shape::Cylinder { base_centre, radius, height } => {
                intersect_cylinder(origin - base_centre, dir, radius, height)
            }
        }
    }

    /// Classifies a world point lying on the surface (face, normal, local coordinates).
    pub fn surface_point(&self, position: DVec3) -> SurfacePoint {
        match *self {
            Shape::Quad { origin, edge_u, edge_v } => {
                let d = position - origin;
                SurfacePoint {
                    position,
                    normal: edge_u.cross(edge_v).normalize(),
                    local: d,
                    face: 0,
                    face_uv: DVec2::new(d.dot(edge_u.normalize()), d.dot(edge_v.normalize())),
                }
            }
            Shape::Cuboid { base_centre, size, yaw } => cuboid_point(base_centre, size, yaw, position),
            Shape::Sphere { centre, radius } => {
                let n = (position - centre).normalize();
                let local = position - centre + DVec3::new(0.0, 0.0, radius);
                let lon = n.y.atan2(n.x) * radius;
                SurfacePoint { position, normal: n, local, face: 0, face_uv: DVec2::new(lon, local.z) }
            }
            Shape::Cylinder { base_centre, radius, height } => {
                cylinder_point(base_centre, radius, height, position)
            }
        }
    }

    /// Points on the surface on a jittered grid of pitch `spacing` (one per cell), with the
    /// faces no camera can see (the bottoms resting on the floor) left out.
    pub fn sample_surface(&self, spacing: f64, rng: &mut impl Rng) -> Vec<SurfacePoint> {
        let mut positions = Vec::new();
        match *self {
            Shape::Quad { origin, edge_u, edge_v } => {
                sample_rect(origin, edge_u, edge_v, spacing, rng, &mut positions)
            }
            Shape::Cuboid { base_centre, size, yaw } => {
                let (ex, ey, ez) =
                    (rotate_z(DVec3::X * size.x, yaw), rotate_z(DVec3::Y * size.y, yaw), DVec3::Z * size.z);
                let c0 = base_centre - ex / 2.0 - ey / 2.0;
                let faces =
                    [(c0, ey, ez), (c0 + ex, ey, ez), (c0, ex, ez), (c0 + ey, ex, ez), (c0 + ez, ex, ey)];
                for (corner, a, b) in faces {
                    sample_rect(corner, a, b, spacing, rng, &mut positions);
                }
            }
            Shape::Sphere { centre, radius } => sample_sphere(centre, radius, spacing, &mut positions),
            Shape::Cylinder { base_centre, radius, height } => {
                sample_cylinder(base_centre, radius, height, spacing, rng, &mut positions)
            }
        }
        positions.into_iter().map(|p| self.surface_point(p)).collect()
    }
}

fn intersect_quad(o: DVec3, eu: DVec3, ev: DVec3, origin: DVec3, dir: DVec3) -> Option<f64> {
    let n = eu.cross(ev);
    let denom = n.dot(dir);
    if denom.abs() < 1e-12 {
        return None;
    }
    let t = n.dot(o - origin) / denom;
    if t <= MIN_T {
        return None;
    }
    let d = origin + dir * t - o;
    let s = d.dot(eu) / eu.length_squared();
    let r = d.dot(ev) / ev.length_squared();
    ((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&r)).then_some(t)
}

fn intersect_slabs(o: DVec3, d: DVec3, lo: DVec3, hi: DVec3) -> Option<f64> {
    let mut t_near = f64::NEG_INFINITY;
    let mut t_far = f64::INFINITY;
    for axis in 0..3 {
        let (oa, da, la, ha) = (o[axis], d[axis], lo[axis], hi[axis]);
        if da.abs() < 1e-15 {
            if oa < la || oa > ha {
                return None;
            }
            continue;
        }
        let (t0, t1) = ((la - oa) / da, (ha - oa) / da);
        t_near = t_near.max(t0.min(t1));
        t_far = t_far.min(t0.max(t1));
    }
    if t_near > t_far {
        return None;
    }
    if t_near > MIN_T {
        Some(t_near)
    } else if t_far > MIN_T {
        Some(t_far)
    } else {
        None
    }
}

fn intersect_sphere(centre: DVec3, radius: f64, origin: DVec3, dir: DVec3) -> Option<f64> {
    let oc = origin - centre;
    let a = dir.length_squared();
    let b = oc.dot(dir);
    let c = oc.length_squared() - radius * radius;
    let disc = b * b - a * c;
    if disc < 0.0 {
        return None;
    }
    let sq = disc.sqrt();
    [(-b - sq) / a, (-b + sq) / a].into_iter().find(|&t| t > MIN_T)
}

/// `o` relative to the base centre.
fn intersect_cylinder(o: DVec3, d: DVec3, radius: f64, height: f64) -> Option<f64> {
    let mut best: Option<f64> = None;
    let mut consider = |t: f64| {
        if t > MIN_T && best.is_none_or(|b| t < b) {
            best = Some(t);
        }
    };
    let a = d.x * d.x + d.y * d.y;
    if a > 1e-15 {
        let b = o.x * d.x + o.y * d.y;
        let c = o.x * o.x + o.y * o.y - radius * radius;
        let disc = b * b - a * c;
        if disc >= 0.0 {
            let sq = disc.sqrt();
            for t in [(-b - sq) / a, (-b + sq) / a] {
                let z = o.z + t * d.z;
                if (0.0..=height).contains(&z) {
                    consider(t);
                }
            }
        }
    }
    if d.z.abs() > 1e-15 {
        for cap in [0.0, height] {
            let t = (cap - o.z) / d.z;
            let p = o + d * t;
            if p.x * p.x + p.y * p.y <= radius * radius {
                consider(t);
            }
        }
    }
    best
}

fn cuboid_point(base_centre: DVec3, size: DVec3, yaw: f64, position: DVec3) -> SurfacePoint {
    let local = rotate_z(position - base_centre, -yaw);
    let half = DVec3::new(size.x / 2.0, size.y / 2.0, size.z / 2.0);
    let centred = local - DVec3::new(0.0, 0.0, half.z);
    let ratios = (centred / half).abs();
    let axis = if ratios.x >= ratios.y && ratios.x >= ratios.z {
        0
    } else if ratios.y >= ratios.z {
        1
    } else {
        2
    };
    let positive = centred[axis] > 0.0;
    let mut n_local = DVec3::ZERO;
    n_local[axis] = if positive { 1.0 } else { -1.0 };
    let face_uv = match axis {
        0 => DVec2::new(local.y, local.z),
        1 => DVec2::new(local.x, local.z),
        _ => DVec2::new(local.x, local.y),
    };
    SurfacePoint {
        position,
        normal: rotate_z(n_local, yaw),
        local,
        face: (2 * axis + usize::from(positive)) as u8,
        face_uv,
    }
}

fn cylinder_point(base_centre: DVec3, radius: f64, height: f64, position: DVec3) -> SurfacePoint {
    let local = position - base_centre;
    let radial = (local.x * local.x + local.y * local.y).sqrt();
    let d_side = (radial - radius).abs();
    let d_top = (local.z - height).abs();
    let d_bottom = local.z.abs();
    let (face, normal) = if d_side <= d_top && d_side <= d_bottom {
        (0, DVec3::new(local.x, local.y, 0.0).normalize_or(DVec3::X))
    } else if d_top <= d_bottom {
        (1, DVec3::Z)
    } else {
        (2, -DVec3::Z)
    };
    let face_uv = if face == 0 {
        DVec2::new(local.y.atan2(local.x) * radius, local.z)
    } else {
        DVec2::new(local.x, local.y)
    };
    SurfacePoint { position, normal, local, face, face_uv }
}

fn sample_rect(corner: DVec3, eu: DVec3, ev: DVec3, spacing: f64, rng: &mut impl Rng, out: &mut Vec<DVec3>) {
    let nu = (eu.length() / spacing).ceil().max(1.0) as usize;
    let nv = (ev.length() / spacing).ceil().max(1.0) as usize;
    for j in 0..nv {
        for i in 0..nu {
            let s = (i as f64 + rng.gen_range(0.15..0.85)) / nu as f64;
            let t = (j as f64 + rng.gen_range(0.15..0.85)) / nv as f64;
            out.push(corner + eu * s + ev * t);
        }
    }
}

/// Fibonacci-lattice points (evenly spread; deterministic without jitter).
fn sample_sphere(centre: DVec3, radius: f64, spacing: f64, out: &mut Vec<DVec3>) {
    let area = 4.0 * std::f64::consts::PI * radius * radius;
    let n = (area / (spacing * spacing)).ceil().max(8.0) as usize;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let r = (1.0 - z * z).sqrt();
        let phi = golden * i as f64;
        let p = DVec3::new(r * phi.cos(), r * phi.sin(), z);
        if p.z > -0.97 {
            out.push(centre + p * radius);
        }
    }
}

fn sample_cylinder(
    base_centre: DVec3,
    radius: f64,
    height: f64,
    spacing: f64,
    rng: &mut impl Rng,
    out: &mut Vec<DVec3>,
) {
    let circumference = std::f64::consts::TAU * radius;
    let na = (circumference / spacing).ceil().max(6.0) as usize;
    let nh = (height / spacing).ceil().max(1.0) as usize;
    for j in 0..nh {
        for i in 0..na {
            let angle = (i as f64 + rng.gen_range(0.15..0.85)) / na as f64 * std::f64::consts::TAU;
            let z = (j as f64 + rng.gen_range(0.15..0.85)) / nh as f64 * height;
            out.push(base_centre + DVec3::new(radius * angle.cos(), radius * angle.sin(), z));
        }
    }
    let mut cap = Vec::new();
    let corner = base_centre + DVec3::new(-radius, -radius, height);
    sample_rect(corner, DVec3::X * 2.0 * radius, DVec3::Y * 2.0 * radius, spacing, rng, &mut cap);
    let inner = radius * 0.97;
    out.extend(cap.into_iter().filter(|p| {
        let d = *p - base_centre;
        d.x * d.x + d.y * d.y <= inner * inner
    }));
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn shapes() -> Vec<Shape> {
        vec![
            Shape::Quad {
                origin: DVec3::new(-1.0, -1.0, 0.0),
                edge_u: DVec3::X * 2.0,
                edge_v: DVec3::Y * 2.0,
            },
            Shape::Cuboid {
                base_centre: DVec3::new(0.2, 0.1, 0.0),
                size: DVec3::new(0.5, 0.3, 0.7),
                yaw: 0.4,
            },
            Shape::Sphere { centre: DVec3::new(0.0, 0.3, 0.5), radius: 0.4 },
            Shape::Cylinder { base_centre: DVec3::new(-0.3, 0.0, 0.0), radius: 0.3, height: 0.9 },
        ]
    }

    #[test]
    fn rays_towards_surface_samples_hit_them_first() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let eye = DVec3::new(2.5, 2.0, 2.2);
        for shape in shapes() {
            let samples = shape.sample_surface(0.05, &mut rng);
            assert!(samples.len() > 50);
            let mut front = 0;
            for sp in &samples {
                let to = sp.position - eye;
                let dir = to.normalize();
                let t = shape.intersect(eye, dir).expect("ray towards a surface point hits");
                assert!(t <= to.length() + 1e-9, "hit beyond the sampled point");
                if sp.normal.dot(-dir) > 0.05 {
                    front += 1;
                    assert!((t - to.length()).abs() < 1e-7, "facing sample not the first hit");
                }
            }
            assert!(front > 10);
        }
    }

    #[test]
    fn normals_are_unit_and_outward() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
        for shape in shapes().into_iter().skip(1) {
            for sp in shape.sample_surface(0.05, &mut rng) {
                assert!((sp.normal.length() - 1.0).abs() < 1e-9);
                let far = sp.position + sp.normal * 100.0;
                // From far outside along the normal, the surface is hit at (about) the sample.
                let t = shape.intersect(far, -sp.normal).expect("hit");
                assert!((far - sp.normal * t - sp.position).length() < 2e-3, "{shape:?} {sp:?}");
            }
        }
    }

    #[test]
    fn cuboid_faces_are_classified_by_side() {
        let shape = Shape::Cuboid { base_centre: DVec3::ZERO, size: DVec3::new(1.0, 2.0, 3.0), yaw: 0.0 };
        assert_eq!(shape.surface_point(DVec3::new(0.5, 0.1, 1.0)).face, 1);
        assert_eq!(shape.surface_point(DVec3::new(-0.5, 0.1, 1.0)).face, 0);
        assert_eq!(shape.surface_point(DVec3::new(0.1, -1.0, 1.0)).face, 2);
        assert_eq!(shape.surface_point(DVec3::new(0.1, 0.2, 3.0)).face, 5);
    }
}
