//! The random layout of the stress families: the room (ids 1–3), then the white-on-white pair
//! and the same-depth pair (always), large foreground objects near the cameras, stacked
//! objects, touching pairs, thin posts and ordinary objects until the drawn count is reached,
//! each placed at random where its footprint (a circle on the floor) keeps clear of the others.
//!
//! Placement uses the view-aligned coordinates of [`crate::layout`] (`a` to the right in the
//! middle view, `b` away from the cameras; the cameras are at `b ≈ −4.3`).

use crate::classes::FailureClass;
use crate::config::SynthConfig;
use crate::geometry::Shape;
use crate::layout::{object, room, world_xy, HardCase, ObjectKind, SceneObject, LATERAL_YAW, WALL_AT, WHITE};
use crate::noise::{hash, rng_for, stream};
use crate::texture::{Rgb, Texture};
use glam::{DVec2, DVec3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// Gap kept between footprints of objects that must not touch, metres.
const GAP_M: f64 = 0.04;
/// Footprint radius a thin post claims when placed (independent of its drawn radius, so a
/// scene at another resolution gets the same layout).
const POST_FOOTPRINT_M: f64 = 0.07;
/// Placement attempts per object before giving up on it.
const ATTEMPTS: usize = 200;
/// Thin posts stand within this distance of the scene centre, where their distance to every
/// camera stays within ±25 % of the orbit radius (so their width stays 2–4 px).
const POST_REGION_M: f64 = 0.9;

/// Where the objects placed so far stand: circles on the floor (world xy).
#[derive(Default)]
struct Floorplan {
    taken: Vec<(DVec2, f64)>,
}

impl Floorplan {
    /// True when a circle fits inside the room and keeps clear of the others.
    fn fits(&self, centre: DVec2, radius: f64) -> bool {
        let inside = centre.x - radius > WALL_AT + 0.05 && centre.y - radius > WALL_AT + 0.05;
        inside && self.taken.iter().all(|&(c, r)| (c - centre).length() > r + radius + GAP_M)
    }
    fn take(&mut self, centre: DVec2, radius: f64) {
        self.taken.push((centre, radius));
    }
}

/// A rectangle of view-aligned `(a, b)`.
#[derive(Clone, Copy)]
struct Region {
    a: (f64, f64),
    b: (f64, f64),
    /// Only the disc of radius `a.1` around the centre.
    disc: bool,
}

/// Where ordinary objects go.
const MAIN: Region = Region { a: (-2.1, 2.1), b: (-1.4, 1.9), disc: false };

fn xy(p: DVec3) -> DVec2 {
    DVec2::new(p.x, p.y)
}

/// A random colour clearly away from white and from grey.
fn colour(rng: &mut ChaCha8Rng) -> Rgb {
    let hue = rng.gen_range(0.0..1.0f64);
    let sat = rng.gen_range(0.4..0.85);
    let val = rng.gen_range(0.35..0.85);
    let rgb_of = |n: f64| {
        let k = (n + hue * 6.0) % 6.0;
        val - val * sat * k.min(4.0 - k).clamp(0.0, 1.0)
    };
    [rgb_of(5.0), rgb_of(3.0), rgb_of(1.0)]
}

/// An ordinary object's texture; `height` is the object's height (for two tones).
/// `pattern_scale` multiplies the stripe period and checker cell.
fn texture(
    rng: &mut ChaCha8Rng,
    multi_tone_share: f64,
    pattern_scale: f64,
    height: f64,
    seed: u64,
) -> Texture {
    if rng.gen_bool(multi_tone_share.clamp(0.0, 1.0)) {
        let (a, b) = (colour(rng), colour(rng));
        if rng.gen_bool(0.5) {
            Texture::Stripes { a, b, period_m: rng.gen_range(0.1..0.3) * pattern_scale }
        } else {
            Texture::TwoTone { bottom: a, top: b, split_m: height * rng.gen_range(0.35..0.65) }
        }
    } else {
        match rng.gen_range(0..10) {
            0..=5 => Texture::Plain { albedo: colour(rng) },
            6 | 7 => Texture::Checkers {
                a: colour(rng),
                b: colour(rng),
                cell_m: rng.gen_range(0.05..0.15) * pattern_scale,
            },
            _ => {
                let base = colour(rng);
                let blotch = base.map(|c| c * 0.7);
                Texture::Blotches { base, blotch, frequency: rng.gen_range(4.0..8.0), seed }
            }
        }
    }
}

/// One object to place, with its footprint relative to its anchor.
struct Piece {
    name: String,
    kind: ObjectKind,
    shape: Shape,
    texture: Texture,
    tags: Vec<HardCase>,
    design: Vec<FailureClass>,
}

/// A random standalone shape standing on the floor at the origin: (kind, shape, footprint
/// radius, height).
fn random_shape(rng: &mut ChaCha8Rng, base: DVec3) -> (ObjectKind, Shape, f64, f64) {
    match rng.gen_range(0..3) {
        0 => {
            let size = DVec3::new(rng.gen_range(0.3..0.7), rng.gen_range(0.3..0.7), rng.gen_range(0.3..0.9));
            let shape = Shape::Cuboid { base_centre: base, size, yaw: rng.gen_range(0.0..PI) };
            (ObjectKind::Box, shape, 0.5 * size.x.hypot(size.y), size.z)
        }
        1 => {
            let r = rng.gen_range(0.18..0.35);
            (ObjectKind::Sphere, Shape::Sphere { centre: base + DVec3::Z * r, radius: r }, r, 2.0 * r)
        }
        _ => {
            let (r, h) = (rng.gen_range(0.15..0.32), rng.gen_range(0.4..1.2));
            (ObjectKind::Cylinder, Shape::Cylinder { base_centre: base, radius: r, height: h }, r, h)
        }
    }
}

/// Moves a shape by `d`.
fn shifted(shape: &Shape, d: DVec3) -> Shape {
    match shape.clone() {
        Shape::Cuboid { base_centre, size, yaw } => Shape::Cuboid { base_centre: base_centre + d, size, yaw },
        Shape::Sphere { centre, radius } => Shape::Sphere { centre: centre + d, radius },
        Shape::Cylinder { base_centre, radius, height } => {
            Shape::Cylinder { base_centre: base_centre + d, radius, height }
        }
        q @ Shape::Quad { .. } => q,
    }
}

struct Builder<'a> {
    rng: ChaCha8Rng,
    plan: Floorplan,
    objects: Vec<SceneObject>,
    config: &'a SynthConfig,
}

