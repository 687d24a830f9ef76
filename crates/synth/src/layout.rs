//! The scene's content: a room corner (floor + two walls) and 7–10 textured objects, placed from
//! a fixed plan with per-seed jitter so the paper's hard cases are always present.
//!
//! Ids (the ground-truth instance ids, equal in every view): 1 floor, 2 left wall, 3 back wall,
//! 4.. the objects in [`CORE`] order, then the chosen extras in [`EXTRAS`] order. 0 = no surface.
//!
//! Placement uses view-aligned coordinates `(a, b)`: `a` is to the right in the middle view of
//! the camera arc, `b` away from the cameras; the arc's middle looks along world `(−1, −1)`.

use crate::classes::FailureClass;
use crate::config::{FloorPattern, RoomConfig, WallPaint};
use crate::geometry::Shape;
use crate::noise::{rng_for, stream};
use crate::texture::{Rgb, RoomPattern, Texture};
use glam::DVec3;
use rand::seq::SliceRandom;
use rand::Rng;
use serde::{Deserialize, Serialize};

/// What kind of thing an instance is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObjectKind {
    /// The floor.
    Floor,
    /// A wall.
    Wall,
    /// A box.
    Box,
    /// A sphere.
    Sphere,
    /// A vertical cylinder.
    Cylinder,
}

/// The hard cases of the paper an object takes part in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HardCase {
    /// One of two objects of identical plain white appearance at clearly different depths
    /// that touch in the image (the paper's "white-on-white dilemma").
    WhiteOnWhite,
    /// One of two touching objects of different colour at the same depth, separated only by an
    /// edge.
    SameDepthPair,
    /// Hides part of another object in some views.
    Occluder,
    /// Placed so the image frame cuts it in some views.
    FrameCut,
}

/// One ground-truth instance of the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneObject {
    /// Instance id (label-map value), ≥ 1.
    pub id: u32,
    /// Stable name, e.g. `white_box`.
    pub name: String,
    /// Kind.
    pub kind: ObjectKind,
    /// Geometry.
    pub shape: Shape,
    /// Surface appearance.
    pub texture: Texture,
    /// Hard cases it takes part in.
    pub tags: Vec<HardCase>,
    /// Failure classes it was built for (thin, stacked, touching, …); the measured ones (cut
    /// by the border, occluded) are added by [`crate::SynthScene::failure_classes`].
    pub design: Vec<FailureClass>,
}

/// The shared albedo of the white-on-white pair.
pub const WHITE: Rgb = [0.9, 0.9, 0.88];

/// Names of the objects present in every scene, in id order from 4.
pub const CORE: [&str; 7] =
    ["white_box", "white_cylinder", "red_box", "blue_box", "striped_cylinder", "two_tone_ball", "frame_post"];

/// Names of the optional objects; each seed picks 0–3 of them.
pub const EXTRAS: [&str; 3] = ["checker_box", "blotch_sphere", "two_tone_box"];

/// Half-width of the square floor region the room spans, around `ROOM_OFFSET`.
pub(crate) const WALL_AT: f64 = -2.6;
const ROOM_FAR: f64 = 5.6;
const WALL_HEIGHT: f64 = 2.6;

/// World xy of view-aligned `(a, b)`.
pub(crate) fn world_xy(a: f64, b: f64) -> DVec3 {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    DVec3::new(-(a + b) * s, (a - b) * s, 0.0)
}

/// World yaw of the view-aligned lateral axis `a`.
pub(crate) const LATERAL_YAW: f64 = 0.75 * std::f64::consts::PI;

struct Jitter<'a, R: Rng> {
    rng: &'a mut R,
}

impl<R: Rng> Jitter<'_, R> {
    /// `v · (1 ± frac)`.
    fn scale(&mut self, v: f64, frac: f64) -> f64 {
        v * (1.0 + self.rng.gen_range(-frac..=frac))
    }
    /// `v ± amount`.
    fn shift(&mut self, v: f64, amount: f64) -> f64 {
        v + self.rng.gen_range(-amount..=amount)
    }
    /// A colour with each channel moved by up to `amount`.
    fn colour(&mut self, c: Rgb, amount: f64) -> Rgb {
        c.map(|v| (v + self.rng.gen_range(-amount..=amount)).clamp(0.0, 1.0))
    }
    fn pos(&mut self, a: f64, b: f64) -> DVec3 {
        let (a, b) = (self.shift(a, 0.07), self.shift(b, 0.07));
        world_xy(a, b)
    }
}