impl Builder<'_> {
    /// Places a group of pieces built around the origin anywhere in `region`, where its
    /// footprint circles (centre relative to the origin, radius) are free; false when no spot
    /// was.
    fn place(&mut self, region: Region, footprint: &[(DVec2, f64)], pieces: Vec<Piece>) -> bool {
        for _ in 0..ATTEMPTS {
            let a = self.rng.gen_range(region.a.0..=region.a.1);
            let b = self.rng.gen_range(region.b.0..=region.b.1);
            if region.disc && a.hypot(b) > region.a.1 {
                continue;
            }
            let anchor = world_xy(a, b);
            if footprint.iter().all(|&(c, r)| self.plan.fits(xy(anchor) + c, r)) {
                for &(c, r) in footprint {
                    self.plan.take(xy(anchor) + c, r);
                }
                for p in pieces {
                    let id = self.objects.len() as u32 + 1;
                    let mut o = object(id, &p.name, p.kind, shifted(&p.shape, anchor), p.texture, &p.tags);
                    o.design = p.design;
                    self.objects.push(o);
                }
                return true;
            }
        }
        false
    }

    fn texture_seed(&self) -> u64 {
        hash(self.config.seed, &[stream::TEXTURE, self.objects.len() as u64])
    }

    /// The white box with the white cylinder ~1.5 m behind it (touching in the image).
    fn white_pair(&mut self) {
        let r = &mut self.rng;
        let size = DVec3::new(r.gen_range(0.5..0.6), r.gen_range(0.5..0.6), r.gen_range(0.62..0.78));
        let box_shape = Shape::Cuboid { base_centre: DVec3::ZERO, size, yaw: r.gen_range(0.6..1.0) };
        let behind = world_xy(r.gen_range(0.0..0.25), r.gen_range(1.4..1.7));
        let (radius, height) = (r.gen_range(0.26..0.34), r.gen_range(1.05..1.25));
        let cylinder = Shape::Cylinder { base_centre: behind, radius, height };
        let tags = vec![HardCase::WhiteOnWhite];
        let pieces = vec![
            Piece {
                name: "white_box".into(),
                kind: ObjectKind::Box,
                shape: box_shape,
                texture: Texture::Plain { albedo: WHITE },
                tags: tags.clone(),
                design: vec![],
            },
            Piece {
                name: "white_cylinder".into(),
                kind: ObjectKind::Cylinder,
                shape: cylinder,
                texture: Texture::Plain { albedo: WHITE },
                tags,
                design: vec![],
            },
        ];
        let footprint = [(DVec2::ZERO, 0.5 * size.x.hypot(size.y)), (xy(behind), radius)];
        self.place(Region { a: (-0.7, 0.7), b: (-1.0, -0.2), disc: false }, &footprint, pieces);
    }

    /// Two boxes of different colours side by side, sharing a face, at the same depth.
    fn same_depth_pair(&mut self) {
        let r = &mut self.rng;
        let yaw = LATERAL_YAW + r.gen_range(-0.12..0.12);
        let axis = DVec3::new(yaw.cos(), yaw.sin(), 0.0);
        let (wa, wb, depth) = (r.gen_range(0.4..0.6), r.gen_range(0.4..0.6), r.gen_range(0.4..0.5));
        let a = Shape::Cuboid {
            base_centre: -axis * (wa / 2.0),
            size: DVec3::new(wa, depth, r.gen_range(0.4..0.6)),
            yaw,
        };
        let b = Shape::Cuboid {
            base_centre: axis * (wb / 2.0),
            size: DVec3::new(wb, depth, r.gen_range(0.5..0.75)),
            yaw,
        };
        let (ca, cb) = (colour(r), colour(r));
        let tags = vec![HardCase::SameDepthPair];
        let piece = |name: &str, shape, albedo| Piece {
            name: name.into(),
            kind: ObjectKind::Box,
            shape,
            texture: Texture::Plain { albedo },
            tags: tags.clone(),
            design: vec![],
        };
        let pieces = vec![piece("pair_left_box", a, ca), piece("pair_right_box", b, cb)];
        let reach = 0.5 * (wa + wb) + 0.35;
        self.place(MAIN, &[(DVec2::ZERO, reach)], pieces);
    }

    /// A large textured object near the cameras, at the side of the middle views.
    fn foreground(&mut self, k: usize) {
        let seed = self.texture_seed();
        let r = &mut self.rng;
        let side = if r.gen_bool(0.5) { 1.0 } else { -1.0 };
        let (shape, kind, reach) = if r.gen_bool(0.6) {
            let size = DVec3::new(r.gen_range(0.6..0.9), r.gen_range(0.6..0.9), r.gen_range(1.0..1.6));
            let shape = Shape::Cuboid { base_centre: DVec3::ZERO, size, yaw: r.gen_range(0.0..PI) };
            (shape, ObjectKind::Box, 0.5 * size.x.hypot(size.y))
        } else {
            let (radius, height) = (r.gen_range(0.3..0.45), r.gen_range(1.0..1.6));
            (Shape::Cylinder { base_centre: DVec3::ZERO, radius, height }, ObjectKind::Cylinder, radius)
        };
        let texture = if r.gen_bool(0.5) {
            let base = colour(r);
            Texture::Blotches { base, blotch: base.map(|c| c * 0.65), frequency: r.gen_range(3.0..6.0), seed }
        } else {
            Texture::Checkers {
                a: colour(r),
                b: colour(r),
                cell_m: r.gen_range(0.08..0.2) * self.config.room.pattern_scale,
            }
        };
        let a = if side > 0.0 { (1.0, 1.5) } else { (-1.5, -1.0) };
        let piece = Piece {
            name: format!("foreground_{k}"),
            kind,
            shape,
            texture,
            tags: vec![HardCase::FrameCut],
            design: vec![],
        };
        self.place(Region { a, b: (-2.4, -1.8), disc: false }, &[(DVec2::ZERO, reach)], vec![piece]);
    }

    /// A box with a smaller object standing on it.
    fn stacked(&mut self, k: usize) {
        let share = self.config.room.multi_tone_share;
        let scale = self.config.room.pattern_scale;
        let (seed_a, seed_b) = (self.texture_seed(), self.texture_seed() ^ 1);
        let r = &mut self.rng;
        let size = DVec3::new(r.gen_range(0.45..0.75), r.gen_range(0.45..0.75), r.gen_range(0.3..0.55));
        let yaw = r.gen_range(0.0..PI);
        let bottom = Shape::Cuboid { base_centre: DVec3::ZERO, size, yaw };
        let top_base = DVec3::Z * size.z;
        let room_on_top = 0.5 * size.x.min(size.y);
        let (kind, top, top_height) = match r.gen_range(0..3) {
            0 => {
                let s = DVec3::new(
                    r.gen_range(0.5..0.9) * room_on_top * 1.4,
                    r.gen_range(0.5..0.9) * room_on_top * 1.4,
                    r.gen_range(0.2..0.45),
                );
                let yaw_top = yaw + r.gen_range(0.2..0.6);
                (ObjectKind::Box, Shape::Cuboid { base_centre: top_base, size: s, yaw: yaw_top }, s.z)
            }
            1 => {
                let radius = r.gen_range(0.5..0.9) * room_on_top;
                (
                    ObjectKind::Cylinder,
                    Shape::Cylinder { base_centre: top_base, radius, height: r.gen_range(0.2..0.5) },
                    0.35,
                )
            }
            _ => {
                let radius = r.gen_range(0.5..0.9) * room_on_top;
                (
                    ObjectKind::Sphere,
                    Shape::Sphere { centre: top_base + DVec3::Z * radius, radius },
                    2.0 * radius,
                )
            }
        };
        let bottom_texture = texture(r, share, scale, size.z, seed_a);
        let top_texture = texture(r, share, scale, top_height, seed_b);
        let design = vec![FailureClass::Stacked];
        let pieces = vec![
            Piece {
                name: format!("stack_{k}_bottom"),
                kind: ObjectKind::Box,
                shape: bottom,
                texture: bottom_texture,
                tags: vec![],
                design: design.clone(),
            },
            Piece {
                name: format!("stack_{k}_top"),
                kind,
                shape: top,
                texture: top_texture,
                tags: vec![],
                design,
            },
        ];
        let reach = 0.5 * size.x.hypot(size.y);
        self.place(MAIN, &[(DVec2::ZERO, reach)], pieces);
    }

    /// A box and another object touching one of its side faces.
    fn touching(&mut self, k: usize) {
        let share = self.config.room.multi_tone_share;
        let scale = self.config.room.pattern_scale;
        let (seed_a, seed_b) = (self.texture_seed(), self.texture_seed() ^ 1);
        let r = &mut self.rng;
        let size = DVec3::new(r.gen_range(0.35..0.6), r.gen_range(0.35..0.6), r.gen_range(0.35..0.8));
        let yaw = r.gen_range(0.0..PI);
        let first = Shape::Cuboid { base_centre: DVec3::ZERO, size, yaw };
        // Which face: ±local x or ±local y.
        let face = r.gen_range(0..4);
        let (local_dir, half) = match face {
            0 => (DVec3::X, size.x / 2.0),
            1 => (-DVec3::X, size.x / 2.0),
            2 => (DVec3::Y, size.y / 2.0),
            _ => (-DVec3::Y, size.y / 2.0),
        };
        let (s, c) = yaw.sin_cos();
        let dir = DVec3::new(c * local_dir.x - s * local_dir.y, s * local_dir.x + c * local_dir.y, 0.0);
        let (kind, second, reach, height) = match r.gen_range(0..3) {
            0 => {
                let radius = r.gen_range(0.15..0.28);
                let h = r.gen_range(0.4..1.0);
                let at = dir * (half + radius);
                (
                    ObjectKind::Cylinder,
                    Shape::Cylinder { base_centre: at, radius, height: h },
                    half + 2.0 * radius,
                    h,
                )
            }
            1 => {
                let radius = r.gen_range(0.15f64..0.3).min(size.z);
                let at = dir * (half + radius) + DVec3::Z * radius;
                (ObjectKind::Sphere, Shape::Sphere { centre: at, radius }, half + 2.0 * radius, 2.0 * radius)
            }
            _ => {
                // A box of the same yaw against the face, slid along it a little.
                let along = if face < 2 { size.y } else { size.x };
                let w = r.gen_range(0.3..0.55);
                let slide = r.gen_range(-0.25..0.25) * along;
                let side = DVec3::new(-dir.y, dir.x, 0.0);
                let at = dir * (half + w / 2.0) + side * slide;
                let other = if face < 2 {
                    DVec3::new(w, r.gen_range(0.3..0.6), r.gen_range(0.3..0.9))
                } else {
                    DVec3::new(r.gen_range(0.3..0.6), w, r.gen_range(0.3..0.9))
                };
                let reach = half + w + 0.5 * other.x.hypot(other.y);
                (ObjectKind::Box, Shape::Cuboid { base_centre: at, size: other, yaw }, reach, other.z)
            }
        };
        let first_texture = texture(r, share, scale, size.z, seed_a);
        let second_texture = texture(r, share, scale, height, seed_b);
        let design = vec![FailureClass::Touching];
        let pieces = vec![
            Piece {
                name: format!("touching_{k}_box"),
                kind: ObjectKind::Box,
                shape: first,
                texture: first_texture,
                tags: vec![],
                design: design.clone(),
            },
            Piece {
                name: format!("touching_{k}_other"),
                kind,
                shape: second,
                texture: second_texture,
                tags: vec![],
                design,
            },
        ];
        // Footprint: a circle around the midpoint covering both.
        let mid = xy(dir) * (reach * 0.5 - 0.1);
        self.place(MAIN, &[(mid, reach * 0.5 + 0.45)], pieces);
    }

    /// A post `thin_post_px` wide in the image at the orbit radius.
    fn thin_post(&mut self, k: usize) {
        let fx = self.config.width as f64 / 2.0 / (self.config.fov_x_deg.to_radians() / 2.0).tan();
        let radius = self.config.room.thin_post_px * crate::cameras::ORBIT_RADIUS / (2.0 * fx);
        let r = &mut self.rng;
        let height = r.gen_range(1.0..2.0);
        let shade = r.gen_range(0.15..0.45);
        let albedo = if r.gen_bool(0.5) { [shade, shade, shade * 1.1] } else { colour(r) };
        let piece = Piece {
            name: format!("thin_post_{k}"),
            kind: ObjectKind::Cylinder,
            shape: Shape::Cylinder { base_centre: DVec3::ZERO, radius, height },
            texture: Texture::Plain { albedo },
            tags: vec![],
            design: vec![FailureClass::Thin],
        };
        let m = POST_REGION_M;
        self.place(
            Region { a: (-m, m), b: (-m, m), disc: true },
            &[(DVec2::ZERO, POST_FOOTPRINT_M)],
            vec![piece],
        );
    }

    /// An ordinary object anywhere.
    fn ordinary(&mut self, k: usize) -> bool {
        let share = self.config.room.multi_tone_share;
        let scale = self.config.room.pattern_scale;
        let seed = self.texture_seed();
        let (kind, shape, reach, height) = random_shape(&mut self.rng, DVec3::ZERO);
        let texture = texture(&mut self.rng, share, scale, height, seed);
        let piece = Piece { name: format!("object_{k}"), kind, shape, texture, tags: vec![], design: vec![] };
        self.place(MAIN, &[(DVec2::ZERO, reach)], vec![piece])
    }
}