pub(crate) fn object(
    id: u32,
    name: &str,
    kind: ObjectKind,
    shape: Shape,
    texture: Texture,
    tags: &[HardCase],
) -> SceneObject {
    SceneObject { id, name: name.to_string(), kind, shape, texture, tags: tags.to_vec(), design: Vec::new() }
}

/// The floor's texture: today's planks, or a two-tone pattern.
fn floor_texture(seed: u64, room: &RoomConfig) -> Texture {
    let pattern = match room.floor {
        FloorPattern::Planks => {
            return Texture::Planks { base: [0.55, 0.4, 0.28], width_m: 0.3, variation: 0.06, seed }
        }
        FloorPattern::Stripes => RoomPattern::Stripes,
        FloorPattern::Checkers => RoomPattern::Checkers,
    };
    Texture::Room {
        a: [0.55, 0.4, 0.28],
        b: [0.72, 0.62, 0.48],
        pattern,
        scale_m: room.floor_scale_m,
        tone_parts: room.tone_parts,
        seed,
    }
}

/// A wall's texture: today's plain paint, or two tones.
fn wall_texture(base: Rgb, second: Rgb, seed: u64, room: &RoomConfig) -> Texture {
    let pattern = match room.walls {
        WallPaint::Plain => return Texture::Wall { base, seed },
        WallPaint::TwoTone => RoomPattern::Split,
        WallPaint::Stripes => RoomPattern::Stripes,
    };
    Texture::Room {
        a: base,
        b: second,
        pattern,
        scale_m: room.wall_scale_m,
        tone_parts: room.tone_parts,
        seed,
    }
}

/// Floor and the two walls of the room corner (ids 1–3).
pub(crate) fn room(seed: u64, config: &RoomConfig) -> Vec<SceneObject> {
    let span = ROOM_FAR - WALL_AT;
    let floor = Shape::Quad {
        origin: DVec3::new(WALL_AT, WALL_AT, 0.0),
        edge_u: DVec3::X * span,
        edge_v: DVec3::Y * span,
    };
    let left_wall = Shape::Quad {
        origin: DVec3::new(WALL_AT, WALL_AT, 0.0),
        edge_u: DVec3::Y * span,
        edge_v: DVec3::Z * WALL_HEIGHT,
    };
    let back_wall = Shape::Quad {
        origin: DVec3::new(WALL_AT, WALL_AT, 0.0),
        edge_u: DVec3::Z * WALL_HEIGHT,
        edge_v: DVec3::X * span,
    };
    vec![
        object(1, "floor", ObjectKind::Floor, floor, floor_texture(seed, config), &[]),
        object(
            2,
            "left_wall",
            ObjectKind::Wall,
            left_wall,
            wall_texture([0.62, 0.72, 0.6], [0.45, 0.55, 0.42], seed ^ 1, config),
            &[],
        ),
        object(
            3,
            "back_wall",
            ObjectKind::Wall,
            back_wall,
            wall_texture([0.58, 0.64, 0.78], [0.82, 0.8, 0.7], seed ^ 2, config),
            &[],
        ),
    ]
}

/// Builds the scene for `seed`: the room, the [`CORE`] objects and 0–3 [`EXTRAS`].
pub fn build_layout(seed: u64) -> Vec<SceneObject> {
    build_plan_layout(seed, &RoomConfig::default())
}