/// Builds the random room of `config` (its seed, family salt and `[room]` knobs).
pub fn build_random_layout(config: &SynthConfig) -> Vec<SceneObject> {
    let rng = rng_for(config.seed, stream::ROOM_LAYOUT, config.family.layout_salt());
    let mut b = Builder { rng, plan: Floorplan::default(), objects: room(config.seed, &config.room), config };
    let knobs = &config.room;
    let [lo, hi] = knobs.objects;
    let target = b.rng.gen_range(lo.min(hi)..=hi.max(lo));
    b.white_pair();
    b.same_depth_pair();
    for k in 0..knobs.thin_posts {
        b.thin_post(k);
    }
    for k in 0..knobs.foreground_objects {
        b.foreground(k);
    }
    for k in 0..knobs.stacked {
        b.stacked(k);
    }
    for k in 0..knobs.touching {
        b.touching(k);
    }
    let mut k = 0;
    let mut failures = 0;
    while b.objects.len() - 3 < target && failures < 5 {
        if b.ordinary(k) {
            k += 1;
        } else {
            failures += 1;
        }
    }
    b.objects
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::family::Family;

    #[test]
    fn every_family_places_its_objects_and_the_two_pairs() {
        for family in Family::ALL.into_iter().skip(1) {
            for seed in 0..12 {
                let config = family.config(seed);
                let objects = build_random_layout(&config);
                let movable = objects.len() - 3;
                let [_, hi] = config.room.objects;
                assert!((6..=hi.max(6)).contains(&movable), "{family} seed {seed}: {movable} objects");
                for (i, o) in objects.iter().enumerate() {
                    assert_eq!(o.id as usize, i + 1);
                }
                let count = |tag| objects.iter().filter(|o| o.tags.contains(&tag)).count();
                assert_eq!(count(HardCase::WhiteOnWhite), 2, "{family} seed {seed}");
                assert_eq!(count(HardCase::SameDepthPair), 2, "{family} seed {seed}");
                let posts = objects.iter().filter(|o| o.design.contains(&FailureClass::Thin)).count();
                assert_eq!(posts, config.room.thin_posts, "{family} seed {seed}");
                let stacked = objects.iter().filter(|o| o.design.contains(&FailureClass::Stacked)).count();
                assert_eq!(stacked, 2 * config.room.stacked, "{family} seed {seed}");
            }
        }
    }

    #[test]
    fn the_same_room_at_another_resolution_differs_only_in_the_post_radius() {
        for seed in 0..6 {
            let rooms = build_random_layout(&Family::Rooms.config(seed));
            let hires = build_random_layout(&Family::Hires.config(seed));
            assert_eq!(rooms.len(), hires.len());
            for (a, b) in rooms.iter().zip(&hires) {
                if a.design.contains(&FailureClass::Thin) {
                    continue;
                }
                assert_eq!(a, b, "seed {seed}");
            }
        }
    }
}