/// [`build_layout`] with the room's walls and floor from `room`.
pub fn build_plan_layout(seed: u64, room_config: &RoomConfig) -> Vec<SceneObject> {
    let mut rng = rng_for(seed, stream::LAYOUT, 0);
    let mut objects = room(seed, room_config);
    let mut j = Jitter { rng: &mut rng };
    let mut next_id = 4;
    let mut push = |objects: &mut Vec<SceneObject>, name: &str, kind, shape, texture, tags: &[HardCase]| {
        objects.push(object(next_id, name, kind, shape, texture, tags));
        next_id += 1;
    };
    use HardCase::*;

    // The white-on-white pair: a box in front, a taller cylinder ~1.5 m further back, behind it.
    let box_size = DVec3::new(j.scale(0.55, 0.05), j.scale(0.55, 0.05), j.scale(0.7, 0.06));
    let shape = Shape::Cuboid {
        base_centre: j.pos(0.0, -0.6),
        size: box_size,
        yaw: j.shift(0.25 * std::f64::consts::PI, 0.15),
    };
    push(
        &mut objects,
        "white_box",
        ObjectKind::Box,
        shape,
        Texture::Plain { albedo: WHITE },
        &[WhiteOnWhite, Occluder],
    );
    let shape = Shape::Cylinder {
        base_centre: j.pos(0.15, 0.95),
        radius: j.scale(0.3, 0.06),
        height: j.scale(1.15, 0.05),
    };
    push(
        &mut objects,
        "white_cylinder",
        ObjectKind::Cylinder,
        shape,
        Texture::Plain { albedo: WHITE },
        &[WhiteOnWhite],
    );

    // Two boxes side by side, touching along a shared face, at the same depth.
    let pair_centre = j.pos(-1.3, 0.1);
    let pair_yaw = j.shift(LATERAL_YAW, 0.12);
    let axis = DVec3::new(pair_yaw.cos(), pair_yaw.sin(), 0.0);
    let (w_red, w_blue) = (j.scale(0.5, 0.06), j.scale(0.5, 0.06));
    let depth = j.scale(0.45, 0.05);
    let red = Shape::Cuboid {
        base_centre: pair_centre - axis * (w_red / 2.0),
        size: DVec3::new(w_red, depth, j.scale(0.5, 0.06)),
        yaw: pair_yaw,
    };
    let blue = Shape::Cuboid {
        base_centre: pair_centre + axis * (w_blue / 2.0),
        size: DVec3::new(w_blue, depth, j.scale(0.62, 0.06)),
        yaw: pair_yaw,
    };
    let (red_c, blue_c) = (j.colour([0.8, 0.15, 0.12], 0.04), j.colour([0.35, 0.6, 0.95], 0.04));
    push(&mut objects, "red_box", ObjectKind::Box, red, Texture::Plain { albedo: red_c }, &[SameDepthPair]);
    push(
        &mut objects,
        "blue_box",
        ObjectKind::Box,
        blue,
        Texture::Plain { albedo: blue_c },
        &[SameDepthPair],
    );

    // A striped cylinder, partly hidden by the ball in front of it in some views.
    let shape = Shape::Cylinder {
        base_centre: j.pos(1.3, 0.35),
        radius: j.scale(0.25, 0.06),
        height: j.scale(0.95, 0.05),
    };
    let texture = Texture::Stripes {
        a: j.colour([0.85, 0.68, 0.25], 0.03),
        b: j.colour([0.25, 0.7, 0.75], 0.03),
        period_m: j.scale(0.2, 0.05),
    };
    push(&mut objects, "striped_cylinder", ObjectKind::Cylinder, shape, texture, &[]);
    let radius = j.scale(0.3, 0.06);
    let centre = j.pos(0.95, -0.85) + DVec3::Z * radius;
    let texture = Texture::TwoTone {
        bottom: j.colour([0.75, 0.35, 0.55], 0.03),
        top: j.colour([0.95, 0.5, 0.15], 0.03),
        split_m: radius,
    };
    push(
        &mut objects,
        "two_tone_ball",
        ObjectKind::Sphere,
        Shape::Sphere { centre, radius },
        texture,
        &[Occluder],
    );

    // A tall post at the side, cut by the image frame in the middle views.
    let shape = Shape::Cylinder {
        base_centre: j.pos(2.15, -0.3),
        radius: j.scale(0.2, 0.05),
        height: j.scale(1.3, 0.05),
    };
    let texture = Texture::Blotches {
        base: j.colour([0.35, 0.62, 0.3], 0.03),
        blotch: [0.22, 0.45, 0.2],
        frequency: 6.0,
        seed: seed ^ stream::TEXTURE,
    };
    push(&mut objects, "frame_post", ObjectKind::Cylinder, shape, texture, &[FrameCut]);

    // Extras: 0–3 of them, chosen per seed, numbered in EXTRAS order.
    let count = j.rng.gen_range(0..=EXTRAS.len());
    let mut chosen: Vec<usize> = (0..EXTRAS.len()).collect();
    chosen.shuffle(j.rng);
    chosen.truncate(count);
    chosen.sort_unstable();
    for which in chosen {
        match which {
            0 => {
                let size = DVec3::new(j.scale(0.6, 0.05), j.scale(0.5, 0.05), j.scale(0.5, 0.05));
                let shape =
                    Shape::Cuboid { base_centre: j.pos(-0.75, 1.65), size, yaw: j.shift(LATERAL_YAW, 0.3) };
                let texture = Texture::Checkers { a: [0.85, 0.55, 0.2], b: [0.6, 0.38, 0.18], cell_m: 0.1 };
                push(&mut objects, "checker_box", ObjectKind::Box, shape, texture, &[]);
            }
            1 => {
                let radius = j.scale(0.28, 0.06);
                let centre = j.pos(-0.95, -1.3) + DVec3::Z * radius;
                let texture = Texture::Blotches {
                    base: [0.85, 0.55, 0.65],
                    blotch: [0.6, 0.35, 0.55],
                    frequency: 7.0,
                    seed: seed ^ 0xB10,
                };
                push(
                    &mut objects,
                    "blotch_sphere",
                    ObjectKind::Sphere,
                    Shape::Sphere { centre, radius },
                    texture,
                    &[Occluder],
                );
            }
            _ => {
                let size = DVec3::new(j.scale(0.45, 0.05), j.scale(0.45, 0.05), j.scale(0.8, 0.05));
                let shape =
                    Shape::Cuboid { base_centre: j.pos(1.2, 1.55), size, yaw: j.shift(LATERAL_YAW, 0.3) };
                let texture = Texture::TwoTone {
                    bottom: [0.55, 0.6, 0.75],
                    top: [0.85, 0.72, 0.3],
                    split_m: size.z * 0.5,
                };
                push(&mut objects, "two_tone_box", ObjectKind::Box, shape, texture, &[]);
            }
        }
    }
    objects
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_contiguous_from_one_and_core_objects_always_present() {
        for seed in 0..20 {
            let objects = build_layout(seed);
            assert!((10..=13).contains(&objects.len()), "{} instances", objects.len());
            for (i, o) in objects.iter().enumerate() {
                assert_eq!(o.id as usize, i + 1);
            }
            for (k, name) in CORE.iter().enumerate() {
                assert_eq!(objects[3 + k].name, *name);
            }
        }
    }

    /// Centre (xy) and radius of a bounding circle of an object's footprint.
    fn footprint(shape: &Shape) -> (DVec3, f64) {
        match *shape {
            Shape::Cuboid { base_centre, size, .. } => (base_centre, 0.5 * (size.x.hypot(size.y))),
            Shape::Sphere { centre, radius } => (centre * DVec3::new(1.0, 1.0, 0.0), radius),
            Shape::Cylinder { base_centre, radius, .. } => (base_centre, radius),
            Shape::Quad { .. } => (DVec3::ZERO, f64::INFINITY),
        }
    }

    #[test]
    fn objects_stand_apart_inside_the_room_except_the_touching_pair() {
        for seed in 0..50 {
            let objects = build_layout(seed);
            let movable: Vec<&SceneObject> = objects.iter().filter(|o| o.id >= 4).collect();
            for (i, a) in movable.iter().enumerate() {
                let (ca, ra) = footprint(&a.shape);
                assert!(ca.x - ra > WALL_AT && ca.y - ra > WALL_AT, "seed {seed}: {} in a wall", a.name);
                for b in &movable[i + 1..] {
                    if a.tags.contains(&HardCase::SameDepthPair) && b.tags.contains(&HardCase::SameDepthPair)
                    {
                        continue;
                    }
                    let (cb, rb) = footprint(&b.shape);
                    let gap = (ca - cb).length() - ra - rb;
                    assert!(gap > 0.02, "seed {seed}: {} and {} overlap ({gap:.3} m)", a.name, b.name);
                }
            }
        }
    }

    #[test]
    fn the_same_depth_pair_shares_a_face() {
        let objects = build_layout(4);
        let pair: Vec<&SceneObject> =
            objects.iter().filter(|o| o.tags.contains(&HardCase::SameDepthPair)).collect();
        let (
            Shape::Cuboid { base_centre: ca, size: sa, yaw: ya },
            Shape::Cuboid { base_centre: cb, size: sb, yaw: yb },
        ) = (&pair[0].shape, &pair[1].shape)
        else {
            panic!("the pair are boxes");
        };
        assert_eq!(ya, yb);
        assert!(((*ca - *cb).length() - (sa.x + sb.x) / 2.0).abs() < 1e-12);
    }

    #[test]
    fn seeds_change_the_layout_and_pick_different_extras() {
        let counts: std::collections::BTreeSet<usize> = (0..20).map(|s| build_layout(s).len()).collect();
        assert!(counts.len() >= 3, "extras barely vary: {counts:?}");
        assert_ne!(build_layout(1), build_layout(2));
        assert_eq!(build_layout(5), build_layout(5));
    }
}
